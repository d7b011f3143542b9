// Tests of platform/admittance_loop: one period of an admittance device on a SimBus against
// the emulated device (hal::AdmittanceEmulator) — the measured force drives the god-object,
// the device is commanded its pose, a silent sensor latches the safe state.
#include "numen/platform/admittance_loop.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "alloc_counter.hpp"
#include "numen/core/rigid_body.hpp"
#include "numen/hal/emulation/admittance_emulator.hpp"
#include "numen/hal/canopen/cia402.hpp"
#include "numen/hal/transport/sim_bus.hpp"

namespace core = numen::core;
namespace hal = numen::hal;
namespace platform = numen::platform;
using core::Vec3;

namespace {

core::Model ball_model(core::CouplingMode mode = core::CouplingMode::kAdmittance) {
  core::Model m;
  m.gravity = Vec3::Zero();
  m.coupling_mode = mode;
  m.material_pairs = {core::MaterialPair{}};
  m.body_spheres = {core::Sphere{Vec3::Zero(), 0.005}};
  core::BodyModel b;
  b.name = "probe";
  b.mass = 0.05;
  b.inertia_body = core::Mat3::Identity() * 1e-4;
  b.sphere_count = 1;
  m.bodies = {b};
  m.initial_attached_body = 0;
  EXPECT_EQ(core::finalize_model(m), "");
  return m;
}

hal::DeviceConfig tracker() {
  hal::DeviceConfig c = hal::make_default_pose_tracker_config(1);
  c.control_period_s = 1e-3;
  return c;
}

/// The loop, the emulated device and the bus of one test (latency 100 µs, phase 300 µs).
struct Rig {
  core::Model model = ball_model();
  core::Data data = core::make_data(model);
  hal::SimBus bus{hal::SimBusSettings{100'000, 0.0, 0.0, 1, 256}};
  hal::AdmittanceEmulator emulator;
  hal::AdmittanceDevice device;
  platform::AdmittanceLoop loop;
  core::Pose hand;
  std::int64_t k = 0;

  explicit Rig(const hal::AdmittanceEmulatorSettings& s,
               const platform::AdmittanceLoopSettings& loop_settings = {})
      : emulator(tracker(), hal::make_admittance_config(tracker()), s),
        device(tracker(), hal::make_admittance_config(tracker()), hal::AxisVector::Zero(6)),
        loop(model, data, bus.controller(), device, loop_settings) {
    emulator.set_axis_values(hal::AxisVector::Zero(6));
  }

  /// One period; `overran`: told to end_period as a paced loop's overrun wake-up.
  const platform::AdmittanceReport& period(bool overran = false) {
    const std::int64_t t = k++ * 1'000'000;
    emulator.set_hand(hand, core::Twist{});
    bus.set_time_ns(t);
    loop.begin_period(t);
    bus.set_time_ns(t + 100'000);
    emulator.poll(bus.device());
    bus.set_time_ns(t + 300'000);
    return loop.end_period(t + 300'000, overran);
  }
};

hal::AdmittanceEmulatorSettings hand_settings() {
  hal::AdmittanceEmulatorSettings s;
  s.k_hand = 200.0;
  s.c_hand = 6.0;
  s.k_hand_rot = 0.05;
  s.c_hand_rot = 0.004;
  s.lag_s = 0.002;
  return s;
}

}  // namespace

TEST(AdmittanceLoop, RefusesAModelThatIsNotInAdmittanceMode) {
  const core::Model m = ball_model(core::CouplingMode::kGodObject);
  core::Data d = core::make_data(m);
  hal::SimBus bus{hal::SimBusSettings{}};
  hal::AdmittanceDevice dev(tracker(), hal::make_admittance_config(tracker()));
  EXPECT_THROW(platform::AdmittanceLoop(m, d, bus.controller(), dev), std::invalid_argument);
  const core::Model a = ball_model();
  platform::AdmittanceLoopSettings s;
  s.force_timeout_periods = 0;
  EXPECT_THROW(platform::AdmittanceLoop(a, d, bus.controller(), dev, s), std::invalid_argument);
}

TEST(AdmittanceLoop, TheHandPullsTheGodObjectAndTheDeviceFollowsIt) {
  Rig rig(hand_settings());
  rig.hand.position = Vec3(0.02, 0.0, 0.0);  // the hand 20 mm away along x
  const platform::AdmittanceReport& first = rig.period();
  EXPECT_TRUE(first.sample_valid);
  EXPECT_TRUE(first.activated);
  EXPECT_EQ(first.lifecycle, hal::LifecycleState::kActive);
  EXPECT_EQ(first.controlword, hal::Controlword::kEnableOperation);
  EXPECT_NEAR(first.measured.force.x(), 4.0, 1e-3);  // 200 N/m × 20 mm
  for (int i = 0; i < 1500; ++i) rig.period();
  // Everything settles on the hand: god-object, set-points, device.
  EXPECT_NEAR(rig.data.bodies[0].position.x(), 0.02, 2e-4);
  EXPECT_NEAR(rig.device.setpoints()[0], 0.02, 2e-4);
  EXPECT_NEAR(rig.emulator.q()[0], 0.02, 2e-4);
  EXPECT_LT(rig.loop.last_report().measured.force.norm(), 0.05);
  EXPECT_EQ(rig.loop.counters().invalid_periods, 0u);
  EXPECT_EQ(rig.data.feedback_wrench.force.norm(), 0.0);
}

TEST(AdmittanceLoop, TheHandTurnsTheGodObjectThroughTheMeasuredTorque) {
  // Rotation path: hand torque → sensor frame → world about the COM → god-object → IK
  // (yaw, pitch, roll set-points) → the device turns with it.
  Rig rig(hand_settings());
  rig.hand.orientation = core::Quat(Eigen::AngleAxisd(0.3, Vec3::UnitZ())) *
                         core::Quat(Eigen::AngleAxisd(0.2, Vec3::UnitX()));
  const platform::AdmittanceReport& first = rig.period();
  // T = k_rot θu with θu the rotation vector from the device (identity) to the hand.
  const Vec3 theta_u = numen::core::quat_log(rig.hand.orientation);
  const double count = 1e-4;  // default torque_scale, N·m per count
  EXPECT_LT((first.measured.torque - 0.05 * theta_u).norm(), count) << first.measured.torque;
  EXPECT_GT(first.measured.torque.norm(), 0.015);
  for (int i = 0; i < 1500; ++i) rig.period();
  const double body_err =
      numen::core::quat_log(rig.hand.orientation * rig.data.bodies[0].orientation.conjugate())
          .norm();
  const double dev_err =
      numen::core::quat_log(rig.hand.orientation * rig.emulator.pose().orientation.conjugate())
          .norm();
  // At rest the residual is the sensor's dead band: below half a count per axis the torque
  // reads 0, i.e. |θ| <= √3 · 0.5 count / k_rot = 1.73 mrad.
  const double dead_band = std::sqrt(3.0) * 0.5 * count / 0.05;
  EXPECT_LT(body_err, dead_band);
  EXPECT_LT(dev_err, dead_band + 1e-5);
  EXPECT_LT(rig.loop.last_report().measured.torque.norm(), count);
}

TEST(AdmittanceLoop, SilentSensorLatchesTheSafeStateAndRearmRecovers) {
  Rig rig(hand_settings());
  rig.hand.position = Vec3(0.01, 0.0, 0.0);
  for (int i = 0; i < 50; ++i) rig.period();
  ASSERT_EQ(rig.loop.lifecycle().state(), hal::LifecycleState::kActive);
  rig.emulator.set_sensor_silent(true);
  // Fresh for max_age (3 ms) after the last frames, then the timeout (3 periods).
  int periods = 0;
  while (rig.loop.lifecycle().state() == hal::LifecycleState::kActive && periods < 20) {
    rig.period();
    ++periods;
  }
  EXPECT_LE(periods, 7);
  EXPECT_TRUE(rig.loop.last_report().entered_safe_stop);
  EXPECT_EQ(rig.loop.last_report().controlword, hal::Controlword::kShutdown);
  rig.period();
  rig.period();
  EXPECT_EQ(rig.loop.lifecycle().state(), hal::LifecycleState::kFault);
  EXPECT_FALSE(rig.emulator.enabled(0));  // the drives got shutdown
  const double x_held = rig.emulator.q()[0];
  for (int i = 0; i < 100; ++i) rig.period();
  EXPECT_EQ(rig.emulator.q()[0], x_held);                             // holds
  EXPECT_NEAR(rig.data.bodies[0].linear_velocity.norm(), 0.0, 1e-9);  // god-object braked
  // Rearm refused while the sensor is silent; accepted once it is back.
  EXPECT_EQ(rig.loop.rearm(), hal::LifecycleResult::kCausePresent);
  rig.emulator.set_sensor_silent(false);
  rig.period();
  EXPECT_EQ(rig.loop.rearm(), hal::LifecycleResult::kOk);
  rig.period();
  EXPECT_EQ(rig.loop.lifecycle().state(), hal::LifecycleState::kActive);
  for (int i = 0; i < 1500; ++i) rig.period();
  EXPECT_NEAR(rig.emulator.q()[0], 0.01, 2e-4);
}

// overrun_limit consecutive overruns latch the safe state (cause kOverruns), as the impedance
// loop's supervisor; fewer, or a streak broken by an on-time period, do not; the re-arm waits
// for an on-time period. The sensor's own faults keep their cause.
TEST(AdmittanceLoop, ConsecutiveOverrunsLatchTheSafeState) {
  platform::AdmittanceLoopSettings settings;
  settings.overrun_limit = 2;
  Rig rig(hand_settings(), settings);
  rig.hand.position = Vec3(0.01, 0.0, 0.0);
  for (int i = 0; i < 50; ++i) rig.period();
  ASSERT_EQ(rig.loop.lifecycle().state(), hal::LifecycleState::kActive);
  for (int i = 0; i < 10; ++i) EXPECT_FALSE(rig.period(i % 2 == 0).entered_safe_stop) << i;
  EXPECT_EQ(rig.loop.counters().overruns, 5u);
  EXPECT_FALSE(rig.period(true).entered_safe_stop);
  const platform::AdmittanceReport& r = rig.period(true);
  EXPECT_TRUE(r.overran);
  EXPECT_TRUE(r.entered_safe_stop);
  EXPECT_EQ(r.cause, platform::AdmittanceFaultCause::kOverruns);
  EXPECT_STREQ(platform::to_string(r.cause), "overruns");
  EXPECT_EQ(r.controlword, hal::Controlword::kShutdown);
  EXPECT_FALSE(r.driven);
  rig.period(true);
  rig.period(true);  // still late: the drives disabled, the cause present
  EXPECT_EQ(rig.loop.lifecycle().state(), hal::LifecycleState::kFault);
  EXPECT_EQ(rig.loop.rearm(), hal::LifecycleResult::kCausePresent);
  rig.period();  // on time
  EXPECT_EQ(rig.loop.rearm(), hal::LifecycleResult::kOk);
  rig.period();
  EXPECT_EQ(rig.loop.lifecycle().state(), hal::LifecycleState::kActive);

  // Without a limit (the default) overruns are only counted.
  Rig counted(hand_settings());
  for (int i = 0; i < 100; ++i) EXPECT_FALSE(counted.period(i >= 20).entered_safe_stop) << i;
  EXPECT_EQ(counted.loop.counters().overruns, 80u);
  EXPECT_EQ(counted.loop.lifecycle().state(), hal::LifecycleState::kActive);

  // A silent sensor's latch names the timeout.
  Rig silent(hand_settings(), settings);
  for (int i = 0; i < 50; ++i) silent.period();
  silent.emulator.set_sensor_silent(true);
  platform::AdmittanceFaultCause cause = platform::AdmittanceFaultCause::kNone;
  for (int i = 0; i < 20 && cause == platform::AdmittanceFaultCause::kNone; ++i)
    cause = silent.period().cause;
  EXPECT_EQ(cause, platform::AdmittanceFaultCause::kForceTimeout);
}

TEST(AdmittanceLoop, PeriodsDoNotAllocate) {
  Rig rig(hand_settings());
  rig.period();
  numen::test::AllocationGuard guard;
  for (int i = 0; i < 5000; ++i) {
    rig.hand.position = Vec3(0.02 * std::sin(2e-3 * i), 0.01, 0.0);
    rig.period();
  }
  EXPECT_EQ(guard.count(), 0);
}

// The overrun supervision's periods too: streaks, the latch, the safe stop, the re-arm.
TEST(AdmittanceLoop, OverrunLatchAndRearmDoNotAllocate) {
  platform::AdmittanceLoopSettings settings;
  settings.overrun_limit = 2;
  Rig rig(hand_settings(), settings);
  rig.hand.position = Vec3(0.01, 0.0, 0.0);
  for (int i = 0; i < 50; ++i) rig.period();
  int latches = 0;
  numen::test::AllocationGuard guard;
  for (int i = 0; i < 5000; ++i) {
    latches += rig.period(i % 100 < 3).entered_safe_stop ? 1 : 0;  // 3 late in a row per 100
    if (i % 100 == 50) (void)rig.loop.rearm();
  }
  EXPECT_EQ(guard.count(), 0);
  EXPECT_EQ(latches, 50);  // each streak latched once, each re-arm was taken
}

// set_step_function (the multirate device period, docs/multirate.md): the loop calls it once
// per period instead of core::step, with the measured wrench in data.device_wrench, and
// commands the device to where it left the held body; null restores core::step.
TEST(AdmittanceLoop, AStepFunctionReplacesCoreStep) {
  Rig rig(hand_settings());
  struct Seen {
    core::Data* data = nullptr;
    int calls = 0;
    Vec3 force = Vec3::Zero();
  } seen;
  seen.data = &rig.data;
  rig.loop.set_step_function(
      [](void* context) noexcept {
        Seen& s = *static_cast<Seen*>(context);
        ++s.calls;
        s.force = s.data->device_wrench.force;
        s.data->bodies[0].position = Vec3(0.0, 0.0, 0.004);  // not where a core::step would go
      },
      &seen);
  rig.hand.position = Vec3(0.02, 0.0, 0.0);  // 200 N/m × 20 mm along x
  const platform::AdmittanceReport& r = rig.period();
  ASSERT_TRUE(r.driven);
  EXPECT_EQ(seen.calls, 1);
  EXPECT_NEAR(seen.force.x(), 4.0, 1e-3);
  for (int i = 0; i < 10; ++i) rig.period();
  EXPECT_EQ(seen.calls, 11);
  EXPECT_EQ(rig.data.step_count, 0);               // core::step never ran
  EXPECT_NEAR(rig.device.setpoints()[2], 0.004, 1e-9);  // the device follows the step's pose
  EXPECT_NEAR(rig.device.setpoints()[0], 0.0, 1e-9);
  rig.loop.set_step_function(nullptr, nullptr);
  rig.period();
  EXPECT_EQ(seen.calls, 11);
  EXPECT_EQ(rig.data.step_count, 1);
  EXPECT_GT(rig.data.bodies[0].position.x(), 0.0);  // the measured force moved it
}
