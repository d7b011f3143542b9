#pragma once
/// @file step_stages.hpp
/// The stages of core::step() (step.hpp) as data: which of them a given model
/// runs, in step order, and why a stage is skipped. Each stage records itself
/// in Data::stages_run when it runs, so a test (and `numen info`) can check that a
/// scene without joints, nets or anything to collide runs no pass for them. The
/// plan of a model is computed once, by finalize_model() (Model::stage_plan).

#include <cstdint>
#include <span>

namespace numen::core {

struct Model;

/// One stage of step(), as a bit of Data::stages_run.
enum StepStage : std::uint32_t {
  kStageDirectTarget = 1u << 0,   ///< impose_direct_target (CouplingMode::kDirect, anchored bodies).
  kStageContacts = 1u << 1,       ///< detect_contacts: broad and narrow phase, bodies.
  kStageNodeContacts = 1u << 2,   ///< detect_node_contacts: net nodes against everything.
  kStageGrasp = 1u << 3,          ///< update_grasps: grasp rules, the held bodies' contacts off (grasp.hpp).
  /// tie_needles (before the forces), find_punctures (after them) and stop_needle_tunnels (after
  /// the integration): a needle through tissue (needle_puncture.hpp). Only a model with nets and a
  /// needle that punctures runs it.
  kStageNeedles = 1u << 4,
  kStageBodyForces = 1u << 5,     ///< gravity, applied wrenches, coupling, contact and grasp forces.
  kStageThreads = 1u << 6,        ///< step_threads: the suture threads' own implicit step (thread.hpp).
  kStageNetForces = 1u << 7,      ///< compute_net_forces: springs, tie, node contacts.
  kStageIntegrate = 1u << 8,      ///< integrate: the bodies' (and nodes') time step.
  kStageJointSolve = 1u << 9,     ///< integrate's KKT tree solve of the joints (Eq. 4–5).
  kStageNetSolve = 1u << 10,      ///< integrate's one system of bodies and nodes (net_solve).
  kStageJointDrift = 1u << 11,    ///< measure_joint_drift.
  kStageMeasureNets = 1u << 12,   ///< measure_nets: strain, tie wrench.
  kStageFeedback = 1u << 13,      ///< compute_feedback: Eq. 8–9.
  kStageChecks = 1u << 14,        ///< check_finite: rollback of a non-finite result.
};

/// A stage of step() and the scene property it depends on.
struct StageDescription {
  StepStage stage;
  const char* name;         ///< Short name, e.g. "joint solve".
  const char* skipped_why;  ///< Why a model skips it ("no joints"); nullptr: always runs.
};

/// Every stage of step(), in the order step() runs them (static table).
std::span<const StageDescription> step_stage_table() noexcept;

/// Bits of the stages step() runs for `model` (its articulation topology derived):
/// the pure function finalize_model() stores as Model::stage_plan, once per model.
/// step() gates its stages on the stored plan and the integrator picks its solve
/// from it (neither calls this); each stage sets its own bit of Data::stages_run
/// where it runs, so that field equals the plan after any step. The integrate
/// stage's variants: kStageNetSolve with nets and a linearised integrator (bodies
/// and nodes as one system, with or without joints; symplectic Euler steps the
/// nodes explicitly), else kStageJointSolve with joints (the KKT tree solve,
/// implicit or symplectic), else the bodies alone. No allocation.
std::uint32_t compiled_stages(const Model& model) noexcept;

}  // namespace numen::core
