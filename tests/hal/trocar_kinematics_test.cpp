// Tests of numen/hal/trocar_kinematics.hpp: geometry, round trips, Jacobian against finite
// differences, virtual work τ = Jᵀ W, and what the inverse loses for a recorded wrist pose.
#include "numen/hal/trocar_kinematics.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <stdexcept>

#include "alloc_counter.hpp"
#include "numen/hal/axis.hpp"

namespace {

using namespace numen::hal;
using numen::core::Pose;
using numen::core::Quat;
using numen::core::Vec3;
using numen::core::Vec6;
using numen::core::Wrench;
constexpr double kPi = std::numbers::pi;
using TK = TrocarKinematics;

Quat rot(double angle, const Vec3& axis) { return Quat(Eigen::AngleAxisd(angle, axis)); }

TrocarGeometry tilted_trocar() {
  TrocarGeometry g;
  g.point = Vec3(0.1, -0.2, 0.3);
  g.orientation =
      (rot(0.4, Vec3::UnitZ()) * rot(2.5, Vec3::UnitX())).normalized();  // shaft down-ish
  return g;
}

Pose some_offset() {
  Pose p;
  p.position = Vec3(0.01, -0.005, 0.02);
  p.orientation = rot(0.3, Vec3(1, 2, 3).normalized());
  return p;
}

AxisVector q_of(double a, double b, double d, double psi, double jaw) {
  AxisVector q(5);
  q << a, b, d, psi, jaw;
  return q;
}

double angle_between(const Quat& x, const Quat& y) { return x.angularDistance(y); }

// Angular velocity (world) taking orientation `from` to `to` over dt.
Vec3 omega(const Quat& from, const Quat& to, double dt) {
  const Eigen::AngleAxisd aa(to * from.conjugate());
  return aa.axis() * aa.angle() / dt;
}

TEST(TrocarKinematics, ZeroPivotsPutTheTipAlongTheTrocarAxis) {
  const TrocarGeometry g = tilted_trocar();
  const TK k(g);
  const Pose p = k.forward(q_of(0, 0, 0.12, 0, 0));
  EXPECT_TRUE(p.position.isApprox(g.point + 0.12 * (g.orientation * Vec3::UnitZ()), 1e-12));
  EXPECT_LT(angle_between(p.orientation, g.orientation), 1e-12);
}

TEST(TrocarKinematics, PivotsFollowTheDocumentedConvention) {
  const TK k(TrocarGeometry{});  // identity trocar at the origin
  // a about x: e_z -> (0, −sin a, cos a)
  Pose p = k.forward(q_of(0.3, 0, 1.0, 0, 0));
  EXPECT_TRUE(p.position.isApprox(Vec3(0, -std::sin(0.3), std::cos(0.3)), 1e-12));
  // b about the rotated y: e_z -> (sin b, −cos b sin a, cos b cos a)
  p = k.forward(q_of(0.3, 0.5, 1.0, 0, 0));
  EXPECT_TRUE(p.position.isApprox(
      Vec3(std::sin(0.5), -std::cos(0.5) * std::sin(0.3), std::cos(0.5) * std::cos(0.3)), 1e-12));
  // ψ rolls about the shaft: position unchanged, x axis turns about z.
  const Pose r = k.forward(q_of(0.3, 0.5, 1.0, 0.7, 0));
  EXPECT_TRUE(r.position.isApprox(p.position, 1e-12));
  EXPECT_TRUE((r.orientation * Vec3::UnitZ()).isApprox(p.orientation * Vec3::UnitZ(), 1e-12));
  EXPECT_NEAR(angle_between(r.orientation, p.orientation), 0.7, 1e-12);
  // The jaw does not move the rigid tool.
  const Pose j = k.forward(q_of(0.3, 0.5, 1.0, 0.7, 0.9));
  EXPECT_TRUE(j.position.isApprox(r.position, 1e-15));
}

TEST(TrocarKinematics, ToolOffsetIsAppliedInTheToolFrame) {
  const Pose off = some_offset();
  const TK k(tilted_trocar(), off);
  const AxisVector q = q_of(0.2, -0.1, 0.15, 0.4, 0.2);
  const Pose tool = k.tool_pose(q);
  const Pose c = k.forward(q);
  EXPECT_TRUE(c.position.isApprox(tool.position + tool.orientation * off.position, 1e-12));
  EXPECT_LT(angle_between(c.orientation, tool.orientation * off.orientation), 1e-12);
}

TEST(TrocarKinematics, InverseOfForwardIsTheIdentity) {
  const TK k(tilted_trocar(), some_offset());
  for (double a : {-1.0, -0.3, 0.0, 0.6, 1.2}) {
    for (double b : {-1.2, -0.2, 0.0, 0.5, 1.3}) {
      for (double psi : {-3.0, -1.0, 0.0, 2.0, kPi}) {
        const AxisVector q = q_of(a, b, 0.17, psi, 0.33);
        const AxisVector back = k.inverse(k.forward(q), q);
        ASSERT_EQ(back.size(), 5);
        EXPECT_NEAR(back[TK::kPivotX], a, 1e-9);
        EXPECT_NEAR(back[TK::kPivotY], b, 1e-9);
        EXPECT_NEAR(back[TK::kDepth], 0.17, 1e-12);
        EXPECT_NEAR(std::abs(axis_difference(back[TK::kRoll], psi, true)), 0.0, 1e-9);
        EXPECT_DOUBLE_EQ(back[TK::kJaw], 0.33);
      }
    }
  }
}

TEST(TrocarKinematics, ForwardOfInverseKeepsTheTipPositionAndRollButDropsTheWrist) {
  const TrocarGeometry g = tilted_trocar();
  const TK k(g);
  // A recorded tip: on a shaft (a, b) = (0.4, −0.3) with roll 0.8, then a wrist bend of 0.5 rad
  // about the tool's x axis (a swing, no twist).
  const AxisVector q = q_of(0.4, -0.3, 0.2, 0.8, 0.1);
  Pose recorded = k.tool_pose(q);
  recorded.orientation = recorded.orientation * rot(0.5, Vec3::UnitX());
  const AxisVector back = k.inverse_tool(recorded, 0.1);
  // Shaft from the position, not the bent orientation.
  EXPECT_NEAR(back[TK::kPivotX], 0.4, 1e-9);
  EXPECT_NEAR(back[TK::kPivotY], -0.3, 1e-9);
  EXPECT_NEAR(back[TK::kDepth], 0.2, 1e-12);
  EXPECT_NEAR(back[TK::kRoll], 0.8, 1e-9);  // twist survives the swing
  const Pose again = k.tool_pose(back);
  EXPECT_TRUE(again.position.isApprox(recorded.position, 1e-12));
  EXPECT_NEAR(angle_between(again.orientation, recorded.orientation), 0.5, 1e-9);  // wrist lost
}

TEST(TrocarKinematics, InverseAtTheTrocarPointUsesTheRecordedAxis) {
  const TrocarGeometry g = tilted_trocar();
  const TK k(g);
  Pose at_point;
  at_point.position = g.point;
  at_point.orientation = k.tool_pose(q_of(0.2, 0.1, 0.0, 0.3, 0)).orientation;
  const AxisVector q = k.inverse_tool(at_point, 0.0);
  EXPECT_NEAR(q[TK::kPivotX], 0.2, 1e-9);
  EXPECT_NEAR(q[TK::kPivotY], 0.1, 1e-9);
  EXPECT_EQ(q[TK::kDepth], 0.0);
  EXPECT_NEAR(q[TK::kRoll], 0.3, 1e-9);
}

class TrocarJacobian : public ::testing::TestWithParam<int> {};

AxisVector sample_q(int i) {
  const double s = 0.37 * i;
  return q_of(0.8 * std::sin(s + 0.1), 0.7 * std::cos(1.3 * s), 0.05 + 0.1 * (1 + std::sin(2 * s)),
              2.5 * std::sin(0.7 * s + 1.0), 0.4);
}

TEST_P(TrocarJacobian, MatchesCentralDifferencesOfForward) {
  const TK k(tilted_trocar(), some_offset());
  const AxisVector q = sample_q(GetParam());
  const Jacobian j = k.jacobian(q);
  ASSERT_EQ(j.rows(), 6);
  ASSERT_EQ(j.cols(), 5);
  const double h = 1e-6;
  for (int c = 0; c < 5; ++c) {
    AxisVector qp = q, qm = q;
    qp[c] += h;
    qm[c] -= h;
    const Pose pp = k.forward(qp), pm = k.forward(qm);
    const Vec3 v = (pp.position - pm.position) / (2 * h);
    const Vec3 w = omega(pm.orientation, pp.orientation, 2 * h);
    EXPECT_LT((j.col(c).head<3>() - v).norm(), 1e-7) << "column " << c;
    EXPECT_LT((j.col(c).tail<3>() - w).norm(), 1e-7) << "column " << c;
  }
  EXPECT_EQ(j.col(TK::kJaw).norm(), 0.0);
}

TEST_P(TrocarJacobian, TransposeMapsWrenchesByVirtualWork) {
  const TK k(tilted_trocar(), some_offset());
  const AxisVector q = sample_q(GetParam());
  Wrench w;
  w.force = Vec3(1.5, -2.0, 0.7);
  w.torque = Vec3(-0.1, 0.05, 0.2);
  const AxisVector tau = torques_from_wrench(k.jacobian(q), w);
  // For a small displacement δq, the work of W on the controlled frame's motion equals τᵀ δq.
  AxisVector dq(5);
  dq << 1e-6, -2e-6, 1.5e-6, 3e-6, 1e-6;
  const Pose p0 = k.forward(q), p1 = k.forward(q + dq);
  const Vec3 dx = p1.position - p0.position;
  const Eigen::AngleAxisd aa(p1.orientation * p0.orientation.conjugate());
  const Vec3 dtheta = aa.axis() * aa.angle();
  const double work = w.force.dot(dx) + w.torque.dot(dtheta);
  EXPECT_NEAR(work, tau.dot(dq), 1e-11);
  EXPECT_EQ(tau[TK::kJaw], 0.0);
}

INSTANTIATE_TEST_SUITE_P(Configurations, TrocarJacobian, ::testing::Range(0, 12));

TEST(TrocarKinematics, InsertionForceIsTheDepthTorque) {
  const TK k(tilted_trocar());
  const AxisVector q = q_of(0.3, -0.2, 0.1, 0.5, 0);
  Wrench w;
  const Vec3 shaft = k.tool_pose(q).orientation * Vec3::UnitZ();
  w.force = 3.0 * shaft;  // pushing the tip along the shaft
  const AxisVector tau = torques_from_wrench(k.jacobian(q), w);
  EXPECT_NEAR(tau[TK::kDepth], 3.0, 1e-12);
  EXPECT_NEAR(tau[TK::kRoll], 0.0, 1e-12);  // no offset: a force at the tip cannot roll it
  EXPECT_NEAR(tau[TK::kPivotX], 0.0, 1e-12);
  EXPECT_NEAR(tau[TK::kPivotY], 0.0, 1e-12);
}

TEST(TrocarKinematics, CallsDoNotAllocate) {
  const TK k(tilted_trocar(), some_offset());
  const AxisVector q = sample_q(3);
  numen::test::AllocationGuard guard;
  double sink = 0;
  for (int i = 0; i < 100; ++i) {
    const Pose p = k.forward(q);
    const Jacobian j = k.jacobian(q);
    const AxisVector back = k.inverse(p, q);
    Wrench w;
    w.force = Vec3(1, 2, 3);
    sink += torques_from_wrench(j, w).sum() + back.sum();
    sink += twist_from_rates(j, q).linear.x();
  }
  EXPECT_EQ(guard.count(), 0);
  EXPECT_TRUE(std::isfinite(sink));
}

TEST(TrocarKinematics, RejectsANonUnitQuaternion) {
  TrocarGeometry g;
  g.orientation = Quat(2, 0, 0, 0);
  EXPECT_THROW(TK k(g), std::invalid_argument);
  g = TrocarGeometry{};
  g.point.x() = std::nan("");
  EXPECT_THROW(TK k(g), std::invalid_argument);
}

}  // namespace
