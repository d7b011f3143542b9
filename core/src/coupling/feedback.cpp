/// @file feedback.cpp
/// Device feedback by virtual coupling (paper Eq. 8).

#include "numen/core/feedback.hpp"

#include <algorithm>

#include "numen/core/coupling.hpp"
#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/rigid_body.hpp"
#include "numen/core/step_stages.hpp"

namespace numen::core {
namespace {

Vec3 clamp_norm(const Vec3& v, double max_norm) noexcept {
  const double n = v.norm();
  if (n <= max_norm) return v;  // also keeps v when max_norm is +inf
  if (!(max_norm > 0.0) || !(n > 0.0)) return Vec3::Zero();
  return (max_norm / n) * v;
}

}  // namespace

Wrench saturate_wrench(const Wrench& w, double max_force, double max_torque) noexcept {
  return Wrench{clamp_norm(w.force, max_force), clamp_norm(w.torque, max_torque)};
}

Wrench feedback_wrench_unsaturated(const FeedbackGains& gains, const Pose& target,
                                   const Twist& target_twist, const BodyState& state) noexcept {
  Wrench w;
  w.force = gains.k_t * (state.position - target.position) +
            gains.gamma_t * (state.linear_velocity - target_twist.linear);
  w.torque = gains.k_r * quat_log(state.orientation * target.orientation.conjugate()) +
             gains.gamma_r * (state.angular_velocity - target_twist.angular);
  return w;
}

Wrench feedback_wrench(const FeedbackGains& gains, const Pose& target, const Twist& target_twist,
                       const BodyState& state) noexcept {
  return saturate_wrench(feedback_wrench_unsaturated(gains, target, target_twist, state),
                         gains.max_force, gains.max_torque);
}

Wrench carry_wrench(const Wrench& w, const Vec3& from, const Vec3& to) noexcept {
  return Wrench{w.force, w.torque + (from - to).cross(w.force)};
}

void compute_feedback(const Model& model, Data& data) noexcept {
  data.stages_run |= kStageFeedback;  // the stage report (step_stages.hpp)
  const int a = data.held_body;
  const bool held = a >= 0 && a < model.num_bodies();
  const bool spring = model.coupling_mode != CouplingMode::kDirect &&
                      model.coupling_mode != CouplingMode::kAdmittance;
  // The held body's target is not finite (kInvalidTarget, apply_coupling()): the device keeps
  // the last step's wrench rather than a step to zero and back in the hand (docs/safety.md).
  if (spring && held && !target_is_finite(data.target, data.target_twist)) return;
  data.feedback_wrench = Wrench{};
  for (Wrench& w : data.body_feedback) w = Wrench{};
  if (!spring) return;  // no spring to feed back: the device is position controlled (admittance)
  bool any = false;
  int last_group = 0;
  for (std::size_t i = 0; i < data.bodies.size(); ++i) {
    const bool own = data.body_targets[i].enabled && static_cast<int>(i) != a;
    const Pose* target = nullptr;
    const Twist* twist = nullptr;
    if (held && static_cast<int>(i) == a) {
      target = &data.target;
      twist = &data.target_twist;
    } else if (own && target_is_finite(data.body_targets[i].pose, data.body_targets[i].twist)) {
      target = &data.body_targets[i].pose;
      twist = &data.body_targets[i].twist;
    } else {
      continue;
    }
    data.body_feedback[i] = feedback_wrench_unsaturated(feedback_gains(model, data.feedback_group[i]),
                                                        *target, *twist, data.bodies[i]);
    last_group = std::max(last_group, data.feedback_group[i]);
    any = true;
  }
  if (!any) return;
  if (!held) {
    // Nothing held: no composite; each body's wrench is clamped on its own.
    for (std::size_t i = 0; i < data.body_feedback.size(); ++i) {
      const FeedbackGains& f = feedback_gains(model, data.feedback_group[i]);
      data.body_feedback[i] = saturate_wrench(data.body_feedback[i], f.max_force, f.max_torque);
    }
    return;
  }
  // Per group (one device's bodies; Data::feedback_group): saturate the composite by one ratio
  // for force and torque, and scale the group's per-body wrenches by it: carried to the
  // reference point (Eq. 9) they sum to the saturated composite exactly, so the motors
  // (Σ J_lᵀ w_l) get the wrench that is logged. The held body's group's composite, about its
  // target, is the feedback wrench; another group's is about its device's controlled frame
  // (Data::feedback_point: its tool, as the held body's target is device 0's — about a point
  // behind the tool, a trocar, the force's moment would take the torque limit and scale the
  // whole wrench down), or its first body's target without one.
  const int held_group = data.feedback_group[static_cast<std::size_t>(a)];
  for (int g = 0; g <= last_group; ++g) {
    Wrench total;
    bool in_group = false;
    const auto gi = static_cast<std::size_t>(g);
    const bool own_point =
        g != held_group && gi < data.feedback_point.size() && data.feedback_point[gi].allFinite();
    Vec3 ref = own_point ? data.feedback_point[gi] : data.target.position;
    for (std::size_t i = 0; i < data.bodies.size(); ++i) {
      if (data.feedback_group[i] != g) continue;
      const Pose* target = nullptr;
      if (static_cast<int>(i) == a)
        target = &data.target;
      else if (data.body_targets[i].enabled &&
               target_is_finite(data.body_targets[i].pose, data.body_targets[i].twist))
        target = &data.body_targets[i].pose;
      else
        continue;
      if (!in_group && g != held_group && !own_point) ref = target->position;
      in_group = true;
      const Wrench carried = carry_wrench(data.body_feedback[i], target->position, ref);  // Eq. 9
      total.force += carried.force;
      total.torque += carried.torque;
    }
    if (!in_group) continue;
    const FeedbackGains& f = feedback_gains(model, g);  // the group's device's saturation
    const Wrench sat = saturate_wrench(total, f.max_force, f.max_torque);
    const double fn = total.force.norm();
    const double tn = total.torque.norm();
    const double sf = fn > 0.0 ? sat.force.norm() / fn : 1.0;
    const double st = tn > 0.0 ? sat.torque.norm() / tn : 1.0;
    const double ratio = std::min(sf, st);
    if (g == held_group) data.feedback_wrench = Wrench{ratio * total.force, ratio * total.torque};
    if (ratio < 1.0)
      for (std::size_t i = 0; i < data.bodies.size(); ++i) {
        if (data.feedback_group[i] != g) continue;
        data.body_feedback[i].force *= ratio;
        data.body_feedback[i].torque *= ratio;
      }
  }
}

}  // namespace numen::core
