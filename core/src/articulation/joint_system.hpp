#pragma once
/// @file joint_system.hpp
/// Private to numen::core (core/src/articulation; tests reach it through numen_core_internal).
/// The joint rows of one time step: Baumgarte-stabilised right-hand sides
/// (paper Eq. 5), the transposed product Gᵀ y, the multipliers and reactions
/// (Eq. 4), and the drift measured after the step. The integrators
/// (integrator.hpp) put these rows into the KKT system solved by
/// articulation.hpp; docs/articulation.md derives the scheme.
///
/// Constraint of one step of length h (configuration q0, twists u0 at the
/// step's start, u1 = u0 + Δu, positions x1 = x0 + h v1, q1 = exp(h ω1) q0):
///   C_pred = C(q0 ⊕ h u0)                   the error after a free drift at u0
///   Ċ0  = 2 (G0 u0 − v_ref) − (C_pred − C0)/h  the error's rate over the last
///                                            step (G0 u0 minus ½ h Ġu, see below)
///   Ċ1  = (Ċ0 − h β C0) / (1 + h α + h² β)   (Baumgarte ODE C̈ + αĊ + βC = 0,
///                                            backward Euler in Ċ and C)
///   C1* = C0 + h Ċ1                          (the error wanted at the step's end)
///   G0 Δu = c = (C1* − C_pred) / h − (G_pred − G0) Δu_prev,
/// with G_pred the rows at the drifted configuration and Δu_prev the last
/// step's velocity change: C(q1) ≈ C_pred + h G_pred Δu = C1* up to
/// O(h² |Δu − Δu_prev| |u|). The KKT system and the reactions use G0 (the
/// impulse along the start configuration's rows, as in SHAKE: no numerical
/// damping of the articulation's energy). v_ref is a prescribed joint's rate. Why Ċ0 is not just G0
/// u0: with chord velocities, (C_pred − C0)/h = G0 u0 + ½ h Ġu, so G0 u0 overstates the error's
/// mean rate by ½ h Ġu (the centripetal term); taking it as Ċ0 leaves a steady error h² Ġu. With α
/// = 2/h, β = 1/h² (the paper's defaults) the error contracts by 1/2 per step, critically damped,
/// for any h. With Integrator::kTrapezoidal the twists u0 are node velocities (projected onto G u =
/// v_ref at the end of the last step, integrator.hpp), not chords: Ċ0 = G0 u0 − v_ref, and Δu is
/// the half step's Δu½ (positions move over h with u0 + Δu½).

#include <span>

#include "numen/core/joint.hpp"
#include "numen/core/types.hpp"

namespace numen::core {

struct Model;
struct Data;

/// Evaluates every joint's rows at the current body states (Data::bodies
/// positions and orientations) into ArticulationScratch::rows (Data::scratch) and the
/// right-hand sides c into `rhs` (one JointVector per joint), using the step's
/// start twists `twist0` (one Vec6 (v, ω) per body), the previous step's
/// velocity changes `delta_prev` (one Vec6 per body, zero after a reset) and, for prescribed
/// joints, Data::joint_prescribed. Also stores c in Data::joints[j].baumgarte_rhs.
/// No allocation.
void build_joint_rows(const Model& model, Data& data, std::span<const Vec6> twist0,
                      std::span<const Vec6> delta_prev, std::span<JointVector> rhs) noexcept;

/// out_b += Σ_j G_j,bᵀ y_j for every body b that is not known
/// (ArticulationScratch::known) — the generalized force of multipliers y.
void add_joint_transpose(const Model& model, const Data& data, std::span<const JointVector> y,
                         std::span<Vec6> out) noexcept;

/// From the solution y of the KKT system (H [Δu; y] = [b; c]) of the step h_s
/// = SolverScratch::system_step (Model::dt, or dt/2 for the trapezoidal rule):
/// λ = −y / h_s (N or N·m per row) into Data::joints[j].multiplier, and the
/// reaction on the child G_childᵀ λ into Data::joints[j].reaction.
void store_joint_multipliers(const Model& model, Data& data, std::span<const JointVector> y) noexcept;

/// After the step: C of every joint at the new configuration into
/// Data::joints[j].position_error and coordinate, and the largest linear and
/// angular errors into Data::max_joint_drift / max_joint_angle_drift. Sets its
/// bit of Data::stages_run (kStageJointDrift, step_stages.hpp).
void measure_joint_drift(const Model& model, Data& data) noexcept;

}  // namespace numen::core
