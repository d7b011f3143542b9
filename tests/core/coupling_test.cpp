// Tests of core/coupling: the rotation error on the shortest arc, the Eq. 2
// wrench, and the coupling modes (god-object, first order, direct).
#include "numen/core/coupling.hpp"

#include <cmath>
#include <limits>
#include <numbers>

#include <gtest/gtest.h>

#include "numen/core/contact_force.hpp"
#include "numen/core/data.hpp"
#include "numen/core/integrator.hpp"
#include "numen/core/model.hpp"
#include "numen/core/rigid_body.hpp"
#include "numen/core/step.hpp"
#include "alloc_counter.hpp"

#include "scratch/data_scratch.hpp"
#include "rotation.hpp"
#include "test_constants.hpp"

namespace core = numen::core;
using core::Mat3;
using core::Quat;
using core::Vec3;

namespace {

using numen::test::kPi;
using numen::test::rot;

core::Model coupled_model(core::Integrator integrator, core::CouplingMode mode, double dt,
                          core::CouplingGains gains, double mass = 1.0) {
  core::Model m;
  m.dt = dt;
  m.gravity = Vec3::Zero();
  m.integrator = integrator;
  m.coupling_mode = mode;
  m.material_pairs = {core::MaterialPair{}};
  core::BodyModel b;
  b.name = "tool";
  b.mass = mass;
  b.inertia_body = Vec3(0.02, 0.03, 0.04).asDiagonal();
  b.coupling = gains;
  m.bodies.push_back(b);
  m.initial_held_body = 0;
  EXPECT_EQ(core::finalize_model(m), "");
  return m;
}

}  // namespace

// ---------------------------------------------------------------- rotation error

TEST(Coupling, RotationErrorIsTheAngleAxisFromQToTarget) {
  const Quat q = rot(0.7, Vec3(1, 2, 3));
  const Vec3 axis = Vec3(-1.0, 0.5, 0.2).normalized();
  const Quat qt = rot(1.1, axis) * q;
  EXPECT_TRUE(core::rotation_error(qt, q).isApprox(1.1 * axis, 1e-13));
  EXPECT_TRUE(core::rotation_error(q, qt).isApprox(-1.1 * axis, 1e-13));
}

TEST(Coupling, RotationErrorTakesTheShortestArcAroundPi) {
  const Vec3 axis = Vec3(0.3, -0.4, 0.8).normalized();
  const Quat q = rot(0.4, Vec3(0, 1, 0));
  for (double eps : {1e-1, 1e-4, 1e-8}) {
    const Vec3 below = core::rotation_error(rot(kPi - eps, axis) * q, q);
    const Vec3 above = core::rotation_error(rot(kPi + eps, axis) * q, q);
    EXPECT_NEAR(below.norm(), kPi - eps, 1e-12) << eps;
    EXPECT_NEAR(above.norm(), kPi - eps, 1e-12) << eps;
    EXPECT_GT(below.normalized().dot(axis), 1.0 - 1e-12) << eps;   // about +axis
    EXPECT_LT(above.normalized().dot(axis), -1.0 + 1e-12) << eps;  // opposite direction
  }
}

TEST(Coupling, RotationErrorIsTheSameForQAndMinusQ) {
  const Quat q = rot(2.0, Vec3(1, 1, 0));
  const Quat qt = rot(2.9, Vec3(0, 1, 1));
  const auto neg = [](const Quat& a) { return Quat(-a.w(), -a.x(), -a.y(), -a.z()); };
  const Vec3 e = core::rotation_error(qt, q);
  EXPECT_TRUE((core::rotation_error(neg(qt), q) - e).norm() < 1e-14);
  EXPECT_TRUE((core::rotation_error(qt, neg(q)) - e).norm() < 1e-14);
  EXPECT_TRUE((core::rotation_error(neg(qt), neg(q)) - e).norm() < 1e-14);
  EXPECT_LE(e.norm(), kPi);
}

TEST(Coupling, RotationErrorIsSmoothNearZero) {
  const Vec3 axis = Vec3(2.0, -1.0, 0.5).normalized();
  const Quat q = rot(1.3, Vec3(0, 0, 1));
  for (double angle : {1e-3, 1e-6, 1e-9, 1e-12, 1e-15}) {
    const Vec3 e = core::rotation_error(rot(angle, axis) * q, q);
    EXPECT_TRUE(e.allFinite());
    // Linear in the angle, with the right axis, down to rounding of q.
    EXPECT_LT((e - angle * axis).norm(), 1e-12 * angle + 1e-15) << angle;
  }
  EXPECT_TRUE(core::rotation_error(q, q).isZero(1e-15));
}

// ---------------------------------------------------------------- wrench

TEST(Coupling, WrenchPullsTowardsTargetAndDampsRelativeVelocity) {
  core::CouplingGains g{200.0, 5.0, 3.0, 0.1};
  core::BodyState s;
  s.position = Vec3(0.1, 0.0, 0.0);
  s.orientation = Quat::Identity();
  core::Pose target{Vec3(0.1, 0.0, 0.02), rot(0.1, Vec3::UnitX())};
  core::Twist tt;
  core::Wrench w = core::coupling_wrench(g, target, tt, s);
  EXPECT_TRUE(w.force.isApprox(Vec3(0.0, 0.0, 200.0 * 0.02), 1e-12));
  EXPECT_TRUE(w.torque.isApprox(Vec3(3.0 * 0.1, 0.0, 0.0), 1e-12));
  // A body moving faster than the target is braked.
  s.position = target.position;
  s.orientation = target.orientation;
  s.linear_velocity = Vec3(0.0, 1.0, 0.0);
  s.angular_velocity = Vec3(0.0, 0.0, -2.0);
  tt.linear = Vec3(0.0, 0.5, 0.0);
  w = core::coupling_wrench(g, target, tt, s);
  EXPECT_TRUE(w.force.isApprox(Vec3(0.0, -5.0 * 0.5, 0.0), 1e-12));
  EXPECT_TRUE(w.torque.isApprox(Vec3(0.0, 0.0, 0.2), 1e-12));
}

TEST(Coupling, StageCouplesOnlyTheHeldBody) {
  core::Model m = coupled_model(core::Integrator::kLinearlyImplicitEuler,
                                core::CouplingMode::kGodObject, 1e-3, {100.0, 2.0, 1.0, 0.1});
  m.bodies.push_back(m.bodies[0]);
  m.bodies[1].coupling = {1000.0, 0.0, 0.0, 0.0};
  ASSERT_EQ(core::finalize_model(m), "");
  core::Data d = core::make_data(m);
  d.target.position = Vec3(0.0, 0.0, 1.0);
  core::apply_external_forces(m, d);
  core::apply_coupling(m, d);
  EXPECT_TRUE(d.body_wrench[0].force.isApprox(Vec3(0, 0, 100.0)));
  EXPECT_TRUE(d.body_wrench[1].force.isZero(0.0));
  EXPECT_EQ(d.scratch->solver.coupled_body, 0);
  core::set_held_body(m, d, 1);  // tool switching
  core::apply_external_forces(m, d);
  core::apply_coupling(m, d);
  EXPECT_TRUE(d.body_wrench[0].force.isZero(0.0));
  EXPECT_TRUE(d.body_wrench[1].force.isApprox(Vec3(0, 0, 1000.0)));
  EXPECT_TRUE(d.coupling_wrench.force.isApprox(Vec3(0, 0, 1000.0)));
  core::set_held_body(m, d, 7);  // out of range → detached
  EXPECT_EQ(d.held_body, -1);
  core::apply_external_forces(m, d);
  core::apply_coupling(m, d);
  EXPECT_TRUE(d.body_wrench[1].force.isZero(0.0));
  EXPECT_TRUE(d.coupling_wrench.force.isZero(0.0));
  EXPECT_EQ(d.scratch->solver.coupled_body, -1);
}

TEST(Coupling, NonFiniteTargetSkipsCouplingAndFlagsIt) {
  const core::Model m = coupled_model(core::Integrator::kLinearlyImplicitEuler,
                                      core::CouplingMode::kGodObject, 1e-3, {100.0, 2.0, 1.0, 0.1});
  core::Data d = core::make_data(m);
  for (int which = 0; which < 4; ++which) {
    core::reset_data(m, d);
    d.target.position = Vec3(0.1, 0.0, 0.0);
    const double nan = std::numeric_limits<double>::quiet_NaN();
    const double inf = std::numeric_limits<double>::infinity();
    if (which == 0) d.target.position.x() = nan;
    if (which == 1) d.target.orientation.w() = inf;
    if (which == 2) d.target_twist.angular.z() = nan;
    if (which == 3) d.target.orientation.coeffs().setZero();
    core::step(m, d);
    EXPECT_TRUE(d.status & core::kInvalidTarget) << which;
    EXPECT_TRUE(core::state_is_finite(d.bodies[0])) << which;
    EXPECT_TRUE(d.coupling_wrench.force.isZero(0.0) && d.coupling_wrench.torque.isZero(0.0));
    EXPECT_TRUE(d.bodies[0].position.isZero(0.0)) << which;  // free body, no gravity
    EXPECT_TRUE(d.feedback_wrench.force.isZero(0.0));
  }
  // A valid target next step clears the flag.
  d.target = core::Pose{};
  d.target_twist = core::Twist{};
  core::step(m, d);
  EXPECT_FALSE(d.status & core::kInvalidTarget);
}

// ---------------------------------------------------------------- first order

namespace {

struct FirstOrderRun {
  double max_err = 0.0;           // |x − x0 e^{−t/τ}| / |x0| over the run
  double max_law_violation = 0.0; // |v − (k/γ) e| / |(k/γ) e|
};

FirstOrderRun run_first_order(core::Integrator integ, double dt, bool rotational) {
  const double k = 100.0, gamma = 10.0;  // τ = γ/k = 0.1 s
  const core::Model m = coupled_model(integ, core::CouplingMode::kFirstOrder, dt,
                                      {k, gamma, k * 0.01, gamma * 0.01}, /*mass=*/50.0);
  core::Data d = core::make_data(m);
  const Vec3 x0(0.05, -0.02, 0.01);
  const Vec3 th0 = Vec3(0.2, 0.1, -0.3);
  d.target.position = Vec3(0.5, 0.5, 0.5);
  d.target.orientation = rot(0.3, Vec3(1, 0, 0));
  if (rotational) {
    d.bodies[0].position = d.target.position;
    d.bodies[0].orientation = core::quat_exp(th0) * d.target.orientation;
  } else {
    d.bodies[0].position = d.target.position + x0;
    d.bodies[0].orientation = d.target.orientation;
  }
  FirstOrderRun out;
  const double tau = gamma / k;
  const int n = static_cast<int>(std::lround(0.3 / dt));
  for (int i = 0; i < n; ++i) {
    const core::BodyState before = d.bodies[0];
    core::step(m, d);
    EXPECT_EQ(d.status, core::kStepOk);
    const core::BodyState& s = d.bodies[0];
    const double t = d.time;
    // Velocity proportional to the error: implicit uses the end-of-step
    // error, the explicit (symplectic) law the start-of-step error.
    const core::BodyState& ref = integ == core::Integrator::kSymplecticEuler ? before : s;
    if (rotational) {
      const Vec3 e = core::rotation_error(d.target.orientation, ref.orientation);
      const Vec3 law = (k / gamma) * e;  // k_r/γ_r = k/γ
      out.max_law_violation = std::max(out.max_law_violation,
                                        (s.angular_velocity - law).norm() / law.norm());
      const Vec3 err = core::rotation_error(d.target.orientation, s.orientation);
      out.max_err =
          std::max(out.max_err, (err + th0 * std::exp(-t / tau)).norm() / th0.norm());
    } else {
      const Vec3 law = (k / gamma) * (d.target.position - ref.position);
      out.max_law_violation = std::max(out.max_law_violation,
                                        (s.linear_velocity - law).norm() / law.norm());
      const Vec3 err = s.position - d.target.position;
      out.max_err = std::max(out.max_err, (err - x0 * std::exp(-t / tau)).norm() / x0.norm());
    }
  }
  return out;
}

}  // namespace

TEST(Coupling, FirstOrderVelocityIsProportionalToErrorAndDecaysWithTauGammaOverK) {
  for (auto integ : {core::Integrator::kLinearlyImplicitEuler, core::Integrator::kSymplecticEuler}) {
    for (bool rotational : {false, true}) {
      const FirstOrderRun a = run_first_order(integ, 1e-3, rotational);
      const FirstOrderRun b = run_first_order(integ, 5e-4, rotational);
      const char* name = integ == core::Integrator::kSymplecticEuler ? "symplectic" : "implicit";
      // The law holds to rounding for translation; the rotation error
      // evolves on SO(3), so the law holds up to O(h) there.
      EXPECT_LT(a.max_law_violation, rotational ? 1e-2 : 1e-9) << name << " rot=" << rotational;
      EXPECT_LT(a.max_err, 0.01) << name << " rot=" << rotational;
      EXPECT_NEAR(a.max_err / b.max_err, 2.0, 0.15) << name << " rot=" << rotational;
      std::printf("[first order %s %s] max rel err dt=1ms %.3e, dt=0.5ms %.3e, ratio %.3f\n", name,
                  rotational ? "rot" : "trans", a.max_err, b.max_err, a.max_err / b.max_err);
    }
  }
}

TEST(Coupling, FirstOrderWithoutDampingFallsBackToGodObject) {
  const core::Model m = coupled_model(core::Integrator::kLinearlyImplicitEuler,
                                      core::CouplingMode::kFirstOrder, 1e-3, {100.0, 0.0, 1.0, 0.1});
  core::Data d = core::make_data(m);
  d.target.position = Vec3(0.01, 0.0, 0.0);
  core::step(m, d);
  EXPECT_FALSE(d.scratch->solver.first_order);
  EXPECT_EQ(d.scratch->solver.coupled_body, 0);
  // God-object: starts from rest, so the first step moves by about h² k e / m.
  EXPECT_NEAR(d.bodies[0].position.x(), 1e-6 * 100.0 * 0.01 / (1.0 + 1e-6 * 100.0), 1e-12);
}

// ---------------------------------------------------------------- direct

TEST(Coupling, DirectModeImposesPoseAndTwistExactly) {
  for (auto integ : {core::Integrator::kLinearlyImplicitEuler, core::Integrator::kSymplecticEuler}) {
    const core::Model m = coupled_model(integ, core::CouplingMode::kDirect, 1e-3, {100.0, 2.0, 1.0, 0.1});
    core::Data d = core::make_data(m);
    for (int i = 0; i < 200; ++i) {
      const double t = i * 1e-3;
      d.target.position = Vec3(0.1 * std::sin(5 * t), 0.2 * t, -0.05);
      d.target.orientation = rot(0.5 + 2.0 * t, Vec3(1, 2, 3));
      d.target_twist.linear = Vec3(0.5 * std::cos(5 * t), 0.2, 0.0);
      d.target_twist.angular = 2.0 * Vec3(1, 2, 3).normalized();
      core::step(m, d);
      ASSERT_EQ(d.status, core::kStepOk);
      EXPECT_EQ(d.bodies[0].position, d.target.position);
      EXPECT_LT(d.bodies[0].orientation.angularDistance(d.target.orientation), 1e-15);
      EXPECT_EQ(d.bodies[0].linear_velocity, d.target_twist.linear);
      EXPECT_EQ(d.bodies[0].angular_velocity, d.target_twist.angular);
      EXPECT_TRUE(d.feedback_wrench.force.isZero(0.0));
      EXPECT_TRUE(d.coupling_wrench.force.isZero(0.0));
    }
  }
}

TEST(Coupling, DirectBodyPushesOthersAndIsNotPushedBack) {
  // Body 0 (imposed, moving +x at 0.1 m/s) touches body 1 through a
  // hand-filled body–body contact (normal from 1 to 0 is −x).
  core::Model m = coupled_model(core::Integrator::kLinearlyImplicitEuler, core::CouplingMode::kDirect,
                                1e-3, {100.0, 2.0, 1.0, 0.1});
  m.bodies.push_back(m.bodies[0]);
  m.bodies[1].initial_pose.position = Vec3(0.19, 0.0, 0.0);
  m.material_pairs[0] = core::MaterialPair{1e4, 10.0, 0.0};
  ASSERT_EQ(core::finalize_model(m), "");
  core::Data d = core::make_data(m);
  d.target.position = Vec3::Zero();
  d.target_twist.linear = Vec3(0.1, 0.0, 0.0);
  const double radius = 0.1;
  int max_iterations = 0;
  for (int i = 0; i < 50; ++i) {
    d.status = 0;
    core::impose_direct_target(m, d);
    const double gap = d.bodies[1].position.x() - d.bodies[0].position.x();
    d.num_contacts = 0;
    if (gap < 2 * radius) {
      core::Contact& c = d.contacts[0];
      c.body_a = 1;
      c.body_b = 0;
      c.normal = Vec3::UnitX();
      c.depth = 2 * radius - gap;
      c.position = Vec3(d.bodies[0].position.x() + radius - 0.5 * c.depth, 0.0, 0.0);
      c.material_pair = 0;
      d.num_contacts = 1;
    }
    core::compute_forces(m, d);
    core::integrate(m, d);
    max_iterations = std::max(max_iterations, d.solver_iterations);
    EXPECT_EQ(d.bodies[0].position, d.target.position);
    EXPECT_EQ(d.bodies[0].linear_velocity, d.target_twist.linear);
    d.target.position += 1e-3 * d.target_twist.linear;
  }
  EXPECT_GT(d.bodies[1].linear_velocity.x(), 0.05);  // pushed along +x
  EXPECT_EQ(max_iterations, 1);  // the imposed body is out of the solve: block diagonal
}

// ---------------------------------------------------------------- admittance (paper Fig. 2 note)

namespace {

/// One ball (r = 10 mm, m = 0.05 kg) held by an admittance device, no gravity; with `wall`, the
/// plane x = 0 (solid for x > 0) with penalty stiffness k_c and damping c_c.
core::Model admittance_model(core::Integrator integrator, bool wall, double k_c = 2e4,
                             double c_c = 20.0) {
  core::Model m;
  m.gravity = Vec3::Zero();
  m.integrator = integrator;
  m.coupling_mode = core::CouplingMode::kAdmittance;
  m.material_pairs = {core::MaterialPair{k_c, c_c, 0.0}};
  if (wall) {
    core::Obstacle w;
    w.name = "wall";
    w.type = core::ShapeType::kPlane;
    w.pose.orientation = core::rotation_between(Vec3::UnitZ(), -Vec3::UnitX());  // normal −x
    m.obstacles = {w};
  }
  m.body_spheres = {core::Sphere{Vec3::Zero(), 0.01}};
  core::BodyModel b;
  b.name = "tool";
  b.mass = 0.05;
  b.inertia_body = Vec3(2e-6, 3e-6, 4e-6).asDiagonal();
  b.sphere_count = 1;
  b.coupling = {1000.0, 10.0, 1.0, 0.1};  // must have no effect in admittance
  b.initial_pose.position = Vec3(-0.05, 0.0, 0.0);
  m.bodies = {b};
  m.feedback = {400.0, 2.0, 0.5, 0.01, 10.0, 1.0};  // must have no effect either
  m.initial_held_body = 0;
  EXPECT_EQ(core::finalize_model(m), "");
  return m;
}

}  // namespace

TEST(CouplingAdmittance, ConstantMeasuredForceAcceleratesAsFOverMInBothIntegrators) {
  // Explicit external wrench, no spring: v_n = n h F/m, x_n = x_0 + h² (F/m) n(n+1)/2 for
  // both schemes (no stiffness or damping term enters the implicit solve); ω_z = n h T_z/I_z
  // (ω along a principal axis: no gyroscopic term).
  for (auto integ : {core::Integrator::kLinearlyImplicitEuler, core::Integrator::kSymplecticEuler}) {
    const core::Model m = admittance_model(integ, false);
    core::Data d = core::make_data(m);
    const Vec3 f(0.3, -0.2, 0.1);
    const double t_z = 2e-5;
    d.device_wrench.force = f;
    d.device_wrench.torque = Vec3(0.0, 0.0, t_z);
    d.target.position = Vec3(5.0, 5.0, 5.0);  // a target far away: ignored in admittance
    const int n = 500;
    const double h = m.dt;
    for (int i = 0; i < n; ++i) core::step(m, d);
    const Vec3 v = n * h * f / m.bodies[0].mass;
    const Vec3 x = Vec3(-0.05, 0.0, 0.0) + h * h * f / m.bodies[0].mass * (n * (n + 1) / 2.0);
    EXPECT_TRUE(d.bodies[0].linear_velocity.isApprox(v, 1e-10)) << static_cast<int>(integ);
    EXPECT_TRUE(d.bodies[0].position.isApprox(x, 1e-10)) << static_cast<int>(integ);
    EXPECT_NEAR(d.bodies[0].angular_velocity.z(), n * h * t_z / 4e-6, 1e-9);
    EXPECT_TRUE(d.coupling_wrench.force.isApprox(f));  // the wrench that drove the body
    EXPECT_EQ(d.feedback_wrench.force.norm(), 0.0);    // position-controlled device: no feedback
    EXPECT_EQ(d.status, core::kStepOk);
  }
}

TEST(CouplingAdmittance, PushedIntoAWallTheBodyStopsAtThePenaltyEquilibrium) {
  // The hand pushes with F = 2 N along +x; the ball comes to rest with k_c δ = F.
  const double k_c = 2e4, f = 2.0;
  for (auto integ : {core::Integrator::kLinearlyImplicitEuler, core::Integrator::kSymplecticEuler}) {
    const core::Model m = admittance_model(integ, true, k_c);
    core::Data d = core::make_data(m);
    d.device_wrench.force = Vec3(f, 0.0, 0.0);
    for (int i = 0; i < 4000; ++i) core::step(m, d);
    EXPECT_NEAR(d.max_penetration, f / k_c, 1e-3 * f / k_c) << static_cast<int>(integ);
    EXPECT_NEAR(d.bodies[0].linear_velocity.norm(), 0.0, 1e-6);
    EXPECT_LT(d.bodies[0].position.x(), 0.0);
  }
}

TEST(CouplingAdmittance, NonFiniteMeasuredWrenchIsIgnoredAndFlagged) {
  const core::Model m = admittance_model(core::Integrator::kLinearlyImplicitEuler, false);
  core::Data d = core::make_data(m);
  d.device_wrench.force = Vec3(std::numeric_limits<double>::quiet_NaN(), 0.0, 0.0);
  core::step(m, d);
  EXPECT_TRUE(d.status & core::kInvalidTarget);
  EXPECT_TRUE(d.bodies[0].position.isApprox(Vec3(-0.05, 0.0, 0.0)));
  // Another mode ignores the device wrench altogether.
  core::Model g = admittance_model(core::Integrator::kLinearlyImplicitEuler, false);
  g.coupling_mode = core::CouplingMode::kGodObject;
  core::Data dg = core::make_data(g);
  dg.target.position = Vec3(-0.05, 0.0, 0.0);
  dg.device_wrench.force = Vec3(100.0, 0.0, 0.0);
  for (int i = 0; i < 10; ++i) core::step(g, dg);
  EXPECT_NEAR(dg.bodies[0].position.x(), -0.05, 1e-12);
}

TEST(CouplingAdmittance, StepsDoNotAllocate) {
  const core::Model m = admittance_model(core::Integrator::kLinearlyImplicitEuler, true);
  core::Data d = core::make_data(m);
  numen::test::AllocationGuard guard;
  for (int i = 0; i < 10000; ++i) {
    d.device_wrench.force = Vec3(2.0 * std::sin(1e-3 * i), 0.1, 0.0);
    core::step(m, d);
  }
  EXPECT_EQ(guard.count(), 0);
}
