/// @file feedback.cpp
/// Device feedback by virtual coupling (paper Eq. 8).

#include "numen/core/feedback.hpp"

#include "numen/core/coupling.hpp"
#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/rigid_body.hpp"

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

Wrench feedback_wrench(const FeedbackGains& gains, const Pose& target, const Twist& target_twist,
                       const BodyState& state) noexcept {
  Wrench w;
  w.force = gains.k_t * (state.position - target.position) +
            gains.gamma_t * (state.linear_velocity - target_twist.linear);
  w.torque = gains.k_r * quat_log(state.orientation * target.orientation.conjugate()) +
             gains.gamma_r * (state.angular_velocity - target_twist.angular);
  return saturate_wrench(w, gains.max_force, gains.max_torque);
}

void compute_feedback(const Model& model, Data& data) noexcept {
  data.feedback_wrench = Wrench{};
  const int b = data.attached_body;
  if (b < 0 || b >= model.num_bodies() || model.coupling_mode == CouplingMode::kDirect) return;
  if (!target_is_finite(data.target, data.target_twist)) return;
  data.feedback_wrench = feedback_wrench(model.feedback, data.target, data.target_twist,
                                         data.bodies[static_cast<std::size_t>(b)]);
}

}  // namespace numen::core
