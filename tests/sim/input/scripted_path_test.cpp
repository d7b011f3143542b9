// Tests of sim/scripted_path: line, circle, hold, step and spin segments,
// continuity between segments, sampling, and InputError keys for bad parameters.
#include "numen/sim/input/scripted_path.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include "alloc_counter.hpp"
#include "numen/sim/input/input_error.hpp"
#include "test_constants.hpp"

namespace {

using numen::core::Quat;
using numen::core::Vec3;
using numen::sim::CircleSegment;
using numen::sim::HoldSegment;
using numen::sim::InputError;
using numen::sim::LineSegment;
using numen::sim::PathSegment;
using numen::sim::ScriptedPath;
using numen::sim::StepSegment;

using numen::test::kPi;

PathSegment line(std::optional<Vec3> from, const Vec3& to, double duration) {
  PathSegment s;
  s.shape = LineSegment{from, to, duration};
  return s;
}

PathSegment hold(std::optional<Vec3> at, double duration) {
  PathSegment s;
  s.shape = HoldSegment{at, duration};
  return s;
}

PathSegment circle(std::optional<Vec3> centre, double radius, const Vec3& axis, double period,
                   double phase, double duration) {
  PathSegment s;
  s.shape = CircleSegment{centre, radius, axis, period, phase, duration};
  return s;
}

PathSegment step(std::optional<Vec3> from, const Vec3& to, double step_time, double duration) {
  PathSegment s;
  s.shape = StepSegment{from, to, std::nullopt, step_time, duration};
  return s;
}

/// The key of the InputError thrown by `f`, or "" if none.
template <class F>
std::string error_key(F&& f) {
  try {
    f();
  } catch (const InputError& e) {
    EXPECT_EQ(e.line(), 0);
    EXPECT_TRUE(e.file().empty());
    return e.key();
  }
  return "";
}

TEST(ScriptedPath, LineEndpointsAndConstantSpeed) {
  const Vec3 a(0.1, 0.0, 0.2), b(0.1, 0.3, -0.2);
  const ScriptedPath path({line(a, b, 2.0)});
  EXPECT_DOUBLE_EQ(path.duration(), 2.0);
  EXPECT_EQ(path.evaluate(0.0).pose.position, a);
  EXPECT_NEAR((path.evaluate(2.0).pose.position - b).norm(), 0.0, 1e-15);
  EXPECT_NEAR((path.evaluate(0.5).pose.position - (a + 0.25 * (b - a))).norm(), 0.0, 1e-15);

  const auto tr = path.sample(1e-3);
  ASSERT_EQ(tr.size(), 2001u);
  EXPECT_EQ(tr[0].pose.position, a);
  EXPECT_NEAR((tr[2000].pose.position - b).norm(), 0.0, 1e-15);
  const Vec3 v = (b - a) / 2.0;  // 0.25 m/s
  for (double t = 0.0; t < 2.0; t += 0.0371) {
    EXPECT_NEAR((tr.twist_at(t).linear - v).norm(), 0.0, 1e-12) << t;
    EXPECT_NEAR(tr.twist_at(t).angular.norm(), 0.0, 1e-15) << t;
  }
}

TEST(ScriptedPath, SegmentsStartWhereThePreviousEnded) {
  const Quat q = Quat(Eigen::AngleAxisd(0.4, Vec3::UnitX()));
  PathSegment first = hold(Vec3(0.0, 0.0, 0.1), 0.5);
  first.orientation = q;
  first.jaw = 0.3;
  const ScriptedPath path(
      {first, line(std::nullopt, Vec3(0.1, 0.0, 0.1), 1.0), hold(std::nullopt, 0.5)});
  EXPECT_DOUBLE_EQ(path.duration(), 2.0);
  EXPECT_DOUBLE_EQ(path.segment_start(1), 0.5);
  EXPECT_DOUBLE_EQ(path.segment_start(2), 1.5);
  const auto mid = path.evaluate(1.0);
  EXPECT_NEAR((mid.pose.position - Vec3(0.05, 0.0, 0.1)).norm(), 0.0, 1e-15);
  EXPECT_NEAR(mid.pose.orientation.angularDistance(q), 0.0, 1e-15);  // orientation carried on
  EXPECT_EQ(mid.jaw, 0.3);                                           // jaw carried on
  EXPECT_NEAR((path.evaluate(1.9).pose.position - Vec3(0.1, 0.0, 0.1)).norm(), 0.0, 1e-15);
}

TEST(ScriptedPath, TheJawRampsOverJawTimeFromThePreviousAngle) {
  // Open at 1.0 rad, then a segment closing to 0.2 rad over its first 0.4 s (jaw_time), then
  // one without jaw_time: a jump back to 1.0 at its start.
  numen::sim::TrajectorySample start;
  start.jaw = 1.0;
  PathSegment close = hold(Vec3::Zero(), 1.0);
  close.jaw = 0.2;
  close.jaw_time = 0.4;
  PathSegment open = hold(std::nullopt, 0.5);
  open.jaw = 1.0;
  const ScriptedPath path({close, open}, start);
  EXPECT_DOUBLE_EQ(path.evaluate(0.0).jaw, 1.0);
  EXPECT_NEAR(path.evaluate(0.1).jaw, 0.8, 1e-12);
  EXPECT_NEAR(path.evaluate(0.3).jaw, 0.4, 1e-12);
  EXPECT_DOUBLE_EQ(path.evaluate(0.4).jaw, 0.2);
  EXPECT_DOUBLE_EQ(path.evaluate(0.9).jaw, 0.2);
  EXPECT_DOUBLE_EQ(path.evaluate(1.0).jaw, 1.0);
  // Sampled at 1 ms, the ramp moves the jaw 2 mrad a sample (0.8 rad over 400 samples).
  const auto tr = path.sample(1e-3);
  double largest = 0.0;
  for (std::size_t k = 1; k < 1000; ++k) largest = std::max(largest, std::abs(tr[k].jaw - tr[k - 1].jaw));
  EXPECT_NEAR(largest, 0.002, 1e-9);
  // A ramp longer than its segment, or negative, is refused at the key.
  EXPECT_EQ(error_key([] {
              PathSegment s = hold(Vec3::Zero(), 0.5);
              s.jaw = 0.1;
              s.jaw_time = 0.6;
              ScriptedPath({s});
            }),
            "path[0].jaw_time");
  EXPECT_EQ(error_key([] {
              PathSegment s = hold(Vec3::Zero(), 0.5);
              s.jaw_time = -0.1;
              ScriptedPath({s});
            }),
            "path[0].jaw_time");
}

TEST(ScriptedPath, FirstSegmentStartsAtTheGivenStart) {
  numen::sim::TrajectorySample start;
  start.pose.position = Vec3(1.0, 2.0, 3.0);
  start.jaw = 0.7;
  const ScriptedPath path({line(std::nullopt, Vec3(1.0, 2.0, 4.0), 1.0)}, start);
  EXPECT_EQ(path.evaluate(0.0).pose.position, start.pose.position);
  EXPECT_EQ(path.evaluate(0.0).jaw, 0.7);
}

TEST(ScriptedPath, CircleRadiusPeriodPhaseAndDirection) {
  const Vec3 c(0.0, 0.1, 0.2);
  const double r = 0.03, period = 0.8;
  const ScriptedPath path({circle(c, r, Vec3(0, 0, 2.0), period, 0.0, 2.0)});
  // Axis z: e1 = x, e2 = y; phase 0 at c + r x, a quarter period later at c + r y.
  EXPECT_NEAR((path.evaluate(0.0).pose.position - (c + r * Vec3::UnitX())).norm(), 0.0, 1e-15);
  EXPECT_NEAR((path.evaluate(period / 4).pose.position - (c + r * Vec3::UnitY())).norm(), 0.0,
              1e-15);
  EXPECT_NEAR((path.evaluate(period).pose.position - path.evaluate(0.0).pose.position).norm(), 0.0,
              1e-15);
  const auto tr = path.sample(1e-3);
  for (std::size_t idx = 0; idx < tr.size(); ++idx) {
    const auto s = tr[idx];
    EXPECT_NEAR((s.pose.position - c).norm(), r, 1e-15);
    EXPECT_NEAR(s.pose.position.z(), c.z(), 1e-15);
  }
  // Speed 2πr/T (the chord of one sample is slightly shorter than the arc).
  const double speed = 2 * kPi * r / period;
  const double chord = 2 * r * std::sin(kPi * 1e-3 / period) / 1e-3;
  EXPECT_NEAR(tr.twist_at(0.3).linear.norm(), chord, 1e-12);
  EXPECT_NEAR(chord, speed, 1e-6);
  // Sample k and k + 800 (one period later) coincide.
  for (std::size_t k = 0; k + 800 < tr.size(); k += 97) {
    EXPECT_NEAR((tr[k].pose.position - tr[k + 800].pose.position).norm(), 0.0, 1e-14) << k;
  }
}

TEST(ScriptedPath, CircleInAnyPlaneAndWithoutACentre) {
  const Vec3 axis = Vec3(1.0, 1.0, 0.2).normalized();
  const double r = 0.05;
  // Starts where the hold is, at phase π/3, centre deduced.
  const Vec3 p0(0.2, -0.1, 0.0);
  const ScriptedPath path({hold(p0, 0.1), circle(std::nullopt, r, axis, 1.0, kPi / 3, 1.0)});
  EXPECT_NEAR((path.evaluate(0.1).pose.position - p0).norm(), 0.0, 1e-15);
  Vec3 centre = Vec3::Zero();
  for (int i = 0; i < 4; ++i) centre += path.evaluate(0.1 + 0.25 * i).pose.position / 4.0;
  for (double t = 0.1; t <= 1.1; t += 0.05) {
    const Vec3 p = path.evaluate(t).pose.position;
    EXPECT_NEAR((p - centre).norm(), r, 1e-12) << t;
    EXPECT_NEAR((p - centre).dot(axis), 0.0, 1e-12) << t;
  }
  // Turns right-handed about the axis.
  const Vec3 a = path.evaluate(0.1).pose.position - centre;
  const Vec3 b = path.evaluate(0.2).pose.position - centre;
  EXPECT_GT(a.cross(b).dot(axis), 0.0);
}

TEST(ScriptedPath, StepJumpsAtTheGivenTime) {
  const Vec3 a(0.0, 0.0, 0.1), b(0.02, 0.0, 0.1);
  const ScriptedPath path({step(a, b, 0.25, 0.5)});
  EXPECT_EQ(path.evaluate(0.2499).pose.position, a);
  EXPECT_EQ(path.evaluate(0.25).pose.position, b);
  EXPECT_EQ(path.evaluate(0.5).pose.position, b);
  const double dt = 1e-3;
  const auto tr = path.sample(dt);
  ASSERT_EQ(tr.size(), 501u);
  EXPECT_EQ(tr[249].pose.position, a);
  EXPECT_EQ(tr[250].pose.position, b);
  for (std::size_t k = 0; k < tr.size(); ++k) {
    EXPECT_EQ(tr[k].pose.position, k < 250 ? a : b) << k;
  }
  // The jump happens within the one interval before 0.25 s.
  EXPECT_NEAR((tr.twist_at(0.2495).linear - (b - a) / dt).norm(), 0.0, 1e-9);
  EXPECT_EQ(tr.twist_at(0.2485).linear, Vec3::Zero());
  EXPECT_EQ(tr.twist_at(0.2505).linear, Vec3::Zero());
}

TEST(ScriptedPath, StepCanTurnTheOrientationToo) {
  PathSegment s = step(Vec3::Zero(), Vec3::Zero(), 0.1, 0.2);
  const Quat turned(Eigen::AngleAxisd(0.5, Vec3::UnitY()));
  std::get<StepSegment>(s.shape).to_orientation = turned;
  const ScriptedPath path({s, hold(std::nullopt, 0.1)});
  EXPECT_NEAR(path.evaluate(0.05).pose.orientation.angularDistance(Quat::Identity()), 0.0, 1e-15);
  EXPECT_NEAR(path.evaluate(0.15).pose.orientation.angularDistance(turned), 0.0, 1e-15);
  EXPECT_NEAR(path.evaluate(0.25).pose.orientation.angularDistance(turned), 0.0, 1e-15);
}

TEST(ScriptedPath, SpinRate) {
  PathSegment s = hold(Vec3(0.0, 0.0, 0.1), 1.0);
  const Vec3 w(0.0, 0.0, 2 * kPi);  // one turn per second about world z
  const Quat q0(Eigen::AngleAxisd(0.3, Vec3::UnitX()));
  s.orientation = q0;
  s.angular_velocity = w;
  const ScriptedPath path({s, hold(std::nullopt, 0.5)});
  const Quat quarter = Quat(Eigen::AngleAxisd(kPi / 2, Vec3::UnitZ())) * q0;
  EXPECT_NEAR(path.evaluate(0.25).pose.orientation.angularDistance(quarter), 0.0, 1e-14);
  const auto tr = path.sample(1e-3);
  for (double t = 0.0; t < 0.999; t += 0.0413) {
    EXPECT_NEAR((tr.twist_at(t).angular - w).norm(), 0.0, 1e-9) << t;
    EXPECT_NEAR(tr.twist_at(t).linear.norm(), 0.0, 1e-15) << t;
  }
  // The next segment holds the orientation reached after one full turn.
  EXPECT_NEAR(path.evaluate(1.2).pose.orientation.angularDistance(q0), 0.0, 1e-12);
  EXPECT_NEAR(tr.twist_at(1.2).angular.norm(), 0.0, 1e-12);
  for (std::size_t k = 1; k < tr.size(); ++k) {
    ASSERT_GT(tr[k].pose.orientation.dot(tr[k - 1].pose.orientation), 0.0) << k;
  }
}

TEST(ScriptedPath, SamplingHoldsTheEndWhenDurationIsNotAMultipleOfDt) {
  const ScriptedPath path({line(Vec3::Zero(), Vec3::UnitX(), 0.0105)});
  const auto tr = path.sample(1e-3);
  ASSERT_EQ(tr.size(), 12u);  // 0 .. 11 ms, the last one at the end point
  EXPECT_NEAR((tr[11].pose.position - Vec3::UnitX()).norm(), 0.0, 1e-15);
  EXPECT_NEAR((tr[10].pose.position - Vec3(10.0 / 10.5, 0, 0)).norm(), 0.0, 1e-12);
}

TEST(ScriptedPath, BadParametersNameTheSegmentAndField) {
  EXPECT_EQ(error_key([] { ScriptedPath({}); }), "path");
  EXPECT_EQ(error_key([] { ScriptedPath({line(Vec3::Zero(), Vec3::UnitX(), -1.0)}); }),
            "path[0].duration");
  EXPECT_EQ(error_key([] {
              ScriptedPath({hold(Vec3::Zero(), 1.0), hold(std::nullopt, 1.0),
                            circle(Vec3::Zero(), 0.0, Vec3::UnitZ(), 1.0, 0.0, 1.0)});
            }),
            "path[2].radius");
  EXPECT_EQ(
      error_key([] { ScriptedPath({circle(Vec3::Zero(), 0.1, Vec3::Zero(), 1.0, 0.0, 1.0)}); }),
      "path[0].axis");
  EXPECT_EQ(
      error_key([] { ScriptedPath({circle(Vec3::Zero(), 0.1, Vec3::UnitZ(), 0.0, 0.0, 1.0)}); }),
      "path[0].period");
  EXPECT_EQ(error_key([] { ScriptedPath({step(Vec3::Zero(), Vec3::UnitX(), 2.0, 1.0)}); }),
            "path[0].step_time");
  EXPECT_EQ(error_key([] { ScriptedPath({line(Vec3::Zero(), Vec3(std::nan(""), 0, 0), 1.0)}); }),
            "path[0].to");
  EXPECT_EQ(error_key([] {
              PathSegment s = hold(Vec3::Zero(), 1.0);
              s.orientation = Quat(0, 0, 0, 0);
              ScriptedPath({s});
            }),
            "path[0].orientation");
  EXPECT_EQ(error_key([] {
              PathSegment s = hold(Vec3::Zero(), 1.0);
              s.jaw = std::numeric_limits<double>::infinity();
              ScriptedPath({hold(Vec3::Zero(), 1.0), s}, {}, "scene.target.path");
            }),
            "scene.target.path[1].jaw");
  // Sampling errors.
  EXPECT_EQ(error_key([] { ScriptedPath({hold(Vec3::Zero(), 1.0)}).sample(0.0); }), "path.dt");
  EXPECT_EQ(error_key([] {
              PathSegment s = hold(Vec3::Zero(), 1.0);
              s.angular_velocity = Vec3(0, 0, 4000.0);  // 4 rad per 1 ms sample
              ScriptedPath({s}).sample(1e-3);
            }),
            "path[0].angular_velocity");
  EXPECT_EQ(
      error_key([] {
        ScriptedPath({circle(Vec3::Zero(), 0.1, Vec3::UnitZ(), 1.5e-3, 0.0, 1.0)}).sample(1e-3);
      }),
      "path[0].period");
}

TEST(ScriptedPath, EvaluateAllocatesNothing) {
  PathSegment spin = hold(Vec3::Zero(), 1.0);
  spin.angular_velocity = Vec3(0.1, 0.2, 3.0);
  const ScriptedPath path({line(Vec3::Zero(), Vec3::UnitX(), 1.0),
                           circle(std::nullopt, 0.1, Vec3::UnitY(), 0.5, 0.0, 1.0), spin,
                           step(std::nullopt, Vec3::Zero(), 0.5, 1.0)});
  double sink = 0.0;
  numen::test::AllocationGuard guard;
  for (double t = -0.1; t < 4.2; t += 0.00137) sink += path.evaluate(t).pose.position.x();
  EXPECT_EQ(guard.count(), 0);
  EXPECT_TRUE(std::isfinite(sink));
}

}  // namespace
