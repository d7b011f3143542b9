/// @file hand_servo_test.cpp
/// A scripted hand's position-based visual servo (sim/device/hand_servo.hpp): the integral law
/// on the error seen `latency` earlier, the target along its span, the offset held where no
/// target is planned and clamped at max_offset, a hand closing the loop on a body pushed off its
/// plan, refused settings, no allocation.

#include "numen/sim/device/hand_servo.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

#include "alloc_counter.hpp"
#include "numen/core/data.hpp"

namespace numen::sim {
namespace {

constexpr double kDt = 1e-3;

/// One body (index 0) at `position`, turned a quarter turn about z.
core::Data data_at(const core::Vec3& position) {
  core::Data d;
  d.bodies.resize(1);
  d.bodies[0].position = position;
  d.bodies[0].orientation = core::Quat(Eigen::AngleAxisd(M_PI / 2, core::Vec3::UnitZ()));
  return d;
}

/// Watches the point 10 mm along the body's x (world +y after its quarter turn); one span
/// [0, 1) s with a constant target 1 mm above where that point is at the origin.
HandServoSpec spec(double latency = 0.005, double time_constant = 0.1, double max_offset = 0.004) {
  HandServoSpec s;
  s.settings.latency_s = latency;
  s.settings.time_constant_s = time_constant;
  s.settings.max_offset_m = max_offset;
  s.body_name = "needle";
  HandServoSpan span;
  span.body = 0;
  span.point = core::Vec3(0.01, 0.0, 0.0);
  span.t0_s = 0.0;
  span.t1_s = 1.0;
  span.target_start = span.target_end = core::Vec3(0.0, 0.01, 0.001);
  s.spans.push_back(span);
  return s;
}

// A constant 1 mm error moves the hand first L after it is seen, then by dt / T of it a period.
TEST(HandServo, AnErrorMovesTheHandAfterItsLatencyAtOneOverTheTimeConstant) {
  HandServo servo(spec(0.005, 0.1), kDt, "right");
  const core::Data d = data_at(core::Vec3::Zero());
  for (int k = 0; k < 5; ++k) {
    servo.observe(k * kDt, d);
    EXPECT_EQ(servo.offset(), core::Vec3::Zero())
        << "period " << k << ": not seen yet (L = 5 periods)";
  }
  for (int k = 5; k < 25; ++k) {
    servo.observe(k * kDt, d);
    const double expected = (k - 4) * (kDt / 0.1) * 0.001;  // (k − 4) updates of 10 µm
    EXPECT_NEAR(servo.offset().z(), expected, 1e-15) << "period " << k;
    EXPECT_NEAR(servo.offset().x(), 0.0, 1e-15);
    EXPECT_NEAR(servo.offset().y(), 0.0, 1e-15)
        << "the point is the turned body's: its error is along z only";
  }
  EXPECT_NEAR(servo.error_max_m(), 0.001, 1e-12);
  EXPECT_EQ(servo.saturated_periods(), 0);
}

// No latency: the error of this period moves the hand at once.
TEST(HandServo, WithoutLatencyThePeriodsErrorActsAtOnce) {
  HandServo servo(spec(0.0, 0.1), kDt, "right");
  servo.observe(0.0, data_at(core::Vec3::Zero()));
  EXPECT_NEAR(servo.offset().z(), 1e-5, 1e-15);
}

// The target runs linearly over its span; outside every span none is planned.
TEST(HandServo, TheTargetRunsAlongItsSpan) {
  HandServoSpec s = spec();
  s.spans[0].target_start = core::Vec3(0.0, 0.0, 0.0);
  s.spans[0].target_end = core::Vec3(0.0, 0.0, 0.01);
  const HandServo servo(s, kDt, "right");
  core::Vec3 target;
  ASSERT_TRUE(servo.target_at(0.25, target));
  EXPECT_NEAR(target.z(), 0.0025, 1e-15);
  ASSERT_TRUE(servo.target_at(0.0, target));
  EXPECT_NEAR(target.z(), 0.0, 1e-15);
  EXPECT_FALSE(servo.target_at(1.0, target)) << "a span ends where the next segment starts";
  EXPECT_FALSE(servo.target_at(-0.1, target));
}

// Where no target is planned the offset is held; the error seen L earlier still counts while it
// was planned then. The offset never passes max_offset: the clamped periods are counted.
TEST(HandServo, HoldsItsOffsetWithoutATargetAndClampsItAtItsMaxOffset) {
  HandServoSpec s = spec(0.002, 0.01, 0.0005);
  s.spans[0].t1_s = 0.02;
  HandServo servo(s, kDt, "right");
  const core::Data d = data_at(core::Vec3::Zero());
  const core::Data far =
      data_at(core::Vec3(0.0, 0.0, -0.05));  // seen only after the span: unplanned
  int k = 0;
  for (; k < 20; ++k) servo.observe(k * kDt, d);
  for (; k < 22; ++k) servo.observe(k * kDt, far);  // the last two planned errors, seen L later
  const core::Vec3 reached = servo.offset();
  EXPECT_NEAR(reached.norm(), 0.0005, 1e-15) << "clamped at max_offset";
  EXPECT_GT(servo.saturated_periods(), 0);
  EXPECT_GE(servo.first_saturation_s(), 0.0);
  for (; k < 40; ++k) servo.observe(k * kDt, far);
  EXPECT_EQ(servo.offset(), reached) << "held where no target is planned";
  EXPECT_NEAR(servo.offset_max_m(), 0.0005, 1e-15);
}

// The loop closed: a hand whose body sits 2 mm below the hand (a load it sags under) is moved up
// until the body is on its target, within a few time constants.
TEST(HandServo, AHandWhoseBodySagsIsMovedUntilTheBodyIsOnItsTarget) {
  HandServoSpec s = spec(0.002, 0.05, 0.004);
  s.spans[0].point = core::Vec3::Zero();
  s.spans[0].t1_s = 2.0;
  s.spans[0].target_start = s.spans[0].target_end = core::Vec3(0.0, 0.0, 0.0);
  HandServo servo(s, kDt, "right");
  const core::Vec3 sag(0.0, 0.0, -0.002);
  core::Data d = data_at(sag);
  for (int k = 0; k < 1000; ++k) {
    servo.observe(k * kDt, d);
    d.bodies[0].position = servo.offset() + sag;  // the body follows the hand, 2 mm under it
  }
  EXPECT_NEAR(d.bodies[0].position.z(), 0.0, 1e-7) << "on its target after 20 time constants";
  EXPECT_NEAR(servo.offset().z(), 0.002, 1e-7);
}

// A hand 150 ms late: integrating what it sees overshoots a 30 ms time constant and rings; a
// hand that takes off what it did since it saw (predict, a Smith predictor) settles as a hand
// without the delay would, 150 ms later.
TEST(HandServo, APredictingHandSettlesDespiteItsLatency) {
  const auto run = [](bool predict) {
    HandServoSpec s = spec(0.15, 0.03, 0.01);
    s.settings.predict = predict;
    s.spans[0].point = core::Vec3::Zero();
    s.spans[0].t1_s = 3.0;
    s.spans[0].target_start = s.spans[0].target_end = core::Vec3::Zero();
    HandServo servo(s, kDt, "right");
    const core::Vec3 sag(0.0, 0.0, -0.002);
    core::Data d = data_at(sag);
    double overshoot = 0.0;
    for (int k = 0; k < 2000; ++k) {
      servo.observe(k * kDt, d);
      d.bodies[0].position = servo.offset() + sag;
      overshoot = std::max(overshoot, d.bodies[0].position.z());
    }
    return std::pair{overshoot, d.bodies[0].position.z()};
  };
  const auto [ringing, ringing_end] = run(false);
  EXPECT_GT(ringing, 0.001) << "the blind integral overshoots the target by more than half the sag";
  const auto [settled, settled_end] = run(true);
  EXPECT_LT(settled, 1e-9) << "never past the target";
  EXPECT_NEAR(settled_end, 0.0, 1e-7) << "on it after 2 s";
  (void)ringing_end;
}

TEST(HandServo, RefusesSettingsOutOfRange) {
  const auto refused = [](HandServoSpec s, const std::string& what) {
    try {
      HandServo servo(std::move(s), kDt, "right");
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("right"), std::string::npos) << e.what();
      return;
    }
    ADD_FAILURE() << "accepted: " << what;
  };
  refused(spec(-0.001), "latency");
  refused(spec(kMaxServoLatency + 0.1), "latency");
  refused(spec(0.002, 0.0), "time_constant");
  refused(spec(0.002, NAN), "time_constant");
  refused(spec(0.002, 0.05, 0.0), "max_offset");
  HandServoSpec overlapping = spec();
  overlapping.spans.push_back(overlapping.spans[0]);
  refused(overlapping, "span 1");
  HandServoSpec empty_span = spec();
  empty_span.spans[0].t1_s = empty_span.spans[0].t0_s;
  refused(empty_span, "span 0");
  HandServoSpec unresolved = spec();
  unresolved.spans[0].body = -1;
  refused(unresolved, "body");
  HandServoSpec bad_target = spec();
  bad_target.spans[0].target_end.x() = INFINITY;
  refused(bad_target, "target");
  EXPECT_THROW(HandServo(spec(), 0.0, "right"), std::invalid_argument);
}

TEST(HandServo, ObservesWithoutAllocating) {
  HandServo servo(spec(0.15, 0.3), kDt, "right");
  const core::Data d = data_at(core::Vec3::Zero());
  numen::test::AllocationGuard guard;
  for (int k = 0; k < 2000; ++k) servo.observe(k * kDt, d);
  EXPECT_EQ(guard.count(), 0);
}

}  // namespace
}  // namespace numen::sim
