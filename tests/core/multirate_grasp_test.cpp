// Tests of grasping in the multirate device loop (issue 69; docs/multirate.md, "Grasping in the
// device loop"): a grasper's jaws close on a free plate that the device loop carries
// (MultirateSettings::carried), grasp it in the device step and lift it, as the single-rate step
// does; the graspers' states reach the run's Data with the scene's body indices; the refusals of
// bodies the device loop cannot carry and of graspers it does not hold.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "numen/core/data.hpp"
#include "numen/core/grasp.hpp"
#include "numen/core/joint.hpp"
#include "numen/core/model.hpp"
#include "numen/core/multirate.hpp"
#include "numen/core/step.hpp"
#include "numen/core/step_stages.hpp"
#include "grasper_rig.hpp"

namespace {

namespace core = numen::core;

using numen::test::kGraspDeg;

/// The grasper of numen::test::add_grasper() (bodies 0–2: the tube the device holds, the jaws;
/// close 30°, open 40°) pointing down over a 10 g block (body 3: a 3 × 3 × 3 grid of 1 mm spheres
/// 2 mm apart) resting on a floor plane, its top 9 mm below the hinge, between the jaws' last
/// spheres. Gravity on; step 0.1 ms (the device period).
core::Model lift_rig() {
  core::Model m;
  m.dt = 1e-4;
  m.gravity = core::Vec3(0, 0, -9.81);
  m.material_names = {"steel"};
  m.material_pairs = {core::MaterialPair{2e4, 10.0, 0.5}};
  numen::test::add_grasper(m, core::Vec3(0, 0, 0.06), 60 * kGraspDeg, 5.0);
  core::BodyModel block;
  block.name = "block";
  block.mass = 0.01;
  block.inertia_body = (0.01 * 0.004 * 0.004 / 6) * core::Mat3::Identity();
  block.sphere_begin = static_cast<int>(m.body_spheres.size());
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k)
        m.body_spheres.push_back(
            core::Sphere{core::Vec3(0.002 * (i - 1), 0.002 * (j - 1), 0.002 * (k - 1)), 0.001});
  block.sphere_count = 27;
  // The hinge at z = 0.02; the block's centre 12 mm below it (its top spheres' tops 9 mm).
  block.initial_pose = core::Pose{core::Vec3(0, 0, 0.008), core::Quat::Identity()};
  m.bodies.push_back(block);
  core::Obstacle floor;
  floor.name = "floor";
  floor.type = core::ShapeType::kPlane;
  floor.pose.position = core::Vec3(0, 0, 0.008 - 0.003);  // under the bottom spheres
  m.obstacles = {floor};
  EXPECT_EQ(core::finalize_model(m), "");
  return m;
}

/// The jaws' opening (rad) and the tube's height over the hinge's start (m) at time t (s): closed
/// from 60° to 10° over the first 0.25 s, then lifted 20 mm at 0.1 m/s.
struct LiftCommand {
  double opening, rate, lift, lift_speed;
};
LiftCommand lift_command(double t) {
  const double close = std::min(t / 0.25, 1.0);
  const double lift = std::clamp((t - 0.3) * 0.1, 0.0, 0.02);
  return {(60.0 - 50.0 * close) * kGraspDeg, t < 0.25 ? -200.0 * kGraspDeg : 0.0, lift,
          t > 0.3 && lift < 0.02 ? 0.1 : 0.0};
}

void drive_lift(core::Data& d, double t) {
  const LiftCommand c = lift_command(t);
  numen::test::set_grasper_opening(d, c.opening, c.rate);
  numen::test::set_grasper_target(d, core::Vec3(0, 0, 0.06 + c.lift), core::Vec3(0, 0, c.lift_speed));
}

/// What a run of the rig gives: when the grasp started (s) and the block's height at the end (m).
struct Lift {
  double grasp_time = -1.0;
  double block_z = 0.0;
  int grasp_body = -1;
};

}  // namespace

// The jaws close on the block and lift it 20 mm: in the single-rate step at 0.1 ms and in the
// multirate device loop at 0.1 ms with the scene loop at 1 ms (the block carried in the device
// loop, the floor's planes from the scene samples). The grasp starts in the same device period,
// the graspers' state in the view names the scene's block, and the block ends within 0.05 mm of
// the single-rate height, 20 mm up.
TEST(MultirateGrasp, TheJawsGraspAndLiftACarriedBodyAsTheSingleRateStep) {
  const core::Model m = lift_rig();
  const int periods = 6000;  // 0.6 s
  Lift single;
  {
    core::Data d = core::make_data(m);
    for (int k = 0; k < periods; ++k) {
      drive_lift(d, k * m.dt);
      core::step(m, d);
      ASSERT_EQ(d.status & core::kNonFinite, 0u) << k;
      if (d.grasps[0].event == core::GraspEvent::kGrasp) single.grasp_time = k * m.dt;
    }
    single.block_z = d.bodies[3].position.z();
    single.grasp_body = d.grasps[0].body;
  }
  Lift multi;
  {
    core::MultirateSettings settings;
    settings.ratio = 10;
    settings.margin = 0.002;
    settings.carried = {3};
    core::MultirateGodObject mr(m, 0, settings);
    ASSERT_EQ(mr.god_object().size(), 4u) << "the grasper's three bodies and the block";
    EXPECT_EQ(mr.device_model().num_grasps(), 1);
    EXPECT_EQ(mr.scene_model().num_grasps(), 0) << "the scene loop does not grasp";
    core::Data run = core::make_data(m);
    for (int k = 0; k < periods; ++k) {
      drive_lift(run, k * m.dt);
      mr.take_targets(run);
      mr.step();
      mr.view(run);
      ASSERT_EQ(run.status & core::kNonFinite, 0u) << k;
      if (run.grasps[0].event == core::GraspEvent::kGrasp) multi.grasp_time = k * m.dt;
    }
    multi.block_z = run.bodies[3].position.z();
    multi.grasp_body = run.grasps[0].body;
    EXPECT_EQ(mr.counters().planes_dropped, 0);
  }
  std::printf("[   info   ] grasp at %.4f s single-rate, %.4f s multirate; block z %.4f mm, %.4f mm\n",
              single.grasp_time, multi.grasp_time, single.block_z * 1e3, multi.block_z * 1e3);
  ASSERT_GT(single.grasp_time, 0.0) << "the jaws grasp the block";
  EXPECT_NEAR(multi.grasp_time, single.grasp_time, 1.5e-4);
  EXPECT_EQ(single.grasp_body, 3);
  EXPECT_EQ(multi.grasp_body, 3) << "the scene's index of the held body";
  EXPECT_NEAR(single.block_z, 0.008 + 0.02, 2e-3) << "lifted with the jaws";
  EXPECT_NEAR(multi.block_z, single.block_z, 5e-5);
}

TEST(MultirateGrasp, BodiesTheDeviceLoopCannotCarryAndGraspersItDoesNotHoldAreRefused) {
  const core::Model m = lift_rig();
  const auto refusal = [&](const core::Model& model, const core::MultirateSettings& s) {
    try {
      // On the heap: the object is large, and ASan gives each inlined call its own frame.
      const auto mr = std::make_unique<core::MultirateGodObject>(model, 0, s);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  core::MultirateSettings s;
  s.ratio = 10;
  s.margin = 0.002;
  s.carried = {1};  // a jaw
  EXPECT_NE(refusal(m, s).find("carried body 'jaw_1' is in joint"), std::string::npos) << refusal(m, s);
  s.carried = {7};
  EXPECT_NE(refusal(m, s).find("carried body 7 is not a body"), std::string::npos) << refusal(m, s);
  core::Model anchored = m;
  anchored.bodies[3].anchored = true;
  ASSERT_EQ(core::finalize_model(anchored), "");
  s.carried = {3};
  EXPECT_NE(refusal(anchored, s).find("carried body 'block' is anchored"), std::string::npos)
      << refusal(anchored, s);
  // A grasper whose jaw is the block, not an instrument's body: the scene loop does not grasp.
  core::Model odd = m;
  odd.grasps.push_back(odd.grasps.front());
  odd.grasps.back().name = "odd";
  odd.grasps.back().jaws = {1, 3};
  ASSERT_EQ(core::finalize_model(odd), "");
  s.carried = {};
  EXPECT_NE(refusal(odd, s).find("grasper 'odd' has a jaw in no device's instrument"), std::string::npos)
      << refusal(odd, s);
  // Tool switching would drop what the jaws hold.
  s.carried = {};
  s.tools = {3};
  EXPECT_NE(refusal(m, s).find("one held body"), std::string::npos) << refusal(m, s);
}
