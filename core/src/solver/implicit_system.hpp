#pragma once
/// @file implicit_system.hpp
/// Private to numen::core (core/src/solver): the builders and solves of the
/// bodies' implicit system A Δu = b, A = M − h_s D − h_s² K (integrator.hpp),
/// that the linearised schemes are made of — the implicit gyroscopic step, the
/// assembly of the 6×6 blocks and right-hand side, the matrix-free product, the
/// block-Jacobi CG and the joints' projected CG (both through detail::pcg()).
/// Reached by the tests through the numen_core_internal target.

#include <span>

#include "scratch/solver_scratch.hpp"
#include "numen/core/integrator.hpp"
#include "numen/core/types.hpp"

namespace numen::core {

struct Model;
struct Data;

/// h_s of Model::integrator (SolverScratch::system_step): Model::dt for the linearly implicit
/// and the symplectic Euler, Model::dt / 2 for the trapezoidal rule. The integrate stage sets
/// SolverScratch::system_step to it; the forces stage does not read it (the nets are
/// linearised over it by the integrator: linearize_nets(), net_solve.hpp).
double linearized_system_step(const Model& model) noexcept;

/// Constants of TR-BDF2 (Integrator::kTrBdf2; Bank et al. 1985, Hosea & Shampine 1996).
namespace tr_bdf2 {
/// γ = 2 − √2: the trapezoidal stage ends at t + γh.
inline constexpr double kGamma = 0.58578643762690495119831127579030192143;  // 2 − √2
/// h_s / h of both stages: γ/2 (trapezoidal stage) = (1 − γ)/(2 − γ) (BDF2 stage) = 1 − 1/√2.
inline constexpr double kStageStep = 0.29289321881345247559915563789515096072;
/// a = 1/(γ (2 − γ)) = (1 + √2)/2: BDF2's weight of the stage value, y1 = a y_γ − (a − 1) y0
/// + h_s F(y1).
inline constexpr double kStageWeight = 1.20710678118654752440084436210484903928;
}  // namespace tr_bdf2

/// First part of the implicit step: stores u0 (SolverScratch::twist0) and the
/// world inertias at the step's start, then replaces the angular velocity of
/// every body in the solve (not kDirect, not a first-order coupled body) by
/// the implicit gyroscopic update implicit_gyroscopic_velocity() (Catto, GDC
/// 2015) over SolverScratch::system_step. Call after the forces stage, before
/// build_implicit_system().
void prepare_implicit_step(const Model& model, Data& data) noexcept;

/// Builds the implicit system of the current step in the solver scratch (Data::scratch, SolverScratch; after
/// prepare_implicit_step()): contact weights (α, β of ContactTerm), the 6×6
/// diagonal blocks of A = M − hD − h²K, h = SolverScratch::system_step (exactly symmetric) and, for
/// a model without joints (the block-Jacobi preconditioner; with joints the tree solve factors
/// them), their Cholesky factors, the packed body–body contacts (SolverScratch::cross_contacts)
/// with the `coupled` flags, and the right-hand side
///   b = h (f0 + h K u0) + M (u* − u0),
/// where u* is Data::bodies' twist after the implicit gyroscopic step (apply
/// that to the state first), f0 = Data::body_wrench, K and D from the coupling
/// springs of SolverScratch::coupled_body (−diag(k_t I3, k_r I3),
/// −diag(γ_t I3, γ_r I3)) and each active contact (K = −k Gᵀ n nᵀ G,
/// D = −c Gᵀ n nᵀ G − μ Gᵀ (I − n nᵀ) G; K u0 uses the contact's normal
/// velocity v_n = n · G u0 stored by compute_contact_forces()). A first-order
/// body (kFirstOrder, γ_t, γ_r > 0) has M_i := 0, giving (γ + h k) v1 = k e + γ v_t + F_other.
/// Rows of a kDirect body are removed (b_i = 0): its twist is known.
void build_implicit_system(const Model& model, Data& data) noexcept;

/// Matrix-free product out = A · in with A = M − hD − h²K as built by
/// build_implicit_system(). Spans have one Vec6 (linear; angular) per body.
/// Rows and columns of bodies not in the solve are zero.
void apply_implicit_system(const Model& model, const Data& data, std::span<const Vec6> in,
                           std::span<Vec6> out) noexcept;

/// Adds the off-diagonal body–body blocks of A = M − hD − h²K times `in` to
/// `out`: for each packed cross contact (SolverScratch::cross_contacts, both
/// bodies in the solve), out_a −= G_aᵀ W G_b in_b and out_b −= G_bᵀ W G_a in_a
/// (G_a = [I, −[r_a]×], W = α n nᵀ + β I). With the diagonal blocks
/// (SolverScratch::block) this is apply_implicit_system(). Spans: one Vec6
/// (linear; angular) per body.
void add_cross_contact_terms(const SolverScratch& s, std::span<const Vec6> in,
                             std::span<Vec6> out) noexcept;

/// Joint-constrained solve of the implicit step (paper Eq. 4, Eq. 7):
///   [A  Gᵀ] [Δu]   [b]
///   [G  0 ] [y ] = [c],   c from build_joint_rows() (Baumgarte, Eq. 5),
/// A = M − hD − h²K as built by build_implicit_system(). The block-diagonal
/// part of A with G is factored in linear time (articulation.hpp, Baraff
/// 1996); without body–body contacts that is the exact solution. With them,
/// a projected preconditioned conjugate gradient (Gould, Hribar & Nocedal,
/// SIAM J. Sci. Comput. 23(4), 2001) iterates on the null space of G with the
/// tree solve as constraint preconditioner and their residual update
/// (r ← r − Gᵀ yz after each preconditioning), stopping on ‖r‖/‖b‖.
/// Writes SolverScratch::delta, joint_y, Data::solver_iterations/residual,
/// Data::joints multipliers. Returns true when converged.
bool solve_constrained_system(const Model& model, Data& data) noexcept;

/// Velocity step of RATTLE (Andersen 1983; Hairer, Lubich & Wanner, "Geometric Numerical
/// Integration", §VII.1.4) for the second-order schemes with joints (the trapezoidal rule, and
/// both stages of TR-BDF2), after the bodies' poses and twists were moved to the end of the
/// (stage) solve. With `remove_half_impulse` (the trapezoidal rule and TR-BDF2's trapezoidal
/// stage), the extrapolated twist u1 = 2 u½ − u0 first loses one copy of the half step's joint
/// impulse, A⁻¹ G0ᵀ y (SolverScratch::joint_y; per body with its diagonal block of A, so exact
/// without body–body contacts and nets). Then u1 is projected onto the joints' velocity
/// constraint at the new configuration, G1 u1 = v_ref, in the metric of the step's diagonal
/// blocks of A = M − h_s D − h_s² K (M where no spring or contact acts, as in RATTLE; with stiff
/// springs and contacts A, so that the second half's joint impulse meets the same implicit
/// resistance as the first's — measured on the instrument against the tissue: M there doubles
/// the error and leaves the reference unconverged):
///   [A  G1ᵀ] [δ]   [0            ]
///   [G1  0 ] [y] = [v_ref − G1 u1],   u1 ← u1 + δ,
/// solved in linear time by the tree solve (articulation.hpp), the rows evaluated at the new
/// configuration and a prescribed joint at value + `elapsed` · rate (`elapsed`: time from the
/// step's start to the new configuration, s). Without it u1 keeps a constraint velocity
/// G1 u1 ≈ −G0 u0 that alternates in sign and feeds the next step's Baumgarte rows: the free
/// double pendulum then converges at order 1 only. Known (imposed) bodies count as at rest,
/// as in build_joint_rows(). Reads SolverScratch::block (A) and joint_y; uses block_factor,
/// projected_residual, residual, a_direction, joint_rhs and joint_y_correction as scratch
/// (the step's solve is done). Only in builds with joints (NUMEN_WITH_ARTICULATION).
void project_joint_velocities(const Model& model, Data& data, double elapsed,
                              bool remove_half_impulse) noexcept;

/// The solve of the linearised system built for this step (after build_implicit_system() and,
/// for a model with nets, build_net_system()): the net solve, the joints' solve or the bodies'
/// block-Jacobi CG, whichever compiled_stages() names (step_stages.hpp), setting its bit of
/// Data::stages_run (kStageNetSolve, kStageJointSolve) and kSolverNotConverged when it ends
/// above the tolerance. Writes SolverScratch::delta (Δu) and NetScratch::delta (Δv). Returns
/// true when converged.
bool solve_linearized_system(const Model& model, Data& data) noexcept;

/// Preconditioned conjugate gradient on A Δu = b (SolverScratch::rhs) with the
/// block-Jacobi preconditioner of the 6×6 body blocks; Δu starts at 0.
/// Stops when ‖r‖/‖b‖ ≤ model.solver.tolerance or after
/// model.solver.max_iterations. Writes SolverScratch::delta,
/// Data::solver_iterations and Data::solver_residual (relative); returns true
/// when converged. Exact in one iteration when A is block diagonal (no
/// body–body contact). A non-finite b gives a NaN Δu (rejected by step()'s
/// checks). Fixed summation order: bit-for-bit deterministic.
/// For a body without cross contacts (SolverScratch::coupled = 0), (A p)_i =
/// B_i p_i and z_i = B_i⁻¹ r_i satisfy the exact recurrences
/// z_i ← z_i − α p_i and (A p)_i ← r_i + β (A p)_i, which replace its 6×6
/// product and block solve in the iterations (same iterates in exact
/// arithmetic).
bool solve_implicit_system(const Model& model, Data& data) noexcept;

}  // namespace numen::core
