#pragma once
/// @file net_solve.hpp
/// Private to numen::core (core/src/net; tests reach it through numen_core_internal).
/// Linearly implicit Euler of the rigid bodies and the deformable nets as one
/// system (paper §4.2, §5; Baraff & Witkin 1998): unknowns Δu per body (6)
/// and Δv per node (3),
///   (M − h D − h² K) [Δu; Δv] = h (f0 + h K [u0; v0]) + [M (u* − u0); 0],
/// with the stiffness and damping Jacobians of the coupling springs, the
/// contacts (bodies and nodes), the net springs (S = α d̂d̂ᵀ + β I per spring,
/// net_state.hpp SweepSpring; the transverse term max(0, 1 − L/l) is dropped
/// under compression so that S stays positive semidefinite, Choi & Ko 2002)
/// and the zero-length ties (c = h γ_tie + h² k_tie per node:
/// A_ii += c I, A_ib = −c J_i, A_bb += c J_iᵀ J_i, J_i = [I, −[ρ_i]×]).
/// Geometric terms (changes of directions and lever arms) are neglected.
///
/// Solved by a preconditioned conjugate gradient on that fixed sparsity
/// (matrix-free: one 3×3 weight per spring, per node contact and per node),
/// warm-started from the last step's Δv.
///
/// Without joints: SSOR (block symmetric Gauss–Seidel) preconditioning with
/// Eisenstat's trick. Unknowns ordered bodies first (6 each, those in the
/// solve), then nodes in the sweep order (Model::node_sweep_order: reverse
/// Cuthill–McKee per net, ~11 % fewer iterations than the vertex order on
/// an icosphere); A = L + D + Lᵀ with D the body–body
/// part A_BB (diagonal blocks and body–body contact cross terms) and the
/// node blocks A_ii, L the strictly lower blocks (node–body: ties −c J_i and
/// node contacts −W J_r; node–node: springs −W_e, W_e = α d̂d̂ᵀ + β I). With
/// D̃ = blockdiag(body blocks, A_ii) (D without the cross terms), the
/// preconditioner M = (D̃+L) D̃⁻¹ (D̃+Lᵀ) is symmetric positive definite. CG on
/// Â = G̃ᵀ (D̃+L)⁻¹ A (D̃+Lᵀ)⁻¹ G̃ (D̃ = G̃G̃ᵀ), written without square roots
/// (q = G̃ p̂, r̂ = G̃ᵀ w) and with
///   A = (D̃+L) + (D̃+Lᵀ) + (D − 2D̃)   (Eisenstat 1981):
///   K q := (D̃+L)⁻¹ A (D̃+Lᵀ)⁻¹ q = t + (D̃+L)⁻¹ (q + (D − 2D̃) t),  t = (D̃+Lᵀ)⁻¹ q,
/// one backward and one forward block sweep per iteration — the price of
/// one product with A. Since (D̃+Lᵀ) t = q, q + (D − 2D̃) t = Lᵀ t + (D − D̃) t,
/// which the backward sweep gathers as it goes (no block product). Iteration:
///   w = (D̃+L)⁻¹ (b − A x0), q = D̃ w, ρ = wᵀ D̃ w;
///   α = ρ / qᵀ K q, x += α t, w −= α K q, ρ' = wᵀ D̃ w, q = D̃ w + (ρ'/ρ) q.
/// It stops on the error (Model::solver.error_estimate_delay = d ≥ 1,
/// detail::PcgErrorStop): x̂ − x̂_k = G̃⁻¹ (D̃+Lᵀ) (x − x_k) gives
/// ‖x̂ − x̂_k‖_Â = ‖x − x_k‖_A, so Hestenes & Stiefel's Σ_{j=k}^{k+d−1} α_j ρ_j
/// estimates the energy-norm error of Δu, Δv; with bᵀx_{k+d} ≈ ‖x‖²_A it stops
/// when η_k = √(Σ α_j ρ_j / bᵀx_{k+d}) ≤ tolerance and returns x_{k+d}. With
/// d = 0 it stops on the residual instead: wᵀ D̃ w = rᵀ M⁻¹ r, and
/// ‖r‖_{M⁻¹} / ‖b‖_{D̃⁻¹} ≤ tolerance (the norm of the preconditioned residual
/// against b's size in the block-Jacobi norm, bᵀ D̃⁻¹ b, which costs no sweep).
///
/// With joints: the "arrowhead" part of A — every body block, every node's
/// 3×3 block and the tie blocks between a net and its rigid component —
/// inverted exactly by eliminating the nodes onto the bodies (Schur blocks
/// S_b = A_bb − Σ c² J_iᵀ A_ii⁻¹ J_i), the body part by the tree solve
/// (articulation.hpp) with the Schur blocks, used as a constraint
/// preconditioner in a projected CG with Gould, Hribar & Nocedal's residual
/// update, as solve_constrained_system() does (integrator.hpp); it stops on
/// the Euclidean ‖r‖ / ‖b‖.

#include <span>

#include "numen/core/types.hpp"

namespace numen::core {

struct Model;
struct Data;

/// Linearisation of the nets for the implicit solve of step h_s = `system_step`
/// (SolverScratch::system_step, solver_scratch.hpp), from the directions, lengths and
/// lever arms compute_net_forces() stored and the velocities of the step's start:
/// the springs' weights W_e = α d̂d̂ᵀ + β I (SweepSpring, the sweep order), their
/// sum at each node (NetScratch::spring_block, from 0) and the springs' part of
/// the node rows' right-hand side, −h_s² Σ k K̃ (v_i − v_j) (NetScratch::rhs, from
/// 0), which build_net_system() completes (net_solve.hpp); and the ties' sums
/// over each net's nodes for its rigid component's rows (NetScratch::tie_sums,
/// read by add_net_body_terms()). Part of the net solve's assembly: called by the
/// linearised integrators after compute_net_forces() and before the body
/// velocities change (prepare_implicit_step()). No-op without nets. No allocation.
void linearize_nets(const Model& model, Data& data, double system_step) noexcept;

/// Adds the nets' terms to the diagonal blocks and right-hand sides of the
/// bodies (SolverScratch::block, rhs) — ties c Σ J_iᵀ J_i and
/// h² k_tie Σ J_iᵀ (v_i0 − v_a0), node–body contacts J_bᵀ W J_b and their
/// impulse — for bodies in the solve; the ties' sums over the nodes come
/// from linearize_nets() (NetScratch::tie_sums). Called by
/// build_implicit_system() before it mirrors and factors the blocks. No-op
/// without nets.
void add_net_body_terms(const Model& model, Data& data) noexcept;

/// Builds the node rows: 3×3 diagonal blocks (mass, ties, springs, contacts;
/// NetScratch::block) and their inverses (in the sweep order into
/// NetScratch::sweep_nodes without joints, NetScratch::block_inverse with
/// joints), node-contact weights, right-hand side
///   b_i = h f_i − h² k_tie (v_i0 − v_a0) − h² Σ_springs k K̃ (v_i0 − v_j0) − h² k_c v_n n,
/// and, with joints, the bodies' Schur blocks of the arrowhead
/// preconditioner (NetScratch). The springs' terms (their weights, their sum
/// per node in NetScratch::spring_block, their part of b) come from
/// linearize_nets(); this adds the rest. Call after linearize_nets()
/// and build_implicit_system() (whose Cholesky factors of the body blocks
/// are the bodies' D̃ without joints), once per linearize_nets().
void build_net_system(const Model& model, Data& data) noexcept;

/// Solves the coupled system (see file comment). Writes SolverScratch::delta
/// (Δu), NetScratch::delta (Δv), the joint multipliers when the model has
/// joints, Data::solver_iterations and Data::solver_residual: without joints
/// the Hestenes–Stiefel estimate of the relative error ‖x − x_k‖_A / ‖x‖_A of the
/// iterate Model::solver.error_estimate_delay = d iterations before the returned one
/// (detail::PcgErrorStop), or with d = 0 ‖r‖_{M⁻¹} / ‖b‖_{D̃⁻¹} (M the SSOR
/// preconditioner, D̃ its block diagonal); with joints ‖r‖ / ‖b‖.
/// Returns true when converged to Model::solver.tolerance (the error rule: its
/// error_tolerance where set) within
/// Model::solver.max_iterations. A non-finite system gives NaN unknowns
/// (rejected by step()'s checks). Deterministic; no allocation.
bool solve_net_system(const Model& model, Data& data) noexcept;

/// Backward sweep of the SSOR preconditioner (model without joints, after
/// build_net_system()): t = (D̃+Lᵀ)⁻¹ q and g = q + (D − 2D̃) t (computed as
/// Lᵀ t + (D − D̃) t), nodes from last to first in the sweep order, then the
/// bodies. Spans: one Vec6 (linear; angular) per body, one Vec3 per node
/// (indexed by node, not by sweep position), in the units of Δu,
/// Δv (t) and of b (q, g). Bodies not in the solve get t = g = 0. The output
/// spans must not alias the inputs.
void net_backward_sweep(const Model& model, const Data& data, std::span<const Vec6> q_b,
                        std::span<const Vec3> q_n, std::span<Vec6> t_b, std::span<Vec3> t_n,
                        std::span<Vec6> g_b, std::span<Vec3> g_n) noexcept;

/// Forward sweep of the SSOR preconditioner (model without joints, after
/// build_net_system()): y = (D̃+L)⁻¹ g, bodies first, then the nodes from first
/// to last in the sweep order. y may be g itself (in place); otherwise they
/// must not overlap.
void net_forward_sweep(const Model& model, const Data& data, std::span<const Vec6> g_b,
                       std::span<const Vec3> g_n, std::span<Vec6> y_b,
                       std::span<Vec3> y_n) noexcept;

/// Eisenstat's preconditioned product (model without joints, after
/// build_net_system()): t = (D̃+Lᵀ)⁻¹ q and K q = (D̃+L)⁻¹ A (D̃+Lᵀ)⁻¹ q =
/// t + (D̃+L)⁻¹ (q + (D − 2D̃) t). Returns qᵀ K q. Uses NetScratch::body_tmp
/// as scratch and kq_n for the intermediate g_n (the forward sweep runs in
/// place); the spans must not alias each other or body_tmp.
double apply_net_preconditioned(const Model& model, Data& data, std::span<const Vec6> q_b,
                                std::span<const Vec3> q_n, std::span<Vec6> t_b, std::span<Vec3> t_n,
                                std::span<Vec6> kq_b, std::span<Vec3> kq_n) noexcept;

}  // namespace numen::core
