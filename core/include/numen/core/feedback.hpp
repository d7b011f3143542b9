#pragma once
/// @file feedback.hpp
/// Device feedback by virtual coupling (paper Eq. 8): the stretch of a damped
/// spring between the god-object and the device target is sent back to the
/// device's motors, with its own gains (Model::feedback; zero for a
/// non-haptic device) and a norm saturation.

#include "numen/core/types.hpp"

namespace numen::core {

struct Model;
struct Data;
struct BodyState;
struct FeedbackGains;

/// Scales `w.force` to norm ≤ max_force (N) and `w.torque` to norm ≤
/// max_torque (N·m), keeping their directions. Infinite limits leave the
/// part unchanged; a zero limit zeroes it.
Wrench saturate_wrench(const Wrench& w, double max_force, double max_torque) noexcept;

/// Eq. 8 feedback wrench (N, N·m; world, about the target point), saturated:
///   F_d = k_d (x − x_t) + γ_d (v − v_t),
///   T_d = k_rd θu' + γ_rd (ω − ω_t),   θu' = shortest-arc angle-axis of q q_t⁻¹,
/// i.e. the device is pulled towards the god-object `state`.
Wrench feedback_wrench(const FeedbackGains& gains, const Pose& target, const Twist& target_twist,
                       const BodyState& state) noexcept;

/// Eq. 8 without the saturation.
Wrench feedback_wrench_unsaturated(const FeedbackGains& gains, const Pose& target,
                                   const Twist& target_twist, const BodyState& state) noexcept;

/// Paper Eq. 9: the same wrench `w` (taken about point `from`) about point
/// `to`: force unchanged, torque + (from − to) × force. World frame, m, N, N·m.
Wrench carry_wrench(const Wrench& w, const Vec3& from, const Vec3& to) noexcept;

/// Feedback stage, after integration. For the held body (target
/// Data::target) and every body with its own enabled target (Eq. 6,
/// Data::body_targets): Data::body_feedback[i] = Eq. 8 about that body's
/// target point. Data::feedback_wrench = Σ of these carried to the held
/// body's target point (Eq. 9: a child's feedback carried to its parent, up
/// to the held body), saturated by one ratio r = min(F_max/|F|, T_max/|T|, 1)
/// that also scales every per-body wrench, so that the per-body wrenches
/// carried to that point sum to the composite exactly. Each feedback group
/// (device, Data::feedback_group) is saturated on its own with its own
/// limits (feedback_gains()): the held body's group about the held body's
/// target, another group about its device's controlled frame
/// (Data::feedback_point; its first targeted body's target without one). When no body is
/// held the composite is zero and each per-body wrench is saturated on its
/// own. When the held body's target is not finite (kInvalidTarget) the
/// composite and the per-body wrenches keep the values of the last step (a
/// hold, not a drop to zero: docs/safety.md "Invalid targets"). All zero in
/// CouplingMode::kDirect and kAdmittance.
/// Sets its bit of Data::stages_run (kStageFeedback, step_stages.hpp).
void compute_feedback(const Model& model, Data& data) noexcept;

}  // namespace numen::core
