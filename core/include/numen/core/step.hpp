#pragma once
/// @file step.hpp
/// One fixed time step of the god-object dynamics.

namespace numen::core {

struct Model;
struct Data;
struct Contact;

/// Advances `data` by model.dt. Stages, in order:
///   1. detect_contacts — collision geometry (collision.hpp), skipped when
///      nothing can collide (contact_capacity() == 0: no contact scratch);
///      with nets, then detect_node_contacts (net_collision.hpp)
///   2. forces — gravity, applied wrenches, coupling (Eq. 2) on the held
///      body and (Eq. 6) on every body with its own target, penalty contact
///      forces (compute_forces); the gyroscopic term is applied by the
///      integrator (implicit step or explicit torque)
///   3. integrate — linearly implicit or symplectic Euler (Eq. 1, §5), or
///      the imposed pose in CouplingMode::kDirect; with joints, the KKT
///      system of Eq. 4 with Baumgarte rows (Eq. 5) solved in linear time
///      (articulation.hpp), then the joint drift is measured
///      (measure_joint_drift) — models without joints skip both; with nets
///      and a linearised integrator the nets are linearised over h_s
///      (linearize_nets, net_forces.hpp) and the bodies and nodes solved as
///      one system (the net solve, which then takes the joints); with
///      symplectic Euler the nodes are stepped explicitly; then the nets'
///      observables are measured (measure_nets)
///   4. feedback — Eq. 8 per targeted body, Eq. 9 composite, saturated; held at
///      the last step's value when the held body's target is not finite
///   5. checks — non-finite results are rejected: every body goes back to its
///      pose before the step with zero twist, every node to its position with
///      zero velocity, the feedback (composite and per body), the joint
///      states and the solver's Δu and Δv are zeroed, the nets' outputs
///      re-measured on the restored nodes (tie wrench zeroed),
///      kNonFinite is set and Data::nonfinite_steps counted (a step whose thread went
///      non-finite and was rolled back by its own stage, step_threads(), is counted too)
/// Data::status is cleared first (then detect_contacts may set
/// kContactOverflow and count contact_overflow_steps); a step that sets kInvalidTarget
/// (a device target that is not finite, coupling.hpp) counts Data::invalid_target_steps;
/// The stages are those Model::stage_plan names (computed once by finalize_model();
/// step_stages.hpp: a model without joints or nets runs no pass for them; a plan left
/// stale by an edit after finalize_model() fails an assertion in builds without NDEBUG);
/// each stage function sets its own bit of Data::stages_run where it runs, so that field is
/// what ran; time += dt and ++step_count at the end. In kDirect the held body's
/// pose/twist are imposed before detect_contacts.
/// Never allocates, throws, locks or calls the OS. Deterministic.
void step(const Model& model, Data& data) noexcept;

/// The step split where its contacts are made (MuJoCo's mj_step1 / mj_step2): step() is
/// step_to_contacts(), the contact stages of Model::stage_plan (detect_contacts(), then
/// detect_node_contacts() with nets), and step_from_contacts(). A caller that makes the step's
/// contacts itself — the multirate device loop's planes (write_plane_contacts(),
/// multirate/device_loop.hpp), the scene loop's cut-back contacts — calls the two halves and
/// writes Data::contacts (add_contact(), or the detection functions) and Data::node_contacts
/// between them; a contact stage it runs sets its bit of Data::stages_run, as each of step()'s
/// stages does.
///
/// The first half: Data::status, stages_run and the step's contact outputs (num_contacts,
/// contacts_dropped, max_penetration) cleared, the state saved for the checks' rollback, the
/// targets imposed (kDirect, impose_direct_target()). Never allocates, throws, locks or calls
/// the OS.
void step_to_contacts(const Model& model, Data& data) noexcept;

/// The second half of a split step, after its contacts: a contact the caller dropped for want
/// of room (Data::contacts_dropped without kContactOverflow) reported as detect_contacts()
/// reports its own (kContactOverflow, contact_overflow_steps), then the grasps, forces,
/// integration, measures, feedback and checks of step(); time += dt, ++step_count. Never
/// allocates, throws, locks or calls the OS.
void step_from_contacts(const Model& model, Data& data) noexcept;

/// Appends `contact` to the step's contacts (Data::contacts[num_contacts++]), in a caller's
/// contact stage between step_to_contacts() and step_from_contacts(). Returns false, and counts
/// it in Data::contacts_dropped, when they are full: kMaxContacts, or the room of the Data's
/// contact scratch (contact_capacity(), DataOptions::written_contacts); step_from_contacts()
/// reports the overflow. No allocation.
bool add_contact(Data& data, const Contact& contact) noexcept;

/// Forces stage of step(): body_wrench := gravity + applied wrench
/// (apply_external_forces), + coupling on the held body (apply_coupling,
/// Eq. 2), + penalty contact forces of data.contacts (compute_contact_forces),
/// + the nets' forces and their reactions (compute_net_forces, when
/// Model::stage_plan has kStageNetForces). Sets kStageBodyForces of
/// Data::stages_run (compute_net_forces sets its own).
/// The gyroscopic term is handled by the integrator (implicit or explicit).
/// Expects detect_contacts() (and impose_direct_target() in kDirect) to have
/// run this step. No allocation.
void compute_forces(const Model& model, Data& data) noexcept;

/// Makes `body` the held body (the device drives it), or none with -1; out-of-range
/// values give none. Tool switching of the paper's construction game.
void set_held_body(const Model& model, Data& data, int body) noexcept;

}  // namespace numen::core
