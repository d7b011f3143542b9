// Tests of numen/hal/instrument_device.hpp fed frame by frame (no bus): acceptance, each
// rejection reason, held targets, twist, torque commands; per-link targets and
// command_links (τ = Σ_l J_lᵀ w_l) on a phantom arm with drives on three of its six axes.
#include "numen/hal/instrument_device.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>
#include <span>
#include <stdexcept>

#include "alloc_counter.hpp"
#include "kinematics_check.hpp"
#include "numen/hal/canopen.hpp"
#include "numen/hal/phantom_kinematics.hpp"
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

TEST(InstrumentDevice, AnOutOfRangeValueFollowedByAGoodOneInThePeriodIsStillRejected) {
  InstrumentDevice dev(trocar_config());
  feed(dev, kQ0, 0);
  const DeviceSample good = dev.sample(0);
  double bad[5];
  std::copy(kQ0, kQ0 + 5, bad);
  bad[TK::kDepth] = 0.5;  // max 0.35 m
  feed(dev, bad, 1 * kMs);
  feed(dev, kQ0, 1 * kMs + kMs / 4);  // a good frame supersedes it before the sample
  const DeviceSample s = dev.sample(1 * kMs + kMs / 2);
  EXPECT_FALSE(s.valid);
  EXPECT_TRUE(s.axis_faults[TK::kDepth] & SampleFault::kOutOfRange);
  EXPECT_EQ(s.q[TK::kDepth], good.q[TK::kDepth]);
  EXPECT_EQ(dev.counters().rejected_out_of_range, 1u);
  // The next period is clean again.
  feed(dev, kQ0, 2 * kMs);
  EXPECT_TRUE(dev.sample(2 * kMs).valid);
  EXPECT_EQ(dev.counters().rejected_out_of_range, 1u);
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

// Issue 17 #7: an error report whose error-class bits read an encoder COB-ID is bus-state
// information, not a malformed TPDO of that axis.
TEST(InstrumentDevice, ErrorFrameWithAnEncoderIdIsNotAMalformedSample) {
  InstrumentDevice dev(trocar_config());
  feed(dev, kQ0, 0);
  ASSERT_TRUE(dev.sample(0).valid);
  feed(dev, kQ0, kMs);
  CanFrame err;
  err.id = dev.config().axes[0].encoder_cob_id;  // class bits 0x181: TX timeout|bus error|restarted
  err.flags = CanFlag::kErrorFrame;
  err.len = 8;
  err.timestamp_ns = kMs;
  EXPECT_FALSE(dev.on_frame(err));
  const DeviceSample s = dev.sample(kMs);
  EXPECT_TRUE(s.valid);
  EXPECT_EQ(s.axis_faults[0], SampleFault::kNone);
  const DeviceCounters& n = dev.counters();
  EXPECT_EQ(n.frames_error, 1u);
  EXPECT_EQ(n.frames_not_data, 0u);
  EXPECT_EQ(n.frames_unknown_id, 0u);
  EXPECT_EQ(n.rejected_malformed, 0u);
  EXPECT_EQ(n.values_rejected, 0u);
}

// A 29-bit frame with an encoder's number is another identifier (unknown, axis untouched); a
// CAN FD frame on the classic encoder id is the axis's but the wrong kind (rejected, counted).
TEST(InstrumentDevice, ExtendedAndFdFramesAreNotEncoderTpdos) {
  InstrumentDevice dev(trocar_config());
  feed(dev, kQ0, 0);
  const DeviceSample good = dev.sample(0);
  ASSERT_TRUE(good.valid);
  feed(dev, kQ0, kMs);
  const AxisConfig& a0 = dev.config().axes[0];
  const AxisConfig& a1 = dev.config().axes[1];
  CanFrame ext = encode_position_pdo(a0.encoder_cob_id, value_to_counts(a0, 0.11), kMs);
  ext.flags = CanFlag::kExtendedId;
  EXPECT_FALSE(dev.on_frame(ext));
  CanFrame fd = encode_position_pdo(a1.encoder_cob_id, value_to_counts(a1, -0.19), kMs);
  fd.flags = CanFlag::kFd;
  EXPECT_TRUE(dev.on_frame(fd));
  const DeviceSample s = dev.sample(kMs);
  EXPECT_EQ(s.axis_faults[0], SampleFault::kNone);
  EXPECT_EQ(s.q[0], good.q[0]);  // the 29-bit value was not taken
  EXPECT_EQ(s.axis_faults[1], SampleFault::kMalformed);
  EXPECT_EQ(s.q[1], good.q[1]);  // held: the FD value was not taken
  const DeviceCounters& n = dev.counters();
  EXPECT_EQ(n.frames_unknown_id, 1u);
  EXPECT_EQ(n.frames_not_data, 1u);
  EXPECT_EQ(n.rejected_malformed, 1u);
}

// The acceptance paths (error report, 29-bit, FD, remote) stay allocation free.
TEST(InstrumentDevice, OnFrameOfEveryKindDoesNotAllocate) {
  InstrumentDevice dev(trocar_config());
  const std::uint32_t id = dev.config().axes[0].encoder_cob_id;
  std::array<CanFrame, 5> frames{};
  const std::array<std::uint8_t, 5> flags = {0, CanFlag::kErrorFrame, CanFlag::kExtendedId,
                                             CanFlag::kFd, CanFlag::kRemote};
  for (std::size_t k = 0; k < frames.size(); ++k) {
    frames[k] = encode_position_pdo(id, 100, kMs);
    frames[k].flags = flags[k];
  }
  std::int64_t allocations = 0;
  {
    numen::test::AllocationGuard guard;
    for (int rep = 0; rep < 100; ++rep) {
      for (const CanFrame& f : frames) dev.on_frame(f);
    }
    allocations = guard.count();
  }
  EXPECT_EQ(allocations, 0);
  EXPECT_EQ(dev.counters().frames_error, 100u);
  EXPECT_EQ(dev.counters().frames_unknown_id, 100u);
  EXPECT_EQ(dev.counters().frames_not_data, 200u);
  EXPECT_EQ(dev.counters().frames_decoded, 100u);
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

// ---- Links and command_links (phantom: six axes, drives on turret, shoulder, elbow) ----

using PK = PhantomKinematics;
using numen::core::Pose;
using numen::core::Quat;

DeviceConfig phantom_config() {
  DeviceConfig c = make_default_phantom_config(30);
  c.phantom.base.position = Vec3(0.1, 0.0, 0.2);
  c.phantom.base.orientation = Quat(Eigen::AngleAxisd(0.3, Vec3::UnitZ()));
  c.tool_offset.position = Vec3(0.03, 0.0, 0.0);  // a tip ahead of the gimbal along the pen
  return c;
}

const double kP0[6] = {0.2, -0.3, 0.4, 0.5, -0.4, 1.0};

// Reads every frame waiting on the device side; returns how many, and the per mille of each
// drive COB-ID 0x200 + node seen (indexed by axis).
int drain(SimBus& bus, const DeviceConfig& c, std::array<std::int16_t, kMaxAxes>& per_mille,
          std::array<int, kMaxAxes>& frames_per_axis) {
  per_mille = {};
  frames_per_axis = {};
  CanFrame f;
  int n = 0;
  while (bus.device().read(f) == IoStatus::kOk) {
    ++n;
    for (std::size_t i = 0; i < c.axes.size(); ++i) {
      const AxisConfig& a = c.axes[i];
      if (!a.has_drive() || a.drive_cob_id != f.id) continue;
      std::int16_t pm = 0;
      EXPECT_EQ(decode_torque_pdo(f, a.drive_cob_id, pm), DecodeStatus::kOk);
      per_mille[i] = pm;
      ++frames_per_axis[i];
    }
  }
  return n;
}

std::array<Wrench, PK::kNumLinks> some_link_wrenches(double scale) {
  SplitMix64 rng(314);
  std::array<Wrench, PK::kNumLinks> w;
  for (Wrench& x : w) x = numen::test::random_wrench(rng, scale);
  return w;
}

TEST(InstrumentDeviceLinks, LinkTargetsAreTheLinkPosesOfTheDecodedAxes) {
  InstrumentDevice dev(phantom_config());
  ASSERT_EQ(dev.num_links(), 5);
  EXPECT_EQ(dev.last_sample().num_links, 5);  // before any frame: links of the held values
  feed(dev, kP0, 0);
  dev.sample(0);
  double q1[6];
  const double rate[6] = {0.5, -0.3, 0.8, 1.0, -2.0, 3.0};
  for (int i = 0; i < 6; ++i) q1[i] = kP0[i] + rate[i] * 1e-3;
  feed(dev, q1, kMs);
  const DeviceSample s = dev.sample(kMs);
  ASSERT_TRUE(s.valid);
  ASSERT_EQ(s.num_links, 5);
  for (int i = 0; i < 6; ++i) {
    const double quant = 0.5 / dev.config().axes[static_cast<std::size_t>(i)].counts_per_unit;
    EXPECT_NEAR(s.q[i], q1[i], quant + 1e-15) << i;
    EXPECT_NE(s.qdot[i], 0.0) << i;
  }
  const Kinematics& k = dev.kinematics();
  for (int l = 0; l < 5; ++l) {
    const auto m = static_cast<std::size_t>(l);
    const Pose p = k.link_pose(l, s.q);
    EXPECT_EQ(s.link_targets[m].position, p.position) << k.link_name(l);
    EXPECT_EQ(s.link_targets[m].orientation.coeffs(), p.orientation.coeffs()) << k.link_name(l);
    const numen::core::Twist t = twist_from_rates(k.link_jacobian(l, s.q), s.qdot);
    EXPECT_EQ(s.link_twists[m].linear, t.linear) << k.link_name(l);
    EXPECT_EQ(s.link_twists[m].angular, t.angular) << k.link_name(l);
  }
  EXPECT_EQ(s.link_targets[0].position, s.target.position);
  EXPECT_EQ(s.link_twists[0].linear, s.twist.linear);
  // The links are distinct frames: the forearm's origin is the elbow, 0.14 m from the turret.
  EXPECT_NEAR(
      (s.link_targets[PK::kLinkForearm].position - s.link_targets[PK::kLinkTurret].position).norm(),
      0.14, 1e-12);
  EXPECT_EQ(s.link_twists[PK::kLinkTurret].linear.norm(), 0.0);  // fixed origin
  EXPECT_GT(s.link_twists[PK::kLinkStylus].angular.norm(), 0.1);
}

TEST(InstrumentDeviceLinks, CommandLinksDrivesOnlyTheMotorisedAxes) {
  const DeviceConfig c = phantom_config();
  InstrumentDevice dev(c);
  SimBus bus(SimBusSettings{});
  feed(dev, kP0, 0);
  const DeviceSample s = dev.sample(0);
  ASSERT_TRUE(s.valid);
  const auto w = some_link_wrenches(0.1);
  ASSERT_EQ(dev.command_links(w, bus.controller(), 3), IoStatus::kOk);
  const AxisVector tau = numen::test::link_torques(dev.kinematics(), s.q, w);
  std::array<std::int16_t, kMaxAxes> pm{};
  std::array<int, kMaxAxes> frames{};
  EXPECT_EQ(drain(bus, c, pm, frames), 3);  // turret, shoulder, elbow
  for (int i = 0; i < 6; ++i) {
    const auto k = static_cast<std::size_t>(i);
    if (i < 3) {
      ASSERT_TRUE(c.axes[k].has_drive());
      EXPECT_EQ(frames[k], 1) << i;
      ASSERT_LT(std::abs(tau[i]), c.axes[k].max_torque) << i;  // not saturated
      EXPECT_NEAR(dev.last_torques()[i], tau[i], 1e-15) << i;
      EXPECT_NEAR(per_mille_to_torque(c.axes[k], pm[k]), tau[i], 0.5e-3 * c.axes[k].rated_torque)
          << i;
      EXPECT_EQ(dev.last_torque_per_mille()[k], pm[k]);
    } else {
      EXPECT_FALSE(c.axes[k].has_drive());
      EXPECT_EQ(frames[k], 0);
      EXPECT_GT(std::abs(tau[i]), 1e-4) << i;  // the gimbal would feel it, but has no motor
      EXPECT_EQ(dev.last_torques()[i], 0.0);
    }
  }
  EXPECT_EQ(dev.counters().torque_saturations, 0u);
  EXPECT_EQ(dev.counters().commands, 1u);
}

TEST(InstrumentDeviceLinks, CommandLinksSaturatesPerAxis) {
  const DeviceConfig c = phantom_config();
  InstrumentDevice dev(c);
  SimBus bus(SimBusSettings{});
  feed(dev, kP0, 0);
  const DeviceSample s = dev.sample(0);
  const auto w = some_link_wrenches(40.0);
  dev.command_links(w, bus.controller(), 0);
  const AxisVector tau = numen::test::link_torques(dev.kinematics(), s.q, w);
  std::uint64_t expected_saturations = 0;
  for (int i = 0; i < 3; ++i) {
    const AxisConfig& a = c.axes[static_cast<std::size_t>(i)];
    const double clamped = std::clamp(tau[i], -a.max_torque, a.max_torque);
    if (clamped != tau[i]) ++expected_saturations;
    EXPECT_DOUBLE_EQ(dev.last_torques()[i], clamped) << i;
    EXPECT_LE(std::abs(dev.last_torques()[i]), a.max_torque);
  }
  EXPECT_GE(expected_saturations, 2u);  // the check is not vacuous
  EXPECT_EQ(dev.counters().torque_saturations, expected_saturations);
}

TEST(InstrumentDeviceLinks, CommandEqualsCommandLinksOfOneWrench) {
  for (const DeviceConfig& c : {phantom_config(), trocar_config()}) {
    InstrumentDevice a(c);
    InstrumentDevice b(c);
    SimBus bus_a(SimBusSettings{});
    SimBus bus_b(SimBusSettings{});
    const double* q0 = c.kind == DeviceKind::kPhantom ? kP0 : kQ0;
    feed(a, q0, 0);
    feed(b, q0, 0);
    a.sample(0);
    b.sample(0);
    Wrench w;
    w.force = Vec3(0.7, -0.2, 0.4);
    w.torque = Vec3(0.01, -0.03, 0.02);
    a.command(w, bus_a.controller(), 5);
    const std::array<Wrench, 1> one{w};
    b.command_links(one, bus_b.controller(), 5);
    EXPECT_EQ(a.last_torques(), b.last_torques());
    EXPECT_EQ(a.last_torque_per_mille(), b.last_torque_per_mille());
    EXPECT_GT(a.last_torques().norm(), 0.0);
    // Missing entries are zero wrenches.
    const std::array<Wrench, 3> padded{w, Wrench{}, Wrench{}};
    b.command_links(padded, bus_b.controller(), 5);
    EXPECT_EQ(a.last_torques(), b.last_torques());
    // And the frames on the bus are the same.
    CanFrame fa, fb;
    int n = 0;
    while (bus_a.device().read(fa) == IoStatus::kOk) {
      ASSERT_EQ(bus_b.device().read(fb), IoStatus::kOk);
      EXPECT_EQ(fa.id, fb.id);
      EXPECT_EQ(fa.data, fb.data);
      ++n;
    }
    EXPECT_EQ(n, 3);
  }
}

TEST(InstrumentDeviceLinks, NonFiniteLinkWrenchSendsZeros) {
  const DeviceConfig c = phantom_config();
  InstrumentDevice dev(c);
  SimBus bus(SimBusSettings{});
  feed(dev, kP0, 0);
  dev.sample(0);
  auto w = some_link_wrenches(0.5);
  dev.command_links(w, bus.controller(), 0);
  EXPECT_GT(dev.last_torques().norm(), 0.0);
  w[PK::kLinkForearm].torque.y() = std::numeric_limits<double>::infinity();
  EXPECT_EQ(dev.command_links(w, bus.controller(), 0), IoStatus::kOk);
  EXPECT_EQ(dev.last_torques().norm(), 0.0);
  EXPECT_EQ(dev.counters().non_finite_wrenches, 1u);
  std::array<std::int16_t, kMaxAxes> pm{};
  std::array<int, kMaxAxes> frames{};
  EXPECT_EQ(drain(bus, c, pm, frames), 6);  // two commands, three drives
  for (int i = 0; i < 3; ++i) EXPECT_EQ(pm[static_cast<std::size_t>(i)], 0) << i;
  // Not ready (after reset): zeros too, whatever the wrench.
  dev.reset();
  w = some_link_wrenches(0.5);
  dev.command_links(w, bus.controller(), 0);
  EXPECT_EQ(dev.last_torques().norm(), 0.0);
}

TEST(InstrumentDeviceLinks, ExtraLinkWrenchesAreIgnoredAndCounted) {
  InstrumentDevice dev(phantom_config());
  SimBus bus(SimBusSettings{});
  feed(dev, kP0, 0);
  dev.sample(0);
  const auto w = some_link_wrenches(0.3);
  dev.command_links(w, bus.controller(), 0);
  const AxisVector five = dev.last_torques();
  std::array<Wrench, 7> seven{};
  std::copy(w.begin(), w.end(), seven.begin());
  seven[5].force = Vec3(100, 100, 100);
  seven[6].force.x() = std::nan("");  // beyond the links: not even checked
  dev.command_links(seven, bus.controller(), 0);
  EXPECT_EQ(dev.last_torques(), five);
  EXPECT_EQ(dev.counters().extra_link_wrenches, 1u);
  EXPECT_EQ(dev.counters().non_finite_wrenches, 0u);
}

TEST(InstrumentDeviceLinks, SampleAndCommandLinksDoNotAllocate) {
  const DeviceConfig c = phantom_config();
  InstrumentDevice dev(c);
  SimBus bus(SimBusSettings{});
  std::array<Wrench, PK::kNumLinks> w{};
  double q[6];
  std::copy(kP0, kP0 + 6, q);
  feed(dev, q, 0);
  dev.sample(0);
  int valid = 0;
  std::int64_t allocations = 0;
  {
    numen::test::AllocationGuard guard;
    CanFrame f;
    for (int k = 1; k <= 1000; ++k) {
      q[0] = kP0[0] + 0.2 * std::sin(0.01 * k);
      q[4] = kP0[4] + 0.3 * std::sin(0.02 * k);
      for (int i = 0; i < 6; ++i) {
        const AxisConfig& a = c.axes[static_cast<std::size_t>(i)];
        dev.on_frame(encode_position_pdo(a.encoder_cob_id, value_to_counts(a, q[i]), k * kMs));
      }
      const DeviceSample s = dev.sample(k * kMs);
      valid += s.valid ? 1 : 0;
      for (int l = 0; l < PK::kNumLinks; ++l) {
        w[static_cast<std::size_t>(l)].force = Vec3(0.1 * l, -0.2, 0.3 * std::sin(0.01 * k));
      }
      dev.command_links(w, bus.controller(), k * kMs);
      while (bus.device().read(f) == IoStatus::kOk) {
      }
    }
    allocations = guard.count();
  }
  EXPECT_EQ(allocations, 0);
  EXPECT_EQ(valid, 1000);
  EXPECT_EQ(dev.counters().commands, 1000u);
}

TEST(InstrumentDeviceLinks, RejectsKinematicsWithTooManyLinks) {
  class ManyLinks final : public Kinematics {
   public:
    int num_axes() const noexcept override { return 5; }
    Pose forward(const AxisVector&) const noexcept override { return Pose{}; }
    Jacobian jacobian(const AxisVector&) const noexcept override { return Jacobian::Zero(6, 5); }
    AxisVector inverse(const Pose&, const AxisVector&) const noexcept override {
      return AxisVector::Zero(5);
    }
    int num_links() const noexcept override { return kMaxLinks + 1; }
  };
  EXPECT_THROW(InstrumentDevice(trocar_config(), std::make_unique<ManyLinks>()),
               std::invalid_argument);
}

}  // namespace

TEST(InstrumentDevice, PeriodsSinceAcceptedIsTheEncoderWatchdogInput) {
  InstrumentDevice dev(trocar_config());
  // Never accepted: counts sample() calls (with kNoData).
  EXPECT_EQ(dev.sample(0).periods_since_accepted[0], 1u);
  EXPECT_EQ(dev.sample(kMs).periods_since_accepted[0], 2u);
  feed(dev, kQ0, 2 * kMs);
  DeviceSample s = dev.sample(2 * kMs);
  ASSERT_TRUE(s.valid);
  for (int i = 0; i < 5; ++i) EXPECT_EQ(s.periods_since_accepted[static_cast<std::size_t>(i)], 0u);
  // No frame: the held value is not stale yet (no fault bit), but the count goes on.
  s = dev.sample(3 * kMs);
  EXPECT_EQ(s.axis_faults[0], SampleFault::kNone);
  EXPECT_EQ(s.periods_since_accepted[0], 1u);
  // Axis 0 gets a frame, the others do not; a rejected frame does not reset the count.
  const AxisConfig& a0 = dev.config().axes[0];
  dev.on_frame(encode_position_pdo(a0.encoder_cob_id, value_to_counts(a0, kQ0[0]), 4 * kMs));
  const AxisConfig& a2 = dev.config().axes[2];
  dev.on_frame(encode_position_pdo(a2.encoder_cob_id, value_to_counts(a2, 1e3), 4 * kMs));
  s = dev.sample(4 * kMs);
  EXPECT_EQ(s.periods_since_accepted[0], 0u);
  EXPECT_EQ(s.periods_since_accepted[1], 2u);
  EXPECT_TRUE(s.axis_faults[2] & SampleFault::kOutOfRange);
  EXPECT_EQ(s.periods_since_accepted[2], 2u);
  EXPECT_EQ(s.periods_since_accepted[5], 0u);  // past n
  dev.reset();
  EXPECT_EQ(dev.sample(5 * kMs).periods_since_accepted[0], 1u);
}
