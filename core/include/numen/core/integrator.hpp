#pragma once
/// @file integrator.hpp
/// Time integration of the rigid bodies (paper Eq. 1, §5): linearly implicit
/// Euler with the stiffness and damping Jacobians of coupling springs and
/// contacts, the linearised trapezoidal rule and TR-BDF2 (second order) on the
/// same systems, and symplectic Euler as the explicit baseline.
///
/// Linearly implicit (backward) Euler, Baraff & Witkin 1998 ("Large steps in
/// cloth simulation", §2.3), on the stacked twists u = (v_0, ω_0, v_1, ω_1, …):
///   (M − h D − h² K) Δu = h (f0 + h K u0) + M (u* − u0),
///   u1 = u0 + Δu,  x1 = x0 + h v1,  q1 = exp(½ h ω1) ⊗ q0,
/// with M = blockdiag(m_i I3, I_w,i), K = ∂f/∂x, D = ∂f/∂u, u* the twist after
/// the implicit gyroscopic step (Catto, GDC 2015). The M (u* − u0) term makes
/// the gyroscopic step an exact split: it equals re-evaluating the (linear in
/// u) forces at u*. The system is symmetric positive definite and solved
/// matrix-free by a conjugate gradient preconditioned with the exact 6×6
/// diagonal block of each body (Cholesky).
///
/// Public: the integrate stage and its three schemes. The solver's scratch
/// (SolverScratch, core/src/scratch/solver_scratch.hpp, behind Data::scratch) and
/// the implicit system's builders and solves the schemes are made of are private
/// to numen::core (core/src/solver/implicit_system.hpp).

namespace numen::core {

struct Model;
struct Data;

/// Integrate stage: dispatches on Model::integrator to
/// integrate_linearly_implicit_euler(), integrate_trapezoidal(), integrate_tr_bdf2() or
/// integrate_symplectic_euler(); the solve inside (net solve, joint solve or the
/// bodies alone) is the one Model::stage_plan names (step_stages.hpp), and sets
/// its bit of Data::stages_run (kStageNetSolve, kStageJointSolve) when it runs; sets
/// kStageIntegrate itself. Needs
/// Data::body_wrench (explicit forces: gravity, applied, coupling, contacts)
/// and the ContactTerm lever arms and normal velocities of this step.
/// Advances Data::bodies by dt.
void integrate(const Model& model, Data& data) noexcept;

/// Symplectic (semi-implicit) Euler, the explicit baseline (paper §5):
///   v1 = v0 + h F/m,  ω1 = ω0 + h I_w⁻¹ (T − ω0 × I_w ω0),
///   x1 = x0 + h v1,   q1 = exp(½ h ω1) ⊗ q0.
/// kFirstOrder held body (γ_t, γ_r > 0): v1 = v_t + (k_t e + F_other)/γ_t,
/// ω1 = ω_t + (k_r θu + T_other)/γ_r (massless limit of Eq. 2, explicit;
/// F_other, T_other: every other force on the body — gravity, applied
/// wrench, contacts; stable for h k/γ < 2).
/// kDirect held body: left at the imposed target. Sets solver_iterations
/// and solver_residual to 0. Conditionally stable: h √(k/m) < 2.
void integrate_symplectic_euler(const Model& model, Data& data) noexcept;

/// Linearly implicit Euler (see file comment; paper §5, Baraff & Witkin 1998):
/// implicit gyroscopic step, build_implicit_system(), solve_implicit_system(),
/// then positions and orientations. Sets kSolverNotConverged when the solve
/// ends at max_iterations above the tolerance (the best iterate is still used).
void integrate_linearly_implicit_euler(const Model& model, Data& data) noexcept;

/// Linearised trapezoidal rule (Integrator::kTrapezoidal; docs/dynamics.md): with
/// h_s = h/2, the linearly implicit Euler system of a half step
///   (M − h/2 D − h²/4 K) Δu½ = h/2 (f0 + h/2 K u0) + M (u* − u0)
/// gives the midpoint twist u½ = u0 + Δu½ (u* from the implicit gyroscopic step over
/// h/2), then x1 = x0 + h v½, q1 = exp(½ h ω½) ⊗ q0, u1 = u0 + 2 Δu½. Equivalently
/// (M − h/2 D − h²/4 K) Δu = h f0 + h²/2 K u0 with Δu = 2 Δu½: the trapezoidal rule
/// applied to the linearisation (a one-stage Rosenbrock method with γ = 1/2, second
/// order when K and D are the exact Jacobians and the explicit forces are evaluated at
/// the step's middle; Hairer & Wanner, Solving ODEs II, §IV.7). Same builders and
/// solvers as the implicit Euler (bodies, joints with Baumgarte rows built over the full
/// step h and RATTLE's velocity projection onto the joints' rows at the step's end — one
/// more linear-time tree solve, docs/dynamics.md — deformable nets); A-stable but not L-stable: a
/// mode with h ω ≫ 1 is kept bounded but not damped (amplification → −1). Sets kSolverNotConverged
/// like the implicit Euler.
void integrate_trapezoidal(const Model& model, Data& data) noexcept;

/// Linearised TR-BDF2 (Integrator::kTrBdf2; Bank et al. 1985, Hosea & Shampine 1996;
/// docs/dynamics.md derives it): TR-BDF2 with γ = 2 − √2 applied to the step's linearisation
/// y' = F0 + J (y − y0), a two-stage Rosenbrock-type method. Both stages solve the linearly
/// implicit Euler system of one step h_s = γh/2 = (1 − γ)/(2 − γ) h (A = M − h_s D − h_s² K):
///   trapezoidal stage to t + γh:  A Δu½ = h_s (f0 + h_s K u0) + M (u* − u0),
///     Δu_γ = 2 Δu½,  Δx_γ = γh (u0 + Δu½);
///   BDF2 stage to t + h:  A Δu = h_s (f0 + h_s K ũ) + a M Δu_γ + M (u* − u0),
///     ũ = u0 + (a / h_s) Δx_γ,  a = 1/(γ (2 − γ)),
///   u1 = u0 + Δu,  x1 = x0 + a Δx_γ + h_s v1,  q1 = exp(½ (a θ_γ + h_s ω1)) ⊗ q0 (unit),
/// θ_γ the stage's rotation vector (Δx_γ's angular part), u* from the implicit gyroscopic step
/// over h_s (kept constant over the step). The forces and the Jacobians are those of the step's
/// start (one force evaluation; the contacts are not detected again at the stage): second order
/// where K and D are the exact Jacobians and time-dependent inputs are fed at t + h/2, as for
/// the trapezoidal rule. L-stable (amplification → 0 as h ω → ∞) and stiffly accurate, so it
/// runs CouplingMode::kFirstOrder. Joints: the trapezoidal stage as integrate_trapezoidal()
/// (Baumgarte rows over γh, RATTLE's projection at x_γ); the BDF2 stage's rows, evaluated at
/// the drifted configuration x0 ⊕ h_s ũ (its constraint force acts at the step's end), put x1
/// on the Baumgarte target over h from the step's start, then u1 is projected onto
/// G(x1) u1 = v_ref.
/// Nets: nodes are unknowns of both stages, v1 = v0 + Δv, x1 = x0 + a Δx_γ + h_s v1.
/// Data::solver_iterations is the sum over both solves, solver_residual the larger. Sets
/// kSolverNotConverged when either solve ends above the tolerance. No allocation.
void integrate_tr_bdf2(const Model& model, Data& data) noexcept;

}  // namespace numen::core
