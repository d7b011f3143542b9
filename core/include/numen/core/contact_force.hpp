#pragma once
/// @file contact_force.hpp
/// Penalty contact forces (paper §5) and their Jacobians for the implicit
/// integrator. For a contact with normal n (unit, from b towards a), depth
/// d > 0 and lever arms r_a, r_b (contact point − COM, world):
///   v_rel = (v_a + ω_a × r_a) − (v_b + ω_b × r_b)    (b static: 0),
///   v_n   = n · v_rel,
///   f_n   = max(0, k d − c v_n)                       (no pulling),
///   f_t   = −μ (v_rel − v_n n)                        (viscous friction),
///   F     = f_n n + f_t on a at the contact point, −F on b,
/// with k, c, μ = MaterialPair::stiffness, damping, friction. Friction acts
/// only while f_n > 0 (an inactive contact applies nothing).

#include <Eigen/Core>

#include "numen/core/types.hpp"

namespace numen::core {

struct Model;
struct Data;
struct Contact;
struct MaterialPair;
struct BodyState;
struct BodyModel;

using Vec12 = Eigen::Matrix<double, 12, 1>;     ///< Stacked (v_a, ω_a, v_b, ω_b).
using Mat3x12 = Eigen::Matrix<double, 3, 12>;   ///< Twists of a pair → a 3-vector.
using Mat12 = Eigen::Matrix<double, 12, 12>;    ///< Pair Jacobian block.

/// Result of the penalty law at one contact.
struct ContactForceResult {
  Vec3 force = Vec3::Zero();  ///< F on body_a at the contact point (N, world); −F on body_b.
  double normal_force = 0.0;  ///< f_n (N), ≥ 0.
  bool active = false;        ///< f_n > 0.
  /// The law's Jacobian coefficients at this state, for the implicit step (K = −stiffness
  /// Gᵀ n nᵀ G, D = −damping Gᵀ n nᵀ G − friction Gᵀ (I − n nᵀ) G): k, c, μ of the material
  /// for the linear law; for the smoothed onset ∂f_n/∂d = k min(d/δ0, 1) − c s'(d) v_n
  /// (floored at 0 so that K stays negative semidefinite), c s(d) and μ s(d). Set when active.
  double stiffness = 0.0;  ///< N/m.
  double damping = 0.0;    ///< N·s/m.
  double friction = 0.0;   ///< N·s/m.
};

/// Relative velocity (m/s, world) of the contact point of a with respect to
/// that of b: (v_a + ω_a × r_a) − (v_b + ω_b × r_b). `b` may be null (static).
Vec3 contact_relative_velocity(const BodyState& a, const Vec3& r_a, const BodyState* b,
                               const Vec3& r_b) noexcept;

/// Penalty law (see file comment) for a contact of `depth` (m, > 0 means
/// penetrating) and unit `normal` (from b towards a), given the relative
/// velocity `v_rel` (m/s) and the material pair. Never pulls: f_n ≥ 0.
/// With MaterialPair::onset_depth δ0 > 0, the smoothed C¹ onset: with t = d/δ0 and the
/// smoothstep s(d) = 3t² − 2t³ (t < 1), 1 (t ≥ 1),
///   e(d) = k d² / (2 δ0) (d < δ0),  k (d − δ0/2) (d ≥ δ0),
///   f_n = max(0, e(d) − c s(d) v_n),   f_t = −μ s(d) (v_rel − v_n n).
/// e and s are C¹ in d (e(0) = e'(0) = 0, e and e' continuous at δ0; s'(0) = s'(δ0) = 0), so the
/// force is C¹ in the state where f_n > 0 and at the onset d = 0 — the linear law's force jumps
/// there in its derivative by k (and by c v_n, μ v_t in value), which caps a second-order
/// scheme's order at a contact (docs/dynamics.md, "Why contacts cap the order"). The quadratic
/// onset is the Hertz-like regularisation of a penalty contact (the force–depth law of
/// Hunt & Crossley 1975 with exponent 2 over the onset), joined C¹ to the linear law so that deep
/// contacts keep the stiffness k (and the time-constant floor acts on it as before); the rest
/// depth under a load F > k δ0/2 is F/k + δ0/2.
ContactForceResult contact_penalty_force(const Vec3& normal, double depth, const Vec3& v_rel,
                                         const MaterialPair& material) noexcept;

/// The elastic energy (J) the penalty law stores at `depth` (m): ∫₀^d e(x) dx of its elastic force
/// e above — k d²/2 for the linear law; with the smoothed onset δ0, k d³/(6 δ0) below δ0 and
/// k δ0²/6 + k (d² − d δ0)/2 beyond. 0 for d ≤ 0. The material's own k (no time-constant floor).
double contact_elastic_energy(double depth, const MaterialPair& material) noexcept;

/// G (3×12): v_rel = G (v_a, ω_a, v_b, ω_b), G = [I, −[r_a]×, −I, [r_b]×].
/// Gᵀ F is the generalized force (F, r_a × F, −F, −r_b × F) of the pair.
Mat3x12 contact_velocity_jacobian(const Vec3& r_a, const Vec3& r_b) noexcept;

/// Stiffness K = ∂f/∂x and damping D = ∂f/∂u (12×12, symmetric negative
/// semidefinite) of the generalized contact force of the pair, with x the
/// stacked displacements (δx_a, δθ_a, δx_b, δθ_b) (m, rad; δθ a world
/// rotation vector) and u the stacked twists:
///   K = −k Gᵀ n nᵀ G,  D = −c Gᵀ n nᵀ G − μ Gᵀ (I − n nᵀ) G   when active,
///   K = D = 0 otherwise. Geometric terms (changes of n and of the lever arms)
/// are neglected. Baraff & Witkin 1998 §5 form.
void contact_stiffness_damping(const Vec3& normal, const Vec3& r_a, const Vec3& r_b, bool active,
                               const MaterialPair& material, Mat12& stiffness,
                               Mat12& damping) noexcept;

/// Effective mass (kg) of a contact along its unit `normal`: 1 / Σ (1/m + (r × n)ᵀ I_w⁻¹ (r × n))
/// over the contact's dynamic bodies (a, and b when not null), r the lever arm (contact point −
/// COM, world), I_w the world inertia from the body's orientation; the mass a unit normal impulse
/// at the contact point meets. A body whose motion is imposed (`*_imposed`: kDirect) counts as
/// infinitely heavy; +∞ when both are. Joints are left out: a jointed body's contact meets at
/// least this mass, so the floor below clamps on the safe side.
double contact_effective_mass(const BodyModel& a, const BodyState& sa, const Vec3& r_a,
                              bool a_imposed, const BodyModel* b, const BodyState* sb,
                              const Vec3& r_b, bool b_imposed, const Vec3& normal) noexcept;

/// The contact time-constant floor (SolverSettings::contact_max_omega_dt): the largest stiffness
/// (N/m) a contact of effective mass `effective_mass` (kg) acts with at step `dt` (s),
/// m_eff (ω_c h / dt)²; +∞ when the floor is off or the mass infinite.
double contact_stiffness_limit(double effective_mass, double dt, double max_omega_dt) noexcept;

/// Smallest contact_stiffness_limit() a contact of `body` can get (N/m): the effective mass at
/// each of its spheres' centres, minimised over the normal direction (the largest eigenvalue of
/// [r]×ᵀ I⁻¹ [r]×), without joints and at Model::dt. A material stiffness above it is clamped on
/// some contacts of the body; for scene loaders' warnings. +∞ for a body without spheres.
double body_contact_stiffness_limit(const Model& model, int body);

/// Contact force stage: for each contact in data.contacts[0, num_contacts)
/// (filled by detect_contacts), computes the penalty force into
/// Contact::force, the lever arms, normal velocity v_n and activity into
/// SolverScratch::contact_terms, and adds (F, r_a × F) to body_wrench[body_a]
/// and (−F, −r_b × F) to body_wrench[body_b] (at the COMs, world). Contacts
/// with an out-of-range body or material_pair index are ignored (force 0,
/// inactive). Forces on a kDirect body are computed but have no effect (its
/// motion is imposed). Contacts beyond the room of the contact scratch
/// (contact_capacity(model): 0 for a model in which nothing can collide) are
/// dropped as an overflow: num_contacts is cut to the room, contacts_dropped
/// counts them and kContactOverflow is set. The stiffness of each contact is the material's, clamped
/// to contact_stiffness_limit() of its effective mass (the time-constant floor; stored in
/// ContactTerm::stiffness; Data::contacts_clamped is reset here and counts them, with the node
/// contacts' of compute_net_forces(); step() counts the steps in Data::contact_clamped_steps).
/// Fixed contact order. No allocation.
void compute_contact_forces(const Model& model, Data& data) noexcept;

}  // namespace numen::core
