/// @file coupling.cpp
/// Coupling of the god-object to the device target (paper Eq. 2, Fig. 5).

#include "numen/core/coupling.hpp"

#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/rigid_body.hpp"
#include "numen/core/step_stages.hpp"

#include "scratch/data_scratch.hpp"

namespace numen::core {
namespace {

bool valid_body(const Model& model, int body) noexcept {
  return body >= 0 && body < model.num_bodies();
}

}  // namespace

Vec3 rotation_error(const Quat& q_target, const Quat& q) noexcept {
  return quat_log(q_target * q.conjugate());
}

Wrench coupling_wrench(const CouplingGains& gains, const Pose& target, const Twist& target_twist,
                       const BodyState& state) noexcept {
  Wrench w;
  w.force = gains.k_t * (target.position - state.position) +
            gains.gamma_t * (target_twist.linear - state.linear_velocity);
  w.torque = gains.k_r * rotation_error(target.orientation, state.orientation) +
             gains.gamma_r * (target_twist.angular - state.angular_velocity);
  return w;
}

bool target_is_finite(const Pose& target, const Twist& target_twist) noexcept {
  return target.position.allFinite() && target.orientation.coeffs().allFinite() &&
         target.orientation.norm() > 1e-9 && target_twist.linear.allFinite() &&
         target_twist.angular.allFinite();
}

bool first_order_applicable(const CouplingGains& gains) noexcept {
  return gains.gamma_t > 0.0 && gains.gamma_r > 0.0;
}

namespace {

/// Imposes pose and twist on body i (kDirect); a non-finite target holds the
/// body still and flags the step.
void impose(Data& data, std::size_t i, const Pose& target, const Twist& twist) noexcept {
  BodyState& s = data.bodies[i];
  data.scratch->solver.imposed[i] = 1;
  if (!target_is_finite(target, twist)) {
    data.status |= kInvalidTarget;
    s.linear_velocity.setZero();
    s.angular_velocity.setZero();
    return;
  }
  s.position = target.position;
  s.orientation = target.orientation.normalized();
  s.linear_velocity = twist.linear;
  s.angular_velocity = twist.angular;
}

/// True when body i has its own enabled target (Eq. 6) other than the held body's.
bool has_own_target(const Data& data, std::size_t i) noexcept {
  return data.body_targets[i].enabled && static_cast<int>(i) != data.held_body;
}

}  // namespace

void apply_device_wrench(const Model& model, Data& data) noexcept {
  if (model.coupling_mode != CouplingMode::kAdmittance || !valid_body(model, data.held_body))
    return;
  const Wrench& w = data.device_wrench;
  if (!(w.force.allFinite() && w.torque.allFinite())) {
    data.status |= kInvalidTarget;
    return;
  }
  const auto i = static_cast<std::size_t>(data.held_body);
  data.coupling_wrench = w;
  data.body_wrench[i].force += w.force;
  data.body_wrench[i].torque += w.torque;
}

void impose_direct_target(const Model& model, Data& data) noexcept {
  for (auto& v : data.scratch->solver.imposed) v = 0;
  if (!(model.stage_plan & kStageDirectTarget)) return;  // the plan: kDirect or anchored bodies
  data.stages_run |= kStageDirectTarget;  // the stage report (step_stages.hpp)
  for (std::size_t i = 0; i < model.bodies.size(); ++i)  // static bodies: where they started
    if (model.bodies[i].anchored) impose(data, i, model.bodies[i].initial_pose, Twist{});
  if (model.coupling_mode != CouplingMode::kDirect) return;
  if (valid_body(model, data.held_body))
    impose(data, static_cast<std::size_t>(data.held_body), data.target, data.target_twist);
  for (std::size_t i = 0; i < data.bodies.size(); ++i)
    if (has_own_target(data, i))
      impose(data, i, data.body_targets[i].pose, data.body_targets[i].twist);
}

void apply_coupling(const Model& model, Data& data) noexcept {
  SolverScratch& s = data.scratch->solver;
  data.coupling_wrench = Wrench{};
  s.coupled_body = -1;
  s.first_order = false;
  for (auto& v : s.target_coupled) v = 0;
  if (model.coupling_mode == CouplingMode::kDirect) return;
  if (model.coupling_mode == CouplingMode::kAdmittance) {
    apply_device_wrench(model, data);
  } else if (valid_body(model, data.held_body)) {
    if (!target_is_finite(data.target, data.target_twist)) {
      data.status |= kInvalidTarget;
    } else {
      const auto i = static_cast<std::size_t>(data.held_body);
      const CouplingGains& gains = model.bodies[i].coupling;
      const Wrench w = coupling_wrench(gains, data.target, data.target_twist, data.bodies[i]);
      data.coupling_wrench = w;
      data.body_wrench[i].force += w.force;
      data.body_wrench[i].torque += w.torque;
      s.coupled_body = data.held_body;
      s.target_coupled[i] = 1;
      s.first_order =
          model.coupling_mode == CouplingMode::kFirstOrder && first_order_applicable(gains);
    }
  }
  // Eq. 6: every other body with its own device target, always second order.
  for (std::size_t i = 0; i < data.bodies.size(); ++i) {
    if (!has_own_target(data, i)) continue;
    const BodyTarget& t = data.body_targets[i];
    if (!target_is_finite(t.pose, t.twist)) {
      data.status |= kInvalidTarget;
      continue;
    }
    const Wrench w = coupling_wrench(model.bodies[i].coupling, t.pose, t.twist, data.bodies[i]);
    data.body_wrench[i].force += w.force;
    data.body_wrench[i].torque += w.torque;
    s.target_coupled[i] = 1;
  }
}

}  // namespace numen::core
