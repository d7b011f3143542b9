// Tests of sim/simulated_instrument: the axis values it reports are the
// instrument's inverse kinematics of the trajectory (forward kinematics gives
// back the recorded tip through the trocar, tool_offset applied), and on the
// bus it answers a SYNC with one encoder TPDO per axis and takes torque RPDOs.
#include "numen/sim/device/simulated_instrument.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <stdexcept>
#include <vector>

#include "alloc_counter.hpp"
#include "numen/hal/device/axis.hpp"
#include "numen/hal/canopen/canopen.hpp"
#include "numen/hal/transport/sim_bus.hpp"
#include "numen/hal/device/trocar_kinematics.hpp"
#include "numen/sim/scene/scene.hpp"
#include "build_features.hpp"
#include "lattice_scene.hpp"
#include "rotation.hpp"
#include "test_constants.hpp"

namespace {

using numen::core::Pose;
using numen::core::Quat;
using numen::core::Vec3;
using numen::hal::AxisVector;
using numen::hal::CanFrame;
using numen::hal::DeviceConfig;
using numen::hal::IoStatus;
using numen::hal::SimBus;
using numen::hal::TrocarKinematics;
using numen::sim::SimulatedInstrument;
using numen::sim::Trajectory;
using TK = TrocarKinematics;
using numen::test::kMs;

Quat rx(double a) { return Quat(Eigen::AngleAxisd(a, Vec3::UnitX())); }
Quat ry(double a) { return Quat(Eigen::AngleAxisd(a, Vec3::UnitY())); }
Quat rz(double a) { return Quat(Eigen::AngleAxisd(a, Vec3::UnitZ())); }

using numen::test::angle_between;

/// A trocar above the origin pointing down (−z), controlled frame 40 mm behind the tip.
DeviceConfig trocar_config() {
  DeviceConfig c = numen::hal::make_default_trocar_config(1);
  c.canopen.managed = false;  // SYNC answered at once (no NMT start-up)
  c.trocar.point = Vec3(0.0, 0.0, 0.2);
  c.trocar.orientation = rx(std::numbers::pi);
  c.tool_offset.position = Vec3(0.0, 0.0, -0.04);
  return c;
}

/// Tool pose of axes (a, b, d, ψ) by the documented formula R = R_c Rx(a) Ry(b) Rz(ψ), tip = p_c + d R e_z.
Pose tool_of(const DeviceConfig& c, double a, double b, double d, double psi) {
  Pose p;
  p.orientation = c.trocar.orientation * rx(a) * ry(b) * rz(psi);
  p.position = c.trocar.point + d * (p.orientation * Vec3::UnitZ());
  return p;
}

// Three tool poses through the trocar, 10 ms apart.
struct Fixture {
  DeviceConfig config = trocar_config();
  std::vector<double> a{0.2, 0.25, 0.3}, b{-0.1, -0.05, 0.0}, d{0.12, 0.13, 0.15}, psi{0.7, 0.6, -0.4},
      jaw{0.4, 0.5, 0.6};
  Trajectory traj = make();
  Trajectory make() const {
    std::vector<Pose> poses;
    for (std::size_t i = 0; i < 3; ++i) poses.push_back(tool_of(config, a[i], b[i], d[i], psi[i]));
    return Trajectory(0.01, poses, jaw);
  }
};

TEST(SimulatedInstrument, AxesAreTheInverseKinematicsOfTheTrajectorySamples) {
  const Fixture f;
  const SimulatedInstrument inst(f.config, f.traj);
  for (std::size_t i = 0; i < 3; ++i) {
    const AxisVector q = inst.axes_at(static_cast<std::int64_t>(i) * 10 * kMs);
    ASSERT_EQ(q.size(), 5);
    EXPECT_NEAR(q[TK::kPivotX], f.a[i], 1e-9) << i;
    EXPECT_NEAR(q[TK::kPivotY], f.b[i], 1e-9) << i;
    EXPECT_NEAR(q[TK::kDepth], f.d[i], 1e-12) << i;
    EXPECT_NEAR(q[TK::kRoll], f.psi[i], 1e-9) << i;
    EXPECT_NEAR(q[TK::kJaw], f.jaw[i], 1e-12) << i;
  }
}

TEST(SimulatedInstrument, ControlledPoseIsTheTrajectoryTipWithToolOffsetApplied) {
  const Fixture f;
  const SimulatedInstrument inst(f.config, f.traj);
  for (double t : {0.0, 0.0037, 0.01, 0.015, 0.02}) {
    const auto t_ns = static_cast<std::int64_t>(std::llround(t * 1e9));
    const numen::sim::TrajectorySample s = f.traj.at(t);
    const Pose c = inst.controlled_pose_at(t_ns);
    const Vec3 shaft = (s.pose.position - f.config.trocar.point).normalized();
    // Controlled frame: 40 mm behind the tip along the shaft, z along the shaft.
    EXPECT_LT((c.position - (s.pose.position - 0.04 * shaft)).norm(), 1e-9) << "t = " << t;
    EXPECT_LT((c.orientation * Vec3::UnitZ() - shaft).norm(), 1e-9) << "t = " << t;
    // Tool frame (tip) by the kinematics.
    const auto& kin = static_cast<const TrocarKinematics&>(inst.kinematics());
    const Pose tool = kin.tool_pose(inst.axes_at(t_ns));
    EXPECT_LT((tool.position - s.pose.position).norm(), 1e-9) << "t = " << t;
  }
  // At the samples the recorded orientation has no wrist bend: it is kept.
  EXPECT_LT(angle_between(inst.controlled_pose_at(10 * kMs).orientation, f.traj[1].pose.orientation), 1e-9);
}

TEST(SimulatedInstrument, StartTimeShiftsTheTrajectory) {
  const Fixture f;
  const SimulatedInstrument late(f.config, f.traj, 1000 * kMs);
  const SimulatedInstrument now(f.config, f.traj);
  for (std::int64_t t : {std::int64_t{0}, 5 * kMs, 10 * kMs, 20 * kMs}) {
    EXPECT_LT((late.axes_at(1000 * kMs + t) - now.axes_at(t)).norm(), 1e-15) << t;
  }
  // Before its start the trajectory holds its first sample.
  EXPECT_LT((late.axes_at(0) - now.axes_at(0)).norm(), 1e-15);
}

TEST(SimulatedInstrument, LatticeSceneReportsTheRecordedTip) {
  NUMEN_REQUIRE_ARTICULATION();
  const numen::sim::Scene scene = numen::sim::load_scene(numen::test::lattice_scene_path());
  const SimulatedInstrument inst(scene.device, scene.trajectory);
  const auto& kin = static_cast<const TrocarKinematics&>(inst.kinematics());
  const Pose offset = scene.device.tool_offset;
  double worst = 0.0;
  for (double t = 0.0; t < scene.trajectory.duration(); t += 0.2371) {
    const auto t_ns = static_cast<std::int64_t>(std::llround(t * 1e9));
    const Vec3 tip = scene.trajectory.at(t).pose.position;
    const Pose c = inst.controlled_pose_at(t_ns);
    // Undo the tool offset: tool = controlled · offset⁻¹.
    const Quat r_tool = c.orientation * offset.orientation.conjugate();
    const Vec3 tool_position = c.position - r_tool * offset.position;
    worst = std::max(worst, (tool_position - tip).norm());
    EXPECT_LT((kin.tool_pose(inst.axes_at(t_ns)).position - tip).norm(), 1e-9) << "t = " << t;
    // Shaft through the trocar point.
    const Vec3 shaft = (tip - scene.device.trocar.point).normalized();
    EXPECT_LT((r_tool * Vec3::UnitZ() - shaft).norm(), 1e-9) << "t = " << t;
    EXPECT_NEAR(inst.axes_at(t_ns)[TK::kJaw], scene.trajectory.at(t).jaw, 1e-12);
  }
  EXPECT_LT(worst, 1e-9);
}

TEST(SimulatedInstrument, PoseTrackerReportsTheHandPose) {
  const numen::sim::Scene scene =
      numen::sim::load_scene(std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/construction.toml");
  const SimulatedInstrument inst(scene.device, scene.trajectory);
  for (double t : {0.0, 1.25, 3.3, 6.0, 8.99}) {
    const auto t_ns = static_cast<std::int64_t>(std::llround(t * 1e9));
    const Pose c = inst.controlled_pose_at(t_ns);
    const Pose p = scene.trajectory.at(t).pose;
    EXPECT_LT((c.position - p.position).norm(), 1e-9) << "t = " << t;
    EXPECT_LT(angle_between(c.orientation, p.orientation), 1e-9) << "t = " << t;
  }
}

TEST(SimulatedInstrument, PollAnswersASyncWithOneTpdoPerAxis) {
  const Fixture f;
  SimulatedInstrument inst(f.config, f.traj);
  numen::hal::SimBusSettings settings;
  settings.latency_ns = 100'000;
  SimBus bus(settings);

  const std::int64_t t0 = 10 * kMs;
  bus.set_time_ns(t0);
  ASSERT_EQ(bus.controller().write(numen::hal::make_sync(t0, 1)), IoStatus::kOk);
  EXPECT_EQ(inst.poll(bus.device()), 0) << "the SYNC is still in flight";
  bus.set_time_ns(t0 + settings.latency_ns);
  EXPECT_EQ(inst.poll(bus.device()), 1);
  EXPECT_EQ(inst.emulator().counters().syncs, 1u);
  EXPECT_EQ(inst.emulator().counters().tpdos_sent, 5u);

  // The encoders latched the trajectory when the SYNC arrived.
  const AxisVector q = inst.axes_at(t0 + settings.latency_ns);
  bus.set_time_ns(t0 + 2 * settings.latency_ns);
  CanFrame frame;
  std::vector<bool> seen(5, false);
  int frames = 0;
  while (bus.controller().read(frame) == IoStatus::kOk) {
    ++frames;
    int axis = -1;
    for (int i = 0; i < 5; ++i)
      if (frame.id == f.config.axes[static_cast<std::size_t>(i)].encoder_cob_id) axis = i;
    ASSERT_GE(axis, 0) << "unexpected COB-ID 0x" << std::hex << frame.id;
    EXPECT_FALSE(seen[static_cast<std::size_t>(axis)]) << "two frames for axis " << axis;
    seen[static_cast<std::size_t>(axis)] = true;
    std::int32_t counts = 0;
    ASSERT_EQ(numen::hal::decode_position_pdo(frame, frame.id, counts), numen::hal::DecodeStatus::kOk);
    const auto& ac = f.config.axes[static_cast<std::size_t>(axis)];
    EXPECT_EQ(counts, numen::hal::value_to_counts(ac, q[axis])) << "axis " << axis;
    EXPECT_NEAR(numen::hal::counts_to_value(ac, counts), q[axis], 0.5 / ac.counts_per_unit + 1e-15);
  }
  EXPECT_EQ(frames, 5);

  // A second SYNC is answered again, with the values of its own time.
  bus.set_time_ns(t0 + kMs);
  ASSERT_EQ(bus.controller().write(numen::hal::make_sync(t0 + kMs, 2)), IoStatus::kOk);
  bus.set_time_ns(t0 + kMs + settings.latency_ns);
  EXPECT_EQ(inst.poll(bus.device()), 1);
  EXPECT_EQ(inst.emulator().counters().syncs, 2u);
  EXPECT_EQ(inst.emulator().counters().tpdos_sent, 10u);
  const AxisVector q2 = inst.axes_at(t0 + kMs + settings.latency_ns);
  for (int i = 0; i < 5; ++i)
    EXPECT_EQ(inst.emulator().counts()[static_cast<std::size_t>(i)],
              numen::hal::value_to_counts(f.config.axes[static_cast<std::size_t>(i)], q2[i]));
}

TEST(SimulatedInstrument, DrivesTakeTorqueRpdos) {
  const Fixture f;
  SimulatedInstrument inst(f.config, f.traj);
  SimBus bus(numen::hal::SimBusSettings{});
  const auto& depth = f.config.axes[TK::kDepth];
  ASSERT_TRUE(depth.has_drive());
  ASSERT_EQ(bus.controller().write(numen::hal::encode_torque_pdo(depth.drive_cob_id, 250, 0)), IoStatus::kOk);
  EXPECT_EQ(inst.poll(bus.device()), 1);
  EXPECT_EQ(inst.emulator().counters().rpdos, 1u);
  EXPECT_NEAR(inst.last_torques()[TK::kDepth], 0.25 * depth.rated_torque, 1e-12);
  EXPECT_EQ(inst.last_torques()[TK::kPivotX], 0.0);
  EXPECT_EQ(bus.pending(SimBus::Direction::kDeviceToController), 0u) << "an RPDO is not answered";
}

TEST(SimulatedInstrument, PollNeverAllocates) {
  const Fixture f;
  SimulatedInstrument inst(f.config, f.traj);
  numen::hal::SimBusSettings settings;
  settings.latency_ns = 100'000;
  SimBus bus(settings);
  std::int64_t count = -1;
  int answered = 0;
  {
    numen::test::AllocationGuard guard;
    CanFrame frame;
    for (int k = 0; k < 1000; ++k) {
      const std::int64_t t = k * kMs;
      bus.set_time_ns(t);
      (void)bus.controller().write(numen::hal::make_sync(t, static_cast<std::uint8_t>(1 + k % 240)));
      bus.set_time_ns(t + settings.latency_ns);
      answered += inst.poll(bus.device());
      bus.set_time_ns(t + 2 * settings.latency_ns);
      while (bus.controller().read(frame) == IoStatus::kOk) {
      }
    }
    count = guard.count();
  }
  EXPECT_EQ(count, 0);
  EXPECT_EQ(answered, 1000);
}

TEST(SimulatedInstrument, InvalidConfigThrows) {
  DeviceConfig c = trocar_config();
  c.axes.pop_back();  // a trocar instrument needs 5 axes
  const Fixture f;
  EXPECT_THROW(SimulatedInstrument(c, f.traj), std::invalid_argument);
}

}  // namespace
