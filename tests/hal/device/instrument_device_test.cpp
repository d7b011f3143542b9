// Tests of numen/hal/device/instrument_device.hpp fed frame by frame (no bus): acceptance, each
// rejection reason, held targets, twist; per-link targets and torques_for (τ = Σ_l J_lᵀ w_l,
// no gate, no clamp) on a phantom arm. What is sent (gate, clamp, RPDOs) is
// minimal_device_test.cpp.
#include "numen/hal/device/instrument_device.hpp"

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
#include "instrument_fixtures.hpp"
#include "kinematics_check.hpp"
#include "numen/hal/canopen/canopen.hpp"
#include "numen/hal/device/phantom_kinematics.hpp"
#include "numen/hal/device/foaw_estimator.hpp"
#include "numen/hal/device/rate_estimator.hpp"
#include "numen/hal/transport/sim_bus.hpp"
#include "numen/hal/device/trocar_kinematics.hpp"
#include "test_constants.hpp"

namespace {

using namespace numen::hal;
using numen::core::Vec3;
using numen::core::Wrench;
using TK = TrocarKinematics;
using numen::test::feed;
using numen::test::kP0;
using numen::test::kQ0;
using numen::test::phantom_config;
using numen::test::some_link_wrenches;
using numen::test::trocar_config;
using numen::test::kMs;




TEST(InstrumentDevice, NotValidBeforeEveryAxisHasASample) {
  InstrumentDevice dev(trocar_config());
  DeviceSample s = dev.sample(0);
  EXPECT_FALSE(s.valid);
  EXPECT_FALSE(s.ready);
  EXPECT_TRUE(s.faults & SampleFault::kNoData);
  EXPECT_TRUE(s.pose.position.allFinite());
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
  EXPECT_TRUE(s.pose.position.isApprox(p.position, 1e-15));
  EXPECT_EQ(dev.counters().values_accepted, 5u);
  EXPECT_EQ(dev.counters().frames_decoded, 5u);
}

// Without a filter (f_c = +inf) the rate is the backward difference of the last two values;
// the filter itself is RateEstimatorTest and the tests below.
TEST(InstrumentDevice, TwistIsJacobianTimesRateOfTheLastTwoSamples) {
  DeviceConfig c = trocar_config();
  c.velocity_cutoff_hz = std::numeric_limits<double>::infinity();
  InstrumentDevice dev(c);
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

// With the default cutoff every axis's rate is the first-order response to the ramp,
// r (1 − exp(−t/τ)), within the filtered quantisation bound α q / Δt, and the twist is J q̇.
TEST(InstrumentDevice, RatesAreFilteredAtTheConfiguredCutoff) {
  DeviceConfig c = trocar_config();
  c.velocity_estimator = VelocityEstimator::kFilter;
  ASSERT_EQ(c.velocity_cutoff_hz, kDefaultVelocityCutoffHz);
  InstrumentDevice dev(c);
  const double rate[5] = {0.5, -0.3, 0.05, 1.0, 2.0};
  const double tau = 1.0 / (2.0 * std::numbers::pi * kDefaultVelocityCutoffHz);
  DeviceSample s;
  for (int k = 0; k <= 20; ++k) {
    double q[5];
    for (int i = 0; i < 5; ++i) q[i] = kQ0[i] + rate[i] * 1e-3 * k;
    feed(dev, q, k * kMs);
    s = dev.sample(k * kMs);
    ASSERT_TRUE(s.valid) << k;
    for (int i = 0; i < 5; ++i) {
      const double quant = 1.0 / c.axes[static_cast<std::size_t>(i)].counts_per_unit;
      const double expected = rate[i] * -std::expm1(-1e-3 * k / tau);
      EXPECT_NEAR(s.qdot[i], expected,
                  RateEstimator::quantisation_bound(kDefaultVelocityCutoffHz, 1e-3, quant) + 1e-12)
          << "axis " << i << " period " << k;
    }
  }
  const numen::core::Twist expected = twist_from_rates(dev.kinematics().jacobian(s.q), s.qdot);
  EXPECT_TRUE(s.twist.linear.isApprox(expected.linear, 1e-12));
}

// A jump that passes the checks (here a jump tolerance wide enough to let it through, as a
// tracker glitch would) gives a rate bounded by the axis's max_speed, not jump / Δt.
TEST(InstrumentDevice, RateIsBoundedByTheAxisMaxSpeed) {
  DeviceConfig c = trocar_config();
  c.velocity_estimator = VelocityEstimator::kFilter;  // and the difference at f_c = ∞
  c.jump_tolerance_counts = 1e5;  // 38 rad on the pivots, 1 m on the depth
  for (const double cutoff : {kDefaultVelocityCutoffHz, std::numeric_limits<double>::infinity()}) {
    c.velocity_cutoff_hz = cutoff;
    InstrumentDevice dev(c);
    feed(dev, kQ0, 0);
    dev.sample(0);
    double jumped[5];
    std::copy(kQ0, kQ0 + 5, jumped);
    jumped[TK::kPivotX] += 0.5;  // 500 rad/s over 1 ms; max_speed 10 rad/s
    jumped[TK::kDepth] += 0.2;   // 200 m/s; max_speed 2 m/s
    feed(dev, jumped, kMs);
    const DeviceSample s = dev.sample(kMs);
    ASSERT_TRUE(s.valid);
    const double a = RateEstimator::smoothing(cutoff, 1e-3);
    EXPECT_DOUBLE_EQ(s.qdot[TK::kPivotX], a * c.axes[TK::kPivotX].max_speed) << cutoff;
    EXPECT_DOUBLE_EQ(s.qdot[TK::kDepth], a * c.axes[TK::kDepth].max_speed) << cutoff;
  }
}

// The roll axis wraps: a turn across ±π is a small rate, not 2π / Δt.
TEST(InstrumentDevice, AWrappingAxisRateUsesTheWrappedDifference) {
  DeviceConfig c = trocar_config();
  c.velocity_cutoff_hz = std::numeric_limits<double>::infinity();
  ASSERT_TRUE(c.axes[TK::kRoll].wraps);
  InstrumentDevice dev(c);
  double q[5];
  std::copy(kQ0, kQ0 + 5, q);
  q[TK::kRoll] = std::numbers::pi - 0.005;
  feed(dev, q, 0);
  dev.sample(0);
  q[TK::kRoll] = -std::numbers::pi + 0.005;
  feed(dev, q, kMs);
  const DeviceSample s = dev.sample(kMs);
  ASSERT_TRUE(s.valid);
  EXPECT_NEAR(s.qdot[TK::kRoll], 0.01 / 1e-3, 2.0 / c.axes[TK::kRoll].counts_per_unit / 1e-3);
}

// A rejected value holds the rate (the next accepted difference spans the gap at its own Δt);
// a stale held value zeroes it and the filter restarts from the next accepted value.
TEST(InstrumentDevice, RateIsHeldOverARejectedValueAndRestartedAfterStaleness) {
  DeviceConfig c = trocar_config();
  c.velocity_estimator = VelocityEstimator::kFilter;
  InstrumentDevice dev(c);
  auto ramp = [](int k, double* q) {
    for (int i = 0; i < 5; ++i) q[i] = kQ0[i] + 0.2 * 1e-3 * k;
  };
  double q[5];
  for (int k = 0; k <= 5; ++k) {
    ramp(k, q);
    feed(dev, q, k * kMs);
    dev.sample(k * kMs);
  }
  const double before = dev.last_sample().qdot[TK::kPivotX];
  ASSERT_GT(before, 0.0);
  // Period 6: pivot_x out of range, rejected: its rate is held, not zeroed nor decayed.
  ramp(6, q);
  q[TK::kPivotX] = 2.0;
  feed(dev, q, 6 * kMs);
  DeviceSample s = dev.sample(6 * kMs);
  EXPECT_TRUE(s.axis_faults[TK::kPivotX] & SampleFault::kOutOfRange);
  EXPECT_EQ(s.qdot[TK::kPivotX], before);
  // Period 7: accepted; the difference spans 2 ms at the true 0.2 rad/s.
  ramp(7, q);
  feed(dev, q, 7 * kMs);
  s = dev.sample(7 * kMs);
  ASSERT_TRUE(s.valid);
  const double a2 = RateEstimator::smoothing(kDefaultVelocityCutoffHz, 2e-3);
  const double quant = 1.0 / c.axes[TK::kPivotX].counts_per_unit;
  EXPECT_NEAR(s.qdot[TK::kPivotX], before + a2 * (0.2 - before), a2 * quant / 2e-3 + 1e-12);
  // No frame for 4 periods: stale from the 4th (max age 3 ms): zero.
  for (int k = 8; k <= 10; ++k) EXPECT_GT(dev.sample(k * kMs).qdot[TK::kPivotX], 0.0) << k;
  s = dev.sample(11 * kMs);
  EXPECT_TRUE(s.axis_faults[TK::kPivotX] & SampleFault::kStale);
  EXPECT_EQ(s.qdot[TK::kPivotX], 0.0);
  // The first value after staleness only restarts the filter; the second gives α × rate.
  ramp(12, q);
  feed(dev, q, 12 * kMs);
  EXPECT_EQ(dev.sample(12 * kMs).qdot[TK::kPivotX], 0.0);
  ramp(13, q);
  feed(dev, q, 13 * kMs);
  const double a1 = RateEstimator::smoothing(kDefaultVelocityCutoffHz, 1e-3);
  EXPECT_NEAR(dev.sample(13 * kMs).qdot[TK::kPivotX], a1 * 0.2, a1 * quant / 1e-3 + 1e-12);
}

// The estimator is the configured one: on the same quantised ramp each axis's rate is what a
// standalone RateEstimator (difference: f_c = +∞; filter) or FoawEstimator (band = the
// configured counts over the axis's counts_per_unit) gives on the accepted values; all three
// keep the rate over a rejected value and restart after staleness (as above).
TEST(InstrumentDevice, TheConfiguredVelocityEstimatorGivesTheRates) {
  for (const VelocityEstimator kind :
       {VelocityEstimator::kDifference, VelocityEstimator::kFilter, VelocityEstimator::kFoaw}) {
    DeviceConfig c = trocar_config();
    c.velocity_estimator = kind;
    c.foaw_max_window = 8;
    c.foaw_noise_counts = 1.0;
    InstrumentDevice dev(c);
    std::array<RateEstimator, 5> rates;
    std::array<FoawEstimator, 5> foaws;
    for (int i = 0; i < 5; ++i) {
      const AxisConfig& a = c.axes[static_cast<std::size_t>(i)];
      rates[static_cast<std::size_t>(i)] =
          RateEstimator(kind == VelocityEstimator::kDifference
                            ? std::numeric_limits<double>::infinity()
                            : c.velocity_cutoff_hz,
                        a.max_speed, a.wraps);
      foaws[static_cast<std::size_t>(i)] = FoawEstimator(8, 1.0 / a.counts_per_unit, a.max_speed, a.wraps);
    }
    for (int k = 0; k <= 30; ++k) {
      double q[5];
      for (int i = 0; i < 5; ++i) q[i] = kQ0[i] + 0.3 * std::sin(0.05 * k + i) * 1e-1;
      feed(dev, q, k * kMs);
      const DeviceSample s = dev.sample(k * kMs);
      ASSERT_TRUE(s.valid) << k;
      for (int i = 0; i < 5; ++i) {
        const auto ii = static_cast<std::size_t>(i);
        const double v = s.q[i];  // the accepted (quantised) value
        const double expected = kind == VelocityEstimator::kFoaw ? foaws[ii].update(v, k * kMs)
                                                                 : rates[ii].update(v, k * kMs);
        EXPECT_EQ(s.qdot[i], expected) << to_string(kind) << " axis " << i << " period " << k;
      }
    }
    EXPECT_NE(dev.last_sample().qdot.norm(), 0.0) << to_string(kind);
    // Stale: every estimator is zeroed and restarted.
    const DeviceSample stale = dev.sample(40 * kMs);
    EXPECT_EQ(stale.qdot.norm(), 0.0) << to_string(kind);
  }
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
  EXPECT_EQ(s.pose.position, good.pose.position);
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

TEST(InstrumentDevice, TheDisplacementIsThePeriodsStepOfTheValuesAndZeroAfterAnInvalidSample) {
  // DeviceSample::dq, the passivity port's flow × T: q of this sample − q of the last one,
  // computed where the values are decoded; 0 when the last sample was not valid.
  DeviceConfig c = trocar_config();
  c.control_period_s = 1e-3;  // max age 3 ms
  InstrumentDevice dev(c);
  double q0_set[5];
  for (int i = 0; i < 5; ++i) q0_set[i] = kQ0[i];
  q0_set[3] = 3.13;  // roll (wraps) near +π: it crosses it below
  feed(dev, q0_set, 0);
  DeviceSample s = dev.sample(0);
  ASSERT_TRUE(s.valid);
  EXPECT_EQ(s.dq.norm(), 0.0);  // the sample before was not valid (no data)
  const AxisVector q0 = s.q;
  double q1[5];
  for (int i = 0; i < 5; ++i) q1[i] = q0_set[i] + 1e-3;
  feed(dev, q1, kMs);
  s = dev.sample(kMs);
  ASSERT_TRUE(s.valid);
  for (int i = 0; i < 5; ++i) EXPECT_EQ(s.dq[i], s.q[i] - q0[i]) << i;
  EXPECT_GT(s.dq[0], 0.0);
  const AxisVector q1_used = s.q;
  q1[3] = -3.14;  // across +π: 12 mrad the short way
  feed(dev, q1, 2 * kMs);
  s = dev.sample(2 * kMs);
  ASSERT_TRUE(s.valid);
  EXPECT_NEAR(s.dq[3], s.q[3] - q1_used[3] + 2.0 * std::numbers::pi, 1e-12);  // not −6.27
  EXPECT_GT(s.dq[3], 0.0);
  EXPECT_EQ(s.dq[0], 0.0);  // the other axes did not move
  s = dev.sample(3 * kMs);  // nothing new: the values held, no displacement
  ASSERT_TRUE(s.valid);
  EXPECT_EQ(s.dq.norm(), 0.0);
  s = dev.sample(6 * kMs);  // stale
  ASSERT_FALSE(s.valid);
  EXPECT_EQ(s.dq.norm(), 0.0);
  double q2[5];
  for (int i = 0; i < 5; ++i) q2[i] = q1[i] + 1e-3;
  feed(dev, q2, 7 * kMs);
  s = dev.sample(7 * kMs);
  ASSERT_TRUE(s.valid);
  EXPECT_EQ(s.dq.norm(), 0.0);  // moved, but from an invalid sample: no step is booked
  feed(dev, q1, 8 * kMs);
  s = dev.sample(8 * kMs);
  ASSERT_TRUE(s.valid);
  EXPECT_LT(s.dq[0], 0.0);
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
  const numen::core::Pose held = s.pose;
  for (int k = 2; k <= 4; ++k) {
    s = dev.sample(k * kMs);  // nothing new: fresh until 3 ms old
    EXPECT_TRUE(s.valid) << k;
  }
  s = dev.sample(5 * kMs);
  EXPECT_FALSE(s.valid);
  EXPECT_EQ(s.faults, SampleFault::kStale);
  EXPECT_EQ(s.pose.position, held.position);
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
  double q1[5];
  for (int i = 0; i < 5; ++i) q1[i] = kQ0[i] + 1e-3;
  feed(dev, q1, kMs);
  ASSERT_NE(dev.sample(kMs).qdot[0], 0.0);
  dev.reset();
  EXPECT_FALSE(dev.sample(kMs).ready);
  EXPECT_EQ(dev.last_sample().qdot.norm(), 0.0);
  // The rates restart: no difference across the reset.
  feed(dev, kQ0, 2 * kMs);
  const DeviceSample s = dev.sample(2 * kMs);
  EXPECT_TRUE(s.valid);
  EXPECT_EQ(s.qdot.norm(), 0.0);
}

// ---- Links and torques_for (phantom: six axes, drives on turret, shoulder, elbow) ----

using PK = PhantomKinematics;
using numen::core::Pose;
using numen::core::Quat;




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
    EXPECT_EQ(s.link_poses[m].position, p.position) << k.link_name(l);
    EXPECT_EQ(s.link_poses[m].orientation.coeffs(), p.orientation.coeffs()) << k.link_name(l);
    const numen::core::Twist t = twist_from_rates(k.link_jacobian(l, s.q), s.qdot);
    EXPECT_EQ(s.link_twists[m].linear, t.linear) << k.link_name(l);
    EXPECT_EQ(s.link_twists[m].angular, t.angular) << k.link_name(l);
  }
  EXPECT_EQ(s.link_poses[0].position, s.pose.position);
  EXPECT_EQ(s.link_twists[0].linear, s.twist.linear);
  // The links are distinct frames: the forearm's origin is the elbow, 0.14 m from the turret.
  EXPECT_NEAR(
      (s.link_poses[PK::kLinkForearm].position - s.link_poses[PK::kLinkTurret].position).norm(),
      0.14, 1e-12);
  EXPECT_EQ(s.link_twists[PK::kLinkTurret].linear.norm(), 0.0);  // fixed origin
  EXPECT_GT(s.link_twists[PK::kLinkStylus].angular.norm(), 0.1);
}

TEST(InstrumentDeviceLinks, TorquesForIsTheSumOfTheLinkJacobiansTransposedUnclampedOnEveryAxis) {
  InstrumentDevice dev(phantom_config());
  feed(dev, kP0, 0);
  const DeviceSample s = dev.sample(0);
  ASSERT_TRUE(s.valid);
  const auto w = some_link_wrenches(40.0);  // far beyond every axis's max_torque
  AxisVector tau;
  dev.torques_for(w, tau);
  const AxisVector expected = numen::test::link_torques(dev.kinematics(), s.q, w);
  ASSERT_EQ(tau.size(), 6);
  bool beyond = false;
  for (int i = 0; i < 6; ++i) {
    EXPECT_NEAR(tau[i], expected[i], 1e-12 * (1.0 + std::abs(expected[i]))) << i;
    beyond = beyond || std::abs(tau[i]) > dev.config().axes[static_cast<std::size_t>(i)].max_torque;
  }
  EXPECT_TRUE(beyond) << "the map does not clamp: that is ImpedanceDevice::write()";
  EXPECT_NE(tau[5], 0.0) << "axes without a drive get their Σ too: ImpedanceDevice::write() gates them";
  // A non-finite wrench is mapped as it is and counted: the NaN reaches ImpedanceDevice::write(),
  // whose trip latches the safe state (the map computes; it does not gate).
  auto bad = w;
  bad[PK::kLinkStylus].force.x() = std::numeric_limits<double>::quiet_NaN();
  dev.torques_for(bad, tau);
  EXPECT_FALSE(tau.allFinite());
  EXPECT_EQ(dev.counters().non_finite_wrenches, 1u);
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
