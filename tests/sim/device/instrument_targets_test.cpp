// Tests of sim/device/instrument_targets: an instrument sample (the trajectory's tool frame, the
// tip) turned into the held body's centre-of-mass target and the other bound bodies' and the
// prescribed joints' — the frame a caller stepping a scene itself must give core::step.
#include "numen/sim/device/instrument_targets.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "alloc_counter.hpp"
#include "build_features.hpp"
#include "numen/core/data.hpp"
#include "numen/core/rigid_body.hpp"
#include "numen/core/step.hpp"
#include "numen/hal/device/trocar_kinematics.hpp"
#include "numen/sim/scene/scene.hpp"
#include "temp_dir.hpp"

namespace {

namespace core = numen::core;
namespace sim = numen::sim;

/// The shipped lattice scene (the default scene's instrument: sleeve, tube, two jaws).
sim::Scene instrument_targets_lattice() {
  return sim::load_scene(std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/lattice.toml");
}

int instrument_targets_body(const core::Model& m, const std::string& name) {
  for (int b = 0; b < m.num_bodies(); ++b)
    if (m.bodies[static_cast<std::size_t>(b)].name == name) return b;
  return -1;
}

double instrument_targets_angle_deg(const core::Quat& a, const core::Quat& b) {
  return 2.0 * std::acos(std::min(1.0, std::abs(a.dot(b)))) * 180.0 / std::numbers::pi;
}

}  // namespace

TEST(InstrumentTargets, TheTrajectorySampleIsTheTipFortyMillimetresAheadOfTheHeldTube) {
  NUMEN_REQUIRE_ARTICULATION();  // the lattice scene has joints
  const sim::Scene scene = instrument_targets_lattice();
  core::Data data = core::make_data(scene.model);
  const int tube = instrument_targets_body(scene.model, "tube");
  ASSERT_EQ(data.held_body, tube);
  const sim::TrajectorySample tip = scene.trajectory.at(0.0);
  const sim::InstrumentTargets targets(scene);
  targets.set(tip, data);
  // The held body's target is the tube's centre of mass: 40 mm behind the tip along the shaft
  // (the tube's link_offset), the shaft through the trocar; the recorded orientation keeps the
  // surgeon's wrist, 16.5° off that shaft.
  const core::Vec3 offset = tip.pose.position - data.target.position;
  EXPECT_NEAR(offset.norm(), 0.040, 1e-12);
  const core::Vec3 shaft = data.target.orientation * core::Vec3::UnitZ();
  EXPECT_NEAR(offset.normalized().dot(shaft), 1.0, 1e-12);
  const core::Vec3 to_tip = (tip.pose.position - scene.device.trocar.point).normalized();
  EXPECT_NEAR(shaft.dot(to_tip), 1.0, 1e-12);
  EXPECT_NEAR(instrument_targets_angle_deg(tip.pose.orientation, data.target.orientation), 16.5, 0.05);
  EXPECT_TRUE(data.target_twist.linear.isZero(0.0));  // a single sample: at rest
  // The sleeve has its own target at the trocar point; the jaws at the tip, each hinge imposed
  // at ±jaw/2.
  const int sleeve = instrument_targets_body(scene.model, "sleeve");
  ASSERT_GE(sleeve, 0);
  EXPECT_TRUE(data.body_targets[static_cast<std::size_t>(sleeve)].enabled);
  EXPECT_NEAR((data.body_targets[static_cast<std::size_t>(sleeve)].pose.position -
               scene.device.trocar.point).norm(), 0.0, 1e-12);
  ASSERT_EQ(scene.model.num_joints(), 4);
  EXPECT_NEAR(data.joint_prescribed[2].value, 0.5 * tip.jaw, 1e-12);   // jaw_1_hinge
  EXPECT_NEAR(data.joint_prescribed[3].value, -0.5 * tip.jaw, 1e-12);  // jaw_2_hinge
}

TEST(InstrumentTargets, TheRatesAreTheTrajectorysOverAPeriodAndTheCallDoesNotAllocate) {
  NUMEN_REQUIRE_ARTICULATION();  // the lattice scene has joints
  const sim::Scene scene = instrument_targets_lattice();
  core::Data data = core::make_data(scene.model);
  const sim::InstrumentTargets targets(scene);
  const double t = 1.0, h = scene.trajectory.period();
  targets.set_at(scene.trajectory, t, data);
  const core::Pose now = data.target;
  const core::Twist twist = data.target_twist;
  targets.set(scene.trajectory.at(t + h), data);
  // The held body's target velocity is the difference of its targets a trajectory period apart
  // (to the rigid transfer's second order: 0.24 % here, the shaft turns little in a period).
  const core::Vec3 difference = (data.target.position - now.position) / h;
  EXPECT_LT((twist.linear - difference).norm(), 5e-3 * difference.norm())
      << twist.linear.transpose() << " vs " << difference.transpose();
  EXPECT_GT(difference.norm(), 1e-3);  // it moves at t = 1 s
  std::int64_t allocations = -1;
  {
    numen::test::AllocationGuard guard;
    for (int k = 0; k < 100; ++k) {
      targets.set_at(scene.trajectory, data.time, data);
      core::step(scene.model, data);
    }
    allocations = guard.count();
  }
  EXPECT_EQ(allocations, 0);
  EXPECT_EQ(data.invalid_target_steps, 0);
}

TEST(InstrumentTargets, WithoutADeviceTheSampleIsTheHeldBodysTarget) {
  // A scene stepped by its caller without [device] (a ball, no trajectory): the identity pose
  // tracker, the ball held.
  numen::test::TempDir dir;
  const std::string path = dir.write("ball.toml", R"([[material]]
name = "m"
[[body]]
name = "ball"
mass = 0.1
spheres = [[0.0, 0.0, 0.0, 0.01]]
)");
  sim::SceneOverrides caller;
  caller.caller_steps = true;
  const sim::Scene scene = sim::load_scene(path, caller);
  ASSERT_FALSE(scene.has_device);
  core::Data data = core::make_data(scene.model);
  ASSERT_EQ(data.held_body, 0);
  sim::TrajectorySample s;
  s.pose.position = core::Vec3(0.01, -0.02, 0.03);
  s.pose.orientation = core::Quat(Eigen::AngleAxisd(0.3, core::Vec3::UnitY()));
  sim::InstrumentTargets(scene).set(s, data);
  EXPECT_NEAR((data.target.position - s.pose.position).norm(), 0.0, 1e-15);
  EXPECT_NEAR(instrument_targets_angle_deg(data.target.orientation, s.pose.orientation), 0.0, 1e-6);
}

TEST(InstrumentTargets, TheHeldBodysTargetAndTheTipOffsetAreReadWithoutSettingAnything) {
  NUMEN_REQUIRE_ARTICULATION();  // the lattice scene has joints
  const sim::Scene scene = instrument_targets_lattice();
  const sim::InstrumentTargets targets(scene);
  const sim::TrajectorySample tip = scene.trajectory.at(1.0);
  core::Data data = core::make_data(scene.model);
  const core::Pose before = data.target;
  core::Pose body, offset;
  ASSERT_TRUE(targets.held_body_target(tip, data, body));
  ASSERT_TRUE(targets.tool_in_held_body(tip, data, offset));
  // Nothing set; then set() gives the held body the same target.
  EXPECT_TRUE(data.target.position == before.position);
  targets.set(tip, data);
  EXPECT_NEAR((data.target.position - body.position).norm(), 0.0, 1e-15);
  EXPECT_NEAR(instrument_targets_angle_deg(data.target.orientation, body.orientation), 0.0, 1e-6);
  // The tip in the tube's centre-of-mass frame: 40 mm ahead along its z (the shaft).
  EXPECT_NEAR((offset.position - core::Vec3(0.0, 0.0, 0.040)).norm(), 0.0, 1e-12)
      << offset.position.transpose();
  // With no body held there is no such target.
  data.held_body = -1;
  EXPECT_FALSE(targets.held_body_target(tip, data, body));
}

TEST(InstrumentTargets, OnTheProbeSceneTheToolFrameIsTheProbesCentreOfMass) {
  sim::SceneOverrides caller;
  caller.caller_steps = true;
  const sim::Scene scene =
      sim::load_scene(std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/probe.toml", caller);
  const core::Data data = core::make_data(scene.model);
  sim::TrajectorySample s;
  s.pose.position = core::Vec3(0.01, 0.0, -0.004);
  core::Pose offset;
  ASSERT_TRUE(sim::InstrumentTargets(scene).tool_in_held_body(s, data, offset));
  EXPECT_NEAR(offset.position.norm(), 0.0, 1e-15);
  EXPECT_NEAR(instrument_targets_angle_deg(offset.orientation, core::Quat::Identity()), 0.0, 1e-6);
}

/// The probe scene's feedback while the caller steps it: its target 20 mm beside the probe from
/// the first step, a 100-step dropout (a NaN target) from step 300 while the hand goes 5 mm
/// further. Returns |force| per step, raw (Data::feedback_wrench) and through `ramp`.
static void feedback_ramp_run(sim::FeedbackRamp& ramp, std::vector<double>& raw,
                              std::vector<double>& ramped) {
  sim::SceneOverrides caller;
  caller.caller_steps = true;
  const sim::Scene scene =
      sim::load_scene(std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/probe.toml", caller);
  core::Data data = core::make_data(scene.model);
  for (int k = 0; k < 600; ++k) {
    const double x = k < 300 ? 0.020 : 0.025;
    data.target.position = core::Vec3(300 <= k && k < 400 ? std::nan("") : x, 0.0, 0.01);
    core::step(scene.model, data);
    raw.push_back(data.feedback_wrench.force.norm());
    ramped.push_back(ramp.apply(data).force.norm());
  }
  ASSERT_EQ(data.invalid_target_steps, 100);
}

TEST(FeedbackRamp, TakesTheKickOutOfTheFirstTargetAndOfTheJumpAfterADropout) {
  sim::SceneOverrides caller;
  caller.caller_steps = true;
  const sim::Scene scene =
      sim::load_scene(std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/probe.toml", caller);
  ASSERT_EQ(scene.device.soft_start_s, 0.1);  // the scenes' default
  sim::FeedbackRamp ramp(scene);
  std::vector<double> raw, ramped;
  feedback_ramp_run(ramp, raw, ramped);
  // Raw: the whole 20 mm spring at step 0 (3.9 N), and the 5 mm the hand went during the
  // dropout in one step (0.98 N). Ramped over 0.1 s: 1 % of them.
  EXPECT_NEAR(raw[0], 3.9136, 1e-4);
  EXPECT_NEAR(ramped[0], 0.01 * raw[0], 1e-12);
  EXPECT_NEAR(raw[400] - raw[399], 0.9784, 1e-4);
  EXPECT_LT(std::abs(ramped[400] - ramped[399]), 0.011);
  double largest = 0.0;
  for (std::size_t k = 1; k < ramped.size(); ++k)
    largest = std::max(largest, std::abs(ramped[k] - ramped[k - 1]));
  EXPECT_LT(largest, 0.04);  // at most the first step's 1 % of 3.9 N
  // Held through the dropout, back to the raw feedback once the ramp is over.
  EXPECT_EQ(ramped[350], ramped[299]);
  EXPECT_NEAR(ramped[599], raw[599], 1e-12);
  EXPECT_EQ(ramp.ramp(), 1.0);
  // Off (soft_start 0): the raw feedback, as it is.
  sim::FeedbackRamp off(0.0, scene.model.dt);
  std::vector<double> raw_off, same;
  feedback_ramp_run(off, raw_off, same);
  EXPECT_EQ(same, raw_off);
  EXPECT_THROW(sim::FeedbackRamp(-1.0, 0.001), std::invalid_argument);
  // apply() does not allocate.
  core::Data data = core::make_data(scene.model);
  std::int64_t allocations = -1;
  {
    numen::test::AllocationGuard guard;
    for (int k = 0; k < 10; ++k) {
      core::step(scene.model, data);
      ramp.apply(data);
    }
    allocations = guard.count();
  }
  EXPECT_EQ(allocations, 0);
}
