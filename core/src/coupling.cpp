/// @file coupling.cpp
/// Coupling of the god-object to the device target (paper Eq. 2, Fig. 5).

#include "numen/core/coupling.hpp"

#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/rigid_body.hpp"

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

void impose_direct_target(const Model& model, Data& data) noexcept {
  data.solver.direct_body = -1;
  if (model.coupling_mode != CouplingMode::kDirect || !valid_body(model, data.attached_body))
    return;
  const auto i = static_cast<std::size_t>(data.attached_body);
  BodyState& s = data.bodies[i];
  data.solver.direct_body = data.attached_body;
  if (!target_is_finite(data.target, data.target_twist)) {
    data.status |= kInvalidTarget;
    s.linear_velocity.setZero();
    s.angular_velocity.setZero();
    return;
  }
  s.position = data.target.position;
  s.orientation = data.target.orientation.normalized();
  s.linear_velocity = data.target_twist.linear;
  s.angular_velocity = data.target_twist.angular;
}

void apply_coupling(const Model& model, Data& data) noexcept {
  data.coupling_wrench = Wrench{};
  data.solver.coupled_body = -1;
  data.solver.first_order = false;
  if (!valid_body(model, data.attached_body) || model.coupling_mode == CouplingMode::kDirect)
    return;
  if (!target_is_finite(data.target, data.target_twist)) {
    data.status |= kInvalidTarget;
    return;
  }
  const auto i = static_cast<std::size_t>(data.attached_body);
  const CouplingGains& gains = model.bodies[i].coupling;
  const Wrench w = coupling_wrench(gains, data.target, data.target_twist, data.bodies[i]);
  data.coupling_wrench = w;
  data.body_wrench[i].force += w.force;
  data.body_wrench[i].torque += w.torque;
  data.solver.coupled_body = data.attached_body;
  data.solver.first_order =
      model.coupling_mode == CouplingMode::kFirstOrder && first_order_applicable(gains);
}

}  // namespace numen::core
