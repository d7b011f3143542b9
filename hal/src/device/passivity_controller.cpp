/// @file passivity_controller.cpp
/// hal::PassivityController: Hannaford & Ryu's passivity observer and controller, per axis.

#include "numen/hal/device/passivity_controller.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace numen::hal {

PassivityController::PassivityController(int num_axes, double period_s, std::uint32_t axis_mask,
                                         double velocity_threshold, double energy_limit)
    : n_(num_axes),
      period_(period_s),
      mask_(axis_mask),
      v_min_(velocity_threshold),
      e_max_(energy_limit) {
  if (num_axes < 0 || num_axes > kMaxAxes)
    throw std::invalid_argument("PassivityController: num_axes must be in [0, " +
                                std::to_string(kMaxAxes) + "]");
  if (!(std::isfinite(period_s) && period_s > 0.0))
    throw std::invalid_argument("PassivityController: period_s must be finite and > 0");
  if (!(std::isfinite(velocity_threshold) && velocity_threshold >= 0.0))
    throw std::invalid_argument("PassivityController: velocity_threshold must be finite and >= 0");
  if (!(energy_limit > 0.0))
    throw std::invalid_argument("PassivityController: energy_limit must be > 0 (+inf: none)");
}

int PassivityController::apply(std::span<double> torque, std::span<const double> rate,
                               std::uint32_t allowed) noexcept {
  observed_ = 0;
  int acted = 0;
  for (int i = 0; i < n_; ++i) {
    const auto k = static_cast<std::size_t>(i);
    const std::uint32_t bit = 1u << static_cast<unsigned>(i);
    alpha_[k] = 0.0;
    if ((mask_ & allowed & bit) == 0 || k >= torque.size()) continue;
    const double tau = torque[k];
    const double v = k < rate.size() ? rate[k] : 0.0;
    if (!std::isfinite(tau) || !std::isfinite(v)) continue;
    // The observer: E(n) = E(n−1) + T f v with f = −τ (power into the environment).
    double e = energy_[k] - period_ * tau * v;
    double out = tau;
    if (e < 0.0 && std::abs(v) > v_min_) {
      // The controller: α = −E / (T v²); the damper −α v dissipates T α v² = −E this period.
      const double a = -e / (period_ * v * v);
      out = tau - a * v;
      const double dissipated = period_ * a * v * v;
      e += dissipated;
      alpha_[k] = a;
      counters_.dissipated_j += dissipated;
      ++counters_.axis_acting_periods[k];
      ++acted;
    }
    energy_[k] = std::min(e, e_max_);
    torque[k] = out;
    torque_[k] = out;
    rate_[k] = v;
    observed_ |= bit;
  }
  if (acted > 0) ++counters_.acting_periods;
  return acted;
}

void PassivityController::sent(std::span<const double> sent_torque) noexcept {
  for (int i = 0; i < n_; ++i) {
    const auto k = static_cast<std::size_t>(i);
    if ((observed_ & (1u << static_cast<unsigned>(i))) == 0) continue;
    const double s = k < sent_torque.size() ? sent_torque[k] : 0.0;
    if (std::isfinite(s))
      energy_[k] = std::min(energy_[k] - period_ * (s - torque_[k]) * rate_[k], e_max_);
  }
  observed_ = 0;
}

double PassivityController::energy(int axis) const noexcept {
  return axis >= 0 && axis < n_ ? energy_[static_cast<std::size_t>(axis)] : 0.0;
}

double PassivityController::damping(int axis) const noexcept {
  return axis >= 0 && axis < n_ ? alpha_[static_cast<std::size_t>(axis)] : 0.0;
}

void PassivityController::reset() noexcept {
  energy_ = {};
  alpha_ = {};
  torque_ = {};
  rate_ = {};
  observed_ = 0;
  counters_ = {};
}

}  // namespace numen::hal
