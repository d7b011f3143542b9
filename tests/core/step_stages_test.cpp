// Tests of core/step_stages: the stages step() runs are those compiled for the
// model, and a scene without joints, nets or obstacles runs no pass for them.
#include "numen/core/step_stages.hpp"

#include <cstring>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "alloc_counter.hpp"
#include "build_features.hpp"
#include "lean_scenes.hpp"
#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/step.hpp"

#include "detail/data_scratch.hpp"

namespace core = numen::core;
using numen::test::LeanPart;
using numen::test::make_lean_model;

TEST(StepStages, TableListsEveryStageOnceInStepOrder) {
  std::uint32_t seen = 0;
  std::uint32_t previous = 0;
  std::set<std::string> names;
  for (const core::StageDescription& s : core::step_stage_table()) {
    EXPECT_EQ(seen & s.stage, 0u) << s.name;
    EXPECT_GT(s.stage, previous) << s.name;  // bits ascend in step order
    previous = s.stage;
    seen |= s.stage;
    EXPECT_TRUE(names.insert(s.name).second) << s.name;
  }
  EXPECT_EQ(seen, (core::kStageChecks << 1) - 1);
}

TEST(StepStages, StepRunsExactlyTheCompiledStages) {
  for (LeanPart part : numen::test::lean_parts()) {
    for (auto integ : {core::Integrator::kLinearlyImplicitEuler, core::Integrator::kSymplecticEuler}) {
      core::Model m = make_lean_model(part);
      m.integrator = integ;
      core::Data d = core::make_data(m);
      EXPECT_EQ(d.stages_run, 0u);
      core::step(m, d);
      EXPECT_EQ(d.stages_run, core::compiled_stages(m)) << static_cast<int>(part);
    }
  }
}

TEST(StepStages, RigidOnlySceneRunsNoPassForWhatItLacks) {
  const core::Model m = make_lean_model(LeanPart::kNone);
  core::Data d = core::make_data(m);
  {
    numen::test::AllocationGuard guard;
    for (int i = 0; i < 100; ++i) core::step(m, d);
    EXPECT_EQ(guard.count(), 0);
  }
  const std::uint32_t absent = core::kStageContacts | core::kStageNodeContacts |
                               core::kStageNetForces | core::kStageJointSolve |
                               core::kStageNetSolve | core::kStageJointDrift |
                               core::kStageMeasureNets | core::kStageDirectTarget;
  EXPECT_EQ(d.stages_run & absent, 0u);
  EXPECT_EQ(d.num_contacts, 0);
  EXPECT_EQ(d.status, core::kStepOk);
}

TEST(StepStages, EachPartTurnsOnItsOwnPasses) {
  NUMEN_REQUIRE_ARTICULATION();
  NUMEN_REQUIRE_DEFORMABLE();
  const auto stages = [](LeanPart p) { return core::compiled_stages(make_lean_model(p)); };
  EXPECT_NE(stages(LeanPart::kObstacle) & core::kStageContacts, 0u);
  EXPECT_EQ(stages(LeanPart::kObstacle) & (core::kStageJointSolve | core::kStageNetSolve), 0u);
  EXPECT_NE(stages(LeanPart::kJoint) & core::kStageJointSolve, 0u);
  EXPECT_NE(stages(LeanPart::kJoint) & core::kStageJointDrift, 0u);
  EXPECT_EQ(stages(LeanPart::kJoint) & (core::kStageContacts | core::kStageNetSolve), 0u);
  const std::uint32_t net_passes = core::kStageNodeContacts | core::kStageNetForces |
                                   core::kStageNetSolve | core::kStageMeasureNets;
  EXPECT_EQ(stages(LeanPart::kNet) & net_passes, net_passes);
  EXPECT_EQ(stages(LeanPart::kNet) & core::kStageJointDrift, 0u);
}

TEST(StepStages, ContactsStillDetectedWhenPossible) {
  // The skipped detection must not hide a real contact: the obstacle scene's
  // body starts 0.1 m above the floor with 0.01 m spheres; pressed into it, it touches.
  const core::Model m = make_lean_model(LeanPart::kObstacle);
  core::Data d = core::make_data(m);
  d.target.position = core::Vec3(0.0, 0.0, -0.02);
  for (int i = 0; i < 500; ++i) core::step(m, d);
  EXPECT_GT(d.num_contacts, 0);
}

namespace {

/// Evidence, independent of Data::stages_run, of the integrate stage's solves
/// after one step from make_data(): the net solve writes the nodes' Δv
/// (NetScratch::delta, zero from make_data(); the symplectic node step never
/// touches it) and reports its CG iterations; a solve that takes the joints — the
/// joint solve (KKT tree, implicit or symplectic), or the net solve with its
/// arrowhead preconditioner — writes their multipliers, which gravity on the
/// hinged body makes non-zero.
struct Ran {
  bool net_solve = false;
  bool joints_solved = false;
};

Ran what_ran(const core::Data& d) {
  Ran r;
  for (const core::Vec3& dv : d.scratch->net.delta) r.net_solve = r.net_solve || !dv.isZero(0.0);
  r.net_solve = r.net_solve && d.solver_iterations > 0;
  for (const core::JointState& j : d.joints)
    r.joints_solved = r.joints_solved || !j.multiplier.isZero(0.0);
  return r;
}

}  // namespace

// Issue 18: with symplectic Euler and a net the report used to name a net solve that
// did not run (0 iterations), and with symplectic Euler, a net and a joint the joint
// solve ran unreported. Every integrator × (joints, nets): the report is what ran.
TEST(StepStages, ReportIsWhatRanForEveryIntegratorJointsAndNets) {
  std::vector<LeanPart> parts{LeanPart::kNone};
  if (core::kWithArticulation) parts.push_back(LeanPart::kJoint);
  if (core::kWithDeformable) parts.push_back(LeanPart::kNet);
  if (core::kWithArticulation && core::kWithDeformable) parts.push_back(LeanPart::kJointAndNet);
  for (LeanPart part : parts) {
    for (auto integ : {core::Integrator::kLinearlyImplicitEuler, core::Integrator::kTrapezoidal,
                       core::Integrator::kTrBdf2, core::Integrator::kSymplecticEuler}) {
      core::Model m = make_lean_model(part);
      m.integrator = integ;
      core::Data d = core::make_data(m);
      {
        numen::test::AllocationGuard guard;
        core::step(m, d);
        EXPECT_EQ(guard.count(), 0);
      }
      const std::string what = "part " + std::to_string(static_cast<int>(part)) +
                               ", integrator " + std::to_string(static_cast<int>(integ));
      ASSERT_EQ(d.status, core::kStepOk) << what;
      const Ran ran = what_ran(d);
      EXPECT_EQ((d.stages_run & core::kStageNetSolve) != 0, ran.net_solve) << what;
      const bool joint_solve = (d.stages_run & core::kStageJointSolve) != 0;
      const bool net_solve = (d.stages_run & core::kStageNetSolve) != 0;
      EXPECT_FALSE(joint_solve && net_solve) << what;
      EXPECT_EQ(joint_solve || (net_solve && !m.joints.empty()), ran.joints_solved) << what;
      EXPECT_EQ(d.stages_run, core::compiled_stages(m)) << what;
      const bool nets = !m.nets.empty(), joints = !m.joints.empty();
      const bool symplectic = integ == core::Integrator::kSymplecticEuler;
      EXPECT_EQ(ran.net_solve, nets && !symplectic) << what;
      EXPECT_EQ(ran.joints_solved, joints) << what;
      EXPECT_EQ(joint_solve, joints && !(nets && !symplectic)) << what;
      // The stages every such model runs, and the parts' own passes.
      for (auto s : {core::kStageBodyForces, core::kStageIntegrate, core::kStageFeedback,
                     core::kStageChecks})
        EXPECT_NE(d.stages_run & s, 0u) << what;
      EXPECT_EQ((d.stages_run & core::kStageNetForces) != 0, nets) << what;
      EXPECT_EQ((d.stages_run & core::kStageMeasureNets) != 0, nets) << what;
      EXPECT_EQ((d.stages_run & core::kStageJointDrift) != 0, joints) << what;
    }
  }
}
