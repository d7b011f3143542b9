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

/// Feedback stage: Data::feedback_wrench = feedback_wrench() of the attached
/// body after integration; zero when no body is attached, in
/// CouplingMode::kDirect, or when the target is not finite.
void compute_feedback(const Model& model, Data& data) noexcept;

}  // namespace numen::core
