#pragma once
/// @file net_solve.hpp
/// Linearly implicit Euler of the rigid bodies and the deformable nets as one
/// system (paper §4.2, §5; Baraff & Witkin 1998): unknowns Δu per body (6)
/// and Δv per node (3),
///   (M − h D − h² K) [Δu; Δv] = h (f0 + h K [u0; v0]) + [M (u* − u0); 0],
/// with the stiffness and damping Jacobians of the coupling springs, the
/// contacts (bodies and nodes), the net springs (S = α d̂d̂ᵀ + β I per spring,
/// net_state.hpp SpringTerm; the transverse term max(0, 1 − L/l) is dropped
/// under compression so that S stays positive semidefinite, Choi & Ko 2002)
/// and the zero-length ties (c = h γ_tie + h² k_tie per node:
/// A_ii += c I, A_ib = −c J_i, A_bb += c J_iᵀ J_i, J_i = [I, −[ρ_i]×]).
/// Geometric terms (changes of directions and lever arms) are neglected.
///
/// Solved by a preconditioned conjugate gradient on that fixed sparsity
/// (matrix-free: one 3×3 weight per spring, per node contact and per node),
/// warm-started from the last step's Δv. Preconditioner: the "arrowhead" part
/// of A — every body block, every node's 3×3 block and the tie blocks between
/// a net and its rigid component — inverted exactly by eliminating the nodes
/// onto the bodies (Schur blocks S_b = A_bb − Σ c² J_iᵀ A_ii⁻¹ J_i), so the
/// stiff tie coupling of a net to its rigid component costs no iteration;
/// only net springs, node–body contacts and body–body contacts are left to
/// the iteration. With joints, the body part of the preconditioner is the
/// tree solve (articulation.hpp) with the Schur blocks, used as a constraint
/// preconditioner in a projected CG with Gould, Hribar & Nocedal's residual
/// update, as solve_constrained_system() does (integrator.hpp).

namespace numen::core {

struct Model;
struct Data;

/// Adds the nets' terms to the diagonal blocks and right-hand sides of the
/// bodies (SolverScratch::block, rhs) — ties c Σ J_iᵀ J_i and
/// h² k_tie Σ J_iᵀ (v_i0 − v_a0), node–body contacts J_bᵀ W J_b and their
/// impulse — for bodies in the solve. Called by build_implicit_system()
/// before it mirrors and factors the blocks. No-op without nets.
void add_net_body_terms(const Model& model, Data& data) noexcept;

/// Builds the node rows: 3×3 diagonal blocks (mass, ties, springs, contacts)
/// and their inverses, spring and node-contact weights, right-hand side
///   b_i = h f_i − h² k_tie (v_i0 − v_a0) − h² Σ_springs k K̃ (v_i0 − v_j0) − h² k_c v_n n,
/// and the bodies' Schur blocks of the preconditioner (NetScratch). Call
/// after build_implicit_system().
void build_net_system(const Model& model, Data& data) noexcept;

/// Solves the coupled system (see file comment). Writes SolverScratch::delta
/// (Δu), NetScratch::delta (Δv), the joint multipliers when the model has
/// joints, Data::solver_iterations and Data::solver_residual (‖r‖/‖b‖).
/// Returns true when converged to Model::solver.tolerance within
/// Model::solver.max_iterations. A non-finite system gives NaN unknowns
/// (rejected by step()'s checks). Deterministic; no allocation.
bool solve_net_system(const Model& model, Data& data) noexcept;

}  // namespace numen::core
