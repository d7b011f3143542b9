/// @file step_stages.cpp
/// The stage table of step() and the stages a model runs (step_stages.hpp).

#include "numen/core/step_stages.hpp"

#include <algorithm>
#include <array>

#include "numen/core/capacity.hpp"
#include "numen/core/model.hpp"

namespace numen::core {
namespace {

constexpr std::array<StageDescription, 15> kStages{{
    {kStageDirectTarget, "direct target", "coupling mode is not direct, no anchored body"},
    {kStageContacts, "contacts (broad + narrow phase)", "nothing to collide"},
    {kStageNodeContacts, "node contacts", "no nets"},
    {kStageGrasp, "grasp (rules, held bodies)", "no graspers"},
    {kStageNeedles, "needles (punctures, ties)", "no nets, or no needle with a puncture force"},
    {kStageBodyForces, "body forces (gravity, coupling, contacts)", nullptr},
    {kStageThreads, "threads", "no threads"},
    {kStageNetForces, "net forces", "no nets"},
    {kStageIntegrate, "integrate", nullptr},
    {kStageJointSolve, "joint solve (KKT tree)", "no joints, or in the net solve"},
    {kStageNetSolve, "net solve (bodies + nodes)", "no nets, or symplectic Euler"},
    {kStageJointDrift, "joint drift", "no joints"},
    {kStageMeasureNets, "measure nets", "no nets"},
    {kStageFeedback, "feedback", nullptr},
    {kStageChecks, "checks (non-finite rollback)", nullptr},
}};

}  // namespace

std::span<const StageDescription> step_stage_table() noexcept { return kStages; }

std::uint32_t compiled_stages(const Model& model) noexcept {
  // The stage plan, stored by finalize_model() as Model::stage_plan: step() gates its
  // stages on it and the integrator picks its solve from it (integrator.cpp).
  std::uint32_t s = kStageBodyForces | kStageIntegrate | kStageFeedback | kStageChecks;
  const bool anchored = std::any_of(model.bodies.begin(), model.bodies.end(),
                                    [](const BodyModel& b) { return b.anchored; });
  if (model.coupling_mode == CouplingMode::kDirect || anchored) s |= kStageDirectTarget;
  if (contact_capacity(model) > 0) s |= kStageContacts;
  const bool nets = !model.nets.empty();
  const bool joints = !model.joints.empty();
  // Symplectic Euler steps the nodes explicitly: no system of bodies and nodes.
  const bool net_solve = nets && model.integrator != Integrator::kSymplecticEuler;
  if (nets) s |= kStageNodeContacts | kStageNetForces | kStageMeasureNets;
  if (net_solve) s |= kStageNetSolve;
  if (joints) s |= kStageJointDrift;
  if (!model.grasps.empty()) s |= kStageGrasp;
  // A needle through tissue: nets, and a needle that punctures (needle_puncture.hpp).
  if (nets && std::any_of(model.needles.begin(), model.needles.end(),
                          [](const NeedleModel& n) { return n.puncture_force > 0.0; }))
    s |= kStageNeedles;
  if (!model.threads.empty()) s |= kStageThreads;
  // The net solve takes the joints in its arrowhead preconditioner; otherwise the
  // joints have their own KKT tree solve (implicit or symplectic).
  if (joints && !net_solve) s |= kStageJointSolve;
  return s;
}

}  // namespace numen::core
