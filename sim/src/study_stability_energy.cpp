/// @file study_stability_energy.cpp
/// The energy meter and the verdict monitor of `numen study stability` (study_stability.hpp,
/// study_stability_cases.hpp).

#include <algorithm>
#include <cmath>

#include "numen/core/coupling.hpp"
#include "numen/sim/study_stability_cases.hpp"

namespace numen::sim {
namespace {

using core::Vec3;

/// ½ k_t |e|² + ½ k_r θ² of a body's coupling springs towards `pose`.
double coupling_potential(const core::CouplingGains& g, const core::BodyState& s,
                          const core::Pose& pose) noexcept {
  const double e2 = (pose.position - s.position).squaredNorm();
  const double th2 = core::rotation_error(pose.orientation, s.orientation).squaredNorm();
  return 0.5 * g.k_t * e2 + 0.5 * g.k_r * th2;
}

/// γ_t (v_t − v)·v_t + γ_r (ω_t − ω)·ω_t: power of the dampers through the target's twist.
double damper_power(const core::CouplingGains& g, const core::BodyState& s,
                    const core::Twist& t) noexcept {
  return g.gamma_t * (t.linear - s.linear_velocity).dot(t.linear) +
         g.gamma_r * (t.angular - s.angular_velocity).dot(t.angular);
}

bool springs_act(const core::Model& model) noexcept {
  return model.coupling_mode == core::CouplingMode::kGodObject ||
         model.coupling_mode == core::CouplingMode::kFirstOrder;
}

}  // namespace

double stored_energy(const core::Model& model, const core::Data& data) noexcept {
  double e = 0.0;
  for (int i = 0; i < model.num_bodies(); ++i) {
    const auto k = static_cast<std::size_t>(i);
    const core::BodyModel& b = model.bodies[k];
    const core::BodyState& s = data.bodies[k];
    const core::Mat3 r = s.orientation.toRotationMatrix();
    const core::Mat3 iw = r * b.inertia_body * r.transpose();
    e += 0.5 * b.mass * s.linear_velocity.squaredNorm() +
         0.5 * s.angular_velocity.dot(iw * s.angular_velocity);
  }
  for (int i = 0; i < model.num_nodes(); ++i) {
    const auto k = static_cast<std::size_t>(i);
    e += 0.5 * model.node_mass[k] * data.nodes[k].velocity.squaredNorm();
  }
  if (springs_act(model)) {
    const int held = data.attached_body;
    if (held >= 0 && held < model.num_bodies()) {
      const auto h = static_cast<std::size_t>(held);
      e += coupling_potential(model.bodies[h].coupling, data.bodies[h], data.target);
    }
    for (int i = 0; i < model.num_bodies(); ++i) {
      const auto k = static_cast<std::size_t>(i);
      if (i == held || k >= data.body_targets.size() || !data.body_targets[k].enabled) continue;
      e += coupling_potential(model.bodies[k].coupling, data.bodies[k], data.body_targets[k].pose);
    }
  }
  for (const core::NetSpring& sp : model.net_springs) {
    const double l = (data.nodes[static_cast<std::size_t>(sp.node_b)].position -
                      data.nodes[static_cast<std::size_t>(sp.node_a)].position)
                         .norm();
    e += 0.5 * sp.stiffness * (l - sp.rest_length) * (l - sp.rest_length);
  }
  for (const core::NetModel& net : model.nets) {
    const core::BodyState& body = data.bodies[static_cast<std::size_t>(net.body)];
    for (int i = net.node_begin; i < net.node_begin + net.node_count; ++i) {
      const auto k = static_cast<std::size_t>(i);
      const Vec3 anchor = body.position + body.orientation * model.node_rest[k];
      e += 0.5 * net.tie_stiffness * (data.nodes[k].position - anchor).squaredNorm();
    }
  }
  return e;
}

double contact_energy(const core::Model& model, const core::Data& data) noexcept {
  double e = 0.0;
  for (int c = 0; c < data.num_contacts; ++c) {
    const core::Contact& ct = data.contacts[static_cast<std::size_t>(c)];
    const double k = model.material_pairs[static_cast<std::size_t>(ct.material_pair)].stiffness;
    e += 0.5 * k * ct.depth * ct.depth;
  }
  for (int c = 0; c < data.num_node_contacts; ++c) {
    const core::NodeContact& ct = data.node_contacts[static_cast<std::size_t>(c)];
    const double k = model.material_pairs[static_cast<std::size_t>(ct.material_pair)].stiffness;
    e += 0.5 * k * ct.depth * ct.depth;
  }
  return e;
}

double input_work(const core::Model& model, const core::Data& data, double energy_before_inputs,
                  double energy_after_inputs) noexcept {
  double w = energy_after_inputs - energy_before_inputs;
  if (springs_act(model)) {
    double p = 0.0;
    const int held = data.attached_body;
    if (held >= 0 && held < model.num_bodies()) {
      const auto h = static_cast<std::size_t>(held);
      p += damper_power(model.bodies[h].coupling, data.bodies[h], data.target_twist);
    }
    for (int i = 0; i < model.num_bodies(); ++i) {
      const auto k = static_cast<std::size_t>(i);
      if (i == held || k >= data.body_targets.size() || !data.body_targets[k].enabled) continue;
      p += damper_power(model.bodies[k].coupling, data.bodies[k], data.body_targets[k].twist);
    }
    w += model.dt * std::max(0.0, p);
  }
  return std::isfinite(w) ? std::max(0.0, w) : w;
}

namespace stability {

core::Model empty_model(const core::MaterialPair& pair) {
  core::Model m;
  m.gravity = Vec3::Zero();
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
