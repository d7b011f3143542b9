/// @file plant_motion_test.cpp
/// The closed loop's emulated device (sim/device/plant_motion.hpp) on a pose tracker_device: a free
/// axis under the drive's torque, the hand pulling the handle to the intent, stiction holding
/// it, the torque's arrival within the period, the port energy of a passive device, limit-cycle
/// detection on clean signals, divergence, refused settings, no allocation.

#include "numen/sim/device/plant_motion.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "alloc_counter.hpp"
#include "numen/hal/device/device_config.hpp"
#include "test_constants.hpp"

namespace numen::sim {
namespace {

using numen::test::kMs;
using numen::test::kPi;

hal::DeviceConfig tracker_device() { return hal::make_default_pose_tracker_config(1); }

/// A trajectory holding the tool at `x` (m) for 10 s, sampled at 1 ms.
Trajectory still_at(const core::Vec3& x) {
  core::Pose p;
  p.position = x;
  return Trajectory(1e-3, std::vector<core::Pose>(10001, p));
}

/// Every axis a 0.1 kg (kg·m² for the angles) mass, no damping or friction.
DevicePlantSettings plant(double inertia = 0.1, double damping = 0.0, double coulomb = 0.0) {
  DevicePlantSettings s;
  AxisPlantSettings a;
  a.inertia = inertia;
  a.damping = damping;
  a.coulomb = coulomb;
  s.axes.assign(6, a);
  return s;
}

HandSettings no_hand() {
  HandSettings h;
  h.mass = h.stiffness = h.damping = 0.0;
  h.rotational_inertia = h.rotational_stiffness = h.rotational_damping = 0.0;
  return h;
}

hal::DriveCommands torque_on_x(double tau) {
  hal::DriveCommands c;
  c.torque = hal::AxisVector::Zero(6);
  c.torque[0] = tau;
  return c;
}

// No hand: the x axis under a held 0.2 N from the first SYNC on moves as ½ (τ/m) t²; the
// torque received at a SYNC acts from the torque phase after the previous one.
TEST(PlantMotion, FreeAxisFollowsTheDrivesTorque) {
  const Trajectory traj = still_at(core::Vec3::Zero());
  DevicePlantSettings s = plant();
  s.torque_phase_s = 0.0;
  PlantMotion m(tracker_device(), s, no_hand(), traj);
  (void)m.at_sync(0, torque_on_x(0.0));
  for (int k = 1; k <= 1000; ++k) (void)m.at_sync(k * kMs, torque_on_x(0.2));
  EXPECT_NEAR(m.state().q[0], 0.5 * 2.0 * 1.0, 1e-9);
  EXPECT_NEAR(m.state().qdot[0], 2.0, 1e-9);
  EXPECT_EQ(m.state().q[1], 0.0);
  // With the torque arriving 0.25 ms after each SYNC, each period's first quarter still holds
  // the previous command: one quarter-period less of it overall.
  s.torque_phase_s = 0.25e-3;
  PlantMotion late(tracker_device(), s, no_hand(), traj);
  (void)late.at_sync(0, torque_on_x(0.0));
  for (int k = 1; k <= 1000; ++k) (void)late.at_sync(k * kMs, torque_on_x(0.2));
  EXPECT_NEAR(late.state().qdot[0], 2.0 * (1.0 - 0.25e-3), 1e-9);
}

// SYNCs late or lost: the interval is integrated whole (q̇ = (τ/m) t across a 5-period gap); a
// silence of more than kMaxSyncGapS restarts the device at rest at the intent.
TEST(PlantMotion, ALateSyncIsIntegratedAndALongSilenceRestarts) {
  const Trajectory traj = still_at(core::Vec3(0.01, 0.0, 0.0));
  DevicePlantSettings s = plant();
  s.torque_phase_s = 0.0;
  PlantMotion m(tracker_device(), s, no_hand(), traj);
  (void)m.at_sync(0, torque_on_x(0.0));
  (void)m.at_sync(1 * kMs, torque_on_x(0.2));
  (void)m.at_sync(6 * kMs, torque_on_x(0.2));
  EXPECT_NEAR(m.state().qdot[0], 2.0 * 6e-3, 1e-12);
  (void)m.at_sync(6 * kMs + static_cast<std::int64_t>(kMaxSyncGapS * 1e9) + kMs, torque_on_x(0.2));
  EXPECT_EQ(m.state().qdot[0], 0.0);
  EXPECT_NEAR(m.state().q[0], 0.01, 1e-12);
  EXPECT_FALSE(m.figures().diverged);
}

// The hand alone (no torque) pulls a damped device onto the intent; the device started there,
// so it is moved by the hand's 10 mm offset only.
TEST(PlantMotion, TheHandPullsTheHandleToTheIntent) {
  const Trajectory traj = still_at(core::Vec3(0.01, 0.0, 0.0));
  PlantMotion m(tracker_device(), plant(0.1, 2.0), HandSettings{}, traj);
  (void)m.at_sync(0, torque_on_x(0.0));
  EXPECT_NEAR(m.state().q[0], 0.01, 1e-12) << "the device starts where the hand is";
  // Push the device off the intent with a torque pulse, then let the hand bring it back.
  for (int k = 1; k <= 50; ++k) (void)m.at_sync(k * kMs, torque_on_x(1.0));
  EXPECT_GT(m.state().q[0], 0.0105);
  for (int k = 51; k <= 3000; ++k) (void)m.at_sync(k * kMs, torque_on_x(0.0));
  EXPECT_NEAR(m.state().q[0], 0.01, 1e-6);
  EXPECT_GT(m.figures().handle_force_max_n, 0.0);
  EXPECT_LT(m.figures().port_energy_min_j, 0.0) << "the drive's pulse came back to the hand";
  EXPECT_FALSE(m.figures().limit_cycle.detected());
}

// Without torque the device is passive: the energy the hand has put in (kinetic, then
// dissipated by damping and friction) never falls below zero, whatever the hand does.
TEST(PlantMotion, AnUndrivenDeviceNeverGivesEnergyBack) {
  std::vector<core::Pose> poses(3001);
  for (std::size_t k = 0; k < poses.size(); ++k)
    poses[k].position = core::Vec3(0.02 * std::sin(2 * kPi * 3.0 * k * 1e-3), 0.0, 0.0);
  const Trajectory traj(1e-3, poses);
  PlantMotion m(tracker_device(), plant(0.1, 0.5, 0.05), HandSettings{}, traj);
  for (int k = 0; k <= 3000; ++k) (void)m.at_sync(k * kMs, torque_on_x(0.0));
  EXPECT_GT(m.figures().port_energy_j, 0.0);
  EXPECT_GE(m.figures().port_energy_min_j, -1e-6 * m.figures().port_energy_j);
}

// Stiction: a torque at or below f_c on an axis at rest does not move it.
TEST(PlantMotion, CoulombFrictionHoldsAWeakTorque) {
  const Trajectory traj = still_at(core::Vec3::Zero());
  PlantMotion m(tracker_device(), plant(0.1, 0.0, 0.3), no_hand(), traj);
  (void)m.at_sync(0, torque_on_x(0.0));
  for (int k = 1; k <= 200; ++k) (void)m.at_sync(k * kMs, torque_on_x(0.3));
  EXPECT_EQ(m.state().q[0], 0.0);
  for (int k = 201; k <= 400; ++k) (void)m.at_sync(k * kMs, torque_on_x(0.4));
  EXPECT_GT(m.state().q[0], 0.0);
}

// An axis of inertia 0 follows the intent exactly (here yaw).
TEST(PlantMotion, AnAxisOfInertiaZeroFollowsTheIntent) {
  std::vector<core::Pose> poses(2001);
  for (std::size_t k = 0; k < poses.size(); ++k)
    poses[k].orientation = core::Quat(Eigen::AngleAxisd(0.2 * k * 1e-3, core::Vec3::UnitZ()));
  const Trajectory traj(1e-3, poses);
  DevicePlantSettings s = plant();
  s.axes[3].inertia = 0.0;
  PlantMotion m(tracker_device(), s, HandSettings{}, traj);
  for (int k = 0; k <= 1000; ++k) (void)m.at_sync(k * kMs, torque_on_x(0.0));
  EXPECT_NEAR(m.state().q[3], 0.2, 1e-9);
}

// A runaway axis (a huge torque on a tiny inertia) is flagged with its axis, its speed and its
// runaway speed (100 x its max_speed), and the plant holds.
TEST(PlantMotion, ARunawayAxisIsFlagged) {
  const Trajectory traj = still_at(core::Vec3::Zero());
  PlantMotion m(tracker_device(), plant(1e-6), no_hand(), traj);
  (void)m.at_sync(0, torque_on_x(0.0));
  for (int k = 1; k <= 10; ++k) (void)m.at_sync(k * kMs, torque_on_x(1e3));
  EXPECT_TRUE(m.figures().diverged);
  EXPECT_EQ(m.figures().diverged_axis, 0);
  EXPECT_TRUE(std::isfinite(m.state().q[0]));
  EXPECT_EQ(m.figures().diverged_speed_limit, 100.0 * tracker_device().axes[0].max_speed);
  EXPECT_GT(m.figures().diverged_speed, m.figures().diverged_speed_limit);
  EXPECT_EQ(m.figures().diverged_speed, std::abs(m.axis(0).qdot())) << "the speed that breached";
}

TEST(PlantMotion, RefusesBadSettingsNamingThem) {
  const Trajectory traj = still_at(core::Vec3::Zero());
  const auto message = [&](const DevicePlantSettings& s, const HandSettings& h) {
    try {
      PlantMotion m(tracker_device(), s, h, traj);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  DevicePlantSettings s = plant();
  s.axes.pop_back();
  EXPECT_NE(message(s, HandSettings{}).find("the plant gives 5 axes, the device has 6"),
            std::string::npos);
  s = plant();
  s.axes[2].damping = -1.0;
  EXPECT_NE(message(s, HandSettings{}).find("axis z: damping must be finite and >= 0"),
            std::string::npos);
  s = plant();
  s.substeps = 0;
  EXPECT_NE(message(s, HandSettings{}).find("substeps"), std::string::npos);
  HandSettings h;
  h.mass = std::nan("");
  EXPECT_NE(message(plant(), h).find("hand mass must be finite and >= 0"), std::string::npos);
}

TEST(PlantMotion, AtSyncNeverAllocates) {
  const Trajectory traj = still_at(core::Vec3(0.01, 0.0, 0.0));
  DevicePlantSettings s = plant(0.1, 1.0, 0.05);
  s.torque_phase_s = 0.3e-3;
  s.axes[0].delay_periods = 2;
  s.axes[0].current_lag_s = 1e-4;
  PlantMotion m(tracker_device(), s, HandSettings{}, traj);
  (void)m.at_sync(0, torque_on_x(0.0));
  numen::test::AllocationGuard guard;
  for (int k = 1; k <= 500; ++k) (void)m.at_sync(k * kMs, torque_on_x(0.5 * std::sin(k * 0.1)));
  EXPECT_EQ(guard.count(), 0);
}

/// Feeds `detector` x = a(t) sin(2π f t) for `seconds` at 1 kHz.
LimitCycleDetector fed(double amplitude_m, double hz, double seconds, double decay_per_s = 0.0) {
  LimitCycleDetector d;
  for (int k = 0; k <= static_cast<int>(seconds * 1000); ++k) {
    const double t = k * 1e-3;
    const double a = amplitude_m * std::exp(-decay_per_s * t);
    d.add(core::Vec3(a * std::sin(2 * kPi * hz * t), 0.0, 0.0), t, 1e-3);
  }
  return d;
}

// A sustained 15 Hz, 1 mm oscillation is a limit cycle (amplitude and frequency measured); the
// hand's own 2 Hz motion, an oscillation that dies out, and motion at the encoder scale are not.
TEST(LimitCycleDetector, FindsASustainedOscillationAndNothingElse) {
  const LimitCycleDetector buzz = fed(1e-3, 15.0, 2.0);
  EXPECT_TRUE(buzz.detected());
  EXPECT_NEAR(buzz.frequency_hz(), 15.0, 1.0);
  EXPECT_NEAR(buzz.amplitude_m(), 1e-3, 0.1e-3);  // the 5 Hz high-pass passes 95 % at 15 Hz
  EXPECT_LT(buzz.time_s(), 1.0);
  EXPECT_FALSE(fed(5e-3, 2.0, 2.0).detected()) << "the hand's motion";
  EXPECT_FALSE(fed(1e-3, 15.0, 2.0, 10.0).detected()) << "a decaying oscillation";
  EXPECT_FALSE(fed(2e-5, 40.0, 2.0).detected()) << "motion inside the 0.05 mm band";
}

}  // namespace
}  // namespace numen::sim
