// Tests of numen/hal/device/trocar_kinematics.hpp: geometry, round trips, Jacobian against finite
// differences, virtual work τ = Jᵀ W, what the inverse loses for a recorded wrist pose, and
// the links (trocar sleeve, tube, jaws): poses, Jacobians, τ = Σ_l J_lᵀ w_l.
#include "numen/hal/device/trocar_kinematics.hpp"

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
using numen::core::Wrench;
using numen::test::kPi;
using TK = TrocarKinematics;

using numen::test::rot;

TrocarGeometry tilted_trocar() {
  TrocarGeometry g;
  g.point = Vec3(0.1, -0.2, 0.3);
  g.orientation =
      (rot(0.4, Vec3::UnitZ()) * rot(2.5, Vec3::UnitX())).normalized();  // shaft down-ish
  return g;
}

Pose trocar_offset() {
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

TEST(TrocarKinematics, ZeroPivotsPutTheTipAlongTheTrocarAxis) {
  const TrocarGeometry g = tilted_trocar();
  const TK k(g);
  const Pose p = k.forward(q_of(0, 0, 0.12, 0, 0));
  EXPECT_TRUE(p.position.isApprox(g.point + 0.12 * (g.orientation * Vec3::UnitZ()), 1e-12));
  EXPECT_LT(p.orientation.angularDistance(g.orientation), 1e-12);
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
  EXPECT_NEAR(r.orientation.angularDistance(p.orientation), 0.7, 1e-12);
  // The jaw does not move the rigid tool.
  const Pose j = k.forward(q_of(0.3, 0.5, 1.0, 0.7, 0.9));
  EXPECT_TRUE(j.position.isApprox(r.position, 1e-15));
}

TEST(TrocarKinematics, ToolOffsetIsAppliedInTheToolFrame) {
  const Pose off = trocar_offset();
  const TK k(tilted_trocar(), off);
  const AxisVector q = q_of(0.2, -0.1, 0.15, 0.4, 0.2);
  numen::test::expect_offset_applied(k.tool_pose(q), off, k.forward(q));
}

TEST(TrocarKinematics, InverseOfForwardIsTheIdentity) {
  const TK k(tilted_trocar(), trocar_offset());
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
  EXPECT_NEAR(again.orientation.angularDistance(recorded.orientation), 0.5,
              1e-9);  // wrist lost
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
  const TK k(tilted_trocar(), trocar_offset());
  const AxisVector q = sample_q(GetParam());
  ASSERT_EQ(k.jacobian(q).cols(), 5);
  numen::test::expect_jacobian_matches_central_differences(k, q, 1e-7);
  EXPECT_EQ(k.jacobian(q).col(TK::kJaw).norm(), 0.0);
}

TEST_P(TrocarJacobian, TransposeMapsWrenchesByVirtualWork) {
  const TK k(tilted_trocar(), trocar_offset());
  const AxisVector q = sample_q(GetParam());
  Wrench w;
  w.force = Vec3(1.5, -2.0, 0.7);
  w.torque = Vec3(-0.1, 0.05, 0.2);
  // For a small displacement δq, the work of W on the controlled frame's motion equals τᵀ δq.
  AxisVector dq(5);
  dq << 1e-6, -2e-6, 1.5e-6, 3e-6, 1e-6;
  const AxisVector tau = numen::test::expect_virtual_work(k, q, w, dq, 1e-11);
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
  const TK k(tilted_trocar(), trocar_offset());
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

// ---- Links: trocar sleeve, tube, two jaws (paper §5; Kinematics link API) ----

using numen::test::uniform;

// Random configuration within the mechanism's useful range (away from d = 0).
AxisVector random_trocar_q(numen::hal::SplitMix64& rng) {
  return q_of(uniform(rng, -1.2, 1.2), uniform(rng, -1.2, 1.2), uniform(rng, 0.02, 0.3),
              uniform(rng, -kPi, kPi), uniform(rng, 0.0, 1.2));
}

TEST(TrocarLinks, NamesAndLookup) {
  const TK k(tilted_trocar());
  const char* const names[] = {"tool", "trocar", "tube", "jaw_1", "jaw_2"};
  numen::test::expect_link_names(k, names);
  EXPECT_EQ(k.find_link("jaw"), -1);
}

TEST(TrocarLinks, LinkZeroIsTheControlledFrame) {
  const TK k(tilted_trocar(), trocar_offset());
  static_assert(TK::kLinkTool == 0);
  numen::hal::SplitMix64 rng(11);
  for (int trial = 0; trial < 20; ++trial)
    numen::test::expect_link_zero_is_the_controlled_frame(k, random_trocar_q(rng));
}

TEST(TrocarLinks, FramesFollowTheDocumentedGeometry) {
  const TrocarGeometry g = tilted_trocar();
  const TK k(g, trocar_offset());
  const AxisVector q = q_of(0.3, -0.4, 0.15, 0.7, 0.6);
  const Quat swing = g.orientation * rot(0.3, Vec3::UnitX()) * rot(-0.4, Vec3::UnitY());
  // Sleeve: at the trocar point, no roll, z along the shaft.
  const Pose sleeve = k.link_pose(TK::kLinkTrocar, q);
  EXPECT_EQ(sleeve.position, g.point);
  EXPECT_LT(sleeve.orientation.angularDistance(swing), 1e-12);
  // Tube == tool_pose (tip, with roll).
  const Pose tube = k.link_pose(TK::kLinkTube, q);
  const Pose tool = k.tool_pose(q);
  EXPECT_TRUE(tube.position.isApprox(tool.position, 1e-15));
  EXPECT_LT(tube.orientation.angularDistance(tool.orientation), 1e-15);
  EXPECT_TRUE(tube.position.isApprox(g.point + 0.15 * (sleeve.orientation * Vec3::UnitZ()), 1e-12));
  // Jaws: at the tip, ±jaw/2 about the tube's x axis, so 0.6 rad apart.
  const Pose j1 = k.link_pose(TK::kLinkJaw1, q);
  const Pose j2 = k.link_pose(TK::kLinkJaw2, q);
  EXPECT_EQ(j1.position, tube.position);
  EXPECT_EQ(j2.position, tube.position);
  EXPECT_LT(j1.orientation.angularDistance(tube.orientation * rot(0.3, Vec3::UnitX())), 1e-12);
  EXPECT_LT(j2.orientation.angularDistance(tube.orientation * rot(-0.3, Vec3::UnitX())), 1e-12);
  EXPECT_NEAR(j1.orientation.angularDistance(j2.orientation), 0.6, 1e-12);
  // Both jaws keep the tube's x axis (the hinge) and open symmetrically about the shaft.
  const Vec3 x_t = tube.orientation * Vec3::UnitX();
  EXPECT_TRUE((j1.orientation * Vec3::UnitX()).isApprox(x_t, 1e-12));
  const Vec3 z1 = j1.orientation * Vec3::UnitZ();
  const Vec3 z2 = j2.orientation * Vec3::UnitZ();
  EXPECT_TRUE((z1 + z2).normalized().isApprox(tube.orientation * Vec3::UnitZ(), 1e-12));
  // jaw = 0: both jaws are the tube.
  const AxisVector closed = q_of(0.3, -0.4, 0.15, 0.7, 0.0);
  EXPECT_LT(k.link_pose(TK::kLinkJaw1, closed)
                .orientation.angularDistance(k.link_pose(TK::kLinkTube, closed).orientation),
            1e-15);
  // An index out of range gives link 0.
  EXPECT_EQ(k.link_pose(7, q).position, k.forward(q).position);
}

TEST(TrocarLinks, EveryLinkJacobianMatchesCentralDifferencesOfItsPose) {
  const TK k(tilted_trocar(), trocar_offset());
  numen::hal::SplitMix64 rng(2024);
  for (int trial = 0; trial < 25; ++trial) {
    SCOPED_TRACE("trial " + std::to_string(trial));
    numen::test::expect_link_jacobians_match_central_differences(k, random_trocar_q(rng), 1e-6);
  }
}

TEST(TrocarLinks, JacobianColumnsHaveTheDocumentedStructure) {
  const TK k(tilted_trocar(), trocar_offset());
  const AxisVector q = q_of(0.2, 0.5, 0.12, -1.0, 0.8);
  // Sleeve: pure rotation about p_c by the pivots only.
  const Jacobian sleeve = k.link_jacobian(TK::kLinkTrocar, q);
  EXPECT_EQ(sleeve.topRows<3>().norm(), 0.0);
  EXPECT_EQ(sleeve.col(TK::kDepth).norm(), 0.0);
  EXPECT_EQ(sleeve.col(TK::kRoll).norm(), 0.0);
  EXPECT_GT(sleeve.col(TK::kPivotX).norm(), 0.5);
  // Tube: the jaw does nothing; jaws: the jaw turns them by ±½ x_tube.
  const Jacobian tube = k.link_jacobian(TK::kLinkTube, q);
  EXPECT_EQ(tube.col(TK::kJaw).norm(), 0.0);
  const Vec3 x_t = k.tool_pose(q).orientation * Vec3::UnitX();
  const Jacobian j1 = k.link_jacobian(TK::kLinkJaw1, q);
  const Jacobian j2 = k.link_jacobian(TK::kLinkJaw2, q);
  EXPECT_TRUE(j1.col(TK::kJaw).tail<3>().isApprox(0.5 * x_t, 1e-12));
  EXPECT_TRUE(j2.col(TK::kJaw).tail<3>().isApprox(-0.5 * x_t, 1e-12));
  EXPECT_EQ(j1.col(TK::kJaw).head<3>().norm(), 0.0);
  EXPECT_EQ((j1.leftCols<4>() - tube.leftCols<4>()).norm(), 0.0);
}

TEST(TrocarLinks, TransposeMapsLinkWrenchesByVirtualWork) {
  // Σ_l w_l · δx_l (δx_l from link_pose only) == τ · δq with τ = Σ_l J_lᵀ w_l, to O(|δq|²).
  const TK k(tilted_trocar(), trocar_offset());
  numen::hal::SplitMix64 rng(77);
  for (int trial = 0; trial < 50; ++trial) {
    SCOPED_TRACE("trial " + std::to_string(trial));
    const AxisVector q = random_trocar_q(rng);
    const numen::test::LinkWorkTrial t = numen::test::expect_link_virtual_work(k, q, rng, 2.0);
    // The jaw axis carries the jaws' torques about the hinge: τ_jaw = ½ x_t · (t_3 − t_4).
    const Vec3 x_t = k.tool_pose(q).orientation * Vec3::UnitX();
    EXPECT_NEAR(t.tau[TK::kJaw], 0.5 * x_t.dot(t.w[3].torque - t.w[4].torque), 1e-12);
  }
}

TEST(TrocarLinks, LinkCallsDoNotAllocate) {
  const TK k(tilted_trocar(), trocar_offset());
  const AxisVector q = sample_q(5);
  numen::test::AllocationGuard guard;
  double sink = 0;
  for (int i = 0; i < 100; ++i) sink += numen::test::link_calls_sum(k, q) + k.find_link("jaw_2");
  EXPECT_EQ(guard.count(), 0);
  EXPECT_TRUE(std::isfinite(sink));
}

}  // namespace
