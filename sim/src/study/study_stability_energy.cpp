/// @file study_stability_energy.cpp
/// The input work and the verdict monitor of `numen study stability` (study_stability.hpp,
/// study_stability_cases.hpp).

#include <algorithm>
#include <cmath>

#include "numen/core/coupling.hpp"
#include "numen/sim/study/study_stability_cases.hpp"

namespace numen::sim {

double input_work(const core::Model& model, const core::Data& data, double energy_before_inputs,
                  double energy_after_inputs) noexcept {
  double w = energy_after_inputs - energy_before_inputs;
  if (coupling_springs_act(model)) {
    double p = 0.0;
    for (int i = 0; i < model.num_bodies(); ++i) {
      const core::Twist* twist = nullptr;
      if (coupling_target(model, data, i, &twist) == nullptr) continue;
      const auto k = static_cast<std::size_t>(i);
      p += damper_power(model.bodies[k].coupling, data.bodies[k], *twist);
    }
    w += model.dt * std::max(0.0, p);
  }
  return std::isfinite(w) ? std::max(0.0, w) : w;
}

namespace stability {

core::Model empty_model(const core::MaterialPair& pair) {
  core::Model m;
  m.gravity = core::Vec3::Zero();
  m.material_names = {"default"};
  m.material_pairs = {pair};
  return m;
}

Monitor::Monitor(const StabilityLimits& limits, double penetration_bound, double drift_bound,
                 std::int64_t planned_steps, double travel_mass, double dt)
    : limits_(limits),
      penetration_bound_(penetration_bound),
      drift_bound_(drift_bound),
      travel_mass_(travel_mass),
      dt_(dt),
      bound_now_(penetration_bound),
      planned_(planned_steps) {}

void Monitor::start(double energy0) noexcept {
  energy0_ = energy0;
  energy_ref_ = energy0;
}

bool Monitor::observe(std::int64_t step, double energy, double work_in, double penetration,
                      double drift, std::int64_t nonfinite_steps) noexcept {
  if (diverged()) return false;
  steps_ = step;
  nonfinite_ = nonfinite_steps;
  energy_ref_ = energy0_ + work_in;
  bound_now_ = penetration_bound_;
  if (travel_mass_ > 0.0)
    bound_now_ += dt_ * std::sqrt(2.0 * std::max(0.0, energy_ref_) / travel_mass_);
  if (std::isfinite(energy))
    ratio_max_ = std::max(ratio_max_, energy / std::max(energy_ref_, limits_.energy_floor_j));
  if (std::isfinite(penetration)) penetration_max_ = std::max(penetration_max_, penetration);
  if (std::isfinite(drift)) drift_max_ = std::max(drift_max_, drift);
  if (4 * step > planned_ && 4 * step <= 2 * planned_) q2_max_ = std::max(q2_max_, energy);
  if (4 * step > 3 * planned_) q4_max_ = std::max(q4_max_, energy);
  if (nonfinite_steps > 0 || !std::isfinite(energy)) {
    fail(step, "non-finite");
  } else if (energy > limits_.energy_factor * std::max(energy_ref_, limits_.energy_floor_j)) {
    fail(step, "energy");
  } else if (!(penetration <= bound_now_)) {
    fail(step, "penetration");
  } else if (!(drift <= drift_bound_)) {
    fail(step, "drift");
  }
  return !diverged();
}

void Monitor::fail(std::int64_t step, const char* reason) noexcept {
  if (diverged()) return;
  diverged_step_ = step;
  steps_ = std::max(steps_, step);
  reason_ = reason;
}

double Monitor::growth_ratio() const noexcept {
  if (diverged() || steps_ < planned_) return kInf;
  return q2_max_ > 0.0 ? q4_max_ / q2_max_ : (q4_max_ > 0.0 ? kInf : 1.0);
}

void Monitor::fill(StabilityRow& row) const {
  row.steps = steps_;
  row.stable = !diverged();
  row.diverged_step = diverged_step_;
  row.reason = reason_;
  row.energy_ref_j = energy_ref_;
  row.energy_ratio_max = ratio_max_;
  row.penetration_max_m = penetration_max_;
  row.penetration_bound_m = bound_now_;
  row.drift_max_m = drift_max_;
  row.nonfinite_steps = nonfinite_;
}

}  // namespace stability
}  // namespace numen::sim
