// Tests of numen/hal/device/phantom_kinematics.hpp: the documented convention (home "L" posture,
// parallelogram elbow, gimbal), Jacobians of the controlled frame and of every link against
// central differences, analytic inverse (round trip on the elbow branch, workspace clamping,
// gimbal lock), the virtual-work identity for τ = Σ_l J_lᵀ w_l, and no allocation.
#include "numen/hal/device/phantom_kinematics.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>

#include "alloc_counter.hpp"
#include "kinematics_check.hpp"
#include "numen/hal/device/axis.hpp"
#include "rotation.hpp"
#include "test_constants.hpp"

namespace {

using namespace numen::hal;
using numen::core::Pose;
using numen::core::Quat;
using numen::core::Vec3;
using numen::test::uniform;
using PK = PhantomKinematics;
using numen::test::kPi;
using numen::test::rot;

// A base that is neither at the origin nor axis aligned, and unequal links.
PhantomGeometry some_geometry() {
  PhantomGeometry g;
  g.base.position = Vec3(0.3, -0.1, 0.05);
  g.base.orientation = rot(0.6, Vec3(0.3, 0.2, 1.0).normalized());
  g.l1 = 0.14;
  g.l2 = 0.17;
  return g;
}

Pose some_offset() {
  Pose p;
  p.position = Vec3(0.04, 0.005, -0.01);  // a tip ahead of the gimbal along the pen
  p.orientation = rot(0.25, Vec3(1, -2, 0.5).normalized());
  return p;
}

AxisVector q_of(double q0, double q1, double q2, double q3, double q4, double q5) {
  AxisVector q(6);
  q << q0, q1, q2, q3, q4, q5;
  return q;
}

// A random configuration on the inverse's branch: |q2 − q1| < π/2 with a margin, the gimbal
// centre in front of the turret axis (reach ρ > 0), the gimbal clear of its lock.
AxisVector random_reachable_q(SplitMix64& rng, const PhantomGeometry& g) {
  for (;;) {
    const double q1 = uniform(rng, -1.0, 1.0);
    const double q2 = q1 + uniform(rng, -1.3, 1.3);
    const double reach = g.l1 * std::cos(q1) - g.l2 * std::sin(q2);
    if (reach < 0.02) continue;
    return q_of(uniform(rng, -2.5, 2.5), q1, q2, uniform(rng, -2.8, 2.8), uniform(rng, -1.3, 1.3),
                uniform(rng, -kPi, kPi));
  }
}

// Any configuration (for Jacobian checks, which hold everywhere).
AxisVector random_q(SplitMix64& rng) {
  AxisVector q(6);
  for (int i = 0; i < 6; ++i) q[i] = uniform(rng, -kPi, kPi);
  return q;
}

TEST(PhantomKinematics, HomePostureIsAnL) {
  const PhantomGeometry g = some_geometry();
  const PK k(g);
  const AxisVector q = AxisVector::Zero(6);
  const Quat& rb = g.base.orientation;
  const Pose elbow = k.link_pose(PK::kLinkForearm, q);
  EXPECT_TRUE(elbow.position.isApprox(g.base.position + g.l1 * (rb * Vec3::UnitX()), 1e-12));
  const Pose stylus = k.stylus_pose(q);
  EXPECT_TRUE(stylus.position.isApprox(g.base.position + rb * Vec3(g.l1, 0.0, -g.l2), 1e-12));
  EXPECT_LT(stylus.orientation.angularDistance(rb), 1e-12);
  // Identity offset: the controlled frame is the stylus frame.
  const Pose f = k.forward(q);
  EXPECT_TRUE(f.position.isApprox(stylus.position, 1e-15));
}

TEST(PhantomKinematics, AxesFollowTheDocumentedConvention) {
  PhantomGeometry g;  // identity base at the origin, 0.14 m links
  const PK k(g);
  const double l = 0.14;
  // q0 turns the whole arm about z.
  Pose p = k.stylus_pose(q_of(0.5, 0, 0, 0, 0, 0));
  EXPECT_TRUE(p.position.isApprox(Vec3(l * std::cos(0.5), l * std::sin(0.5), -l), 1e-12));
  // q1 > 0 lowers the elbow; the forearm only translates (parallelogram): the stylus
  // orientation does not change and the gimbal moves with the elbow.
  const Pose e1 = k.link_pose(PK::kLinkForearm, q_of(0, 0.3, 0, 0, 0, 0));
  EXPECT_TRUE(e1.position.isApprox(Vec3(l * std::cos(0.3), 0, -l * std::sin(0.3)), 1e-12));
  EXPECT_LT(e1.orientation.angularDistance(Quat::Identity()), 1e-15);
  p = k.stylus_pose(q_of(0, 0.3, 0, 0, 0, 0));
  EXPECT_TRUE(p.position.isApprox(e1.position + Vec3(0, 0, -l), 1e-12));
  EXPECT_LT(p.orientation.angularDistance(Quat::Identity()), 1e-15);
  // q2 > 0 swings the gimbal back towards the turret axis, measured from the turret (the
  // same forearm direction whatever q1).
  for (double q1 : {-0.4, 0.0, 0.5}) {
    const Pose e = k.link_pose(PK::kLinkForearm, q_of(0, q1, 0.4, 0, 0, 0));
    const Pose s = k.stylus_pose(q_of(0, q1, 0.4, 0, 0, 0));
    EXPECT_TRUE(
        (s.position - e.position).isApprox(l * Vec3(-std::sin(0.4), 0, -std::cos(0.4)), 1e-12))
        << q1;
  }
  // Gimbal: yaw about the forearm (vertical at home), pitch about the yawed y, roll about the
  // pen (x of the stylus frame).
  p = k.stylus_pose(q_of(0, 0, 0, 0.3, -0.2, 0.7));
  const Quat expected =
      rot(0.3, Vec3::UnitZ()) * rot(-0.2, Vec3::UnitY()) * rot(0.7, Vec3::UnitX());
  EXPECT_LT(p.orientation.angularDistance(expected), 1e-12);
  EXPECT_TRUE(p.position.isApprox(Vec3(l, 0, -l), 1e-12));  // the gimbal does not move g
  // Roll turns about the pen: the pen axis x_S does not change.
  const Pose r = k.stylus_pose(q_of(0, 0, 0, 0.3, -0.2, -1.1));
  EXPECT_TRUE((r.orientation * Vec3::UnitX()).isApprox(p.orientation * Vec3::UnitX(), 1e-12));
}

TEST(PhantomKinematics, ToolOffsetIsAppliedInTheStylusFrame) {
  const Pose off = some_offset();
  const PK k(some_geometry(), off);
  const AxisVector q = q_of(0.2, -0.3, 0.4, 0.5, -0.6, 0.7);
  numen::test::expect_offset_applied(k.stylus_pose(q), off, k.forward(q));
}

TEST(PhantomKinematics, LinkNamesAndLinkZero) {
  const PK k(some_geometry(), some_offset());
  const char* const names[] = {"tool", "turret", "upper_arm", "forearm", "stylus"};
  numen::test::expect_link_names(k, names);
  EXPECT_EQ(k.find_link("gimbal"), -1);
  static_assert(PK::kLinkTool == 0);
  SplitMix64 rng(5);
  for (int trial = 0; trial < 10; ++trial)
    numen::test::expect_link_zero_is_the_controlled_frame(k, random_q(rng));
}

TEST(PhantomKinematics, LinkFramesSitWhereDocumented) {
  const PhantomGeometry g = some_geometry();
  const PK k(g);
  const AxisVector q = q_of(0.4, -0.2, 0.3, 1.0, 0.5, -0.5);
  const Quat r_t = g.base.orientation * rot(0.4, Vec3::UnitZ());
  const Pose turret = k.link_pose(PK::kLinkTurret, q);
  EXPECT_EQ(turret.position, g.base.position);
  EXPECT_LT(turret.orientation.angularDistance(r_t), 1e-12);
  const Pose upper = k.link_pose(PK::kLinkUpperArm, q);
  EXPECT_EQ(upper.position, g.base.position);
  EXPECT_LT(upper.orientation.angularDistance(r_t * rot(-0.2, Vec3::UnitY())), 1e-12);
  const Pose fore = k.link_pose(PK::kLinkForearm, q);
  EXPECT_TRUE(
      fore.position.isApprox(g.base.position + g.l1 * (upper.orientation * Vec3::UnitX()), 1e-12));
  EXPECT_LT(fore.orientation.angularDistance(r_t * rot(0.3, Vec3::UnitY())), 1e-12);
  const Pose stylus = k.link_pose(PK::kLinkStylus, q);
  EXPECT_TRUE(
      stylus.position.isApprox(fore.position - g.l2 * (fore.orientation * Vec3::UnitZ()), 1e-12));
  EXPECT_NEAR((stylus.position - fore.position).norm(), g.l2, 1e-12);
}

class PhantomJacobian : public ::testing::TestWithParam<int> {};

TEST_P(PhantomJacobian, ControlledFrameMatchesCentralDifferencesOfForward) {
  const PK k(some_geometry(), some_offset());
  SplitMix64 rng(1000 + static_cast<std::uint64_t>(GetParam()));
  const AxisVector q = random_q(rng);
  const Jacobian j = k.jacobian(q);
  ASSERT_EQ(j.cols(), 6);
  numen::test::expect_jacobian_matches_central_differences(k, q, 1e-6);
  EXPECT_GT(j.col(PK::kShoulder).head<3>().norm(), 0.05);  // the check is not vacuous
  EXPECT_EQ(j.col(PK::kShoulder).tail<3>().norm(), 0.0);   // parallelogram: no rotation
}

TEST_P(PhantomJacobian, EveryLinkJacobianMatchesCentralDifferencesOfItsPose) {
  const PK k(some_geometry(), some_offset());
  SplitMix64 rng(2000 + static_cast<std::uint64_t>(GetParam()));
  numen::test::expect_link_jacobians_match_central_differences(k, random_q(rng), 1e-6);
}

TEST_P(PhantomJacobian, TransposeMapsLinkWrenchesByVirtualWork) {
  // Σ_l w_l · δx_l (δx_l from link_pose only) == τ · δq with τ = Σ_l J_lᵀ w_l, to O(|δq|²).
  const PK k(some_geometry(), some_offset());
  SplitMix64 rng(3000 + static_cast<std::uint64_t>(GetParam()));
  for (int trial = 0; trial < 5; ++trial) {
    SCOPED_TRACE("trial " + std::to_string(trial));
    const AxisVector q = random_q(rng);
    const numen::test::LinkWorkTrial t = numen::test::expect_link_virtual_work(k, q, rng, 3.0);
    EXPECT_GT(std::abs(t.tau.dot(t.dq)), 1e-8);  // first order, well above its tolerance
  }
}

INSTANTIATE_TEST_SUITE_P(Configurations, PhantomJacobian, ::testing::Range(0, 12));

TEST(PhantomKinematics, InverseOfForwardIsTheIdentityOnTheElbowBranch) {
  const PhantomGeometry g = some_geometry();
  for (const Pose& off : {Pose{}, some_offset()}) {
    const PK k(g, off);
    SplitMix64 rng(99);
    for (int trial = 0; trial < 200; ++trial) {
      const AxisVector q = random_reachable_q(rng, g);
      const AxisVector back = k.inverse(k.forward(q), AxisVector());
      ASSERT_EQ(back.size(), 6);
      for (int i = 0; i < 6; ++i) {
        EXPECT_NEAR(axis_difference(back[i], q[i], true), 0.0, 1e-9)
            << "axis " << i << " trial " << trial;
      }
      EXPECT_LT(std::abs(back[PK::kElbow] - back[PK::kShoulder]), kPi / 2);
    }
  }
}

TEST(PhantomKinematics, UnreachableTargetsAreClampedToTheWorkspaceBoundary) {
  const PhantomGeometry g = some_geometry();  // l1 = 0.14, l2 = 0.17
  const PK k(g);
  const Quat& rb = g.base.orientation;
  const Quat orientation = rb * rot(0.4, Vec3(1, 1, 0).normalized());
  // Too far: onto the outer sphere l1 + l2, in the target's direction from the shoulder.
  for (const Vec3& dir_b : {Vec3(1, 0, 0), Vec3(0.3, -0.5, -0.8), Vec3(-1, 0.2, 0.4)}) {
    const Vec3 dir = rb * dir_b.normalized();
    Pose target;
    target.position = g.base.position + 5.0 * dir;
    target.orientation = orientation;
    const AxisVector q = k.inverse(target, AxisVector());
    ASSERT_TRUE(q.allFinite());
    const Pose p = k.forward(q);
    EXPECT_NEAR((p.position - g.base.position).norm(), g.l1 + g.l2, 1e-9);
    EXPECT_TRUE((p.position - g.base.position).normalized().isApprox(dir, 1e-9));
    EXPECT_LT(p.orientation.angularDistance(orientation), 1e-9);  // orientation kept
  }
  // Too near (inside the inner sphere |l1 − l2|): radially out onto it.
  Pose near;
  near.position = g.base.position + 0.01 * (rb * Vec3(0.6, 0, -0.8));
  near.orientation = orientation;
  AxisVector q = k.inverse(near, AxisVector());
  ASSERT_TRUE(q.allFinite());
  Pose p = k.forward(q);
  EXPECT_NEAR((p.position - g.base.position).norm(), 0.03, 1e-9);
  EXPECT_TRUE((p.position - g.base.position).normalized().isApprox(rb * Vec3(0.6, 0, -0.8), 1e-9));
  // Exactly at the shoulder (direction undefined): straight below it; the turret keeps q_free.
  near.position = g.base.position;
  const AxisVector q_free = q_of(0.7, 0, 0, 0, 0, 0);
  q = k.inverse(near, q_free);
  ASSERT_TRUE(q.allFinite());
  EXPECT_DOUBLE_EQ(q[PK::kTurret], 0.7);
  p = k.forward(q);
  EXPECT_TRUE((p.position - g.base.position).isApprox(rb * Vec3(0, 0, -0.03), 1e-9));
  // Equal links, target at the shoulder: finite, and forward puts the gimbal there.
  PhantomGeometry eq = g;
  eq.l2 = eq.l1;
  const PK ke(eq);
  q = ke.inverse(near, AxisVector());
  ASSERT_TRUE(q.allFinite());
  EXPECT_LT((ke.forward(q).position - g.base.position).norm(), 1e-12);
}

TEST(PhantomKinematics, TargetOnTheTurretAxisKeepsTheGivenTurretAngle) {
  const PhantomGeometry g = some_geometry();
  const PK k(g);
  Pose target;
  target.position = g.base.position + g.base.orientation * Vec3(0, 0, -0.2);  // below
  target.orientation = g.base.orientation;
  for (double q0 : {-0.9, 0.0, 0.4}) {
    const AxisVector q = k.inverse(target, q_of(q0, 0, 0, 0, 0, 0));
    ASSERT_TRUE(q.allFinite());
    EXPECT_DOUBLE_EQ(q[PK::kTurret], q0);
    const Pose p = k.forward(q);
    EXPECT_LT((p.position - target.position).norm(), 1e-9);
    EXPECT_LT(p.orientation.angularDistance(target.orientation), 1e-9);
  }
}

TEST(PhantomKinematics, GimbalLockKeepsTheGivenRollAndThePose) {
  const PK k(some_geometry(), some_offset());
  for (double pitch : {kPi / 2, -kPi / 2}) {
    const AxisVector q = q_of(0.3, -0.1, 0.2, 0.8, pitch, 0.5);
    const Pose target = k.forward(q);
    const AxisVector back = k.inverse(target, q_of(0, 0, 0, 0, 0, -0.4));
    ASSERT_TRUE(back.allFinite());
    const Pose p = k.forward(back);
    EXPECT_LT((p.position - target.position).norm(), 1e-9);
    EXPECT_LT(p.orientation.angularDistance(target.orientation), 1e-7);
    EXPECT_NEAR(std::abs(back[PK::kGimbalPitch]), kPi / 2, 1e-7);
  }
}

TEST(PhantomKinematics, CallsDoNotAllocate) {
  const PK k(some_geometry(), some_offset());
  SplitMix64 rng(1);
  const AxisVector q = random_reachable_q(rng, some_geometry());
  numen::test::AllocationGuard guard;
  double sink = 0;
  for (int i = 0; i < 100; ++i) {
    const Pose p = k.forward(q);
    sink += k.jacobian(q).sum() + k.inverse(p, q).sum() + numen::test::link_calls_sum(k, q);
  }
  EXPECT_EQ(guard.count(), 0);
  EXPECT_TRUE(std::isfinite(sink));
}

TEST(PhantomKinematics, RejectsBadGeometry) {
  PhantomGeometry g;
  g.l1 = 0.0;
  EXPECT_THROW(PK k(g), std::invalid_argument);
  g = PhantomGeometry{};
  g.l2 = std::nan("");
  EXPECT_THROW(PK k(g), std::invalid_argument);
  g = PhantomGeometry{};
  g.base.orientation = Quat(2, 0, 0, 0);
  EXPECT_THROW(PK k(g), std::invalid_argument);
  g = PhantomGeometry{};
  g.base.position.z() = INFINITY;
  EXPECT_THROW(PK k(g), std::invalid_argument);
  EXPECT_NO_THROW(PK k(PhantomGeometry{}));
}

}  // namespace
