#pragma once
/// @file net_forces.hpp
/// Force stage of the deformable nets (paper §4.2; Meseure & Chaillou 2000)
/// and their explicit node step. Spring law and symbols in net_model.hpp.

namespace numen::core {

struct Model;
struct Data;

/// Explicit forces on every node at the step's start, into NetScratch::force
/// (N, world):
///   gravity m g;
///   structural and bending springs f_a = −f_b = k (l − L) d̂ + γ (d̂ · (v_b − v_a)) d̂;
///   the tie of each node to its rest position on the rigid component,
///   f = −k_tie (x − a) − γ_tie (v − v_a), a = x_b + R_b r (r: Model::node_rest),
///   v_a = v_b + ω_b × (R_b r); its reaction (−f at a) is added to
///   Data::body_wrench of the rigid component (at the COM) and summed in
///   NetOutput::tie_wrench;
///   each node contact's penalty force (contact_penalty_force(), the node on
///   side a), its reaction added to body_b's wrench; its stiffness clamped by the
///   contact time-constant floor (SolverSettings::node_contact_max_omega_dt) on the effective mass 1 / (1/m_node + the body's
///   mobility along n, contact_effective_mass()) into NodeContact::stiffness, and
///   counted in Data::contacts_clamped (contact_force.hpp).
/// Also stores what the implicit solve's linearisation (linearize_nets()) starts
/// from: spring directions (SweepSpring; a spring of zero length keeps its last
/// direction) and lengths (NetScratch::spring_length), lever arms ρ = R_b r
/// (NetScratch::lever), and each NodeContact's r_b, normal_velocity, active
/// and force, and each net's energy at the step's start (NetOutput::start_energy, from the
/// same lengths and tie stretches). Independent of the integrator: it reads no h_s.
/// Call after compute_contact_forces() (body_wrench is reset by
/// apply_external_forces()) and after detect_node_contacts(). Nothing to do
/// without nets; with nets it sets its bit of Data::stages_run (kStageNetForces,
/// step_stages.hpp). No allocation.
void compute_net_forces(const Model& model, Data& data) noexcept;

/// Symplectic Euler of the nodes: v1 = v0 + h f/m, x1 = x0 + h v1, with the
/// forces of compute_net_forces(). Explicit in the ties and springs: stable
/// for h √(k/m) < 2 with k the stiffest spring sum on a node — and, for the
/// rigid component, for its rotation against the net it carries: with the
/// ties' total damping and stiffness seen about the COM,
/// h Σγ_tie |ρ⊥|² / I_r + h² Σk_tie |ρ⊥|² / (2 I_r) < 2, I_r = I I_net / (I + I_net)
/// the reduced inertia of the body and the net (I_net = Σ m_i |ρ⊥|²) (a light rigid component
/// with a heavy net spins up: tests/core/step_deformable_test.cpp). A
/// first-order rigid component (CouplingMode::kFirstOrder) takes the ties'
/// damping explicitly: it needs γ_t > Σγ_tie and γ_r > Σγ_tie |ρ⊥|².
/// Prefer the linearly implicit integrator for nets.
void integrate_nodes_symplectic(const Model& model, Data& data) noexcept;

/// Node update of the linearised step (integrator.hpp), h = Model::dt, Δv =
/// NetScratch::delta solved with h_s = SolverScratch::system_step:
/// x1 = x0 + h (v0 + Δv), v1 = v0 + (h / h_s) Δv — the implicit Euler's
/// v1 = v0 + Δv, x1 = x0 + h v1 (h_s = h), or the trapezoidal rule's midpoint
/// positions and v1 = v0 + 2 Δv½ (h_s = h/2).
void integrate_nodes_implicit(const Model& model, Data& data) noexcept;

/// End-of-step observables of every net into Data::nets (NetOutput):
/// largest tie stretch |x − a| against the rigid component's end pose,
/// largest structural strain, kinetic energy, largest node speed, and for a net given by its
/// material its tetrahedra well shaped at rest whose signed volume is not positive
/// (NetOutput::inverted_tetrahedra; one pass over Model::net_tetrahedra, 4 positions and a
/// triple product each). Sets its bit
/// of Data::stages_run (kStageMeasureNets, step_stages.hpp).
void measure_nets(const Model& model, Data& data) noexcept;

}  // namespace numen::core
