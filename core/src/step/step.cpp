/// @file step.cpp
/// One fixed time step of the god-object dynamics: a readable list of stages.

#include "numen/core/step.hpp"

#include <cassert>

#include "numen/core/collision.hpp"
#include "numen/core/contact_force.hpp"
#include "numen/core/coupling.hpp"
#include "numen/core/data.hpp"
#include "numen/core/features.hpp"
#include "numen/core/feedback.hpp"
#include "numen/core/grasp.hpp"
#include "numen/core/integrator.hpp"
#include "numen/core/model.hpp"
#include "numen/core/needle_puncture.hpp"
#include "numen/core/net_collision.hpp"
#include "numen/core/net_forces.hpp"
#include "numen/core/rigid_body.hpp"
#include "numen/core/sliding_tie.hpp"
#include "numen/core/step_stages.hpp"
#include "numen/core/thread.hpp"

#include "scratch/data_scratch.hpp"
#include "articulation/joint_system.hpp"

namespace numen::core {
namespace {

void save_state(Data& data) noexcept {
  for (std::size_t i = 0; i < data.bodies.size(); ++i) data.scratch->solver.saved_state[i] = data.bodies[i];
  for (std::size_t i = 0; i < data.nodes.size(); ++i) data.scratch->net.saved[i] = data.nodes[i];
}

/// Checks stage: rejects a non-finite result (rollback to the saved poses and
/// node positions, zero twists and node velocities, zero feedback, and the solver's and joints' outputs cleared
/// so that nothing non-finite is carried into the next step: Δu is the next
/// step's Δu_prev, joint_system.hpp). Sets its bit of Data::stages_run. Returns true
/// when the step was accepted.
bool check_finite(Data& data) noexcept {
  data.stages_run |= kStageChecks;
  bool finite = data.feedback_wrench.force.allFinite() && data.feedback_wrench.torque.allFinite();
  for (const BodyState& s : data.bodies) finite = finite && state_is_finite(s);
  for (const Vec6& d : data.scratch->solver.delta) finite = finite && d.allFinite();
  for (const NodeState& n : data.nodes)
    finite = finite && n.position.allFinite() && n.velocity.allFinite();
  if (finite) {
    // A stage that rolled its own part back this step (a thread, step_threads()) set kNonFinite:
    // the step is kept, and counted with the rejected ones.
    if (data.status & kNonFinite) ++data.nonfinite_steps;
    return true;
  }
  for (Vec6& d : data.scratch->solver.delta) d.setZero();
  for (Vec3& d : data.scratch->net.delta) d.setZero();  // the next step's warm start
  for (std::size_t i = 0; i < data.nodes.size(); ++i) {
    data.nodes[i].position = data.scratch->net.saved[i].position;
    data.nodes[i].velocity.setZero();
  }
  for (Wrench& w : data.body_feedback) w = Wrench{};
  for (JointState& j : data.joints) j = JointState{};
  data.max_joint_drift = 0.0;
  data.max_joint_angle_drift = 0.0;
  for (std::size_t i = 0; i < data.bodies.size(); ++i) {
    BodyState& s = data.bodies[i];
    s = data.scratch->solver.saved_state[i];
    s.linear_velocity.setZero();
    s.angular_velocity.setZero();
  }
  data.feedback_wrench = Wrench{};
  data.status |= kNonFinite;
  ++data.nonfinite_steps;
  return false;
}

}  // namespace

void compute_forces(const Model& model, Data& data) noexcept {
  apply_external_forces(model, data);
  apply_coupling(model, data);
  compute_contact_forces(model, data);
  apply_grasp_forces(model, data);
  apply_sliding_ties(model, data);
  data.stages_run |= kStageBodyForces;
  if (model.stage_plan & kStageThreads) step_threads(model, data);  // sets its bit; body reactions
  if constexpr (kWithDeformable) {
    if (model.stage_plan & kStageNetForces) compute_net_forces(model, data);  // sets its bit
  }
}

void step_to_contacts(const Model& model, Data& data) noexcept {
  // The stages this model runs: its plan, computed once by finalize_model()
  // (Model::stage_plan, step_stages.hpp), never here. Every stage function sets its own
  // bit of Data::stages_run where it runs (the integrator's solves in integrator.cpp),
  // so the report is what ran. A part compiled out (features.hpp) has no model:
  // finalize_model() refuses it.
  assert(model.stage_plan == compiled_stages(model) &&
         "Model::stage_plan is stale: call finalize_model() again after editing the model");
  data.status = kStepOk;
  data.stages_run = 0;
  data.num_contacts = 0;
  data.contacts_dropped = 0;
  data.max_penetration = 0.0;
  data.num_node_thread_ties = 0;  // written again by the threads' stage, after the needles' ties
  save_state(data);
  impose_direct_target(model, data);  // clears SolverScratch::imposed; imposes by the plan
}

bool add_contact(Data& data, const Contact& contact) noexcept {
  const int room = std::min(kMaxContacts, static_cast<int>(data.scratch->solver.contact_terms.size()));
  if (data.num_contacts >= room) {
    ++data.contacts_dropped;
    return false;
  }
  data.contacts[static_cast<std::size_t>(data.num_contacts++)] = contact;
  return true;
}

void step_from_contacts(const Model& model, Data& data) noexcept {
  const std::uint32_t plan = model.stage_plan;
  if (data.contacts_dropped > 0 && (data.status & kContactOverflow) == 0) {  // the caller's
    data.status |= kContactOverflow;
    ++data.contact_overflow_steps;
  }
  if (plan & kStageGrasp) update_grasps(model, data);  // sets its bit; drops the held bodies' contacts
  if constexpr (kWithDeformable) {
    if (plan & kStageNeedles) tie_needles(model, data);  // sets its bit; after the grasp springs
  }
  compute_forces(model, data);
  if constexpr (kWithDeformable) {
    if (plan & kStageNeedles) find_punctures(model, data);  // reads this step's node contact forces
  }
  if (data.contacts_clamped > 0) ++data.contact_clamped_steps;  // body and node contacts
  integrate(model, data);  // sets its bit, and kStageNetSolve or kStageJointSolve if run
  if constexpr (kWithDeformable) {
    if (plan & kStageNeedles) stop_needle_tunnels(model, data);  // the tip's sweep against the nets
  }
  if constexpr (kWithArticulation) {
    if (plan & kStageJointDrift) measure_joint_drift(model, data);  // sets its bit
  }
  if constexpr (kWithDeformable) {
    if (plan & kStageMeasureNets) measure_nets(model, data);  // sets its bit
  }
  compute_feedback(model, data);  // sets its bit; holds the last feedback on an invalid target
  const bool accepted = check_finite(data);  // sets its bit
  if (data.status & kInvalidTarget) ++data.invalid_target_steps;
  if constexpr (kWithDeformable) {
    if (!accepted && (plan & kStageMeasureNets)) {
      for (NetOutput& o : data.nets) o.tie_wrench = Wrench{};
      measure_nets(model, data);  // describe the restored net (finite, at rest)
    }
  }
  data.time += model.dt;
  ++data.step_count;
}

void step(const Model& model, Data& data) noexcept {
  step_to_contacts(model, data);
  if (model.stage_plan & kStageContacts) detect_contacts(model, data);  // sets its bit; may set kContactOverflow
  if constexpr (kWithDeformable) {
    if (model.stage_plan & kStageNodeContacts) detect_node_contacts(model, data);  // sets its bit
  }
  step_from_contacts(model, data);
}

void set_held_body(const Model& model, Data& data, int body) noexcept {
  data.held_body = (body >= 0 && body < model.num_bodies()) ? body : -1;
}

}  // namespace numen::core
