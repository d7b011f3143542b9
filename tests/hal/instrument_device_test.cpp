// Tests of numen/hal/instrument_device.hpp fed frame by frame (no bus): acceptance, each
// rejection reason, held targets, twist, torque commands.
#include "numen/hal/instrument_device.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <numbers>
#include <stdexcept>

#include "numen/hal/canopen.hpp"
#include "numen/hal/sim_bus.hpp"
#include "numen/hal/trocar_kinematics.hpp"

namespace {

using namespace numen::hal;
using numen::core::Vec3;
using numen::core::Wrench;
using TK = TrocarKinematics;
constexpr std::int64_t kMs = 1'000'000;

DeviceConfig trocar_config() {
  DeviceConfig c = make_default_trocar_config(1);
  c.trocar.point = Vec3(0, 0, 0.2);
  c.trocar.orientation = numen::core::Quat(Eigen::AngleAxisd(std::numbers::pi, Vec3::UnitX()));
  return c;
}

// Feeds one TPDO per axis for axis values q, stamped t.
void feed(InstrumentDevice& dev, const double* q, std::int64_t t) {
  for (int i = 0; i < dev.num_axes(); ++i) {
    const AxisConfig& a = dev.config().axes[static_cast<std::size_t>(i)];
    EXPECT_TRUE(dev.on_frame(encode_position_pdo(a.encoder_cob_id, value_to_counts(a, q[i]), t)));
  }
}

const double kQ0[5] = {0.1, -0.2, 0.1, 0.5, 0.3};

TEST(InstrumentDevice, NotValidBeforeEveryAxisHasASample) {
  InstrumentDevice dev(trocar_config());
  DeviceSample s = dev.sample(0);
  EXPECT_FALSE(s.valid);
  EXPECT_FALSE(s.ready);
  EXPECT_TRUE(s.faults & SampleFault::kNoData);
  EXPECT_TRUE(s.target.position.allFinite());
  // Four of five axes.
  for (int i = 0; i < 4; ++i) {
    const AxisConfig& a = dev.config().axes[static_cast<std::size_t>(i)];
    dev.on_frame(encode_position_pdo(a.encoder_cob_id, value_to_counts(a, kQ0[i]), kMs));
  }
  s = dev.sample(kMs);
  EXPECT_FALSE(s.valid);
  EXPECT_EQ(s.axis_faults[4], SampleFault::kNoData);
  EXPECT_EQ(s.axis_faults[0], SampleFault::kNone);
  EXPECT_EQ(dev.counters().values_rejected, 0u);  // no data is not a rejection
  feed(dev, kQ0, 2 * kMs);
  s = dev.sample(2 * kMs);
  EXPECT_TRUE(s.valid);
  EXPECT_TRUE(s.ready);
}

TEST(InstrumentDevice, TargetIsTheForwardKinematicsOfTheDecodedAxes) {
  InstrumentDevice dev(trocar_config());
  feed(dev, kQ0, 0);
  const DeviceSample s = dev.sample(kMs / 2);
  ASSERT_TRUE(s.valid);
  for (int i = 0; i < 5; ++i) {
    const double quant = 0.5 / dev.config().axes[static_cast<std::size_t>(i)].counts_per_unit;
    EXPECT_NEAR(s.q[i], kQ0[i], quant + 1e-15) << i;
  }
  const numen::core::Pose p = dev.kinematics().forward(s.q);
  EXPECT_TRUE(s.target.position.isApprox(p.position, 1e-15));
  EXPECT_EQ(dev.counters().values_accepted, 5u);
  EXPECT_EQ(dev.counters().frames_decoded, 5u);
}

TEST(InstrumentDevice, TwistIsJacobianTimesRateOfTheLastTwoSamples) {
  InstrumentDevice dev(trocar_config());
  feed(dev, kQ0, 0);
  dev.sample(0);
  double q1[5];
  const double rate[5] = {0.5, -0.3, 0.05, 1.0, 2.0};
  for (int i = 0; i < 5; ++i) q1[i] = kQ0[i] + rate[i] * 1e-3;
  feed(dev, q1, kMs);
  const DeviceSample s = dev.sample(kMs);
  ASSERT_TRUE(s.valid);
  for (int i = 0; i < 5; ++i) {
    const double quant = 1.0 / dev.config().axes[static_cast<std::size_t>(i)].counts_per_unit;
    EXPECT_NEAR(s.qdot[i], rate[i], quant / 1e-3) << i;  // two roundings over 1 ms
  }
  const numen::core::Twist expected = twist_from_rates(dev.kinematics().jacobian(s.q), s.qdot);
  EXPECT_TRUE(s.twist.linear.isApprox(expected.linear, 1e-12));
  EXPECT_TRUE(s.twist.angular.isApprox(expected.angular, 1e-12));
}

TEST(InstrumentDevice, OutOfRangeIsRejectedAndTheTargetHeld) {
  InstrumentDevice dev(trocar_config());
  feed(dev, kQ0, 0);
  const DeviceSample good = dev.sample(0);
  double bad[5];
  std::copy(kQ0, kQ0 + 5, bad);
  bad[TK::kDepth] = 0.5;  // max 0.35 m
  feed(dev, bad, 1 * kMs);
  const DeviceSample s = dev.sample(1 * kMs);
  EXPECT_FALSE(s.valid);
  EXPECT_TRUE(s.ready);
  EXPECT_TRUE(s.axis_faults[TK::kDepth] & SampleFault::kOutOfRange);
  EXPECT_EQ(s.q[TK::kDepth], good.q[TK::kDepth]);
  EXPECT_EQ(s.target.position, good.target.position);
  EXPECT_EQ(dev.counters().rejected_out_of_range, 1u);
  EXPECT_EQ(dev.counters().values_rejected, 1u);
}

TEST(InstrumentDevice, JumpIsRejectedUntilTimeMakesItPlausible) {
  InstrumentDevice dev(trocar_config());
  feed(dev, kQ0, 0);
  dev.sample(0);
  double jumped[5];
  std::copy(kQ0, kQ0 + 5, jumped);
  jumped[TK::kPivotX] += 0.1;  // 10 rad/s max: plausible only after ~10 ms
  int first_accepted = -1;
  for (int k = 1; k <= 20; ++k) {
    feed(dev, jumped, k * kMs);
    const DeviceSample s = dev.sample(k * kMs);
    if (s.axis_faults[TK::kPivotX] & SampleFault::kJump) {
      EXPECT_NEAR(s.q[TK::kPivotX], kQ0[TK::kPivotX], 1e-3);
    } else if (first_accepted < 0) {
      first_accepted = k;
    }
  }
  EXPECT_EQ(first_accepted, 10);  // 10 rad/s · 10 ms = 0.1 rad
  EXPECT_EQ(dev.counters().rejected_jump, 9u);
}

TEST(InstrumentDevice, StaleWhenNoFrameArrivesAndVelocityDropsToZero) {
  DeviceConfig c = trocar_config();
  c.control_period_s = 1e-3;  // max age 3 ms
  InstrumentDevice dev(c);
  feed(dev, kQ0, 0);
  dev.sample(0);
  double q1[5];
  for (int i = 0; i < 5; ++i) q1[i] = kQ0[i] + 1e-3;
  feed(dev, q1, kMs);
  DeviceSample s = dev.sample(kMs);
  ASSERT_TRUE(s.valid);
  EXPECT_NE(s.qdot[0], 0.0);
  const numen::core::Pose held = s.target;
  for (int k = 2; k <= 4; ++k) {
    s = dev.sample(k * kMs);  // nothing new: fresh until 3 ms old
    EXPECT_TRUE(s.valid) << k;
  }
  s = dev.sample(5 * kMs);
  EXPECT_FALSE(s.valid);
  EXPECT_EQ(s.faults, SampleFault::kStale);
  EXPECT_EQ(s.target.position, held.position);
  EXPECT_EQ(s.qdot.norm(), 0.0);
  EXPECT_EQ(s.twist.linear.norm(), 0.0);
  EXPECT_EQ(dev.counters().rejected_stale, 5u);  // one per axis
  // A fresh frame recovers.
  feed(dev, q1, 6 * kMs);
  EXPECT_TRUE(dev.sample(6 * kMs).valid);
}

TEST(InstrumentDevice, AFrameOlderThanTheMaxAgeIsStale) {
  InstrumentDevice dev(trocar_config());
  feed(dev, kQ0, 0);
  const DeviceSample s = dev.sample(10 * kMs);
  EXPECT_FALSE(s.ready);
  EXPECT_TRUE(s.faults & SampleFault::kStale);
  EXPECT_EQ(dev.counters().rejected_stale, 5u);
}

TEST(InstrumentDevice, MalformedAndUnknownFramesAreCounted) {
  InstrumentDevice dev(trocar_config());
  feed(dev, kQ0, 0);
  const DeviceSample good = dev.sample(0);
  CanFrame f = encode_position_pdo(0x181, 12345, kMs);
  f.len = 3;
  EXPECT_TRUE(dev.on_frame(f));
  CanFrame r = encode_position_pdo(0x182, 0, kMs);
  r.flags = CanFlag::kRemote;
  EXPECT_TRUE(dev.on_frame(r));
  EXPECT_FALSE(dev.on_frame(encode_position_pdo(0x1F0, 0, kMs)));
  const DeviceSample s = dev.sample(kMs);
  EXPECT_EQ(s.axis_faults[0], SampleFault::kMalformed);
  EXPECT_EQ(s.axis_faults[1], SampleFault::kMalformed);
  EXPECT_EQ(s.q[0], good.q[0]);
  const DeviceCounters& n = dev.counters();
  EXPECT_EQ(n.frames_wrong_length, 1u);
  EXPECT_EQ(n.frames_not_data, 1u);
  EXPECT_EQ(n.frames_unknown_id, 1u);
  EXPECT_EQ(n.rejected_malformed, 2u);
}

TEST(InstrumentDevice, NewestFrameOfAnAxisWins) {
  InstrumentDevice dev(trocar_config());
  feed(dev, kQ0, 0);
  double later[5];
  for (int i = 0; i < 5; ++i) later[i] = kQ0[i] + 1e-3;
  feed(dev, later, kMs / 2);
  const DeviceSample s = dev.sample(kMs);
  EXPECT_NEAR(s.q[0], later[0], 1e-3);
  EXPECT_EQ(dev.counters().values_accepted, 5u);
}

TEST(InstrumentDevice, CommandSendsJTransposeWrenchOnDrivenAxes) {
  DeviceConfig c = trocar_config();
  InstrumentDevice dev(c);
  SimBus bus(SimBusSettings{});
  feed(dev, kQ0, 0);
  const DeviceSample s = dev.sample(0);
  Wrench w;
  w.force = Vec3(0.5, -0.3, 1.0);
  w.torque = Vec3(0.01, 0.02, -0.01);
  ASSERT_EQ(dev.command(w, bus.controller(), 7), IoStatus::kOk);
  const AxisVector tau = torques_from_wrench(dev.kinematics().jacobian(s.q), w);
  CanFrame f;
  int frames = 0;
  while (bus.device().read(f) == IoStatus::kOk) {
    ++frames;
    bool found = false;
    for (int i = 0; i < 5; ++i) {
      const AxisConfig& a = c.axes[static_cast<std::size_t>(i)];
      if (!a.has_drive() || a.drive_cob_id != f.id) continue;
      found = true;
      std::int16_t pm = 0;
      ASSERT_EQ(decode_torque_pdo(f, a.drive_cob_id, pm), DecodeStatus::kOk);
      EXPECT_NEAR(per_mille_to_torque(a, pm), tau[i], 0.5e-3 * a.rated_torque + 1e-12) << i;
      EXPECT_DOUBLE_EQ(dev.last_torques()[i], tau[i]);
    }
    EXPECT_TRUE(found) << f.id;
  }
  EXPECT_EQ(frames, 3);  // pivot_x, pivot_y, depth
  EXPECT_EQ(dev.last_torques()[TK::kRoll], 0.0);
  EXPECT_EQ(dev.counters().torque_saturations, 0u);
}

TEST(InstrumentDevice, CommandSaturatesPerAxis) {
  InstrumentDevice dev(trocar_config());
  SimBus bus(SimBusSettings{});
  feed(dev, kQ0, 0);
  dev.sample(0);
  Wrench w;
  w.force = Vec3(100, 100, 100);
  dev.command(w, bus.controller(), 0);
  EXPECT_GT(dev.counters().torque_saturations, 0u);
  for (int i = 0; i < 5; ++i) {
    EXPECT_LE(std::abs(dev.last_torques()[i]),
              dev.config().axes[static_cast<std::size_t>(i)].max_torque + 1e-12);
  }
}

TEST(InstrumentDevice, ZeroTorqueBeforeReadyForNonFiniteWrenchAndOnCommandZero) {
  InstrumentDevice dev(trocar_config());
  SimBus bus(SimBusSettings{});
  Wrench w;
  w.force = Vec3(1, 1, 1);
  dev.sample(0);
  EXPECT_EQ(dev.command(w, bus.controller(), 0), IoStatus::kOk);  // not ready
  EXPECT_EQ(dev.last_torques().norm(), 0.0);
  feed(dev, kQ0, 0);
  dev.sample(0);
  dev.command(w, bus.controller(), 0);
  EXPECT_GT(dev.last_torques().norm(), 0.0);
  w.force.x() = std::nan("");
  dev.command(w, bus.controller(), 0);
  EXPECT_EQ(dev.last_torques().norm(), 0.0);
  EXPECT_EQ(dev.counters().non_finite_wrenches, 1u);
  w.force.x() = 1.0;
  dev.command(w, bus.controller(), 0);
  dev.command_zero(bus.controller(), 0);
  EXPECT_EQ(dev.last_torques().norm(), 0.0);
  // The last three frames on the bus are zeros.
  CanFrame f;
  std::int16_t last_pm[3] = {1, 1, 1};
  int n = 0;
  while (bus.device().read(f) == IoStatus::kOk) {
    std::int16_t pm = 0;
    decode_torque_pdo(f, f.id, pm);
    last_pm[n++ % 3] = pm;
  }
  EXPECT_EQ(n, 15);
  for (std::int16_t pm : last_pm) EXPECT_EQ(pm, 0);
}

TEST(InstrumentDevice, CommandReportsBusFailures) {
  InstrumentDevice dev(trocar_config());
  SimBusSettings st;
  st.capacity = 2;
  SimBus bus(st);
  EXPECT_EQ(dev.command_zero(bus.controller(), 0), IoStatus::kWouldBlock);  // 3 drives, room for 2
  EXPECT_EQ(dev.counters().write_would_block, 1u);
  bus.set_state(BusState::kBusOff);
  EXPECT_EQ(dev.command_zero(bus.controller(), 0), IoStatus::kError);
  EXPECT_EQ(dev.counters().write_errors, 3u);
}

TEST(InstrumentDevice, ConstructionErrors) {
  EXPECT_THROW(InstrumentDevice(trocar_config(), nullptr), std::invalid_argument);
  EXPECT_THROW(InstrumentDevice(trocar_config(),
                                std::make_unique<PoseTrackerKinematics>(PoseTrackerGeometry{})),
               std::invalid_argument);
  DeviceConfig c = trocar_config();
  c.axes[0].sign = 0;
  EXPECT_THROW(InstrumentDevice{c}, std::invalid_argument);
}

TEST(InstrumentDevice, ResetForgetsAcceptedValues) {
  InstrumentDevice dev(trocar_config());
  feed(dev, kQ0, 0);
  EXPECT_TRUE(dev.sample(0).valid);
  dev.reset();
  EXPECT_FALSE(dev.sample(0).ready);
}

}  // namespace
