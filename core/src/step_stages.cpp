/// @file step_stages.cpp
/// The stage table of step() and the stages a model runs (step_stages.hpp).

#include "numen/core/step_stages.hpp"

#include <array>

#include "numen/core/capacity.hpp"
#include "numen/core/model.hpp"

namespace numen::core {
namespace {

constexpr std::array<StageDescription, 12> kStages{{
    {kStageDirectTarget, "direct target", "coupling mode is not direct"},
    {kStageContacts, "contacts (broad + narrow phase)", "nothing to collide"},
    {kStageNodeContacts, "node contacts", "no nets"},
    {kStageBodyForces, "body forces (gravity, coupling, contacts)", nullptr},
    {kStageNetForces, "net forces", "no nets"},
    {kStageIntegrate, "integrate", nullptr},
    {kStageJointSolve, "joint solve (KKT tree)", "no joints"},
    {kStageNetSolve, "net solve (bodies + nodes)", "no nets"},
    {kStageJointDrift, "joint drift", "no joints"},
    {kStageMeasureNets, "measure nets", "no nets"},
    {kStageFeedback, "feedback", nullptr},
    {kStageChecks, "checks (non-finite rollback)", nullptr},
}};

}  // namespace

std::span<const StageDescription> step_stage_table() noexcept { return kStages; }

std::uint32_t compiled_stages(const Model& model) noexcept {
  std::uint32_t s = kStageBodyForces | kStageIntegrate | kStageFeedback | kStageChecks;
  if (model.coupling_mode == CouplingMode::kDirect) s |= kStageDirectTarget;
  if (contact_capacity(model) > 0) s |= kStageContacts;
  const bool nets = !model.nets.empty();
  const bool joints = !model.joints.empty();
  if (nets) s |= kStageNodeContacts | kStageNetForces | kStageNetSolve | kStageMeasureNets;
  if (joints) s |= kStageJointDrift;
  if (joints && !nets) s |= kStageJointSolve;
  return s;
}

}  // namespace numen::core
