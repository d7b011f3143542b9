// Tests of core/src/body/types.cpp: rotation_between().
#include "numen/core/types.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace numen::core {
namespace {

// The rotation turns `from`'s direction onto `to`'s, whatever their lengths, and is a unit
// quaternion.
TEST(RotationBetween, TurnsTheFirstDirectionOntoTheSecond) {
  const Vec3 pairs[][2] = {{Vec3::UnitZ(), Vec3::UnitX()},
                           {Vec3(0.0, 0.0, 3.0), Vec3(0.1, -0.05, 1.0)},
                           {Vec3(1.0, 2.0, -0.5), Vec3(-4.0, 0.3, 0.7)},
                           {Vec3::UnitZ(), Vec3::UnitZ()}};
  for (const auto& [from, to] : pairs) {
    const Quat q = rotation_between(from, to);
    EXPECT_NEAR(q.norm(), 1.0, 1e-12);
    EXPECT_LT((q * from.normalized() - to.normalized()).norm(), 1e-12) << from.transpose();
  }
}

// Opposite directions: a half turn about an axis perpendicular to both, to about √ε (Eigen's
// branch for them takes w = √((1 + cos θ) / 2), cos θ = −1 to rounding: 7.5e-9 here).
TEST(RotationBetween, OppositeDirectionsGiveAHalfTurn) {
  const Vec3 from(0.2, -1.0, 0.4);
  const Quat q = rotation_between(from, -2.0 * from);
  EXPECT_NEAR(q.norm(), 1.0, 1e-12);
  EXPECT_NEAR(q.w(), 0.0, 1e-7);
  EXPECT_NEAR(q.vec().dot(from), 0.0, 1e-12);
  EXPECT_LT((q * from + from).norm(), 1e-7 * from.norm());
}

// The least angle: the axis is perpendicular to both directions and the angle is theirs.
TEST(RotationBetween, TakesTheLeastAngle) {
  const Vec3 from = Vec3::UnitZ();
  const Vec3 to = Vec3(1.0, 1.0, 1.0).normalized();
  const Eigen::AngleAxisd aa(rotation_between(from, to));
  EXPECT_NEAR(aa.angle(), std::acos(to.z()), 1e-12);
  EXPECT_NEAR(aa.axis().dot(from), 0.0, 1e-12);
  EXPECT_NEAR(aa.axis().dot(to), 0.0, 1e-12);
}

}  // namespace
}  // namespace numen::core
