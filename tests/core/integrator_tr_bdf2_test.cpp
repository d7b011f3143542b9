// Tests of core/integrator_tr_bdf2: the linearised TR-BDF2 against the method's own closed
// form on the linear oscillator, L-stability (amplification → 0 as h ω → ∞), energy on stiff
// couplings, exact free fall, first-order coupling (stiffly accurate), unit quaternions,
// contacts, and allocation-free steps.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdio>
#include <vector>

#include "alloc_counter.hpp"
#include "numen/core/coupling.hpp"
#include "numen/core/data.hpp"
#include "numen/core/integrator.hpp"
#include "numen/core/model.hpp"
#include "numen/core/rigid_body.hpp"
#include "numen/core/step.hpp"

#include "solver/implicit_system.hpp"

namespace core = numen::core;
using core::Mat3;
using core::Quat;
using core::Vec3;

namespace {

core::Model one_body(core::Integrator integ, double dt, double mass, double inertia,
                     core::CouplingGains gains) {
  core::Model m;
  m.dt = dt;
  m.gravity = Vec3::Zero();
  m.integrator = integ;
  m.material_pairs = {core::MaterialPair{}};
  core::BodyModel b;
  b.mass = mass;
  b.inertia_body = inertia * Mat3::Identity();
  b.coupling = gains;
  m.bodies = {b};
  m.initial_held_body = 0;
  EXPECT_EQ(core::finalize_model(m), "");
  return m;
}

/// TR-BDF2's stability function R(z), z = h λ (Hosea & Shampine 1996, γ = 2 − √2): the trapezoidal
/// stage (1 + w)/(1 − w), then BDF2, w = h_s λ = z γ/2.
std::complex<double> stability_function(std::complex<double> z) {
  const double a = core::tr_bdf2::kStageWeight;
  const std::complex<double> w = core::tr_bdf2::kStageStep * z;
  const std::complex<double> stage = (1.0 + w) / (1.0 - w);
  return (a * stage - (a - 1.0)) / (1.0 - w);
}

}  // namespace

TEST(TrBdf2, StageConstantsAreThoseOfGammaTwoMinusRootTwo) {
  const double g = 2.0 - std::sqrt(2.0);
  EXPECT_NEAR(core::tr_bdf2::kGamma, g, 2e-16);
  EXPECT_NEAR(core::tr_bdf2::kStageStep, 0.5 * g, 2e-16);
  EXPECT_NEAR(core::tr_bdf2::kStageStep, (1.0 - g) / (2.0 - g), 2e-16);  // one matrix, two stages
  EXPECT_NEAR(core::tr_bdf2::kStageWeight, 1.0 / (g * (2.0 - g)), 1e-15);
  core::Model m = one_body(core::Integrator::kTrBdf2, 1e-3, 1.0, 1.0, {});
  EXPECT_DOUBLE_EQ(core::linearized_system_step(m), core::tr_bdf2::kStageStep * 1e-3);
}

TEST(TrBdf2, StepIsTrBdf2OnTheLinearOscillator) {
  // Linear forces: the linearised scheme is TR-BDF2 itself. With y = (x, v) and
  // J = [[0, 1], [−k/m, −γ/m]]: (I − h_s J) y_γ = (I + h_s J) y0, then
  // (I − h_s J) y1 = a y_γ − (a − 1) y0.
  const double m = 0.3, k = 250.0, gamma = 1.7, h = 2e-3;
  const core::Model model =
      one_body(core::Integrator::kTrBdf2, h, m, 0.01, {k, gamma, 0.0, 0.0});
  core::Data d = core::make_data(model);
  d.target = core::Pose{};
  Eigen::Vector2d y(0.04, -0.3);
  d.bodies[0].position.x() = y(0);
  d.bodies[0].linear_velocity.x() = y(1);
  Eigen::Matrix2d j;
  j << 0.0, 1.0, -k / m, -gamma / m;
  const double hs = core::tr_bdf2::kStageStep * h, a = core::tr_bdf2::kStageWeight;
  const Eigen::Matrix2d lhs_inverse = (Eigen::Matrix2d::Identity() - hs * j).inverse();
  for (int i = 0; i < 500; ++i) {
    core::step(model, d);
    ASSERT_EQ(d.status, core::kStepOk);
    const Eigen::Vector2d yg = lhs_inverse * ((Eigen::Matrix2d::Identity() + hs * j) * y);
    y = lhs_inverse * (a * yg - (a - 1.0) * y);
    ASSERT_NEAR(d.bodies[0].position.x(), y(0), 1e-13) << i;
    ASSERT_NEAR(d.bodies[0].linear_velocity.x(), y(1), 1e-11) << i;
    ASSERT_EQ(d.bodies[0].position.y(), 0.0);
  }
}

TEST(TrBdf2, AmplificationTendsToZeroAsTheStepOutrunsTheMode) {
  // Undamped oscillator, energy norm (√k x, √m v): J is skew there, so one step multiplies the
  // norm by at most |R(i ω h)| and the state (x0, 0) by exactly the norm of R(hJ) applied to it.
  // L-stability: |R(i ω h)| ~ (2a − 1)/(h_s ω h) → 0; the trapezoidal rule keeps |R| = 1.
  const double m = 0.01, h = 1e-3;
  double prev = 1.0;
  for (double wh : {1.0, 10.0, 100.0, 1e3, 1e4}) {
    const double k = m * (wh / h) * (wh / h);
    const core::Model model = one_body(core::Integrator::kTrBdf2, h, m, 1e-6, {k, 0.0, 0.0, 0.0});
    core::Data d = core::make_data(model);
    d.target = core::Pose{};
    d.bodies[0].position = Vec3(1e-3, 0.0, 0.0);
    const auto norm = [&] {
      return std::sqrt(k * d.bodies[0].position.squaredNorm() +
                       m * d.bodies[0].linear_velocity.squaredNorm());
    };
    const double n0 = norm();
    double amplification = 0.0;
    for (int i = 0; i < 4; ++i) {  // the worst single step over a few
      const double before = norm();
      core::step(model, d);
      ASSERT_EQ(d.status, core::kStepOk);
      amplification = std::max(amplification, norm() / before);
    }
    const double r = std::abs(stability_function({0.0, wh}));
    std::printf("[tr-bdf2 L-stability] omega h %.0e: measured %.4e, |R(i omega h)| %.4e, after 4 "
                "steps %.3e\n",
                wh, amplification, r, norm() / n0);
    EXPECT_LE(amplification, r * (1.0 + 1e-9)) << wh;
    EXPECT_LE(r, prev) << wh;
    if (wh >= 100.0) {
      EXPECT_LT(r, 5.0 / wh) << wh;  // (2a − 1)/(h_s/h) = 4.83
    }
    prev = r;
  }
  EXPECT_LT(prev, 1e-3);
}

TEST(TrBdf2, EnergyNeverGrowsOnAStiffCoupling) {
  // k = 1e7 N/m on m = 0.01 kg at h = 1 ms (ω h = 31.6): translation and rotation, damped
  // (ζ = 0.7) and undamped. Energy ½ m v² + ½ k x² (+ rotation) never grows and is gone
  // within a few steps (the trapezoidal rule keeps 0.92 of it per step, damped).
  for (double zeta : {0.7, 0.0}) {
    const double m = 0.01, k = 1e7, gamma = core::damping_from_ratio(zeta, m, k);
    const double k_r = 1e3, i0 = 1e-6, gamma_r = core::damping_from_ratio(zeta, i0, k_r);
    const core::Model model =
        one_body(core::Integrator::kTrBdf2, 1e-3, m, i0, {k, gamma, k_r, gamma_r});
    core::Data d = core::make_data(model);
    d.bodies[0].position = Vec3(0.01, -0.02, 0.005);
    d.bodies[0].orientation = Quat(Eigen::AngleAxisd(0.05, Vec3(1, 1, 0).normalized()));
    const auto energy = [&]() {
      const core::BodyState& b = d.bodies[0];
      const double th = core::rotation_error(Quat::Identity(), b.orientation).norm();
      return 0.5 * m * b.linear_velocity.squaredNorm() + 0.5 * k * b.position.squaredNorm() +
             0.5 * i0 * b.angular_velocity.squaredNorm() + 0.5 * k_r * th * th;
    };
    const double e0 = energy();
    double e_prev = e0;
    for (int i = 0; i < 300; ++i) {
      core::step(model, d);
      ASSERT_EQ(d.status, core::kStepOk) << i;
      const double e = energy();
      ASSERT_LE(e, e_prev + 1e-9 * e0) << "zeta " << zeta << " step " << i;
      e_prev = e;
    }
    std::printf("[tr-bdf2 stiff coupling] zeta %.1f: E/E0 after 300 steps %.3e\n", zeta,
                e_prev / e0);
    EXPECT_LT(e_prev, 1e-6 * e0) << zeta;
  }
}

TEST(TrBdf2, FreeFallIsExact) {
  // Second order and exact on quadratics: x = −g t²/2 with no O(h) term.
  core::Model m = one_body(core::Integrator::kTrBdf2, 1e-3, 2.0, 0.01, {});
  m.gravity = Vec3(0.0, 0.0, -9.81);
  m.initial_held_body = -1;
  core::Data d = core::make_data(m);
  for (int i = 0; i < 1000; ++i) core::step(m, d);
  EXPECT_NEAR(d.bodies[0].linear_velocity.z(), -9.81, 1e-10);
  EXPECT_NEAR(d.bodies[0].position.z(), -0.5 * 9.81, 1e-10);
}

TEST(TrBdf2, FirstOrderCouplingApproachesTheTargetWithoutAlternating) {
  // The massless body's twist is an algebraic unknown. TR-BDF2 is stiffly accurate (its last
  // stage is BDF2's): the twist follows γ v = k e, so the offset decays monotonically at the
  // rate k/γ, where the trapezoidal rule (refused for this mode) would flip the twist's sign
  // every step. x' = −(k/γ) x is linear: x_n = R(−h k/γ)ⁿ x0 exactly, and close to e^{−k t/γ}.
  core::Model m = one_body(core::Integrator::kTrBdf2, 1e-3, 0.2, 1e-3, {1e3, 5.0, 1.0, 0.05});
  m.coupling_mode = core::CouplingMode::kFirstOrder;
  ASSERT_EQ(core::finalize_model(m), "");
  core::Data d = core::make_data(m);
  d.target = core::Pose{};
  d.bodies[0].position = Vec3(0.01, 0.0, 0.0);
  double x_prev = 0.01;
  const int n = 20;  // 0.02 s, k t / γ = 4
  for (int i = 0; i < n; ++i) {
    core::step(m, d);
    ASSERT_EQ(d.status, core::kStepOk);
    const double x = d.bodies[0].position.x();
    ASSERT_GT(x, 0.0) << i;
    ASSERT_LT(x, x_prev) << i;
    ASSERT_LT(d.bodies[0].linear_velocity.x(), 0.0) << i;  // never reversed
    x_prev = x;
  }
  const double scheme = 0.01 * std::pow(stability_function({-1e-3 * 1e3 / 5.0, 0.0}).real(), n);
  EXPECT_NEAR(x_prev, scheme, 1e-9 * scheme);
  const double exact = 0.01 * std::exp(-1e3 / 5.0 * 1e-3 * n);
  EXPECT_NEAR(x_prev, exact, 0.01 * exact);
}

TEST(TrBdf2, OrientationStaysUnitWhileSpinningOnACoupling) {
  const Mat3 ib = Vec3(0.02, 0.03, 0.04).asDiagonal();
  core::Model m = one_body(core::Integrator::kTrBdf2, 1e-3, 1.0, 1.0, {100.0, 5.0, 0.5, 0.01});
  m.bodies[0].inertia_body = ib;
  ASSERT_EQ(core::finalize_model(m), "");
  core::Data d = core::make_data(m);
  d.bodies[0].angular_velocity = Vec3(30.0, -20.0, 50.0);
  double worst = 0.0;
  for (int i = 0; i < 5000; ++i) {
    core::step(m, d);
    ASSERT_EQ(d.status, core::kStepOk);
    worst = std::max(worst, std::abs(d.bodies[0].orientation.norm() - 1.0));
  }
  EXPECT_LT(worst, 1e-14);
}

TEST(TrBdf2, BodyRestsOnAPlaneWhereTheContactCarriesItsWeight) {
  // A 10 mm sphere of 0.1 kg dropped on the plane z = 0 (k = 2e4 N/m, c = 10 N·s/m) comes to
  // rest at depth m g / k; 1000 steps with contacts do not allocate.
  core::Model m = one_body(core::Integrator::kTrBdf2, 1e-3, 0.1, 4e-6, {});
  m.gravity = Vec3(0.0, 0.0, -9.81);
  m.initial_held_body = -1;
  m.material_pairs = {core::MaterialPair{2e4, 10.0, 0.5}};
  m.body_spheres = {core::Sphere{Vec3::Zero(), 0.01}};
  m.bodies[0].sphere_begin = 0;
  m.bodies[0].sphere_count = 1;
  core::Obstacle plane;
  plane.type = core::ShapeType::kPlane;
  m.obstacles = {plane};
  m.bodies[0].initial_pose.position = Vec3(0.0, 0.0, 0.012);
  ASSERT_EQ(core::finalize_model(m), "");
  core::Data d = core::make_data(m);
  {
    numen::test::AllocationGuard guard;
    for (int i = 0; i < 1000; ++i) core::step(m, d);
    EXPECT_EQ(guard.count(), 0);
  }
  EXPECT_EQ(d.status, core::kStepOk);
  EXPECT_EQ(d.num_contacts, 1);
  EXPECT_NEAR(d.bodies[0].position.z(), 0.01 - 0.1 * 9.81 / 2e4, 1e-9);
  EXPECT_NEAR(d.bodies[0].linear_velocity.norm(), 0.0, 1e-9);
}

TEST(TrBdf2, CoupledStepDoesNotAllocate) {
  core::Model m = one_body(core::Integrator::kTrBdf2, 1e-3, 0.2, 1e-3, {1e3, 5.0, 1.0, 0.05});
  core::Data d = core::make_data(m);
  d.target.position = Vec3(0.01, 0.0, 0.0);
  numen::test::AllocationGuard guard;
  for (int i = 0; i < 1000; ++i) core::step(m, d);
  EXPECT_EQ(guard.count(), 0);
  EXPECT_EQ(d.status, core::kStepOk);
}

namespace {

/// Positions every 10 ms over 1 s of the accuracy study's wall (docs/accuracy.md) without
/// friction: a 10 mm, 0.1 kg sphere on its coupling spring (200 N/m, ζ 0.85) pulled along a
/// quintic path 20 mm into the plane z = 0 (2e4 N/m, 10 N·s/m, onset δ0), inputs at t + h/2.
std::vector<Vec3> frictionless_wall(double dt, double onset) {
  core::Model m = one_body(core::Integrator::kTrBdf2, dt, 0.1, 4e-6, {});
  m.bodies[0].coupling = {200.0, core::damping_from_ratio(0.85, 0.1, 200.0), 1e-3,
                          core::damping_from_ratio(0.85, 4e-6, 1e-3)};
  m.material_pairs = {core::MaterialPair{2e4, 10.0, 0.0, onset}};
  m.body_spheres = {core::Sphere{Vec3::Zero(), 0.01}};
  m.bodies[0].sphere_begin = 0;
  m.bodies[0].sphere_count = 1;
  const Vec3 from(0.0, 0.0, 0.02), to(0.03, 0.0, -0.01);
  m.bodies[0].initial_pose.position = from;
  core::Obstacle plane;
  plane.type = core::ShapeType::kPlane;
  m.obstacles = {plane};
  EXPECT_EQ(core::finalize_model(m), "");
  core::Data d = core::make_data(m);
  std::vector<Vec3> out;
  const long n = std::lround(1.0 / dt), every = std::lround(0.01 / dt);
  for (long k = 0; k < n; ++k) {
    const double tau = std::clamp((k + 0.5) * dt / 0.6, 0.0, 1.0);
    const double s = tau * tau * tau * (10.0 - 15.0 * tau + 6.0 * tau * tau);
    const double ds = 30.0 * tau * tau * (1.0 - tau) * (1.0 - tau) / 0.6;
    d.target.position = from + s * (to - from);
    d.target_twist.linear = ds * (to - from);
    core::step(m, d);
    EXPECT_EQ(d.status, core::kStepOk);
    if ((k + 1) % every == 0) out.push_back(d.bodies[0].position);
  }
  return out;
}

}  // namespace

TEST(TrBdf2, SmoothedContactOnsetGivesSecondOrderOnAFrictionlessWall) {
  // With the smoothed C¹ onset (δ0 = 0.1 mm) the contact's force is C¹ and its Jacobian exact
  // (no friction: the faded friction's depth derivative, a non-symmetric term, is not in K),
  // so the error falls 4× per halving of h; against a run at h/16 of the finest step.
  const std::vector<Vec3> ref = frictionless_wall(1.25e-5, 1e-4);
  std::vector<double> err;
  for (double h : {2e-4, 1e-4, 5e-5}) {
    const std::vector<Vec3> run = frictionless_wall(h, 1e-4);
    double e = 0.0;
    for (std::size_t i = 0; i < run.size(); ++i) e = std::max(e, (run[i] - ref[i]).norm());
    err.push_back(e);
  }
  std::printf("[tr-bdf2 frictionless wall, smoothed onset] error at 0.2, 0.1, 0.05 ms: %.3e %.3e "
              "%.3e mm, ratios %.2f %.2f\n",
              1e3 * err[0], 1e3 * err[1], 1e3 * err[2], err[0] / err[1], err[1] / err[2]);
  EXPECT_NEAR(err[0] / err[1], 4.0, 0.6);
  EXPECT_NEAR(err[1] / err[2], 4.0, 0.6);
}
