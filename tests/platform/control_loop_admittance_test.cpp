// Tests of platform::ControlLoop running an admittance device (hal::AdmittanceDevice) on a
// SimBus against the emulated device (hal::AdmittanceEmulator): the measured force drives the
// god-object, the device is commanded its pose, a silent sensor or overruns latch the safe
// state with their hal::FaultCause, the re-arm waits for the cause to clear.
#include "numen/platform/control_loop.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "alloc_counter.hpp"
#include "control_loop_fixtures.hpp"
#include "spring_hand.hpp"
#include "numen/core/rigid_body.hpp"
#include "numen/hal/emulation/admittance_emulator.hpp"
#include "numen/hal/canopen/cia402.hpp"
#include "numen/hal/transport/sim_bus.hpp"
#include "numen/platform/monotonic_clock.hpp"

namespace core = numen::core;
namespace hal = numen::hal;
namespace platform = numen::platform;
using core::Vec3;

namespace {

core::Model ball_model(core::CouplingMode mode = core::CouplingMode::kAdmittance) {
  return numen::test::control_loop_fixtures::probe_model(mode);
}

hal::DeviceConfig tracker() {
  hal::DeviceConfig c = hal::make_default_pose_tracker_config(1);
  c.control_period_s = 1e-3;
  return c;
}

/// The loop, the emulated device and the bus of one test (latency 100 µs, phase 300 µs).
/// The hand's springs and dampers (SpringHand): N/m, N·s/m, N·m/rad, N·m·s/rad.
struct HandGains {
  double k, c, k_rot, c_rot;
};

/// The loop's settings with overruns supervised (a paced loop's).
platform::ControlLoopSettings paced() {
  platform::ControlLoopSettings s;
  s.supervise_overruns = true;
  return s;
}

struct Rig {
  core::Model model = ball_model();
  core::Data data = core::make_data(model);
  hal::SimBus bus{hal::SimBusSettings{100'000, 0.0, 0.0, 1, 256}};
  numen::test::SpringHand motion;
  hal::AdmittanceEmulator emulator;
  hal::AdmittanceDevice device;
  platform::ControlLoop loop;
  core::Pose hand;
  std::int64_t k = 0;

  explicit Rig(const HandGains& s, const hal::AdmittanceSettings& device_settings = {})
      : motion(tracker(), s.k, s.c, s.k_rot, s.c_rot),
        emulator(tracker(), hal::make_admittance_config(tracker())),
        device(tracker(), hal::make_admittance_config(tracker()), bus.controller(),
               hal::AxisVector::Zero(6), device_settings),
        loop(model, data, device, paced()) {
    emulator.set_axis_values(hal::AxisVector::Zero(6));
    emulator.set_motion(&motion);
  }

  /// One period; `late`: stamped with a deadline 10 periods in the past, so the loop's
  /// statistics find it overran (the next period's supervision sees it, as a paced loop's).
  const platform::PeriodReport& period(bool late = false) {
    const std::int64_t t = k++ * 1'000'000;
    motion.hand = hand;
    bus.set_time_ns(t);
    const std::int64_t now = platform::monotonic_now_ns();
    if (late)
      loop.begin_period(t, now - 10'000'000, now);
    else
      loop.begin_period(t, now + 10'000'000, now + 10'000'000);
    bus.set_time_ns(t + 100'000);
    emulator.poll(bus.device());
    bus.set_time_ns(t + 300'000);
    return loop.end_period(t + 300'000);
  }
  hal::LifecycleState state() const { return loop.device().lifecycle(); }
};

HandGains hand_settings() { return HandGains{200.0, 6.0, 0.05, 0.004}; }

}  // namespace

TEST(ControlLoopAdmittance, RefusesAModelThatIsNotInAdmittanceModeAndZeroTimeouts) {
  const core::Model m = ball_model(core::CouplingMode::kGodObject);
  core::Data d = core::make_data(m);
  hal::SimBus bus{hal::SimBusSettings{}};
  hal::AdmittanceDevice dev(tracker(), hal::make_admittance_config(tracker()), bus.controller());
  EXPECT_THROW(platform::ControlLoop(m, d, dev), std::invalid_argument);
  hal::AdmittanceSettings s;
  s.force_timeout_periods = 0;
  EXPECT_THROW(hal::AdmittanceDevice(tracker(), hal::make_admittance_config(tracker()),
                                     bus.controller(), hal::AxisVector(), s),
               std::invalid_argument);
}

TEST(ControlLoopAdmittance, TheHandPullsTheGodObjectAndTheDeviceFollowsIt) {
  Rig rig(hand_settings());
  rig.hand.position = Vec3(0.02, 0.0, 0.0);  // the hand 20 mm away along x
  const platform::PeriodReport& first = rig.period();
  EXPECT_TRUE(first.sample_valid);
  EXPECT_TRUE(first.activated);
  EXPECT_EQ(first.lifecycle, hal::LifecycleState::kActive);
  EXPECT_EQ(first.controlword, hal::Controlword::kEnableOperation);
  EXPECT_NEAR(first.feedback.force.x(), 4.0, 1e-3);  // 200 N/m × 20 mm
  for (int i = 0; i < 1500; ++i) rig.period();
  // Everything settles on the hand: god-object, set-points, device.
  EXPECT_NEAR(rig.data.bodies[0].position.x(), 0.02, 2e-4);
  EXPECT_NEAR(rig.device.setpoints()[0], 0.02, 2e-4);
  EXPECT_NEAR(rig.emulator.q()[0], 0.02, 2e-4);
  EXPECT_LT(rig.loop.last_report().feedback.force.norm(), 0.05);
  EXPECT_EQ(rig.device.counters().invalid_periods, 0u);
  EXPECT_FALSE(rig.loop.last_report().torque_commanded);
  EXPECT_EQ(rig.data.feedback_wrench.force.norm(), 0.0);
}

TEST(ControlLoopAdmittance, TheHandTurnsTheGodObjectThroughTheMeasuredTorque) {
  // Rotation path: hand torque → sensor frame → world about the COM → god-object → IK
  // (yaw, pitch, roll set-points) → the device turns with it.
  Rig rig(hand_settings());
  rig.hand.orientation = core::Quat(Eigen::AngleAxisd(0.3, Vec3::UnitZ())) *
                         core::Quat(Eigen::AngleAxisd(0.2, Vec3::UnitX()));
  const platform::PeriodReport& first = rig.period();
  // T = k_rot θu with θu the rotation vector from the device (identity) to the hand.
  const Vec3 theta_u = numen::core::quat_log(rig.hand.orientation);
  const double count = 1e-4;  // default torque_scale, N·m per count
  EXPECT_LT((first.feedback.torque - 0.05 * theta_u).norm(), count) << first.feedback.torque;
  EXPECT_GT(first.feedback.torque.norm(), 0.015);
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
  EXPECT_LT(rig.loop.last_report().feedback.torque.norm(), count);
}

TEST(ControlLoopAdmittance, SilentSensorLatchesTheSafeStateAndRearmRecovers) {
  Rig rig(hand_settings());
  rig.hand.position = Vec3(0.01, 0.0, 0.0);
  for (int i = 0; i < 50; ++i) rig.period();
  ASSERT_EQ(rig.state(), hal::LifecycleState::kActive);
  rig.emulator.set_sensor_silent(true);
  // Fresh for max_age (3 ms) after the last frames, then the timeout (3 periods).
  int periods = 0;
  while (rig.state() == hal::LifecycleState::kActive && periods < 20) {
    rig.period();
    ++periods;
  }
  EXPECT_LE(periods, 7);
  EXPECT_TRUE(rig.loop.last_report().entered_safe_stop);
  EXPECT_EQ(rig.loop.last_report().controlword, hal::Controlword::kShutdown);
  rig.period();
  rig.period();
  EXPECT_EQ(rig.state(), hal::LifecycleState::kFault);
  EXPECT_FALSE(rig.emulator.enabled(0));  // the drives got shutdown
  const double x_held = rig.emulator.q()[0];
  for (int i = 0; i < 100; ++i) rig.period();
  EXPECT_EQ(rig.emulator.q()[0], x_held);                             // holds
  EXPECT_NEAR(rig.data.bodies[0].linear_velocity.norm(), 0.0, 1e-9);  // god-object braked
  ASSERT_NE(rig.device.first_fault(), nullptr);
  EXPECT_EQ(rig.device.first_fault()->cause, hal::FaultCause::kForceTimeout);
  // The re-arm is accepted but waits while the sensor is silent; it happens once it is back.
  EXPECT_EQ(rig.loop.rearm(), platform::RearmResult::kAccepted);
  for (int i = 0; i < 10; ++i) rig.period();
  EXPECT_EQ(rig.state(), hal::LifecycleState::kFault);
  EXPECT_TRUE(rig.loop.rearm_pending());
  rig.emulator.set_sensor_silent(false);
  rig.period();
  rig.period();
  EXPECT_EQ(rig.state(), hal::LifecycleState::kActive);
  EXPECT_FALSE(rig.loop.rearm_pending());
  EXPECT_EQ(rig.device.first_fault(), nullptr) << "the re-arm clears the first fault";
  for (int i = 0; i < 1500; ++i) rig.period();
  EXPECT_NEAR(rig.emulator.q()[0], 0.01, 2e-4);
}

// overrun_limit consecutive overruns latch the safe state (cause kOverruns), as the impedance
// stack's supervisor; fewer, or a streak broken by an on-time period, do not; the re-arm waits
// for an on-time period. The sensor's own faults keep their cause. A late period is seen by
// the next period's supervision (the loop's statistics judge a period when it ends).
TEST(ControlLoopAdmittance, ConsecutiveOverrunsLatchTheSafeState) {
  hal::AdmittanceSettings settings;
  settings.overrun_limit = 2;
  Rig rig(hand_settings(), settings);
  rig.hand.position = Vec3(0.01, 0.0, 0.0);
  for (int i = 0; i < 50; ++i) rig.period();
  ASSERT_EQ(rig.state(), hal::LifecycleState::kActive);
  for (int i = 0; i < 10; ++i) EXPECT_FALSE(rig.period(i % 2 == 0).entered_safe_stop) << i;
  EXPECT_EQ(rig.loop.statistics().summary().overruns, 5);
  EXPECT_FALSE(rig.period(true).entered_safe_stop);
  EXPECT_FALSE(rig.period(true).entered_safe_stop) << "judged by the next period";
  const platform::PeriodReport& r = rig.period(true);
  EXPECT_TRUE(r.entered_safe_stop);
  ASSERT_NE(rig.device.first_fault(), nullptr);
  EXPECT_EQ(rig.device.first_fault()->cause, hal::FaultCause::kOverruns);
  EXPECT_STREQ(hal::to_string(rig.device.first_fault()->cause), "overruns");
  EXPECT_EQ(r.controlword, hal::Controlword::kShutdown);
  EXPECT_FALSE(r.driven);
  rig.period(true);
  rig.period(true);  // still late: the drives disabled, the cause present
  EXPECT_EQ(rig.state(), hal::LifecycleState::kFault);
  EXPECT_EQ(rig.loop.rearm(), platform::RearmResult::kAccepted);
  rig.period(true);
  EXPECT_EQ(rig.state(), hal::LifecycleState::kFault) << "the re-arm waits for an on-time period";
  rig.period();  // on time: the next period's supervision finds no overrun
  rig.period();
  EXPECT_EQ(rig.state(), hal::LifecycleState::kActive);

  // Without a limit (the default) overruns are only counted.
  Rig counted(hand_settings());
  for (int i = 0; i < 100; ++i) EXPECT_FALSE(counted.period(i >= 20).entered_safe_stop) << i;
  EXPECT_EQ(counted.loop.statistics().summary().overruns, 80);
  EXPECT_EQ(counted.state(), hal::LifecycleState::kActive);

  // A silent sensor's latch names the timeout.
  Rig silent(hand_settings(), settings);
  for (int i = 0; i < 50; ++i) silent.period();
  silent.emulator.set_sensor_silent(true);
  for (int i = 0; i < 20 && silent.device.first_fault() == nullptr; ++i) silent.period();
  ASSERT_NE(silent.device.first_fault(), nullptr);
  EXPECT_EQ(silent.device.first_fault()->cause, hal::FaultCause::kForceTimeout);
}

TEST(ControlLoopAdmittance, PeriodsDoNotAllocate) {
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
TEST(ControlLoopAdmittance, OverrunLatchAndRearmDoNotAllocate) {
  hal::AdmittanceSettings settings;
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

// A Stepper (the multirate device period, docs/multirate.md): the loop calls its step() once
// per period instead of core::step, over the loop's own Model and Data, with the measured
// wrench in data.device_wrench, and commands the device to where it left the held body; then
// its finish(), after the commands; null restores core::step.
struct AdmittanceSeenStepper final : platform::Stepper {
  const core::Model* model = nullptr;
  core::Data* data = nullptr;
  int calls = 0;
  int finishes = 0;
  bool same_objects = true;  // every call got the loop's Model and Data
  Vec3 force = Vec3::Zero();
  void step(const core::Model& m, core::Data& d) noexcept override {
    ++calls;
    same_objects = same_objects && &m == model && &d == data;
    force = d.device_wrench.force;
    d.bodies[0].position = Vec3(0.0, 0.0, 0.004);  // not where a core::step would go
  }
  void finish(const core::Model& m, core::Data& d) noexcept override {
    ++finishes;
    same_objects = same_objects && &m == model && &d == data;
  }
};

TEST(ControlLoopAdmittance, AStepperReplacesCoreStep) {
  Rig rig(hand_settings());
  AdmittanceSeenStepper seen;
  seen.model = &rig.model;
  seen.data = &rig.data;
  rig.loop.set_stepper(&seen);
  rig.hand.position = Vec3(0.02, 0.0, 0.0);  // 200 N/m × 20 mm along x
  const platform::PeriodReport& r = rig.period();
  ASSERT_TRUE(r.driven);
  EXPECT_EQ(seen.calls, 1);
  EXPECT_NEAR(seen.force.x(), 4.0, 1e-3);
  for (int i = 0; i < 10; ++i) rig.period();
  EXPECT_EQ(seen.calls, 11);
  EXPECT_EQ(rig.data.step_count, 0);               // core::step never ran
  EXPECT_NEAR(rig.device.setpoints()[2], 0.004, 1e-9);  // the device follows the step's pose
  EXPECT_NEAR(rig.device.setpoints()[0], 0.0, 1e-9);
  EXPECT_EQ(seen.finishes, 11);
  EXPECT_TRUE(seen.same_objects);
  rig.loop.set_stepper(nullptr);
  rig.period();
  EXPECT_EQ(seen.calls, 11);
  EXPECT_EQ(seen.finishes, 11);
  EXPECT_EQ(rig.data.step_count, 1);
  EXPECT_GT(rig.data.bodies[0].position.x(), 0.0);  // the measured force moved it
}
