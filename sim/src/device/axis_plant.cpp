/// @file axis_plant.cpp
/// One axis of an emulated device: inertia, viscous damping, Karnopp friction, a held and
/// delayed torque through a current loop; integrated in closed form (axis_plant.hpp).

#include "numen/sim/device/axis_plant.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace numen::sim {
namespace {

bool finite_at_least(double v, double low) noexcept { return std::isfinite(v) && v >= low; }

/// (1 − e^{−u}) / u and (u − 1 + e^{−u}) / u² for u >= 0, without cancellation near 0.
void phi(double u, double& phi1, double& phi2) noexcept {
  if (u < 1e-4) {
    phi1 = 1.0 - u / 2.0 + u * u / 6.0;
    phi2 = 0.5 - u / 6.0 + u * u / 24.0;
  } else {
    const double one_minus = -std::expm1(-u);
    phi1 = one_minus / u;
    phi2 = (u - one_minus) / (u * u);
  }
}

}  // namespace

AxisPlant::AxisPlant(const AxisPlantSettings& s) : settings_(s) {
  const auto bad = [](const std::string& what) { throw std::invalid_argument(what); };
  if (!(std::isfinite(s.inertia) && s.inertia > 0.0)) bad("inertia must be finite and > 0");
  if (!finite_at_least(s.damping, 0.0)) bad("damping must be finite and >= 0");
  if (!finite_at_least(s.coulomb, 0.0)) bad("coulomb must be finite and >= 0");
  if (!finite_at_least(s.current_lag_s, 0.0)) bad("current_lag must be finite and >= 0");
  if (std::isnan(s.max_torque) || !(s.max_torque > 0.0)) bad("max_torque must be > 0");
  if (s.delay_periods < 0 || s.delay_periods > kMaxPlantDelayPeriods)
    bad("delay_periods must be in [0, " + std::to_string(kMaxPlantDelayPeriods) + "]");
}

void AxisPlant::reset(double q, double qdot) noexcept {
  q_ = q;
  qdot_ = qdot;
  current_ = 0.0;
  applied_ = 0.0;
  commanded_ = 0.0;
  stuck_ = qdot == 0.0;
  delay_line_.fill(0.0);
  head_ = 0;
  energy_ = AxisPlantEnergy{};
}

void AxisPlant::command(double torque) noexcept {
  const int size = settings_.delay_periods + 1;
  head_ = (head_ + 1) % size;
  delay_line_[static_cast<std::size_t>(head_)] = std::isfinite(torque) ? torque : 0.0;
  commanded_ = delay_line_[static_cast<std::size_t>((head_ + 1) % size)];
}

void AxisPlant::slide(double h, double force, double friction, double m, double b) noexcept {
  // m v̇ = G − b v with G = force + friction, closed form (u = b h / m):
  //   v(h) = v0 e^{−u} + (G/m) h φ1(u),  x(h) = x0 + v0 h φ1(u) + (G/m) h² φ2(u).
  const double g = force + friction;
  const double v0 = qdot_;
  double phi1 = 1.0, phi2 = 0.5;
  const double u = b * h / m;
  if (u > 0.0) phi(u, phi1, phi2);
  const double v1 = v0 * std::exp(-u) + g / m * h * phi1;
  const double dx = v0 * h * phi1 + g / m * h * h * phi2;
  // Work of the net force minus the kinetic energy gained is what the damper took.
  energy_.damping += g * dx - 0.5 * m * (v1 * v1 - v0 * v0);
  energy_.friction += std::abs(friction * dx);
  q_ += dx;
  qdot_ = v1;
}

void AxisPlant::step(double h, double external, double extra_inertia,
                     double extra_damping) noexcept {
  if (!(h > 0.0)) return;
  // The drive: the held command through the current loop (its exact mean over the step),
  // saturated.
  const double lag = settings_.current_lag_s;
  double mean = commanded_;
  if (lag > 0.0) {
    const double decay = std::exp(-h / lag);
    mean = commanded_ + (current_ - commanded_) * (-std::expm1(-h / lag)) * lag / h;
    current_ = commanded_ + (current_ - commanded_) * decay;
  } else {
    current_ = commanded_;
  }
  const double limit = settings_.max_torque;
  applied_ = mean > limit ? limit : (mean < -limit ? -limit : mean);
  if (!std::isfinite(external)) external = 0.0;
  const double m = settings_.inertia + (extra_inertia > 0.0 ? extra_inertia : 0.0);
  const double b = settings_.damping + (extra_damping > 0.0 ? extra_damping : 0.0);
  const double fc = settings_.coulomb;
  const double force = applied_ + external;
  const double q_start = q_;

  double left = h;
  if (qdot_ != 0.0) {
    // Sliding: friction against the velocity until the velocity reaches zero (if it does
    // within the step; t* solves v(t*) = 0 for the closed form above).
    const double s = qdot_ > 0.0 ? 1.0 : -1.0;
    const double g = force - fc * s;
    double t_stop = left;
    bool stops = false;
    if (g * s < 0.0) {
      if (b > 0.0) {
        const double v_inf = g / b;  // opposite sign to qdot_
        t_stop = m / b * std::log1p(-qdot_ / v_inf);
      } else {
        t_stop = -qdot_ * m / g;
      }
      stops = t_stop < left;
    }
    if (stops) {
      slide(t_stop, force, -fc * s, m, b);
      qdot_ = 0.0;
      left -= t_stop;
    } else {
      slide(left, force, -fc * s, m, b);
      left = 0.0;
      stuck_ = false;
    }
  }
  if (left > 0.0) {
    // At rest: stiction holds while the other forces do not exceed f_c; otherwise the axis
    // starts sliding in their direction (and, friction included, cannot stop again within
    // the step).
    if (std::abs(force) <= fc) {
      stuck_ = true;
    } else {
      const double s = force > 0.0 ? 1.0 : -1.0;
      slide(left, force, -fc * s, m, b);
      stuck_ = false;
    }
  }
  const double dx = q_ - q_start;
  energy_.drive += applied_ * dx;
  energy_.external += external * dx;
}

}  // namespace numen::sim
