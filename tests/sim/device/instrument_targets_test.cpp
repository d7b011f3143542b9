// Tests of sim/device/instrument_targets: an instrument sample (the trajectory's tool frame, the
// tip) turned into the held body's centre-of-mass target and the other bound bodies' and the
// prescribed joints' — the frame a caller stepping a scene itself must give core::step.
#include "numen/sim/device/instrument_targets.hpp"

#include <cmath>
#include <numbers>
#include <string>

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
