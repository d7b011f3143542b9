#pragma once
/// @file coupling.hpp
/// Coupling of the god-object to the device target (paper Eq. 2, §3, Fig. 5):
///   F = k_t (x_t − x) + γ_t (v_t − v),
///   T = k_r θu + γ_r (ω_t − ω),   θu = shortest-arc angle-axis of q_t q⁻¹,
/// a zero-length damped spring pair acting at the COM of the held body
/// (Data::held_body, Data::target; gains BodyModel::coupling) and, for an
/// articulated tool, of every body with its own enabled target
/// (Data::body_targets, paper Eq. 6: one spring per body; bodies without a
/// target are left to the simulation). Modes
/// (Model::coupling_mode): kGodObject (this wrench on a body with mass),
/// kFirstOrder (massless limit, handled by the integrator), kDirect (pose and
/// twist imposed: impose_direct_target()), kAdmittance (no spring: the measured
/// device wrench Data::device_wrench on the held body, apply_device_wrench()).

#include "numen/core/types.hpp"

namespace numen::core {

struct Model;
struct Data;
struct BodyState;
struct CouplingGains;

/// Rotation error θu (rad, world frame) that takes orientation `q` to
/// `q_target`: the shortest-arc angle-axis of q_target q⁻¹, θ in [0, π]
/// (quat_log). Invariant under q → −q and q_target → −q_target. Smooth at
/// θ = 0; uses atan2, robust at θ = π. Paper Eq. 2 (α u).
Vec3 rotation_error(const Quat& q_target, const Quat& q) noexcept;

/// Coupling wrench of Eq. 2 (N, N·m; world, at the COM) pulling `state`
/// towards `target`/`target_twist` with `gains`.
Wrench coupling_wrench(const CouplingGains& gains, const Pose& target, const Twist& target_twist,
                       const BodyState& state) noexcept;

/// True when the target pose and twist are finite and the target quaternion
/// has a non-negligible norm (> 1e-9). A device target failing this check is
/// ignored for the step (StepStatus::kInvalidTarget).
bool target_is_finite(const Pose& target, const Twist& target_twist) noexcept;

/// True when the first-order (massless) coupling can be used with `gains`:
/// γ_t > 0 and γ_r > 0. Otherwise CouplingMode::kFirstOrder falls back to the
/// god-object model (kGodObject) for that body.
bool first_order_applicable(const CouplingGains& gains) noexcept;

/// Imposes every anchored body (BodyModel::anchored) at its initial pose with a zero twist,
/// in every coupling mode; then, in kDirect only, imposes x, q, v, ω of the held
/// body := Data::target / target_twist, and of every other body with an
/// enabled Data::body_targets entry := that target (q normalised), and marks
/// them in SolverScratch::imposed, i.e. moving bodies of infinite mass for the
/// rest of the step (their joints to each other are disabled). With a
/// non-finite target, sets kInvalidTarget and holds that body still (pose
/// kept, twist zeroed). Imposes only when Model::stage_plan has
/// kStageDirectTarget (kDirect or an anchored body), and then records itself in
/// Data::stages_run (step_stages.hpp).
/// Call before detect_contacts() so that contacts see the imposed pose.
void impose_direct_target(const Model& model, Data& data) noexcept;

/// kAdmittance only (no-op otherwise, and without a held body): adds Data::device_wrench
/// (world; N at, N·m about, the held body's COM) to the held body's explicit wrench
/// and copies it to Data::coupling_wrench (the wrench that drives the god-object). A
/// non-finite device wrench is ignored for the step and sets kInvalidTarget. Called by
/// apply_coupling().
void apply_device_wrench(const Model& model, Data& data) noexcept;

/// Coupling stage (Eq. 2, Eq. 6): computes Data::coupling_wrench for the
/// held body and adds it to body_wrench, adds the springs of every other
/// body with an enabled Data::body_targets entry (always second order), and
/// records in Data::solver which bodies are coupled (target_coupled,
/// coupled_body) and whether the held one is first order (first_order).
/// Nothing in kDirect mode; in kAdmittance the held body gets apply_device_wrench()
/// instead of the spring (the other bodies' Eq. 6 springs are kept); a body whose target is not finite gets no spring
/// this step and kInvalidTarget is set in Data::status. Call after
/// apply_external_forces().
void apply_coupling(const Model& model, Data& data) noexcept;

}  // namespace numen::core
