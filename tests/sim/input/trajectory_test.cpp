// Tests of sim/trajectory: interpolation (linear / shortest-arc slerp),
// finite-difference twist, placement, resampling, and no allocation in at().
#include "numen/sim/input/trajectory.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

#include "alloc_counter.hpp"
#include "numen/sim/input/input_error.hpp"
#include "test_constants.hpp"

namespace {

using numen::core::Pose;
using numen::core::Quat;
using numen::core::Vec3;
using numen::sim::InputError;
using numen::sim::Trajectory;

using numen::test::kPi;

Quat about(const Vec3& axis, double angle) {
  return Quat(Eigen::AngleAxisd(angle, axis.normalized()));
}

/// Angle (rad) between two rotations, sign-insensitive.

/// A 30 Hz trajectory moving at constant linear velocity `v` and spinning at
/// constant world angular velocity `w` from orientation `q_init`.
Trajectory constant_rate(const Vec3& v, const Vec3& w, const Quat& q_init, std::size_t n,
                         double period) {
  std::vector<Pose> poses(n);
  std::vector<double> jaw(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double t = static_cast<double>(i) * period;
    poses[i].position = Vec3(0.1, -0.2, 0.3) + v * t;
    poses[i].orientation = numen::core::quat_exp(w * t) * q_init;
    jaw[i] = 0.1 + 0.5 * t;
  }
  return Trajectory(period, std::move(poses), std::move(jaw));
}

TEST(Trajectory, RejectsBadConstruction) {
  std::vector<Pose> one(1);
  EXPECT_THROW(Trajectory(0.0, one), InputError);
  EXPECT_THROW(Trajectory(-1e-3, one), InputError);
  EXPECT_THROW(Trajectory(std::nan(""), one), InputError);
  EXPECT_THROW(Trajectory(1e-3, {}), InputError);
  EXPECT_THROW(Trajectory(1e-3, one, {0.0, 1.0}), InputError);
  std::vector<Pose> bad(2);
  bad[1].position.x() = std::numeric_limits<double>::infinity();
  try {
    Trajectory(1e-3, bad);
    FAIL() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.key(), "trajectory.samples[1].position");
  }
  std::vector<Pose> zero_q(1);
  zero_q[0].orientation.coeffs().setZero();
  EXPECT_THROW(Trajectory(1e-3, zero_q), InputError);
}

TEST(Trajectory, SizesAndTimes) {
  const Trajectory tr = constant_rate(Vec3::UnitX(), Vec3::Zero(), Quat::Identity(), 31, 1.0 / 30);
  EXPECT_EQ(tr.size(), 31u);
  EXPECT_DOUBLE_EQ(tr.period(), 1.0 / 30);
  EXPECT_NEAR(tr.duration(), 1.0, 1e-15);
  EXPECT_EQ(tr[30].time, 30.0 / 30.0);
  const Trajectory empty;
  EXPECT_TRUE(empty.empty());
  EXPECT_EQ(empty.at(1.0).pose.position, Vec3::Zero());
  EXPECT_EQ(empty.twist_at(1.0).linear, Vec3::Zero());
}

TEST(Trajectory, MakesQuaternionSignsContinuous) {
  std::vector<Pose> poses(4);
  for (int i = 0; i < 4; ++i) poses[i].orientation = about(Vec3::UnitY(), 0.1 * i);
  poses[2].orientation.coeffs() *= -1.0;  // same rotation, other sign
  poses[0].orientation.coeffs() *= -1.0;  // the first becomes w >= 0
  const Trajectory tr(0.01, poses);
  EXPECT_GE(tr[0].pose.orientation.w(), 0.0);
  for (std::size_t i = 0; i + 1 < tr.size(); ++i) {
    EXPECT_GT(tr[i].pose.orientation.dot(tr[i + 1].pose.orientation), 0.0) << i;
  }
  EXPECT_NEAR(tr[2].pose.orientation.angularDistance(about(Vec3::UnitY(), 0.2)), 0.0, 1e-15);
}

TEST(Trajectory, AtSampleInstantsReturnsTheSamples) {
  const Trajectory tr = constant_rate(Vec3(0.01, 0.02, -0.03), Vec3(0.3, -0.2, 1.1),
                                      about(Vec3(1, 2, 3), 0.7), 40, 1.0 / 30);
  for (std::size_t i = 0; i < tr.size(); ++i) {
    const auto s = tr.at(static_cast<double>(i) / 30.0);
    EXPECT_EQ(s.pose.position, tr[i].pose.position) << i;
    EXPECT_EQ(s.pose.orientation.coeffs(), tr[i].pose.orientation.coeffs()) << i;
    EXPECT_EQ(s.jaw, tr[i].jaw) << i;
  }
}

TEST(Trajectory, InterpolatesLinearPositionAndSlerpAgainstHandComputedMidpoint) {
  std::vector<Pose> poses(2);
  poses[0].position = Vec3(0.0, 0.0, 0.0);
  poses[1].position = Vec3(0.02, -0.04, 0.06);
  poses[0].orientation = Quat::Identity();
  poses[1].orientation = Quat(std::cos(kPi / 4), 0.0, 0.0, std::sin(kPi / 4));  // 90° about z
  const Trajectory tr(0.1, poses, {0.2, 0.6});
  const auto mid = tr.at(0.05);
  EXPECT_NEAR((mid.pose.position - Vec3(0.01, -0.02, 0.03)).norm(), 0.0, 1e-15);
  // 45° about z, by hand: (cos 22.5°, 0, 0, sin 22.5°).
  const Quat expected(std::cos(kPi / 8), 0.0, 0.0, std::sin(kPi / 8));
  EXPECT_NEAR((mid.pose.orientation.coeffs() - expected.coeffs()).norm(), 0.0, 1e-15);
  EXPECT_NEAR(mid.jaw, 0.4, 1e-15);
  EXPECT_DOUBLE_EQ(mid.time, 0.05);
  // A quarter of the way: 22.5° about z.
  const auto quarter = tr.at(0.025);
  const Quat q4(std::cos(kPi / 16), 0.0, 0.0, std::sin(kPi / 16));
  EXPECT_NEAR((quarter.pose.orientation.coeffs() - q4.coeffs()).norm(), 0.0, 1e-15);
  EXPECT_NEAR((quarter.pose.position - Vec3(0.005, -0.01, 0.015)).norm(), 0.0, 1e-15);
}

TEST(Trajectory, SlerpTakesTheShortestArc) {
  const Quat q0 = Quat::Identity();
  Quat q1 = about(Vec3::UnitX(), 0.5);
  q1.coeffs() *= -1.0;  // the long way round if taken literally
  const Quat mid = numen::sim::slerp_shortest(q0, q1, 0.5);
  EXPECT_NEAR(mid.angularDistance(about(Vec3::UnitX(), 0.25)), 0.0, 1e-15);
  EXPECT_GT(mid.dot(q0), 0.0);  // stays in the hemisphere of q0
  // Agrees with Eigen's slerp away from tiny angles.
  const Quat a = about(Vec3(1, -1, 2), 0.3), b = about(Vec3(0, 1, 1), 2.0);
  for (double s : {0.1, 0.5, 0.9}) {
    EXPECT_NEAR(numen::sim::slerp_shortest(a, b, s).angularDistance(a.slerp(s, b)), 0.0, 1e-12);
  }
}

TEST(Trajectory, RotationVectorRoundTripsIncludingTinyAndLargeAngles) {
  for (double angle : {0.0, 1e-14, 1e-9, 1e-3, 1.0, 3.0, kPi - 1e-9}) {
    const Vec3 axis = Vec3(0.2, -0.7, 0.4).normalized();
    const Quat q = about(axis, angle);
    const Vec3 v = numen::core::quat_log(q);
    EXPECT_NEAR((v - angle * axis).norm(), 0.0, 1e-14 * std::max(1.0, angle)) << angle;
    Quat minus = q;
    minus.coeffs() *= -1.0;
    EXPECT_NEAR((numen::core::quat_log(minus) - v).norm(), 0.0, 1e-14) << angle;
    const Quat back = numen::core::quat_exp(v);
    EXPECT_NEAR(back.angularDistance(q), 0.0, 1e-14) << angle;
    EXPECT_NEAR(back.norm(), 1.0, 1e-15);
  }
}

TEST(Trajectory, ClampsToTheEnds) {
  const Trajectory tr = constant_rate(Vec3::UnitX(), Vec3::UnitZ(), Quat::Identity(), 10, 0.1);
  EXPECT_EQ(tr.at(-1.0).pose.position, tr[0].pose.position);
  EXPECT_EQ(tr.at(std::nan("")).pose.position, tr[0].pose.position);
  EXPECT_EQ(tr.at(5.0).pose.position, tr[9].pose.position);
  EXPECT_EQ(tr.at(5.0).pose.orientation.coeffs(), tr[9].pose.orientation.coeffs());
  EXPECT_DOUBLE_EQ(tr.at(5.0).time, tr.duration());
  EXPECT_EQ(tr.twist_at(-0.01).linear, Vec3::Zero());
  EXPECT_EQ(tr.twist_at(0.95).angular, Vec3::Zero());
  EXPECT_EQ(tr.twist_at(std::nan("")).linear, Vec3::Zero());
}

TEST(Trajectory, TwistRecoversConstantLinearAndAngularVelocity) {
  const Vec3 v(0.01, -0.03, 0.02);
  const Vec3 w(0.3, -0.2, 1.1);  // rad/s, world
  const Trajectory tr = constant_rate(v, w, about(Vec3(1, 2, 3), 0.7), 60, 1.0 / 30);
  for (double t : {0.0, 0.01, 1.0 / 30, 0.5, 1.234, tr.duration()}) {
    const auto tw = tr.twist_at(t);
    EXPECT_NEAR((tw.linear - v).norm(), 0.0, 1e-12) << t;
    EXPECT_NEAR((tw.angular - w).norm(), 0.0, 1e-12) << t;
  }
}

TEST(Trajectory, TwistIsTheDerivativeOfAt) {
  // Between samples, at() moves at exactly twist_at(): compare with a central difference.
  std::vector<Pose> poses(3);
  poses[1].position = Vec3(0.01, 0.0, 0.0);
  poses[2].position = Vec3(0.01, 0.03, 0.0);
  poses[1].orientation = about(Vec3::UnitZ(), 0.2);
  poses[2].orientation = about(Vec3::UnitX(), 0.3) * poses[1].orientation;
  const Trajectory bent(0.1, poses);
  const double h = 1e-6;
  for (double t : {0.03, 0.13, 0.17}) {
    const auto a = bent.at(t - h), b = bent.at(t + h);
    const Vec3 lin = (b.pose.position - a.pose.position) / (2 * h);
    const Vec3 ang =
        numen::core::quat_log(b.pose.orientation * a.pose.orientation.conjugate()) / (2 * h);
    EXPECT_NEAR((lin - bent.twist_at(t).linear).norm(), 0.0, 1e-7) << t;
    EXPECT_NEAR((ang - bent.twist_at(t).angular).norm(), 0.0, 1e-6) << t;
  }
  // At a sample instant the interval starting there is used.
  EXPECT_NEAR((bent.twist_at(0.1).linear - Vec3(0.0, 0.3, 0.0)).norm(), 0.0, 1e-12);
  EXPECT_NEAR((bent.twist_at(0.1).angular - Vec3(3.0, 0.0, 0.0)).norm(), 0.0, 1e-12);
}

// The control loop samples a trajectory at each period's time with at(): no resampling at dt.
TEST(Interpolation, EqualsTheRecordedPosesAtSampleInstantsOfA1kHzLoop) {
  const Trajectory rec = constant_rate(Vec3(0.01, 0.02, -0.03), Vec3(0.3, -0.2, 1.1),
                                       about(Vec3(1, 2, 3), 0.7), 31, 1.0 / 30);
  for (std::size_t i = 0; i < rec.size(); ++i) {
    const std::size_t k =
        static_cast<std::size_t>(std::lround(static_cast<double>(i) * 1000.0 / 30.0));
    if (std::abs(static_cast<double>(k) * 30.0 - static_cast<double>(i) * 1000.0) > 1e-9) continue;
    const auto s = rec.at(static_cast<double>(k) * 1e-3);
    EXPECT_NEAR((s.pose.position - rec[i].pose.position).norm(), 0.0, 1e-15) << i;
    EXPECT_NEAR(s.pose.orientation.angularDistance(rec[i].pose.orientation), 0.0, 1e-15) << i;
  }
  EXPECT_NEAR((rec.at(1.0).pose.position - rec[30].pose.position).norm(), 0.0, 1e-15);
}

TEST(Interpolation, InterpolatesBetweenRecordedSamples) {
  std::vector<Pose> poses(2);
  poses[1].position = Vec3(0.03, 0.0, 0.0);
  poses[1].orientation = about(Vec3::UnitY(), 0.6);
  const Trajectory rec(1.0 / 30, poses, {0.0, 0.3});
  // The midpoint: 1.5 cm, 0.3 rad about y, jaw 0.15.
  const auto mid = rec.at(10.0 / 600);
  EXPECT_NEAR((mid.pose.position - Vec3(0.015, 0.0, 0.0)).norm(), 0.0, 1e-15);
  const Quat half(std::cos(0.15), 0.0, std::sin(0.15), 0.0);
  EXPECT_NEAR((mid.pose.orientation.coeffs() - half.coeffs()).norm(), 0.0, 1e-15);
  EXPECT_NEAR(mid.jaw, 0.15, 1e-15);
  // A quarter.
  EXPECT_NEAR(rec.at(5.0 / 600).pose.orientation.angularDistance(about(Vec3::UnitY(), 0.15)), 0.0,
              1e-15);
}

TEST(Interpolation, RecoversTheAngularVelocityOfAConstantRateRotation) {
  const Vec3 w(-0.8, 0.5, 2.0);  // rad/s
  const Trajectory rec = constant_rate(Vec3::Zero(), w, about(Vec3(0, 1, 1), 1.0), 91, 1.0 / 30);
  double worst = 0.0;
  for (double t = 0.0; t < rec.duration(); t += 0.0123) {
    worst = std::max(worst, (rec.twist_at(t).angular - w).norm());
  }
  EXPECT_LT(worst, 1e-9);
}

// Issue 17, defect 1: a 30 s recording at 30 Hz keeps its 900 knots whatever the control
// period; it used to be resampled at dt up front (497 MB at dt = 1e-5, ~23 GB at 1e-7).
TEST(Interpolation, KeepsTheRecordedKnotsOnly) {
  const Trajectory rec = constant_rate(0.01 * Vec3::UnitX(), Vec3::Zero(), Quat::Identity(), 900, 1.0 / 30);
  EXPECT_EQ(rec.size(), 900u);
  EXPECT_LE(rec.memory_bytes(), 900 * sizeof(numen::sim::TrajectorySample));
}

TEST(Placement, MovesRotatesAndScalesTheWholeTrajectory) {
  const Vec3 v(0.01, 0.0, 0.0), w(0.0, 0.0, 1.0);
  const Trajectory rec = constant_rate(v, w, Quat::Identity(), 10, 0.1);
  numen::sim::Placement placement;
  placement.origin = Vec3(0.1, -0.2, 0.3);  // first position of constant_rate()
  placement.pose.position = Vec3(1.0, 2.0, 3.0);
  placement.pose.orientation = about(Vec3::UnitX(), kPi / 2);
  placement.scale = 2.0;
  const Trajectory moved = numen::sim::transformed(rec, placement);
  ASSERT_EQ(moved.size(), rec.size());
  EXPECT_NEAR((moved[0].pose.position - Vec3(1.0, 2.0, 3.0)).norm(), 0.0, 1e-15);
  const Quat r = placement.pose.orientation;
  for (std::size_t i = 0; i < rec.size(); ++i) {
    const Vec3 expected =
        Vec3(1.0, 2.0, 3.0) + r * (2.0 * (rec[i].pose.position - placement.origin));
    EXPECT_NEAR((moved[i].pose.position - expected).norm(), 0.0, 1e-15);
    EXPECT_NEAR(moved[i].pose.orientation.angularDistance(r * rec[i].pose.orientation), 0.0, 1e-15);
    EXPECT_EQ(moved[i].jaw, rec[i].jaw);
  }
  const auto tw = moved.twist_at(0.25);
  EXPECT_NEAR((tw.linear - r * (2.0 * v)).norm(), 0.0, 1e-12);
  EXPECT_NEAR((tw.angular - r * w).norm(), 0.0, 1e-12);  // (0, 0, 1) → (0, -1, 0)
  EXPECT_NEAR((numen::sim::apply(placement, placement.origin) - placement.pose.position).norm(),
              0.0, 0.0);
  placement.scale = 0.0;
  EXPECT_THROW(numen::sim::transformed(rec, placement), InputError);
  placement.scale = 1.0;
  placement.pose.orientation.coeffs().setZero();
  EXPECT_THROW(numen::sim::transformed(rec, placement), InputError);
}

TEST(Trajectory, AtAndTwistAtAllocateNothing) {
  const Trajectory rec =
      constant_rate(Vec3(0.01, 0.02, -0.03), Vec3(0.3, -0.2, 1.1), Quat::Identity(), 300, 1.0 / 30);
  double sink = 0.0;
  numen::test::AllocationGuard guard;
  for (double t = -0.5; t < rec.duration() + 0.5; t += 0.000731) {
    const auto s = rec.at(t);
    const auto tw = rec.twist_at(t);
    sink += s.pose.position.x() + s.pose.orientation.w() + tw.angular.z() + s.jaw;
  }
  EXPECT_EQ(guard.count(), 0);
  EXPECT_TRUE(std::isfinite(sink));
}

}  // namespace
