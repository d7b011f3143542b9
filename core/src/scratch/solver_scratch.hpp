#pragma once
/// @file solver_scratch.hpp
/// Private to numen::core (core/src/scratch; tests and benchmarks reach it through
/// numen_core_internal): the integrator's scratch (SolverScratch) and the per-contact
/// terms of its implicit system (integrator.hpp; builders in implicit_system.hpp). Held
/// in DataScratch (data_scratch.hpp) behind Data::scratch, sized once by make_data().

#include <cstdint>
#include <vector>

#include "linalg/block_cholesky.hpp"
#include "numen/core/data.hpp"
#include "numen/core/joint.hpp"
#include "numen/core/types.hpp"

namespace numen::core {

struct Model;

/// Linearisation of one contact for the implicit solve, filled by
/// compute_contact_forces() (lever arms, normal velocity, activity) and the
/// integrator (weight).
struct ContactTerm {
  Vec3 r_a = Vec3::Zero();   ///< Contact point − COM of body_a (m, world).
  Vec3 r_b = Vec3::Zero();   ///< Contact point − COM of body_b (m, world); zero when static.
  double normal_force = 0.0; ///< f_n (N), ≥ 0.
  double normal_velocity = 0.0;  ///< v_n = n · v_rel at the step's start (m/s).
  bool active = false;       ///< f_n > 0: the contact contributes forces and Jacobians.
  /// k_eff (N/m): the material pair's stiffness, clamped by the contact time-constant floor
  /// (SolverSettings::contact_max_omega_dt); the force uses it. When active: the law's ∂f_n/∂d
  /// (contact_penalty_force(): k_eff for the linear law), the Jacobian's stiffness.
  double stiffness = 0.0;
  /// The law's damping and friction coefficients for the Jacobian D (N·s/m): the material
  /// pair's, faded in by the smoothed onset (contact_penalty_force()); set when active.
  double damping = 0.0;
  double friction = 0.0;  ///< See damping (N·s/m).
  bool clamped = false;      ///< k_eff < the material pair's stiffness this step.
  /// Weight W = (h c + h² k) n nᵀ + h μ (I − n nᵀ) = α n nᵀ + β I (N·s/m),
  /// stored as its two scalars: the contact's contribution to A = M − hD − h²K
  /// is Gᵀ W G (G: contact_velocity_jacobian).
  double weight_normal = 0.0;   ///< α = h c + h² k − h μ (N·s/m).
  double weight_isotropic = 0.0;  ///< β = h μ (N·s/m).
};

/// A body–body contact whose two bodies are both in the solve, packed by
/// build_implicit_system() for the cross terms −G_aᵀ W G_b of the matrix-free
/// product (apply_implicit_system()). Same quantities as Contact/ContactTerm.
struct CrossContact {
  int body_a = -1;
  int body_b = -1;
  double weight_normal = 0.0;     ///< α of ContactTerm (N·s/m).
  double weight_isotropic = 0.0;  ///< β of ContactTerm (N·s/m).
  Vec3 normal = Vec3::UnitZ();    ///< n, unit, from b towards a.
  Vec3 r_a = Vec3::Zero();        ///< Lever arm on body_a (m, world).
  Vec3 r_b = Vec3::Zero();        ///< Lever arm on body_b (m, world).
};

/// Moments of the isotropic contact weights β (ContactTerm::weight_isotropic)
/// of one body over their lever arms r, accumulated by build_implicit_system():
/// Σ β Jᵀ J = [[Σβ I, −[Σβ r]×], [[Σβ r]×, tr(Σβ r rᵀ) I − Σβ r rᵀ]], J = [I, −[r]×].
struct IsotropicMoments {
  double sum = 0.0;               ///< Σ β (N·s/m).
  Vec3 first = Vec3::Zero();      ///< Σ β r (N·s).
  Mat3 second = Mat3::Zero();     ///< Σ β r rᵀ (N·s·m).
};

/// Scratch of the integrator, sized once by resize(). Fixed-size Eigen types
/// per body/contact; nothing is resized during step().
struct SolverScratch {
  std::vector<BodyState> saved_state;   ///< State before the current step (non-finite rollback).
  std::vector<Mat3> inertia_world;      ///< I_w per body at the step's start (kg·m²).
  std::vector<Vec6> twist0;             ///< u0 per body: (v, ω) at the step's start.
  std::vector<Vec6> rhs;                ///< b of A Δu = b (N·s, N·m·s).
  std::vector<Vec6> delta;              ///< Δu, the unknowns (m/s, rad/s).
  std::vector<Vec6> residual;           ///< CG residual r.
  std::vector<Vec6> precond_residual;   ///< CG z = P⁻¹ r.
  std::vector<Vec6> direction;          ///< CG search direction p.
  std::vector<Vec6> a_direction;        ///< CG A p.
  std::vector<Mat6> block;              ///< Diagonal 6×6 blocks of A (preconditioner).
  std::vector<IsotropicMoments> isotropic_moments;  ///< Per body, this step's contacts.
  std::vector<BlockCholesky> block_factor;  ///< Cholesky factors of `block` (preconditioner).
  std::vector<std::uint8_t> in_solve;   ///< 1: body's twist is unknown; 0: known (kDirect body).
  std::vector<ContactTerm> contact_terms;   ///< Size max(contact_capacity(), DataOptions::written_contacts), parallel to Data::contacts.
  std::vector<CrossContact> cross_contacts;  ///< Size cross_contact_capacity(); [0, num_cross_contacts) valid.
  int num_cross_contacts = 0;  ///< Active body–body contacts in the solve this step.
  /// 1: the body has a cross contact this step (off-diagonal blocks in its rows
  /// of A); 0: its rows of A are its diagonal block only.
  std::vector<std::uint8_t> coupled;

  // Joints (sized only when the model has joints).
  std::vector<JointVector> joint_rhs;         ///< c of G Δu = c per joint (joint_system.hpp).
  std::vector<JointVector> joint_y;           ///< y of the KKT solve per joint (−impulse per row).
  std::vector<JointVector> joint_y_correction;  ///< y of the preconditioner solve (projected CG).
  std::vector<Vec6> projected_residual;       ///< Gᵀ yz per body (projected CG residual update).

  /// Per body: 1 if its own coupling springs (Eq. 6, Data::body_targets or
  /// the held body's target) act this step; their stiffness and damping
  /// enter the body's block of A.
  std::vector<std::uint8_t> target_coupled;

  /// h_s, the step of the linearised system A = M − h_s D − h_s² K built this step (s):
  /// Model::dt for the linearly implicit and the symplectic Euler, Model::dt / 2 for the
  /// trapezoidal rule (its half step to the midpoint). Every Jacobian weight, the gyroscopic
  /// step and the joint multipliers (λ = −y / h_s) use it; positions always move over Model::dt.
  double system_step = 0.0;

  /// How build_joint_rows() (joint_system.hpp) maps the solve's Δu to the joints' positions:
  /// the positions at the end of the (stage) solve are x0 ⊕ joint_drift_step · (twist0 + Δu),
  /// reached joint_horizon after the step's start (s). Both Model::dt for the Euler schemes and
  /// the trapezoidal rule; γh and γh for TR-BDF2's trapezoidal stage, h_s and h for its BDF2
  /// stage (integrator_tr_bdf2.cpp). Set by every integrator before its solve.
  double joint_drift_step = 0.0;
  double joint_horizon = 0.0;  ///< See joint_drift_step (s).
  /// true: the joints' rate Ċ0 = G0 u0 − v_ref takes u0 from stage_start (TR-BDF2's BDF2 stage,
  /// whose twist0 is the drift twist ũ); false: from twist0.
  bool joint_rate_from_stage_start = false;
  /// true: the joint solve's rows G are evaluated at the drifted configuration
  /// x0 ⊕ joint_drift_step · twist0 instead of x0 (TR-BDF2's BDF2 stage, whose constraint
  /// force acts at the step's end); false: at x0.
  bool joint_rows_at_drift_end = false;

  // TR-BDF2 (integrator_tr_bdf2.cpp), sized for every model.
  std::vector<BodyState> stage_start;  ///< Body states at the step's start.
  /// Per body: the trapezoidal stage's displacement Δx_γ = γh (u0 + Δu½) (linear m; angular:
  /// rotation vector, rad, world).
  std::vector<Vec6> stage_move;
  std::vector<Vec6> stage_delta;  ///< Per body: the trapezoidal stage's Δu_γ = u_γ − u0.
  std::vector<Vec3> stage_gyro;   ///< Per body: ω* − ω0 of the implicit gyroscopic step over h_s.

  int coupled_body = -1;     ///< Body whose coupling springs act this step (-1: none).
  bool first_order = false;  ///< coupled_body uses the massless (first-order) model this step.
  /// Per body: 1 if its pose and twist are imposed from the device this step
  /// (CouplingMode::kDirect: the held body and every targeted body).
  std::vector<std::uint8_t> imposed;

  /// Sizes every buffer for `model`, the contacts' for `written_contacts` at least
  /// (DataOptions::written_contacts). Allocates: make_data() only.
  void resize(const Model& model, int written_contacts = 0);
};

}  // namespace numen::core
