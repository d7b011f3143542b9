// Tests of numen/hal/device/pose_tracker_kinematics.hpp: Euler convention, round trips, gimbal
// lock, Jacobian against finite differences and the virtual-work identity (kinematics_check.hpp).
#include "numen/hal/device/pose_tracker_kinematics.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "alloc_counter.hpp"
#include "kinematics_check.hpp"
#include "numen/hal/device/axis.hpp"
#include "rotation.hpp"
#include "test_constants.hpp"

namespace pose_tracker_kinematics_test {  // named: the unity build shares a TU with other test files

using namespace numen::hal;
using numen::core::Pose;
using numen::core::Quat;
using numen::core::Vec3;
using numen::core::Wrench;
using PK = PoseTrackerKinematics;
using numen::test::kPi;
using numen::test::rot;

PoseTrackerGeometry some_base() {
  PoseTrackerGeometry g;
  g.base.position = Vec3(0.5, 0.1, -0.2);
  g.base.orientation = rot(0.7, Vec3(0.2, -1, 0.5).normalized());
  return g;
}

Pose some_offset() {
  Pose p;
  p.position = Vec3(0.0, 0.03, 0.05);
  p.orientation = rot(-0.4, Vec3(1, 0, 1).normalized());
  return p;
}

AxisVector q_of(double x, double y, double z, double yaw, double pitch, double roll) {
  AxisVector q(6);
  q << x, y, z, yaw, pitch, roll;
  return q;
}

TEST(PoseTrackerKinematics, IdentityBaseAndOffsetGiveTheAxesDirectly) {
  const PK k;
  const Pose p = k.forward(q_of(0.1, 0.2, 0.3, 0.4, 0.5, 0.6));
  EXPECT_TRUE(p.position.isApprox(Vec3(0.1, 0.2, 0.3), 1e-15));
  const Quat expected = rot(0.4, Vec3::UnitZ()) * rot(0.5, Vec3::UnitY()) * rot(0.6, Vec3::UnitX());
  EXPECT_LT(p.orientation.angularDistance(expected), 1e-12);
}

TEST(PoseTrackerKinematics, InverseOfForwardIsTheIdentity) {
  const PK k(some_base(), some_offset());
  for (double yaw : {-3.0, -1.0, 0.0, 2.0, kPi}) {
    for (double pitch : {-1.5, -0.4, 0.0, 0.9, 1.5}) {
      for (double roll : {-2.5, 0.0, 1.0, 3.1}) {
        const AxisVector q = q_of(0.1, -0.2, 0.05, yaw, pitch, roll);
        const AxisVector back = k.inverse(k.forward(q), AxisVector());
        for (int i = 0; i < 3; ++i) EXPECT_NEAR(back[i], q[i], 1e-12);
        EXPECT_NEAR(axis_difference(back[PK::kYaw], yaw, true), 0.0, 1e-9);
        EXPECT_NEAR(back[PK::kPitch], pitch, 1e-9);
        EXPECT_NEAR(axis_difference(back[PK::kRoll], roll, true), 0.0, 1e-9);
      }
    }
  }
}

TEST(PoseTrackerKinematics, GimbalLockKeepsThePose) {
  const PK k;
  const AxisVector q = q_of(0, 0, 0, 0.3, kPi / 2, 0.5);
  const Pose p = k.forward(q);
  const AxisVector back = k.inverse(p, AxisVector());
  EXPECT_NEAR(back[PK::kRoll], 0.0, 1e-12);
  EXPECT_LT(k.forward(back).orientation.angularDistance(p.orientation), 1e-7);
}

class TrackerJacobian : public ::testing::TestWithParam<int> {};

AxisVector sample_q(int i) {
  const double s = 0.41 * i;
  return q_of(0.1 * std::sin(s), -0.2 * std::cos(s), 0.3, 3.0 * std::sin(0.5 * s + 0.2),
              1.2 * std::sin(1.7 * s), 2.8 * std::cos(0.9 * s));
}

TEST_P(TrackerJacobian, MatchesCentralDifferencesOfForward) {
  const PK k(some_base(), some_offset());
  const AxisVector q = sample_q(GetParam());
  ASSERT_EQ(k.jacobian(q).cols(), 6);
  numen::test::expect_jacobian_matches_central_differences(k, q, 1e-7);
}

TEST_P(TrackerJacobian, TransposeMapsWrenchesByVirtualWork) {
  const PK k(some_base(), some_offset());
  const AxisVector q = sample_q(GetParam());
  Wrench w;
  w.force = Vec3(-1.0, 0.4, 2.0);
  w.torque = Vec3(0.3, -0.2, 0.1);
  AxisVector dq(6);
  dq << 1e-6, -1e-6, 2e-6, 1.5e-6, -0.5e-6, 1e-6;
  numen::test::expect_virtual_work(k, q, w, dq, 1e-11);
}

INSTANTIATE_TEST_SUITE_P(Configurations, TrackerJacobian, ::testing::Range(0, 12));

TEST(PoseTrackerKinematics, CallsDoNotAllocate) {
  const PK k(some_base(), some_offset());
  const AxisVector q = sample_q(2);
  numen::test::AllocationGuard guard;
  double sink = 0;
  for (int i = 0; i < 100; ++i) {
    const Pose p = k.forward(q);
    sink += k.jacobian(q).sum() + k.inverse(p, q).sum();
  }
  EXPECT_EQ(guard.count(), 0);
  EXPECT_TRUE(std::isfinite(sink));
}

}  // namespace pose_tracker_kinematics_test
