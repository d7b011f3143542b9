// Tests of platform/control_loop: one control period on a SimBus against an
// emulated instrument — SYNC out, encoder answers in, checked target into
// core::Data, one core::step, torque RPDOs out; zero torque before the device
// is ready or while no body is held; failures counted; no allocation.
#include "numen/platform/control_loop.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

#include "alloc_counter.hpp"
#include "control_loop_fixtures.hpp"
#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/step.hpp"
#include "numen/hal/device/axis.hpp"
#include "numen/hal/canopen/canopen.hpp"
#include "numen/hal/device/device_config.hpp"
#include "numen/hal/emulation/device_emulator.hpp"
#include "numen/hal/canopen/emcy.hpp"
#include "numen/hal/canopen/nmt.hpp"
#include "numen/hal/device/instrument_device.hpp"
#include "numen/hal/transport/sim_bus.hpp"

using namespace numen::test::control_loop_fixtures;

namespace control_loop_test {  // named: the unity build shares a TU with other test files

/// Bus, emulated instrument, controller-side device, model, data and the loop.
struct Rig {
  numen::hal::DeviceConfig config;
  SimBus bus{bus_settings()};
  numen::hal::DeviceEmulator emulator{config};
  numen::hal::InstrumentDevice device{config};
  numen::core::Model model = small_model();
  numen::core::Data data = numen::core::make_data(model);
  ControlLoop loop;

  /// The trocar instrument (`c`) on the loop of `settings`, its axes at kQ.
  explicit Rig(numen::hal::DeviceConfig c = trocar_config(),
               const numen::platform::ControlLoopSettings& settings = {})
      : config(std::move(c)),
        loop{model, data, bus.controller(), device, numen::platform::DeviceBinding::rigid(),
             settings} {
    emulator.set_axis_values(kQ);
  }

  /// Period k as SceneRunner runs it; the emulator then takes the torque RPDOs.
  const PeriodReport& period(std::int64_t k) {
    const std::int64_t t = k * kMs;
    bus.set_time_ns(t);
    loop.begin_period(t);
    bus.set_time_ns(t + kLatency);
    emulator.poll(bus.device());
    bus.set_time_ns(t + kPhase);
    const PeriodReport& r = loop.end_period(t + kPhase);
    bus.set_time_ns(t + kPhase + kLatency);
    emulator.poll(bus.device());  // torque RPDOs
    return r;
  }

  /// Target the device should report: forward kinematics of the quantised axes.
  Pose expected_target() const {
    AxisVector q(5);
    for (int i = 0; i < 5; ++i) {
      const auto& a = config.axes[static_cast<std::size_t>(i)];
      q[i] = numen::hal::counts_to_value(a, numen::hal::value_to_counts(a, kQ[i]));
    }
    return device.kinematics().forward(q);
  }
};

// One period steps the model once: the device's control period is Model::dt (the scene copies
// it into DeviceConfig::control_period_s), and a loop whose device disagrees is refused.
TEST(ControlLoop, RefusesADeviceWhoseControlPeriodIsNotTheModelsStep) {
  numen::hal::DeviceConfig config = trocar_config();
  SimBus bus{bus_settings()};
  numen::core::Model model = small_model();
  numen::core::Data data = numen::core::make_data(model);
  ASSERT_EQ(config.control_period_s, model.dt);
  config.control_period_s = 2.0 * model.dt;
  numen::hal::InstrumentDevice slow{config};
  try {
    ControlLoop loop{model, data, bus.controller(), slow};
    ADD_FAILURE() << "a 2 ms device period ran a 1 ms model";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("control_period_s"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("model's step dt"), std::string::npos) << e.what();
  }
  config.control_period_s = model.dt;
  numen::hal::InstrumentDevice same{config};
  EXPECT_NO_THROW((ControlLoop{model, data, bus.controller(), same}));
}

TEST(ControlLoop, BeginPeriodWritesASyncWithACounter) {
  Rig rig;
  rig.bus.set_time_ns(5 * kMs);
  rig.loop.begin_period(5 * kMs);
  EXPECT_EQ(rig.bus.pending(SimBus::Direction::kControllerToDevice), 1u);
  rig.bus.set_time_ns(5 * kMs + kLatency);
  CanFrame f;
  ASSERT_EQ(rig.bus.device().read(f), IoStatus::kOk);
  EXPECT_TRUE(numen::hal::is_sync(f));
  EXPECT_EQ(f.id, 0x080u);
  ASSERT_EQ(f.len, 1);
  EXPECT_EQ(f.data[0], 1);
  // The counter runs 1..240 and wraps to 1.
  for (int k = 2; k <= 241; ++k) {
    const std::int64_t t = (4 + k) * kMs;
    rig.bus.set_time_ns(t);
    rig.loop.begin_period(t);
    rig.bus.set_time_ns(t + kLatency);
    ASSERT_EQ(rig.bus.device().read(f), IoStatus::kOk);
    EXPECT_EQ(f.timestamp_ns, t + kLatency);
    ASSERT_TRUE(numen::hal::is_sync(f));
    ASSERT_EQ(f.data[0], k <= 240 ? k : 1) << k;
  }
  EXPECT_EQ(rig.loop.counters().sync_write_failures, 0u);
}

TEST(ControlLoop, EndPeriodSetsTheTargetFromTheDeviceAndStepsOnce) {
  Rig rig;
  ASSERT_EQ(rig.data.step_count, 0);
  const PeriodReport& r = rig.period(0);
  EXPECT_EQ(r.frames_read, 5);
  EXPECT_TRUE(r.sample_valid);
  EXPECT_TRUE(r.target_ready);
  EXPECT_EQ(r.command_status, IoStatus::kOk);
  EXPECT_EQ(rig.data.step_count, 1);
  EXPECT_DOUBLE_EQ(rig.data.time, rig.model.dt);
  const Pose expected = rig.expected_target();
  EXPECT_LT((rig.data.target.position - expected.position).norm(), 1e-12);
  EXPECT_LT(rig.data.target.orientation.angularDistance(expected.orientation), 1e-9);
  EXPECT_EQ(rig.data.target.position, rig.device.last_sample().pose.position);
  EXPECT_EQ(rig.loop.counters().periods, 1u);
  EXPECT_EQ(rig.loop.counters().periods_zero_torque, 0u);
  EXPECT_EQ(rig.loop.step_time().count(), 1);

  // The body was pulled toward the target by the coupling spring.
  const Vec3 before = rig.model.bodies[0].initial_pose.position;
  const Vec3 after = rig.data.bodies[0].position;
  EXPECT_GT((after - before).dot(expected.position - before), 0.0);

  for (int k = 1; k < 10; ++k) rig.period(k);
  EXPECT_EQ(rig.data.step_count, 10);
  EXPECT_EQ(rig.loop.counters().periods, 10u);
  EXPECT_EQ(rig.loop.step_time().count(), 10);
  EXPECT_EQ(rig.device.counters().values_rejected, 0u);
}

TEST(ControlLoop, TorqueFramesReachTheEmulator) {
  Rig rig;
  rig.period(0);
  // The god-object is ~0.1 m from the target: the feedback is saturated at 5 N.
  EXPECT_NEAR(rig.data.feedback_wrench.force.norm(), rig.model.feedback.max_force, 1e-9);
  // Three drives (pivot_x, pivot_y, depth) each got one RPDO.
  EXPECT_EQ(rig.emulator.counters().rpdos, 3u);
  double largest = 0.0;
  for (int i = 0; i < 5; ++i) {
    const auto& a = rig.config.axes[static_cast<std::size_t>(i)];
    const double sent = rig.loop.impedance().sent_torques().torque[i];
    const double got = rig.emulator.last_torques()[i];
    EXPECT_NEAR(got, sent, a.has_drive() ? 0.5e-3 * a.rated_torque + 1e-12 : 0.0) << "axis " << i;
    EXPECT_EQ(rig.emulator.last_torque_per_mille()[static_cast<std::size_t>(i)],
              rig.loop.impedance().sent_torques().per_mille[static_cast<std::size_t>(i)]);
    largest = std::max(largest, std::abs(got));
  }
  EXPECT_GT(largest, 0.01) << "no torque reached the drives";
  // τ = Jᵀ w at the sampled axes.
  const AxisVector tau = numen::hal::torques_from_wrench(
      rig.device.kinematics().jacobian(rig.device.last_sample().q), rig.data.feedback_wrench);
  for (int i = 0; i < 3; ++i) {
    const auto& a = rig.config.axes[static_cast<std::size_t>(i)];
    EXPECT_NEAR(rig.loop.impedance().sent_torques().torque[i], std::clamp(tau[i], -a.max_torque, a.max_torque),
                0.5e-3 * a.rated_torque + 1e-12)
        << "axis " << i;
  }
}

TEST(ControlLoop, ZeroTorqueAndTargetUntouchedBeforeTheDeviceIsReady) {
  Rig rig;
  rig.emulator.set_responding(false);
  Pose sentinel;
  sentinel.position = Vec3(1.0, 2.0, 3.0);
  sentinel.orientation = Quat(Eigen::AngleAxisd(0.4, Vec3::UnitZ()));
  rig.data.target = sentinel;
  for (int k = 0; k < 3; ++k) {
    const PeriodReport& r = rig.period(k);
    EXPECT_FALSE(r.target_ready) << k;
    EXPECT_FALSE(r.sample_valid) << k;
    EXPECT_EQ(r.frames_read, 0) << k;
    EXPECT_EQ(rig.data.target.position, sentinel.position) << k;
    EXPECT_EQ(rig.data.target.orientation.coeffs(), sentinel.orientation.coeffs()) << k;
    EXPECT_EQ(rig.loop.counters().periods_zero_torque, static_cast<std::uint64_t>(k + 1));
    EXPECT_EQ(rig.data.step_count, k + 1) << "the world still steps";
  }
  EXPECT_EQ(rig.emulator.counters().syncs_ignored, 3u);
  // Zero torque was sent to every drive each period.
  EXPECT_EQ(rig.emulator.counters().rpdos, 9u);
  for (int i = 0; i < 5; ++i) EXPECT_EQ(rig.emulator.last_torque_per_mille()[static_cast<std::size_t>(i)], 0);

  // The device answers: the target is set, torques flow.
  rig.emulator.set_responding(true);
  const PeriodReport& r = rig.period(3);
  EXPECT_TRUE(r.target_ready);
  EXPECT_EQ(rig.loop.counters().periods_zero_torque, 3u);
  EXPECT_LT((rig.data.target.position - rig.expected_target().position).norm(), 1e-12);
  EXPECT_EQ(rig.emulator.counters().rpdos, 12u);
}

TEST(ControlLoop, ZeroTorqueWhileNoBodyIsHeld) {
  Rig rig;
  numen::core::set_held_body(rig.model, rig.data, -1);
  for (int k = 0; k < 4; ++k) rig.period(k);
  EXPECT_EQ(rig.loop.counters().periods_zero_torque, 4u);
  EXPECT_TRUE(rig.loop.last_report().target_ready);
  for (int i = 0; i < 5; ++i) EXPECT_EQ(rig.emulator.last_torques()[i], 0.0) << i;
  // Holding again: torque is commanded.
  numen::core::set_held_body(rig.model, rig.data, 0);
  rig.period(4);
  EXPECT_EQ(rig.loop.counters().periods_zero_torque, 4u);
  EXPECT_GT(rig.emulator.last_torques().cwiseAbs().maxCoeff(), 0.0);
}

TEST(ControlLoop, BusOffIsCountedAndStaleSamplesGetZeroTorque) {
  Rig rig;
  rig.period(0);
  rig.bus.set_state(numen::hal::BusState::kBusOff);
  const std::int64_t steps = rig.data.step_count;
  const Vec3 held_target = rig.data.target.position;
  // Nothing gets through: the last good target is held (and counts as valid
  // while younger than max_sample_age = 3 periods), then the sample goes stale.
  for (int k = 1; k <= 5; ++k) {
    const PeriodReport& r = rig.period(k);
    EXPECT_EQ(r.frames_read, 0) << k;
    EXPECT_EQ(r.command_status, IoStatus::kError) << k;
    EXPECT_TRUE(r.target_ready) << k;
  }
  EXPECT_FALSE(rig.loop.last_report().sample_valid);
  EXPECT_GT(rig.device.counters().rejected_stale, 0u);
  EXPECT_TRUE(rig.loop.impedance().sent_torques().torque.isZero()) << "no torque from a stale sample";
  EXPECT_GT(rig.loop.counters().periods_zero_torque, 0u);
  EXPECT_EQ(rig.data.target.position, held_target);
  EXPECT_EQ(rig.loop.counters().sync_write_failures, 5u);
  EXPECT_EQ(rig.loop.counters().command_failures, 5u);
  EXPECT_EQ(rig.data.step_count, steps + 5) << "the world keeps stepping";
  rig.bus.set_state(numen::hal::BusState::kOk);
  rig.period(6);
  EXPECT_EQ(rig.loop.counters().command_failures, 5u);
  EXPECT_EQ(rig.loop.counters().sync_write_failures, 5u);
  EXPECT_TRUE(rig.loop.last_report().sample_valid);
}

// Issue 70: a device whose samples went stale (here the bus off for 10 periods) while the hand
// moved: when they come back, its target stepped to the resumed pose in one period and the
// feedback came back at full force. With ControlLoopSettings::rejoin_after_stale (live inputs)
// the target glides there over the soft start (10 periods, no step over 0.15 of the gap) and the
// torques ramp in again from zero.
TEST(ControlLoop, AfterStaleSamplesTheTargetGlidesToTheResumedPoseAndTheFeedbackRampsInAgain) {
  for (const bool rejoin : {false, true}) {
    numen::hal::DeviceConfig config = trocar_config();
    config.soft_start_s = 0.01;  // 10 periods
    numen::platform::ControlLoopSettings settings;
    settings.rejoin_after_stale = rejoin;
    Rig rig(config, settings);
    ControlLoop& loop = rig.loop;
    numen::core::Data& data = rig.data;
    const auto period = [&](std::int64_t k) { rig.period(k); };
    for (int k = 0; k < 20; ++k) period(k);  // the start's soft start is over
    ASSERT_DOUBLE_EQ(loop.impedance().sent_torques().ramp, 1.0);
    rig.bus.set_state(numen::hal::BusState::kBusOff);
    std::int64_t allocations = 0;  // the stale periods and the glide allocate nothing
    {
      numen::test::AllocationGuard guard;
      for (int k = 20; k < 30; ++k) period(k);
      allocations += guard.count();
    }
    ASSERT_FALSE(loop.last_report().sample_valid);
    const Vec3 held = data.target.position;
    double moved[5];
    for (int i = 0; i < 5; ++i) moved[i] = kQ[i] + 0.02;  // the hand moved meanwhile
    rig.emulator.set_axis_values(moved);
    rig.bus.set_state(numen::hal::BusState::kOk);
    std::vector<Vec3> targets;
    std::vector<double> ramps;
    targets.reserve(15);
    ramps.reserve(15);
    {
      numen::test::AllocationGuard guard;
      for (int k = 30; k < 45; ++k) {
        period(k);
        EXPECT_TRUE(loop.last_report().sample_valid) << k;
        targets.push_back(data.target.position);
        ramps.push_back(loop.impedance().sent_torques().ramp);
      }
      allocations += guard.count();
    }
    EXPECT_EQ(allocations, 0);
    const Vec3 resumed = rig.device.last_sample().pose.position;
    const double gap = (resumed - held).norm();
    ASSERT_GT(gap, 1e-3);
    double step_max = (targets[0] - held).norm();
    for (std::size_t i = 1; i < targets.size(); ++i)
      step_max = std::max(step_max, (targets[i] - targets[i - 1]).norm());
    if (!rejoin) {
      EXPECT_NEAR(step_max, gap, 1e-9);  // one step
      EXPECT_DOUBLE_EQ(ramps[0], 1.0);
      EXPECT_EQ(loop.rejoins().rejoins, 0u);
      continue;
    }
    EXPECT_LT(step_max, 0.16 * gap);  // the smoothstep's fastest: 1.5 / 10 of the gap
    EXPECT_GT((targets[0] - held).norm(), 0.0);
    EXPECT_LT((targets[9] - resumed).norm(), 1e-12);  // there at the 10th period
    EXPECT_NEAR(ramps[0], 0.1, 1e-12);  // the feedback ramps in again from zero
    EXPECT_NEAR(ramps[4], 0.5, 1e-12);
    EXPECT_DOUBLE_EQ(ramps[9], 1.0);
    EXPECT_EQ(loop.rejoins().rejoins, 1u);
    EXPECT_EQ(loop.rejoins().last_period, 30);
    EXPECT_NEAR(loop.rejoins().gap_max_m, gap, 1e-9);
  }
}

// Issue 17 #7, end to end: controller error reports (as SocketCanBus::read returns them) whose
// class bits read encoder COB-IDs, and 29-bit frames with those numbers, arriving after the
// encoder TPDOs of each period: the samples stay valid and torque keeps flowing.
TEST(ControlLoop, ErrorAndExtendedFramesWithEncoderIdsDoNotSpoilTheSample) {
  Rig rig;
  rig.period(0);
  for (std::int64_t k = 1; k <= 5; ++k) {
    const std::int64_t t = k * kMs;
    rig.bus.set_time_ns(t);
    rig.loop.begin_period(t);
    rig.bus.set_time_ns(t + kLatency);
    rig.emulator.poll(rig.bus.device());  // the TPDOs go out first
    CanFrame err;
    err.id = 0x181;  // CAN_ERR_TX_TIMEOUT | CAN_ERR_BUSERROR | CAN_ERR_RESTARTED
    err.flags = numen::hal::CanFlag::kErrorFrame;
    err.len = 8;
    ASSERT_EQ(rig.bus.device().write(err), IoStatus::kOk);
    CanFrame ext = numen::hal::encode_position_pdo(0x182, 7, t);
    ext.flags = numen::hal::CanFlag::kExtendedId;
    ASSERT_EQ(rig.bus.device().write(ext), IoStatus::kOk);
    rig.bus.set_time_ns(t + kPhase);
    const PeriodReport& r = rig.loop.end_period(t + kPhase);
    EXPECT_EQ(r.frames_read, 7) << k;
    EXPECT_TRUE(r.sample_valid) << k;
    rig.bus.set_time_ns(t + kPhase + kLatency);
    rig.emulator.poll(rig.bus.device());
  }
  const numen::hal::DeviceCounters& c = rig.device.counters();
  EXPECT_EQ(c.rejected_malformed, 0u);
  EXPECT_EQ(c.values_rejected, 0u);
  EXPECT_EQ(c.frames_error, 5u);
  EXPECT_EQ(c.frames_unknown_id, 5u);
  EXPECT_EQ(rig.loop.counters().periods_zero_torque, 0u);
}

TEST(ControlLoop, PeriodsNeverAllocate) {
  Rig rig;
  rig.period(0);  // warm-up outside the guard
  std::int64_t count = -1;
  {
    numen::test::AllocationGuard guard;
    for (int k = 1; k <= 2000; ++k) rig.period(k);
    count = guard.count();
  }
  EXPECT_EQ(count, 0);
  EXPECT_EQ(rig.data.step_count, 2001);
  EXPECT_EQ(rig.device.counters().samples_valid, 2001u);
}

}  // namespace control_loop_test
