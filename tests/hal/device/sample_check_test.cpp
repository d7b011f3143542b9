// Tests of numen/hal/device/sample_check.hpp: each plausibility check in isolation.
#include "numen/hal/device/sample_check.hpp"
#include "test_constants.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>

namespace {

using namespace numen::hal;
using numen::test::kMs;

AxisCheckLimits limits() {
  AxisConfig a;
  a.counts_per_unit = 1000.0;  // 1 mrad per count
  a.min = -1.0;
  a.max = 1.0;
  a.max_speed = 2.0;  // rad/s
  return make_check_limits(a, 0.003, 2.0);
}

TEST(SampleCheck, LimitsFromTheAxis) {
  const AxisCheckLimits l = limits();
  EXPECT_EQ(l.max_age_ns, 3 * kMs);
  EXPECT_DOUBLE_EQ(l.jump_tolerance, 0.002);
}

TEST(SampleCheck, AcceptsAPlausibleValue) {
  const AcceptedValue last{0.5, 10 * kMs};
  EXPECT_EQ(check_sample(limits(), 0.501, 11 * kMs, 12 * kMs, &last), SampleFault::kNone);
  EXPECT_EQ(check_sample(limits(), 0.0, 11 * kMs, 12 * kMs, nullptr), SampleFault::kNone);
}

TEST(SampleCheck, NonFiniteShortCircuits) {
  EXPECT_EQ(check_sample(limits(), std::nan(""), 0, 100 * kMs, nullptr), SampleFault::kNonFinite);
  EXPECT_EQ(check_sample(limits(), std::numeric_limits<double>::infinity(), 0, 0, nullptr),
            SampleFault::kNonFinite);
}

TEST(SampleCheck, OutOfRange) {
  EXPECT_EQ(check_sample(limits(), 1.0001, 0, 0, nullptr), SampleFault::kOutOfRange);
  EXPECT_EQ(check_sample(limits(), -1.0, 0, 0, nullptr), SampleFault::kNone);  // inclusive
}

TEST(SampleCheck, StaleBothWays) {
  EXPECT_EQ(check_sample(limits(), 0.0, 0, 3 * kMs, nullptr), SampleFault::kNone);
  EXPECT_EQ(check_sample(limits(), 0.0, 0, 3 * kMs + 1, nullptr), SampleFault::kStale);
  EXPECT_EQ(check_sample(limits(), 0.0, 4 * kMs, 0, nullptr), SampleFault::kStale);  // clock skew
  EXPECT_EQ(check_fresh(limits(), 0, 3 * kMs + 1), SampleFault::kStale);
}

TEST(SampleCheck, JumpAllowsSpeedTimesDtPlusTolerance) {
  const AcceptedValue last{0.0, 0};
  // 1 ms at 2 rad/s = 0.002 rad, plus 0.002 rad tolerance.
  EXPECT_EQ(check_sample(limits(), 0.0039, kMs, kMs, &last), SampleFault::kNone);
  EXPECT_EQ(check_sample(limits(), 0.0041, kMs, kMs, &last), SampleFault::kJump);
  EXPECT_EQ(check_sample(limits(), -0.0041, kMs, kMs, &last), SampleFault::kJump);
  // An older frame than the last accepted one gets only the tolerance.
  const AcceptedValue newer{0.0, 2 * kMs};
  EXPECT_EQ(check_sample(limits(), 0.003, kMs, 2 * kMs, &newer), SampleFault::kJump);
}

TEST(SampleCheck, WrappedJump) {
  AxisConfig a;
  a.counts_per_unit = 1000.0;
  a.min = -std::numbers::pi;
  a.max = std::numbers::pi;
  a.max_speed = 2.0;
  a.wraps = true;
  const AxisCheckLimits l = make_check_limits(a, 0.003, 2.0);
  const AcceptedValue last{std::numbers::pi - 0.001, 0};
  EXPECT_EQ(check_sample(l, -std::numbers::pi + 0.001, kMs, kMs, &last), SampleFault::kNone);
  a.wraps = false;
  a.min = -4;
  a.max = 4;
  EXPECT_EQ(
      check_sample(make_check_limits(a, 0.003, 2.0), -std::numbers::pi + 0.001, kMs, kMs, &last),
      SampleFault::kJump);
}

TEST(SampleCheck, InfiniteSpeedDisablesTheJumpCheck) {
  AxisConfig a;
  a.max_speed = std::numeric_limits<double>::infinity();
  const AcceptedValue last{-1.0, 0};
  EXPECT_EQ(check_sample(make_check_limits(a, 0.003, 0.0), 1.0, 0, 0, &last), SampleFault::kNone);
}

TEST(SampleCheck, SeveralFaultsAreReportedTogether) {
  const AcceptedValue last{0.0, 0};
  const FaultMask f = check_sample(limits(), 5.0, kMs, 100 * kMs, &last);
  EXPECT_EQ(f, SampleFault::kOutOfRange | SampleFault::kStale | SampleFault::kJump);
  EXPECT_STREQ(sample_fault_name(f), "multiple");
  EXPECT_STREQ(sample_fault_name(SampleFault::kJump), "jump");
}

}  // namespace
