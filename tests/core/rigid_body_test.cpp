// Tests of core/rigid_body: inertia, quaternion exponential/logarithm,
// orientation integration, gyroscopic terms (paper Eq. 1).
#include "numen/core/rigid_body.hpp"

#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "numen/core/data.hpp"
#include "numen/core/model.hpp"

namespace core = numen::core;
using core::Mat3;
using core::Quat;
using core::Vec3;

namespace {

Quat random_body_rotation(int seed) {
  // Deterministic, well-spread unit quaternions.
  const double a = 0.37 * seed + 0.1, b = 1.13 * seed + 0.2, c = 2.71 * seed + 0.3;
  Quat q(std::cos(a), std::sin(a) * std::cos(b), std::sin(a) * std::sin(b) * std::cos(c),
         std::sin(a) * std::sin(b) * std::sin(c));
  return q.normalized();
}

}  // namespace

TEST(RigidBody, SkewIsCrossProduct) {
  const Vec3 a(0.3, -1.2, 2.0), b(-0.7, 0.4, 1.1);
  EXPECT_TRUE((core::skew(a) * b).isApprox(a.cross(b), 1e-15));
  EXPECT_TRUE((core::skew(a) + core::skew(a).transpose()).isZero(0.0));
}

TEST(RigidBody, WorldInertiaRotatesTheBodyInertia) {
  Mat3 ib;
  ib << 0.02, 0.001, 0.0, 0.001, 0.03, -0.002, 0.0, -0.002, 0.05;
  for (int s = 0; s < 5; ++s) {
    const Quat q = random_body_rotation(s);
    const Mat3 iw = core::world_inertia(q, ib);
    // The angular momentum of a body-frame ω equals R (I_b ω_b).
    const Vec3 wb(0.4, -1.0, 2.0);
    EXPECT_TRUE((iw * (q * wb)).isApprox(q * (ib * wb), 1e-13));
    const Mat3 iw_inv = core::world_inertia_inverse(q, ib.inverse());
    EXPECT_TRUE((iw * iw_inv).isApprox(Mat3::Identity(), 1e-12));
  }
}

TEST(RigidBody, QuatExpMatchesAngleAxisIncludingTinyAndLargeAngles) {
  const Vec3 axis = Vec3(1.0, -2.0, 0.5).normalized();
  for (double angle : {0.0, 1e-12, 1e-7, 9.9e-5, 1.01e-4, 0.3, 2.0, 3.0, 3.2, 6.0}) {
    const Quat q = core::quat_exp(angle * axis);
    const Quat ref(Eigen::AngleAxisd(angle, axis));
    EXPECT_NEAR(q.w(), ref.w(), 1e-15) << angle;
    EXPECT_TRUE(q.vec().isApprox(ref.vec(), 1e-14) || (q.vec() - ref.vec()).norm() < 1e-20)
        << angle;
    EXPECT_NEAR(q.norm(), 1.0, 1e-15);
  }
}

TEST(RigidBody, QuatLogInvertsExpOnTheShortestArc) {
  const Vec3 axis = Vec3(0.2, 0.9, -0.4).normalized();
  for (double angle : {0.0, 1e-10, 1e-6, 0.5, 2.5, std::numbers::pi - 1e-9}) {
    const Vec3 phi = angle * axis;
    EXPECT_TRUE((core::quat_log(core::quat_exp(phi)) - phi).norm() < 1e-14 * (1.0 + angle))
        << angle;
    // −q is the same rotation.
    const Quat q = core::quat_exp(phi);
    const Quat mq(-q.w(), -q.x(), -q.y(), -q.z());
    EXPECT_TRUE((core::quat_log(mq) - phi).norm() < 1e-14 * (1.0 + angle)) << angle;
  }
  // Beyond π the log returns the complementary rotation about −axis.
  const double angle = std::numbers::pi + 0.25;
  const Vec3 log = core::quat_log(core::quat_exp(angle * axis));
  EXPECT_TRUE(log.isApprox(-(2.0 * std::numbers::pi - angle) * axis, 1e-13));
}

TEST(RigidBody, OrientationIntegrationIsExactForConstantAngularVelocity) {
  // The exact exponential accumulates no error for a constant ω; the first
  // order update q += ½ h ω q followed by normalisation would lag in angle.
  const Vec3 axis = Vec3(1.0, 1.0, 0.0).normalized();
  const double rate = 30.0, h = 1e-3;
  const int n = 1000;
  Quat q = random_body_rotation(3);
  const Quat q0 = q;
  Quat q_first = q;
  for (int i = 0; i < n; ++i) {
    q = core::integrate_orientation(q, rate * axis, h);
    const Vec3 w = rate * axis;
    Quat dq(0.0, 0.5 * h * w.x(), 0.5 * h * w.y(), 0.5 * h * w.z());
    dq = dq * q_first;
    q_first.coeffs() += dq.coeffs();
    q_first.normalize();
  }
  const Quat ref = Quat(Eigen::AngleAxisd(rate * h * n, axis)) * q0;
  const double err = q.angularDistance(ref);
  const double err_first = q_first.angularDistance(ref);
  EXPECT_LT(err, 1e-12);
  EXPECT_GT(err_first, 1e3 * err + 1e-9);  // the test can tell the two apart
  EXPECT_NEAR(q.norm(), 1.0, 1e-15);
}

TEST(RigidBody, ImplicitGyroscopicStepConsistentWithExplicitForSmallSteps) {
  Mat3 ib = Vec3(0.01, 0.02, 0.03).asDiagonal();
  const Quat q = random_body_rotation(7);
  const Vec3 w(3.0, -1.0, 2.0);
  const Mat3 iw = core::world_inertia(q, ib);
  const Vec3 alpha = iw.inverse() * core::gyroscopic_torque(iw, w);
  double prev = 0.0;
  for (double h : {1e-3, 5e-4}) {
    const Vec3 w1 = core::implicit_gyroscopic_velocity(q, ib, w, h);
    const double err = ((w1 - w) / h - alpha).norm();
    EXPECT_LT(err, 0.05 * alpha.norm());
    if (prev > 0.0) {
      EXPECT_NEAR(prev / err, 2.0, 0.2);  // O(h) difference
    }
    prev = err;
  }
}

TEST(RigidBody, ImplicitGyroscopicStepLeavesPrincipalSpinsAndSymmetricBodiesAlone) {
  const Mat3 ib = Vec3(0.01, 0.02, 0.03).asDiagonal();
  const Quat q = random_body_rotation(2);
  const Vec3 w = q * Vec3(0.0, 0.0, 50.0);  // about a principal axis
  EXPECT_TRUE((core::implicit_gyroscopic_velocity(q, ib, w, 1e-2) - w).norm() < 1e-12);
  const Mat3 iso = 0.02 * Mat3::Identity();
  const Vec3 w2(3.0, -4.0, 12.0);
  EXPECT_TRUE((core::implicit_gyroscopic_velocity(q, iso, w2, 1e-2) - w2).norm() < 1e-12);
}

TEST(RigidBody, ExternalForcesAreGravityPlusAppliedWrench) {
  core::Model m;
  m.gravity = Vec3(0.0, 0.0, -9.81);
  m.material_pairs = {core::MaterialPair{}};
  core::BodyModel b;
  b.mass = 2.5;
  m.bodies = {b, b};
  m.bodies[1].mass = 0.5;
  ASSERT_EQ(core::finalize_model(m), "");
  core::Data d = core::make_data(m);
  d.applied_wrench[1].force = Vec3(1.0, 2.0, 3.0);
  d.applied_wrench[1].torque = Vec3(-1.0, 0.0, 0.5);
  d.body_wrench[0].force = Vec3(100.0, 0.0, 0.0);  // stale values are overwritten
  core::apply_external_forces(m, d);
  EXPECT_TRUE(d.body_wrench[0].force.isApprox(2.5 * m.gravity));
  EXPECT_TRUE(d.body_wrench[0].torque.isZero(0.0));
  EXPECT_TRUE(d.body_wrench[1].force.isApprox(0.5 * m.gravity + Vec3(1.0, 2.0, 3.0)));
  EXPECT_TRUE(d.body_wrench[1].torque.isApprox(Vec3(-1.0, 0.0, 0.5)));
}

TEST(RigidBody, KineticEnergyAndFiniteness) {
  core::BodyModel b;
  b.mass = 2.0;
  b.inertia_body = Vec3(1.0, 2.0, 3.0).asDiagonal();
  core::BodyState s;
  s.linear_velocity = Vec3(1.0, 0.0, 0.0);
  s.angular_velocity = Vec3(0.0, 0.0, 2.0);
  EXPECT_DOUBLE_EQ(core::kinetic_energy(b, s), 0.5 * 2.0 * 1.0 + 0.5 * 3.0 * 4.0);
  EXPECT_TRUE(core::state_is_finite(s));
  s.orientation.x() = std::nan("");
  EXPECT_FALSE(core::state_is_finite(s));
}
