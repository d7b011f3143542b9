#pragma once
/// @file rigid_body.hpp
/// Rigid-body kinematics and inertia helpers (paper Eq. 1: m ẍ = ΣF,
/// I Ω̇ = ΣT − Ω×IΩ, q̇ = ½ Ω q). Conventions: a body's state is its COM
/// position x (m), unit quaternion q (body → world, Hamilton), linear velocity
/// v of the COM (m/s) and angular velocity ω (rad/s), both world frame.
/// Every function here is noexcept, allocation-free and deterministic.

#include "numen/core/types.hpp"

namespace numen::core {

struct Model;
struct Data;
struct BodyModel;
struct BodyState;

/// Cross-product matrix [v]× (3×3) such that [v]× w = v × w.
Mat3 skew(const Vec3& v) noexcept;

/// World inertia I_w = R I_b Rᵀ (kg·m², about the COM) of a body whose
/// orientation is `q` (unit, body → world) and body-frame inertia `inertia_body`.
Mat3 world_inertia(const Quat& q, const Mat3& inertia_body) noexcept;

/// Same, from the rotation matrix R (body → world) when the caller already has it.
Mat3 world_inertia(const Mat3& rotation, const Mat3& inertia_body) noexcept;

/// Inverse world inertia I_w⁻¹ = R I_b⁻¹ Rᵀ (1/(kg·m²)) from the precomputed
/// body-frame inverse (BodyModel::inertia_body_inv).
Mat3 world_inertia_inverse(const Quat& q, const Mat3& inertia_body_inv) noexcept;

/// Exact quaternion exponential of a rotation vector φ (rad, any frame):
/// exp(½ φ) = (cos(|φ|/2), sin(|φ|/2) φ/|φ|), the rotation of angle |φ| about
/// φ/|φ|. Smooth at φ = 0 (Taylor series of sin(θ/2)/θ below 1e-4 rad).
/// Result has unit norm up to rounding.
Quat quat_exp(const Vec3& rotation_vector) noexcept;

/// Shortest-arc logarithm: the rotation vector θu (rad) of `q`, with θ in
/// [0, π]. q and −q give the same result (w < 0 is negated first). Robust at
/// θ → 0 and θ → π: θ = 2·atan2(‖vec‖, w), never acos. `q` need not be unit
/// (scale-invariant); a zero quaternion returns the zero vector.
Vec3 quat_log(const Quat& q) noexcept;

/// Orientation after a step h (s) at constant world angular velocity ω
/// (rad/s): q1 = exp(½ h ω) ⊗ q0 with the exact exponential (not the first
/// order q + ½ h ω q), renormalised. Source: paper Eq. 1, q̇ = ½ Ω q.
Quat integrate_orientation(const Quat& q0, const Vec3& omega_world, double h) noexcept;

/// Explicit gyroscopic torque −ω × (I_w ω) (N·m, world) for the world inertia
/// `inertia_world` and world angular velocity `omega` (rad/s). Paper Eq. 1.
Vec3 gyroscopic_torque(const Mat3& inertia_world, const Vec3& omega) noexcept;

/// Implicit gyroscopic update of the angular velocity over a step h (s):
/// one Newton step on the body-frame residual
///   f(ω_b) = I_b (ω_b − ω_b0) + h ω_b × I_b ω_b,
///   J = I_b + h ([ω_b]× I_b − [I_b ω_b]×),  ω_b1 = ω_b0 − J⁻¹ f(ω_b0),
/// then mapped back to the world. Returns the new world ω (rad/s). Stable for
/// fast spins about any axis. If J is numerically singular, returns ω
/// unchanged. Source: E. Catto, "Numerical Methods", GDC 2015; Bullet's
/// btRigidBody::computeGyroscopicImpulseImplicit_Body.
Vec3 implicit_gyroscopic_velocity(const Quat& q, const Mat3& inertia_body,
                                  const Vec3& omega_world, double h) noexcept;

/// Same, from the rotation matrix R of q (body → world) when the caller
/// already has it (the implicit integrator shares it with world_inertia()).
Vec3 implicit_gyroscopic_velocity(const Mat3& rotation, const Mat3& inertia_body,
                                  const Vec3& omega_world, double h) noexcept;

/// Kinetic energy ½ m v·v + ½ ω·I_w ω (J) of a body in `state`.
double kinetic_energy(const BodyModel& body, const BodyState& state) noexcept;

/// True when every component of the state (position, quaternion, velocities)
/// is finite.
bool state_is_finite(const BodyState& state) noexcept;

/// Forces stage, explicit part: sets Data::body_wrench[i] = (m_i g, 0) +
/// Data::applied_wrench[i] for every body (N, N·m, world, about the COM).
/// Coupling (apply_coupling) and contacts (compute_contact_forces) add to it.
void apply_external_forces(const Model& model, Data& data) noexcept;

}  // namespace numen::core
