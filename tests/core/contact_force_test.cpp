// Tests of core/contact_force: the penalty law, its Jacobians against finite
// differences, the stage's wrenches, and a coupled body pushed into a plane.
#include "numen/core/contact_force.hpp"

#include <cmath>
#include <limits>

#include <Eigen/Eigenvalues>
#include <gtest/gtest.h>

#include "numen/core/collision.hpp"
#include "numen/core/contact.hpp"
#include "numen/core/coupling.hpp"
#include "numen/core/data.hpp"
#include "numen/core/feedback.hpp"
#include "numen/core/integrator.hpp"
#include "numen/core/model.hpp"
#include "numen/core/rigid_body.hpp"
#include "numen/core/step.hpp"

#include "scratch/data_scratch.hpp"
#include "rotation.hpp"

namespace core = numen::core;
using core::Mat12;
using core::Mat3;
using core::Quat;
using core::Vec12;
using core::Vec3;

namespace {

using numen::test::rot;

const core::MaterialPair kMat{2.0e4, 30.0, 4.0};

/// Generalized force (F, r_a × F, −F, −r_b × F) of the pair for stacked twists u.
Vec12 generalized_force(const Vec3& n, double depth, const Vec3& r_a, const Vec3& r_b,
                        const Vec12& u, const core::MaterialPair& mat) {
  core::BodyState a, b;
  a.linear_velocity = u.segment<3>(0);
  a.angular_velocity = u.segment<3>(3);
  b.linear_velocity = u.segment<3>(6);
  b.angular_velocity = u.segment<3>(9);
  const Vec3 v_rel = core::contact_relative_velocity(a, r_a, &b, r_b);
  const Vec3 f = core::contact_penalty_force(n, depth, v_rel, mat).force;
  Vec12 q;
  q << f, r_a.cross(f), -f, -r_b.cross(f);
  return q;
}

/// Sphere (body-frame centre s, radius rho) of a body at (x, q) against the plane z = 0.
struct PlaneContact {
  double depth;
  Vec3 position;
};
PlaneContact sphere_plane(const Vec3& x, const Quat& q, const Vec3& s, double rho) {
  const Vec3 c = x + q * s;
  const double depth = rho - c.z();
  return {depth, c - (rho - 0.5 * depth) * Vec3::UnitZ()};
}

}  // namespace

TEST(ContactForce, NormalForceIsASpringDamperThatNeverPulls) {
  const Vec3 n(0.0, 0.0, 1.0);
  const double depth = 2e-3;
  // At rest: f = k d along n.
  auto r = core::contact_penalty_force(n, depth, Vec3::Zero(), kMat);
  EXPECT_TRUE(r.active);
  EXPECT_TRUE(r.force.isApprox(kMat.stiffness * depth * n, 1e-14));
  // Approaching (v_n < 0): more force; separating: less.
  r = core::contact_penalty_force(n, depth, Vec3(0, 0, -0.1), kMat);
  EXPECT_NEAR(r.normal_force, kMat.stiffness * depth + kMat.damping * 0.1, 1e-12);
  r = core::contact_penalty_force(n, depth, Vec3(0, 0, 0.5), kMat);
  EXPECT_NEAR(r.normal_force, kMat.stiffness * depth - kMat.damping * 0.5, 1e-12);
  // Separating fast: k d − c v_n < 0 → no pulling, no friction, inactive.
  r = core::contact_penalty_force(n, depth, Vec3(3.0, 0, 2.0), kMat);
  EXPECT_FALSE(r.active);
  EXPECT_EQ(r.normal_force, 0.0);
  EXPECT_TRUE(r.force.isZero(0.0));
  // Any velocity: f_n ≥ 0.
  for (double vn = -5.0; vn <= 5.0; vn += 0.25)
    EXPECT_GE(core::contact_penalty_force(n, depth, Vec3(0, 0, vn), kMat).force.dot(n), 0.0);
}

TEST(ContactForce, FrictionOpposesTangentialSliding) {
  const Vec3 n = Vec3(0.0, 1.0, 1.0).normalized();
  const Vec3 slide = Vec3(1.0, 0.3, -0.3);  // tangential to n
  ASSERT_NEAR(slide.dot(n), 0.0, 1e-15);
  const auto r = core::contact_penalty_force(n, 1e-3, slide, kMat);
  const Vec3 ft = r.force - r.force.dot(n) * n;
  EXPECT_LT(ft.dot(slide), 0.0);
  EXPECT_TRUE(ft.isApprox(-kMat.friction * slide, 1e-12));
  EXPECT_NEAR(r.force.dot(n), kMat.stiffness * 1e-3, 1e-12);  // sliding does not change f_n
}

TEST(ContactForce, RelativeVelocityIncludesRotation) {
  core::BodyState a, b;
  a.linear_velocity = Vec3(1, 0, 0);
  a.angular_velocity = Vec3(0, 0, 2);
  b.linear_velocity = Vec3(0, 1, 0);
  b.angular_velocity = Vec3(1, 0, 0);
  const Vec3 ra(0.1, 0, 0), rb(0, 0, 0.2);
  const Vec3 expect = (Vec3(1, 0, 0) + Vec3(0, 0.2, 0)) - (Vec3(0, 1, 0) + Vec3(0, -0.2, 0));
  EXPECT_TRUE(core::contact_relative_velocity(a, ra, &b, rb).isApprox(expect));
  EXPECT_TRUE(core::contact_relative_velocity(a, ra, nullptr, rb).isApprox(Vec3(1, 0.2, 0)));
  // G maps the stacked twists to the same vector.
  Vec12 u;
  u << a.linear_velocity, a.angular_velocity, b.linear_velocity, b.angular_velocity;
  EXPECT_TRUE((core::contact_velocity_jacobian(ra, rb) * u).isApprox(expect));
}

TEST(ContactForce, DampingMatchesFiniteDifferencesOfTheGeneralizedForce) {
  const Vec3 n = Vec3(0.2, -0.3, 1.0).normalized();
  const Vec3 ra(0.03, -0.05, -0.08), rb(-0.02, 0.04, 0.07);
  const double depth = 3e-3;
  Vec12 u;
  u << 0.01, -0.02, -0.005, 0.3, -0.1, 0.2, -0.01, 0.03, 0.002, 0.1, 0.05, -0.2;
  Mat12 k, d;
  core::contact_stiffness_damping(n, ra, rb, true, kMat, k, d);
  Mat12 fd;
  const double eps = 1e-6;
  for (int j = 0; j < 12; ++j) {
    Vec12 up = u, um = u;
    up(j) += eps;
    um(j) -= eps;
    fd.col(j) = (generalized_force(n, depth, ra, rb, up, kMat) -
                 generalized_force(n, depth, ra, rb, um, kMat)) /
                (2 * eps);
  }
  EXPECT_LT((fd - d).norm(), 1e-7 * d.norm()) << "D\n" << d << "\nFD\n" << fd;
  // Symmetric negative semidefinite.
  EXPECT_LT((d - d.transpose()).norm(), 1e-12 * d.norm());
  EXPECT_LT((k - k.transpose()).norm(), 1e-12 * k.norm());
  Eigen::SelfAdjointEigenSolver<Mat12> ed(d), ek(k);
  EXPECT_LE(ed.eigenvalues().maxCoeff(), 1e-9 * d.norm());
  EXPECT_LE(ek.eigenvalues().maxCoeff(), 1e-9 * k.norm());
  // Inactive: nothing.
  core::contact_stiffness_damping(n, ra, rb, false, kMat, k, d);
  EXPECT_TRUE(k.isZero(0.0) && d.isZero(0.0));
}

TEST(ContactForce, StiffnessMatchesFiniteDifferencesSphereOnPlane) {
  // Body a: sphere off its COM; static plane z = 0 (n = +z). Perturb the
  // body's position and orientation (δθ: world rotation vector) and
  // differentiate the contact force on a.
  const Vec3 s(0.05, -0.02, 0.03);
  const double rho = 0.1;
  const Quat q0 = rot(0.6, Vec3(1, -1, 0.5));
  const Vec3 x0 = Vec3(0.1, 0.2, 0.0) - Vec3::UnitZ() * ((q0 * s).z() - rho + 4e-3);
  const Vec3 n = Vec3::UnitZ();
  const auto force = [&](const Vec3& x, const Quat& q) {
    const PlaneContact c = sphere_plane(x, q, s, rho);
    return core::contact_penalty_force(n, c.depth, Vec3::Zero(), kMat).force;
  };
  const PlaneContact c0 = sphere_plane(x0, q0, s, rho);
  ASSERT_NEAR(c0.depth, 4e-3, 1e-12);
  Mat12 k, d;
  core::contact_stiffness_damping(n, c0.position - x0, Vec3::Zero(), true, kMat, k, d);
  Eigen::Matrix<double, 3, 6> fd;
  const double eps = 1e-7;
  for (int j = 0; j < 6; ++j) {
    Vec3 dx = Vec3::Zero(), dth = Vec3::Zero();
    (j < 3 ? dx : dth)(j % 3) = eps;
    const Vec3 fp = force(x0 + dx, core::quat_exp(dth) * q0);
    const Vec3 fm = force(x0 - dx, core::quat_exp(-dth) * q0);
    fd.col(j) = (fp - fm) / (2 * eps);
  }
  const Eigen::Matrix<double, 3, 6> analytic = k.block<3, 6>(0, 0);
  EXPECT_LT((fd - analytic).norm(), 1e-6 * analytic.norm()) << analytic << "\n\n" << fd;
  EXPECT_GT((analytic.block<3, 3>(0, 3).norm()), 1.0);  // the rotational coupling is exercised
}

TEST(ContactForce, StiffnessNormalRowMatchesFiniteDifferencesSphereOnSphere) {
  // Two bodies with off-centre spheres; the normal component of the force,
  // k·depth, is differentiated against all 12 displacement coordinates.
  const Vec3 sa(0.02, 0.01, -0.03), sb(-0.01, 0.03, 0.02);
  const double ra_ = 0.06, rb_ = 0.05;
  const Quat qa0 = rot(0.3, Vec3(0, 1, 1)), qb0 = rot(-0.8, Vec3(1, 0, 1));
  const Vec3 xb0(0.0, 0.0, 0.0);
  const Vec3 dir = Vec3(0.3, 0.2, 1.0).normalized();
  const Vec3 cb0 = xb0 + qb0 * sb;
  const Vec3 ca0 = cb0 + (ra_ + rb_ - 5e-3) * dir;
  const Vec3 xa0 = ca0 - qa0 * sa;
  const auto geometry = [&](const Vec3& xa, const Quat& qa, const Vec3& xb, const Quat& qb,
                            Vec3& n, double& depth, Vec3& p) {
    const Vec3 ca = xa + qa * sa, cb = xb + qb * sb;
    const double dist = (ca - cb).norm();
    n = (ca - cb) / dist;
    depth = ra_ + rb_ - dist;
    p = cb + (rb_ - 0.5 * depth) * n;
  };
  Vec3 n0, p0;
  double depth0;
  geometry(xa0, qa0, xb0, qb0, n0, depth0, p0);
  ASSERT_NEAR(depth0, 5e-3, 1e-12);
  Mat12 k, d;
  core::contact_stiffness_damping(n0, p0 - xa0, p0 - xb0, true, kMat, k, d);
  const Eigen::Matrix<double, 1, 12> analytic = n0.transpose() * k.topRows<3>();
  Eigen::Matrix<double, 1, 12> fd;
  const double eps = 1e-7;
  for (int j = 0; j < 12; ++j) {
    Vec12 e = Vec12::Zero();
    e(j) = eps;
    double val[2];
    for (int sgn = 0; sgn < 2; ++sgn) {
      const Vec12 de = sgn == 0 ? e : Vec12(-e);
      Vec3 n, p;
      double depth;
      geometry(xa0 + de.segment<3>(0), core::quat_exp(de.segment<3>(3)) * qa0, xb0 + de.segment<3>(6),
               core::quat_exp(de.segment<3>(9)) * qb0, n, depth, p);
      val[sgn] = n0.dot(core::contact_penalty_force(n, depth, Vec3::Zero(), kMat).force);
    }
    fd(j) = (val[0] - val[1]) / (2 * eps);
  }
  EXPECT_LT((fd - analytic).norm(), 1e-5 * analytic.norm()) << analytic << "\n" << fd;
}

TEST(ContactForce, StageAppliesEqualAndOppositeWrenchesAboutEachCom) {
  core::Model m;
  m.gravity = Vec3::Zero();
  m.material_pairs = {kMat};
  core::BodyModel b;
  m.bodies = {b, b};
  m.initial_held_body = -1;
  ASSERT_EQ(core::finalize_model(m), "");
  core::Data d = core::make_data(m);
  d.bodies[0].position = Vec3(0.0, 0.0, 0.1);
  d.bodies[1].position = Vec3(0.02, 0.0, -0.1);
  d.bodies[0].linear_velocity = Vec3(0.1, 0.0, -0.05);
  d.bodies[1].angular_velocity = Vec3(0.0, 1.0, 0.0);
  d.num_contacts = 2;
  core::Contact& c = d.contacts[0];
  c.body_a = 0;
  c.body_b = 1;
  c.position = Vec3(0.01, 0.01, 0.0);
  c.normal = Vec3::UnitZ();
  c.depth = 1e-3;
  core::Contact& c2 = d.contacts[1];  // invalid material index: ignored
  c2 = c;
  c2.material_pair = 5;
  core::apply_external_forces(m, d);
  core::compute_contact_forces(m, d);
  const Vec3 f = c.force;
  EXPECT_GT(f.z(), 0.0);
  EXPECT_TRUE(c2.force.isZero(0.0));
  EXPECT_TRUE(d.body_wrench[0].force.isApprox(f));
  EXPECT_TRUE(d.body_wrench[1].force.isApprox(-f));
  EXPECT_TRUE(d.body_wrench[0].torque.isApprox((c.position - d.bodies[0].position).cross(f)));
  EXPECT_TRUE(d.body_wrench[1].torque.isApprox(-(c.position - d.bodies[1].position).cross(f)));
  // Total torque about the world origin balances (action = reaction at the same point).
  const Vec3 total = d.body_wrench[0].torque + d.bodies[0].position.cross(d.body_wrench[0].force) +
                     d.body_wrench[1].torque + d.bodies[1].position.cross(d.body_wrench[1].force);
  EXPECT_LT(total.norm(), 1e-14);
  EXPECT_TRUE(d.scratch->solver.contact_terms[0].active);
  EXPECT_FALSE(d.scratch->solver.contact_terms[1].active);
}

namespace {

/// One body with a sphere of radius `rho` at its COM, coupled to a target
/// below the static plane z = 0; contacts are filled by hand each step.
struct PushResult {
  double z;
  double contact_force;
  core::Wrench feedback;
  int max_iterations;
};

PushResult push_into_plane(core::Integrator integ, double z_target) {
  const double rho = 0.05, kc = 5000.0, kt = 200.0, m = 0.1;
  core::Model model;
  model.dt = 1e-3;
  model.gravity = Vec3::Zero();
  model.integrator = integ;
  model.material_pairs = {core::MaterialPair{kc, 20.0, 1.0}};
  core::BodyModel b;
  b.mass = m;
  b.inertia_body = 1e-4 * Mat3::Identity();
  b.coupling = {kt, core::damping_from_ratio(0.8, m, kt), 0.01, 1e-3};
  b.initial_pose.position = Vec3(0.0, 0.0, 0.2);
  model.bodies = {b};
  core::Obstacle plane;  // the plane z = 0 whose contact the loop below writes by hand
  plane.name = "plane";  // (it gives the model its contact room: capacity.hpp)
  model.obstacles = {plane};
  model.feedback = {kt, 0.0, 0.01, 0.0};
  EXPECT_EQ(core::finalize_model(model), "");
  core::Data d = core::make_data(model);
  d.target.position = Vec3(0.01, 0.0, z_target);
  PushResult out{};
  for (int i = 0; i < 3000; ++i) {
    d.status = 0;
    const core::BodyState& s = d.bodies[0];
    d.num_contacts = 0;
    if (s.position.z() < rho) {
      core::Contact& c = d.contacts[0];
      c.body_a = 0;
      c.body_b = -1;
      c.normal = Vec3::UnitZ();
      c.depth = rho - s.position.z();
      c.position = s.position - (rho - 0.5 * c.depth) * Vec3::UnitZ();
      c.material_pair = 0;
      d.num_contacts = 1;
    }
    core::compute_forces(model, d);
    core::integrate(model, d);
    core::compute_feedback(model, d);
    EXPECT_EQ(d.status, core::kStepOk);
    out.max_iterations = std::max(out.max_iterations, d.solver_iterations);
  }
  out.z = d.bodies[0].position.z();
  out.contact_force = d.num_contacts ? d.contacts[0].force.z() : 0.0;
  out.feedback = d.feedback_wrench;
  return out;
}

}  // namespace

TEST(ContactForce, CoupledBodyPushedIntoAStaticPlaneSettlesAtTheSpringBalance) {
  const double rho = 0.05, kc = 5000.0, kt = 200.0, zt = -0.03;
  const double z_eq = (kt * zt + kc * rho) / (kt + kc);  // k_t (z_t − z) + k_c (ρ − z) = 0
  for (auto integ : {core::Integrator::kLinearlyImplicitEuler, core::Integrator::kSymplecticEuler}) {
    const PushResult r = push_into_plane(integ, zt);
    EXPECT_NEAR(r.z, z_eq, 1e-9);
    EXPECT_NEAR(r.contact_force, kt * (z_eq - zt), 1e-6);
    // The device feels the contact: feedback pushes it up by the contact force.
    EXPECT_NEAR(r.feedback.force.z(), r.contact_force, 1e-6);
    // x settles on the target (viscous friction only slows it, through the
    // slow rolling mode of the weak rotational coupling).
    EXPECT_NEAR(r.feedback.force.x(), 0.0, 1e-5);
    if (integ == core::Integrator::kLinearlyImplicitEuler) {
      EXPECT_EQ(r.max_iterations, 1);
    }
  }
}

TEST(ContactForce, PushIntoPlaneThroughTheCollisionStage) {
  // Same scene through step() and the real collision stage. Skipped while
  // collision.cpp is the placeholder (no contacts reported).
  const double rho = 0.05, kc = 5000.0, kt = 200.0, m = 0.1, zt = -0.03;
  core::Model model;
  model.gravity = Vec3::Zero();
  model.material_pairs = {core::MaterialPair{kc, 20.0, 1.0}};
  core::Obstacle plane;
  plane.name = "floor";
  plane.type = core::ShapeType::kPlane;
  model.obstacles = {plane};
  model.body_spheres = {core::Sphere{Vec3::Zero(), rho}};
  core::BodyModel b;
  b.mass = m;
  b.inertia_body = 1e-4 * Mat3::Identity();
  b.sphere_count = 1;
  b.coupling = {kt, core::damping_from_ratio(0.8, m, kt), 0.01, 1e-3};
  b.initial_pose.position = Vec3(0.0, 0.0, 0.2);
  model.bodies = {b};
  ASSERT_EQ(core::finalize_model(model), "");
  core::Data d = core::make_data(model);
  d.target.position = Vec3(0.0, 0.0, zt);
  int contact_steps = 0;
  for (int i = 0; i < 3000; ++i) {
    core::step(model, d);
    contact_steps += d.num_contacts > 0;
  }
  ASSERT_GT(contact_steps, 0) << "the collision stage must report the plane contact";
  const double z_eq = (kt * zt + kc * rho) / (kt + kc);
  EXPECT_NEAR(d.bodies[0].position.z(), z_eq, 1e-6);
}

// ---- the contact time-constant floor (SolverSettings::contact_max_omega_dt) ----

TEST(ContactForce, EffectiveMassIsTheInverseOfTheContactsMobility) {
  // m_eff = 1 / Σ gᵀ M⁻¹ g, g = (n, r × n), M = diag(m I, I_w) per body: checked against the
  // dense 6×6 mass matrices of two rotated bodies.
  core::BodyModel a, b;
  a.mass = 0.05;
  a.inertia_body = Vec3(4e-4, 3e-4, 2e-5).asDiagonal();
  a.inertia_body_inv = a.inertia_body.inverse();
  b.mass = 0.2;
  b.inertia_body = Vec3(1e-3, 2e-3, 3e-3).asDiagonal();
  b.inertia_body_inv = b.inertia_body.inverse();
  core::BodyState sa, sb;
  sa.orientation = rot(0.7, Vec3(1, 2, 3));
  sb.orientation = rot(-1.1, Vec3(0, 1, -1));
  const Vec3 n = Vec3(0.2, -0.3, 1.0).normalized(), r_a(0.01, -0.12, 0.03), r_b(-0.02, 0.04, 0.05);
  auto mobility = [&](const core::BodyModel& bm, const core::BodyState& s, const Vec3& r) {
    Eigen::Matrix<double, 6, 6> mm = Eigen::Matrix<double, 6, 6>::Zero();
    mm.topLeftCorner<3, 3>() = bm.mass * Mat3::Identity();
    mm.bottomRightCorner<3, 3>() = core::world_inertia(s.orientation, bm.inertia_body);
    Eigen::Matrix<double, 6, 1> g;
    g << n, r.cross(n);
    return g.dot(mm.inverse() * g);
  };
  const double both = 1.0 / (mobility(a, sa, r_a) + mobility(b, sb, r_b));
  EXPECT_NEAR(core::contact_effective_mass(a, sa, r_a, false, &b, &sb, r_b, false, n), both,
              1e-12 * both);
  EXPECT_NEAR(core::contact_effective_mass(a, sa, r_a, false, nullptr, nullptr, r_b, false, n),
              1.0 / mobility(a, sa, r_a), 1e-12);
  // An imposed (kDirect) body is infinitely heavy.
  EXPECT_NEAR(core::contact_effective_mass(a, sa, r_a, false, &b, &sb, r_b, true, n),
              1.0 / mobility(a, sa, r_a), 1e-12);
  EXPECT_TRUE(std::isinf(core::contact_effective_mass(a, sa, r_a, true, nullptr, nullptr, r_b, false, n)));
  // Lever arm along the normal: no rotation, the body's mass.
  EXPECT_NEAR(core::contact_effective_mass(a, sa, 0.1 * n, false, nullptr, nullptr, r_b, false, n),
              a.mass, 1e-15);
  EXPECT_DOUBLE_EQ(core::contact_stiffness_limit(0.05, 1e-3, 10.0), 0.05 * 1e8);
  EXPECT_TRUE(std::isinf(core::contact_stiffness_limit(0.05, 1e-3, std::numeric_limits<double>::infinity())));
}

namespace {

/// One 50 g ball (r = 10 mm, contact lever arm along the normal: m_eff = m) 1 mm into the plane
/// z = 0, moving down at 0.1 m/s, contact stiffness k; one step.
core::Data ball_step(double k, double max_omega_dt, core::Model* out = nullptr) {
  core::Model m;
  m.gravity = Vec3::Zero();
  m.material_pairs = {core::MaterialPair{k, 5.0, 0.5}};
  m.solver.contact_max_omega_dt = max_omega_dt;
  core::Obstacle plane;
  plane.name = "floor";
  plane.type = core::ShapeType::kPlane;
  m.obstacles = {plane};
  m.body_spheres = {core::Sphere{Vec3::Zero(), 0.01}};
  core::BodyModel b;
  b.mass = 0.05;
  b.inertia_body = 2e-6 * Mat3::Identity();
  b.sphere_count = 1;
  b.initial_pose.position = Vec3(0.0, 0.0, 0.009);
  b.initial_twist.linear = Vec3(0.02, 0.0, -0.1);
  m.bodies = {b};
  m.initial_held_body = -1;
  EXPECT_EQ(core::finalize_model(m), "");
  core::Data d = core::make_data(m);
  core::step(m, d);
  if (out) *out = m;
  return d;
}

}  // namespace

TEST(ContactForce, StiffnessBelowTheFloorActsAsDeclaredBitForBit) {
  // ω h = √(k/m) h = 1.41 at k = 1e5 N/m: below the default floor. The step is bit-identical
  // to the one without a floor (+∞), and nothing is counted.
  const core::Data with = ball_step(1e5, core::SolverSettings{}.contact_max_omega_dt);
  const core::Data without = ball_step(1e5, std::numeric_limits<double>::infinity());
  EXPECT_EQ(with.bodies[0].position, without.bodies[0].position);
  EXPECT_EQ(with.bodies[0].linear_velocity, without.bodies[0].linear_velocity);
  EXPECT_EQ(with.contacts[0].force, without.contacts[0].force);
  EXPECT_EQ(with.contacts_clamped, 0);
  EXPECT_EQ(with.contact_clamped_steps, 0);
  EXPECT_EQ(with.scratch->solver.contact_terms[0].stiffness, 1e5);
  EXPECT_FALSE(with.scratch->solver.contact_terms[0].clamped);
}

TEST(ContactForce, StiffnessAboveTheFloorIsClampedToTheEffectiveMassAndCounted) {
  // k = 1e12 N/m on m_eff = 0.05 kg at h = 1 ms: clamped to m_eff (ω_c h / h)²; the step is the
  // one of a material of exactly that stiffness.
  const double w = core::SolverSettings{}.contact_max_omega_dt;
  const double k_eff = 0.05 * (w / 1e-3) * (w / 1e-3);
  const core::Data clamped = ball_step(1e12, w);
  const core::Data declared = ball_step(k_eff, std::numeric_limits<double>::infinity());
  EXPECT_DOUBLE_EQ(clamped.scratch->solver.contact_terms[0].stiffness, k_eff);
  EXPECT_TRUE(clamped.scratch->solver.contact_terms[0].clamped);
  EXPECT_EQ(clamped.contacts_clamped, 1);
  EXPECT_EQ(clamped.contact_clamped_steps, 1);
  EXPECT_NEAR((clamped.bodies[0].position - declared.bodies[0].position).norm(), 0.0, 1e-15);
  EXPECT_NEAR(clamped.contacts[0].force.z(), k_eff * 1e-3 + 5.0 * 0.1, 1e-6 * k_eff * 1e-3);
  // The body–plane bound of a body: its smallest effective mass (here m) times (ω_c / h)².
  core::Model m;
  ball_step(1e12, w, &m);
  EXPECT_NEAR(core::body_contact_stiffness_limit(m, 0), k_eff, 1e-9 * k_eff);
}

// The smoothed onset (MaterialPair::onset_depth δ0 > 0): the force and its derivatives are
// continuous at d = 0 and d = δ0, the Jacobian coefficients the law reports are its own
// derivatives, and the default (δ0 = 0) is the linear law bit for bit.
TEST(ContactForce, SmoothedOnsetIsContinuouslyDifferentiableAndReportsItsOwnDerivatives) {
  core::MaterialPair mat{2.0e4, 30.0, 4.0};
  mat.onset_depth = 2e-4;
  const double d0 = mat.onset_depth;
  const Vec3 n = Vec3::UnitZ();
  const auto fn = [&](double depth, double vn) {
    return core::contact_penalty_force(n, depth, Vec3(0.01, 0.0, vn), mat);
  };
  for (double vn : {-0.05, 0.0, 0.002}) {
    // Value and slope across the onset (d = 0) and the joint (d = δ0).
    for (double at : {0.0, d0}) {
      const double e = 1e-9;
      const double below = fn(at - e, vn).normal_force, above = fn(at + e, vn).normal_force;
      EXPECT_NEAR(below, above, 1e-4 * std::max(1.0, std::abs(above))) << at << " " << vn;
      const double slope_below = (fn(at - e, vn).normal_force - fn(at - 2 * e, vn).normal_force) / e;
      const double slope_above = (fn(at + 2 * e, vn).normal_force - fn(at + e, vn).normal_force) / e;
      EXPECT_NEAR(slope_below, slope_above, 2e-3 * mat.stiffness) << at << " " << vn;
    }
    // Inside the onset the reported ∂f_n/∂d, c s(d), μ s(d) are the law's derivatives.
    for (double depth : {0.2 * d0, 0.5 * d0, 0.9 * d0, 3.0 * d0}) {
      const core::ContactForceResult r = fn(depth, vn);
      if (!r.active) continue;
      const double e = 1e-10;
      const double dfdd = (fn(depth + e, vn).normal_force - fn(depth - e, vn).normal_force) / (2 * e);
      EXPECT_NEAR(r.stiffness, std::max(0.0, dfdd), 1e-4 * mat.stiffness) << depth << " " << vn;
      const double dfdv = (fn(depth, vn + 1e-7).normal_force - fn(depth, vn - 1e-7).normal_force) / 2e-7;
      EXPECT_NEAR(r.damping, -dfdv, 1e-6 * mat.damping) << depth;
      EXPECT_NEAR(-r.force.x() / 0.01, r.friction, 1e-9) << depth;  // f_t = −μ s v_t
    }
  }
  // Past the onset: k (d − δ0/2) − c v_n with the material's coefficients.
  const core::ContactForceResult deep = fn(5.0 * d0, -0.01);
  EXPECT_NEAR(deep.normal_force, mat.stiffness * 4.5 * d0 + mat.damping * 0.01, 1e-9);
  EXPECT_EQ(deep.stiffness, mat.stiffness);
  EXPECT_EQ(deep.damping, mat.damping);
  EXPECT_EQ(deep.friction, mat.friction);
  // Approaching the surface from outside never pulls and never acts.
  EXPECT_FALSE(fn(-1e-6, -1.0).active);
  // δ0 = 0: the linear law, with the material's coefficients reported.
  const core::ContactForceResult lin = core::contact_penalty_force(n, 1e-4, Vec3(0.0, 0.0, -0.01), kMat);
  EXPECT_DOUBLE_EQ(lin.normal_force, kMat.stiffness * 1e-4 - kMat.damping * -0.01);  // clang: 1 ulp
  EXPECT_EQ(lin.stiffness, kMat.stiffness);
  EXPECT_EQ(lin.damping, kMat.damping);
  EXPECT_EQ(lin.friction, kMat.friction);
}

TEST(ContactForce, SmoothedOnsetRestsDeeperByHalfItsOnsetDepth) {
  // A coupled body pushed into the plane with the smoothed onset settles where
  // k (d − δ0/2) balances the spring: δ0/2 deeper than with the linear law.
  for (double onset : {0.0, 1e-4}) {  // the load 1.96 N is above k δ0 / 2 = 1 N
    core::Model m;
    m.dt = 1e-3;
    m.gravity = Vec3(0.0, 0.0, -9.81);
    core::MaterialPair mat{2.0e4, 30.0, 0.0};
    mat.onset_depth = onset;
    m.material_pairs = {mat};
    m.body_spheres = {core::Sphere{Vec3::Zero(), 0.01}};
    core::BodyModel b;
    b.mass = 0.2;
    b.inertia_body = 1e-5 * Mat3::Identity();
    b.sphere_begin = 0;
    b.sphere_count = 1;
    b.initial_pose.position = Vec3(0.0, 0.0, 0.011);
    m.bodies = {b};
    core::Obstacle plane;
    plane.type = core::ShapeType::kPlane;
    m.obstacles = {plane};
    ASSERT_EQ(core::finalize_model(m), "");
    core::Data d = core::make_data(m);
    for (int i = 0; i < 3000; ++i) core::step(m, d);
    const double depth = 0.01 - d.bodies[0].position.z();
    EXPECT_NEAR(depth, 0.2 * 9.81 / 2.0e4 + 0.5 * onset, 1e-8) << onset;
  }
}

TEST(ContactForce, NegativeOnsetDepthIsRefused) {
  core::Model m;
  core::MaterialPair mat;
  mat.onset_depth = -1e-4;
  m.material_pairs = {mat};
  const std::string err = core::finalize_model(m);
  EXPECT_NE(err.find("onset_depth"), std::string::npos) << err;
}
