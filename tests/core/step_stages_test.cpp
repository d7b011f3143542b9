// Tests of core/step_stages: the stages step() runs are those compiled for the
// model, and a scene without joints, nets or obstacles runs no pass for them.
#include "numen/core/step_stages.hpp"

#include <cstring>
#include <memory>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "alloc_counter.hpp"
#include "build_features.hpp"
#include "lean_scenes.hpp"
#include "numen/core/collision.hpp"
#include "numen/core/coupling.hpp"
#include "numen/core/data.hpp"
#include "numen/core/feedback.hpp"
#include "numen/core/integrator.hpp"
#include "numen/core/model.hpp"
#include "numen/core/multirate.hpp"
#include "numen/core/net_collision.hpp"
#include "numen/core/net_forces.hpp"
#include "numen/core/step.hpp"

#include "scratch/data_scratch.hpp"
#include "articulation/joint_system.hpp"

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

namespace {

/// make_lean_model(part) with the integrator `integ`: edited, so finalized again (the
/// stage plan, Model::stage_plan, is derived by finalize_model()).
core::Model lean_model(LeanPart part, core::Integrator integ) {
  core::Model m = make_lean_model(part);
  m.integrator = integ;
  const std::string err = core::finalize_model(m);
  EXPECT_EQ(err, "");
  return m;
}

}  // namespace

TEST(StepStages, FinalizeStoresThePlanOnce) {
  core::Model unfinalized;
  EXPECT_EQ(unfinalized.stage_plan, 0u);
  for (LeanPart part : numen::test::lean_parts()) {
    for (auto integ :
         {core::Integrator::kLinearlyImplicitEuler, core::Integrator::kSymplecticEuler}) {
      const core::Model m = lean_model(part, integ);
      EXPECT_EQ(m.stage_plan, core::compiled_stages(m)) << static_cast<int>(part);
    }
  }
  // A refused model has no plan, even one it had before.
  core::Model refused = make_lean_model(LeanPart::kNone);
  ASSERT_NE(refused.stage_plan, 0u);
  refused.dt = -1.0;
  EXPECT_NE(core::finalize_model(refused), "");
  EXPECT_EQ(refused.stage_plan, 0u);
}

TEST(StepStages, MakeDataRefusesAMissingOrStalePlan) {
  core::Model m = make_lean_model(LeanPart::kNone);
  core::Model unfinalized = m;
  unfinalized.stage_plan = 0;
  try {
    (void)core::make_data(unfinalized);
    ADD_FAILURE() << "a model without a plan accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("finalize_model()"), std::string::npos) << e.what();
  }
  m.coupling_mode = core::CouplingMode::kDirect;  // the plan gains kStageDirectTarget
  try {
    (void)core::make_data(m);
    ADD_FAILURE() << "a stale plan accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("stale"), std::string::npos) << e.what();
  }
  ASSERT_EQ(core::finalize_model(m), "");
  core::Data d = core::make_data(m);
  core::step(m, d);
  EXPECT_NE(d.stages_run & core::kStageDirectTarget, 0u);
  EXPECT_EQ(d.stages_run, m.stage_plan);
}

TEST(StepStages, StepRunsExactlyTheCompiledStages) {
  for (LeanPart part : numen::test::lean_parts()) {
    for (auto integ :
         {core::Integrator::kLinearlyImplicitEuler, core::Integrator::kSymplecticEuler}) {
      const core::Model m = lean_model(part, integ);
      core::Data d = core::make_data(m);
      EXPECT_EQ(d.stages_run, 0u);
      core::step(m, d);
      EXPECT_EQ(d.stages_run, m.stage_plan) << static_cast<int>(part);
    }
  }
}

// Every stage function sets its own bit where it runs, also called alone (outside step()).
TEST(StepStages, EachStageFunctionReportsItself) {
  const auto alone = [](const core::Model& m, void (*stage)(const core::Model&, core::Data&)) {
    core::Data d = core::make_data(m);
    stage(m, d);
    return d.stages_run;
  };
  const core::Model rigid = make_lean_model(LeanPart::kObstacle);
  EXPECT_EQ(alone(rigid, core::detect_contacts), core::kStageContacts);
  EXPECT_EQ(alone(rigid, core::compute_forces), core::kStageBodyForces);
  EXPECT_EQ(alone(rigid, core::integrate), core::kStageIntegrate);
  EXPECT_EQ(alone(rigid, core::compute_feedback), core::kStageFeedback);
  EXPECT_EQ(alone(rigid, core::impose_direct_target), 0u) << "god-object coupling: no target";
  core::Model direct = rigid;
  direct.coupling_mode = core::CouplingMode::kDirect;
  ASSERT_EQ(core::finalize_model(direct), "");
  EXPECT_EQ(alone(direct, core::impose_direct_target), core::kStageDirectTarget);
  if constexpr (core::kWithArticulation) {
    const core::Model hinged = make_lean_model(LeanPart::kJoint);
    EXPECT_EQ(alone(hinged, core::measure_joint_drift), core::kStageJointDrift);
    EXPECT_EQ(alone(hinged, core::integrate), core::kStageIntegrate | core::kStageJointSolve);
  }
  if constexpr (core::kWithDeformable) {
    const core::Model net = make_lean_model(LeanPart::kNet);
    EXPECT_EQ(alone(net, core::detect_node_contacts), core::kStageNodeContacts);
    EXPECT_EQ(alone(net, core::compute_net_forces), core::kStageNetForces);
    EXPECT_EQ(alone(net, core::compute_forces), core::kStageBodyForces | core::kStageNetForces);
    EXPECT_EQ(alone(net, core::measure_nets), core::kStageMeasureNets);
  }
}

// The forces stage runs the nets' forces by the plan, not by the model's nets.
TEST(StepStages, NetForcesFollowThePlan) {
  NUMEN_REQUIRE_DEFORMABLE();
  core::Model m = make_lean_model(LeanPart::kNet);
  core::Data d = core::make_data(m);
  std::vector<core::Vec3>& node_force = d.scratch->net.force;  // written by compute_net_forces()
  ASSERT_FALSE(node_force.empty());
  m.stage_plan &= ~static_cast<std::uint32_t>(core::kStageNetForces);  // by hand: no step()
  for (core::Vec3& f : node_force) f.setZero();
  core::compute_forces(m, d);
  EXPECT_EQ(d.stages_run, core::kStageBodyForces);
  EXPECT_TRUE(node_force[0].isZero(0.0)) << "the nets' forces ran without their stage";
  m.stage_plan |= core::kStageNetForces;
  d.stages_run = 0;
  core::compute_forces(m, d);
  EXPECT_EQ(d.stages_run, core::kStageBodyForces | core::kStageNetForces);
  EXPECT_FALSE(node_force[0].isZero(0.0)) << "the node's weight";
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
      const core::Model m = lean_model(part, integ);
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
      EXPECT_EQ(d.stages_run, m.stage_plan) << what;
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

// The multirate god-object's two loops step their own models (the god-object model and the
// scene-loop model, each finalized by the object: Model::stage_plan current), each reporting
// its plan, and the single-rate view reports both: every multirate integrator × (joints, nets).
TEST(StepStages, MultirateLoopsReportTheirModelsPlans) {
  std::vector<LeanPart> parts{LeanPart::kNone, LeanPart::kObstacle};
  if (core::kWithArticulation) parts.push_back(LeanPart::kJoint);
  if (core::kWithDeformable) parts.push_back(LeanPart::kNet);
  if (core::kWithArticulation && core::kWithDeformable) parts.push_back(LeanPart::kJointAndNet);
  for (LeanPart part : parts) {
    for (auto integ :
         {core::Integrator::kLinearlyImplicitEuler, core::Integrator::kSymplecticEuler}) {
      const core::Model scene = lean_model(part, integ);
      const auto mr = std::make_unique<core::MultirateGodObject>(
          scene, 0, core::MultirateSettings{2, 0.0, {}});
      core::Data view = core::make_data(scene);
      const std::string what = "part " + std::to_string(static_cast<int>(part)) +
                               ", integrator " + std::to_string(static_cast<int>(integ));
      const core::Model& device = mr->device_model();
      const core::Model& scene_loop = mr->scene_model();
      EXPECT_EQ(device.stage_plan, core::compiled_stages(device)) << what;
      EXPECT_EQ(scene_loop.stage_plan, core::compiled_stages(scene_loop)) << what;
      // The device model has nothing to collide: step() would detect nothing. Its loop steps it
      // split at the contacts, the planes' write_plane_contacts() its contact stage (step.hpp).
      EXPECT_EQ(device.stage_plan & core::kStageContacts, 0u) << what << ": nothing to detect";
      const std::uint32_t device_run = device.stage_plan | core::kStageContacts;  // the planes
      EXPECT_NE(scene_loop.stage_plan & core::kStageDirectTarget, 0u) << what << ": imposed";
      for (int k = 0; k < 4; ++k) {
        mr->step();
        ASSERT_EQ(mr->device_data().status, core::kStepOk) << what;
        EXPECT_EQ(mr->device_data().stages_run, device_run) << what;
        EXPECT_EQ(mr->scene_data().stages_run, scene_loop.stage_plan) << what;
        mr->view(view);
        const std::uint32_t both =
            device_run | (mr->took_model() ? scene_loop.stage_plan : 0u);
        EXPECT_EQ(view.stages_run, both) << what << ", period " << k;
      }
    }
  }
}
