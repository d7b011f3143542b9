// Tests of core/integrator: accuracy against the closed-form damped
// oscillator (paper Eq. 3 in free space), stability on stiff couplings, the
// preconditioned CG against a dense reference, gyroscopic stability,
// allocation-free stage calls.
#include "numen/core/integrator.hpp"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include "alloc_counter.hpp"
#include "numen/core/contact_force.hpp"
#include "numen/core/coupling.hpp"
#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/rigid_body.hpp"
#include "numen/core/step.hpp"

#include "scratch/data_scratch.hpp"
#include "solver/implicit_system.hpp"
#include "rotation.hpp"

namespace core = numen::core;
using core::Mat12;
using core::Mat3;
using core::Quat;
using core::Vec3;
using core::Vec6;

namespace {

using numen::test::rot;

const char* name(core::Integrator i) {
  return i == core::Integrator::kSymplecticEuler ? "symplectic"
         : i == core::Integrator::kTrapezoidal   ? "trapezoidal"
         : i == core::Integrator::kTrBdf2        ? "tr-bdf2"
                                                 : "implicit";
}

/// Closed form of m ẍ + γ ẋ + k x = 0 with x(0) = x0, ẋ(0) = 0.
double oscillator(double m, double k, double gamma, double x0, double t) {
  const double wn = std::sqrt(k / m);
  const double zeta = gamma / (2.0 * std::sqrt(m * k));
  if (zeta < 1.0 - 1e-12) {
    const double wd = wn * std::sqrt(1.0 - zeta * zeta);
    return std::exp(-zeta * wn * t) * (x0 * std::cos(wd * t) + zeta * wn * x0 / wd * std::sin(wd * t));
  }
  if (zeta <= 1.0 + 1e-12) return std::exp(-wn * t) * (x0 + wn * x0 * t);
  const double s = std::sqrt(zeta * zeta - 1.0);
  const double r1 = -wn * (zeta - s), r2 = -wn * (zeta + s);
  const double a = -r2 * x0 / (r1 - r2);  // a + b = x0, r1 a + r2 b = 0
  return a * std::exp(r1 * t) + (x0 - a) * std::exp(r2 * t);
}

core::Model single_body(core::Integrator integ, double dt, double mass, const Mat3& inertia,
                        core::CouplingGains gains) {
  core::Model m;
  m.dt = dt;
  m.gravity = Vec3::Zero();
  m.integrator = integ;
  m.material_pairs = {core::MaterialPair{}};
  core::BodyModel b;
  b.mass = mass;
  b.inertia_body = inertia;
  b.coupling = gains;
  m.bodies = {b};
  m.initial_held_body = 0;
  EXPECT_EQ(core::finalize_model(m), "");
  return m;
}

/// Max over [0, T] of |x_num − x_exact| / |x0| for a translational offset.
double translational_error(core::Integrator integ, double dt, double zeta, double t_end) {
  const double m = 1.0, k = 100.0, gamma = core::damping_from_ratio(zeta, m, k);
  const core::Model model = single_body(integ, dt, m, 0.01 * Mat3::Identity(), {k, gamma, 1.0, 0.1});
  core::Data d = core::make_data(model);
  const Vec3 target(0.3, 0.2, 0.1), x0(0.1, -0.05, 0.02);
  d.target.position = target;
  d.bodies[0].position = target + x0;
  double err = 0.0;
  const int n = static_cast<int>(std::lround(t_end / dt));
  for (int i = 0; i < n; ++i) {
    core::step(model, d);
    EXPECT_EQ(d.status, core::kStepOk);
    const double t = (i + 1) * dt;
    Vec3 exact;
    for (int j = 0; j < 3; ++j) exact(j) = oscillator(m, k, gamma, x0(j), t);
    err = std::max(err, (d.bodies[0].position - target - exact).norm() / x0.norm());
  }
  return err;
}

/// Max over [0, T] of the angle error / θ0 for a rotation about a principal axis.
double rotational_error(core::Integrator integ, double dt, double zeta, double t_end) {
  const Mat3 ib = Vec3(0.02, 0.03, 0.04).asDiagonal();
  const double i_zz = 0.04, k = 2.0, gamma = core::damping_from_ratio(zeta, i_zz, k);
  const core::Model model = single_body(integ, dt, 1.0, ib, {10.0, 1.0, k, gamma});
  core::Data d = core::make_data(model);
  const Quat qt = rot(0.8, Vec3(1, 2, -1));
  const Vec3 axis = qt * Vec3::UnitZ();  // principal axis z of the body, in the world
  const double th0 = 0.3;
  d.target.orientation = qt;
  d.bodies[0].orientation = rot(th0, axis) * qt;
  double err = 0.0;
  const int n = static_cast<int>(std::lround(t_end / dt));
  for (int i = 0; i < n; ++i) {
    core::step(model, d);
    EXPECT_EQ(d.status, core::kStepOk);
    const double t = (i + 1) * dt;
    const Vec3 e = -core::rotation_error(qt, d.bodies[0].orientation);  // = θ axis
    const double exact = oscillator(i_zz, k, gamma, th0, t);
    err = std::max(err, (e - exact * axis).norm() / th0);
  }
  return err;
}

}  // namespace

TEST(Integrator, FreeSpaceCouplingMatchesTheDampedOscillatorAtFirstOrder) {
  for (auto integ : {core::Integrator::kLinearlyImplicitEuler, core::Integrator::kSymplecticEuler}) {
    for (double zeta : {0.1, 0.7, 1.0}) {
      const double e1 = translational_error(integ, 1e-3, zeta, 2.0);
      const double e2 = translational_error(integ, 5e-4, zeta, 2.0);
      std::printf("[oscillator %-10s zeta %.1f] max rel err dt=1ms %.3e  dt=0.5ms %.3e  ratio %.3f\n",
                  name(integ), zeta, e1, e2, e1 / e2);
      EXPECT_LT(e1, zeta < 0.5 ? 0.05 : 0.01) << name(integ) << " zeta " << zeta;
      EXPECT_NEAR(e1 / e2, 2.0, 0.15) << name(integ) << " zeta " << zeta;
    }
  }
}

TEST(Integrator, FreeSpaceRotationalCouplingMatchesTheDampedOscillatorAtFirstOrder) {
  for (auto integ : {core::Integrator::kLinearlyImplicitEuler, core::Integrator::kSymplecticEuler}) {
    for (double zeta : {0.1, 0.7}) {
      const double e1 = rotational_error(integ, 1e-3, zeta, 2.0);
      const double e2 = rotational_error(integ, 5e-4, zeta, 2.0);
      std::printf("[rot oscillator %-10s zeta %.1f] max rel err dt=1ms %.3e  dt=0.5ms %.3e  ratio %.3f\n",
                  name(integ), zeta, e1, e2, e1 / e2);
      EXPECT_LT(e1, zeta < 0.5 ? 0.05 : 0.01) << name(integ) << " zeta " << zeta;
      EXPECT_NEAR(e1 / e2, 2.0, 0.15) << name(integ) << " zeta " << zeta;
    }
  }
}

// Observed order over a range of steps: e(h) / e(h/2) for h = 4, 2, 1 ms
// (three ratios), translational (ζ = 0.7) and rotational about a principal
// axis (ζ = 0.1). Theory: 2 for both Euler schemes, 4 for the trapezoidal rule and TR-BDF2.
TEST(Integrator, ObservedOrderIsTwoForTheTrapezoidalRuleAndTrBdf2AndOneForTheEulerSchemes) {
  for (auto integ : {core::Integrator::kLinearlyImplicitEuler, core::Integrator::kSymplecticEuler,
                     core::Integrator::kTrapezoidal, core::Integrator::kTrBdf2}) {
    const bool second = integ == core::Integrator::kTrapezoidal || integ == core::Integrator::kTrBdf2;
    const double expected = second ? 4.0 : 2.0;
    for (int kind = 0; kind < 2; ++kind) {
      double prev = 0.0;
      for (double h : {4e-3, 2e-3, 1e-3, 5e-4}) {
        const double e = kind == 0 ? translational_error(integ, h, 0.7, 2.0)
                                   : rotational_error(integ, h, 0.1, 2.0);
        if (prev > 0.0) {
          std::printf("[order %-11s %s] dt %.1e: err %.3e, ratio %.3f\n", name(integ),
                      kind == 0 ? "transl" : "rot   ", h, e, prev / e);
          EXPECT_NEAR(prev / e, expected, 0.1 * expected)
              << name(integ) << " h " << h << " kind " << kind;
        }
        prev = e;
      }
    }
  }
}

TEST(Integrator, TrapezoidalStepIsCrankNicolsonOnTheLinearOscillator) {
  // For linear forces the linearised trapezoidal step is exactly the
  // trapezoidal rule: Δv = (h f0 − ½ h² k v0) / (m + ½ h γ + ¼ h² k),
  // f0 = −k x0 − γ v0, v1 = v0 + Δv, x1 = x0 + ½ h (v0 + v1).
  const double m = 0.3, k = 250.0, gamma = 1.7, h = 2e-3;
  core::Model model = single_body(core::Integrator::kTrapezoidal, h, m, 0.01 * Mat3::Identity(),
                                  {k, gamma, 0.0, 0.0});
  core::Data d = core::make_data(model);
  d.target = core::Pose{};
  double x = 0.04, v = -0.3;
  d.bodies[0].position.x() = x;
  d.bodies[0].linear_velocity.x() = v;
  for (int i = 0; i < 500; ++i) {
    core::step(model, d);
    const double dv =
        (h * (-k * x - gamma * v) - 0.5 * h * h * k * v) / (m + 0.5 * h * gamma + 0.25 * h * h * k);
    x += 0.5 * h * (2.0 * v + dv);
    v += dv;
    ASSERT_NEAR(d.bodies[0].position.x(), x, 1e-14) << i;
    ASSERT_NEAR(d.bodies[0].linear_velocity.x(), v, 1e-13) << i;
  }
}

TEST(Integrator, TrapezoidalFreeFallIsExact) {
  core::Model m =
      single_body(core::Integrator::kTrapezoidal, 1e-3, 2.0, 0.01 * Mat3::Identity(), {});
  m.gravity = Vec3(0.0, 0.0, -9.81);
  m.initial_held_body = -1;
  core::Data d = core::make_data(m);
  for (int i = 0; i < 1000; ++i) core::step(m, d);
  EXPECT_NEAR(d.bodies[0].linear_velocity.z(), -9.81, 1e-10);
  EXPECT_NEAR(d.bodies[0].position.z(), -0.5 * 9.81, 1e-10);  // x = −g t²/2, no O(h) term
}

TEST(Integrator, TrapezoidalNeverGainsEnergyOnAStiffCoupling) {
  // k = 1e7 N/m on m = 0.01 kg at h = 1 ms (ω h = 31.6, where symplectic
  // Euler diverges): the trapezoidal rule is A-stable, so the damped linear
  // oscillator's energy ½ m v² + ½ k x² (and its rotational counterpart)
  // never grows; it is not L-stable, so the decay per step is only |R| ≈ 0.92
  // (R = (1 + z)/(1 − z), z = ½ h λ), against ≈ 0.03 for backward Euler.
  const double m = 0.01, k = 1e7, gamma = core::damping_from_ratio(0.7, m, k);
  const double k_r = 1e3, i0 = 1e-6, gamma_r = core::damping_from_ratio(0.7, i0, k_r);
  const core::Model model = single_body(core::Integrator::kTrapezoidal, 1e-3, m,
                                        i0 * Mat3::Identity(), {k, gamma, k_r, gamma_r});
  core::Data d = core::make_data(model);
  d.bodies[0].position = Vec3(0.01, -0.02, 0.005);
  d.bodies[0].orientation = rot(0.05, Vec3(1, 1, 0));
  const auto energy = [&]() {
    const core::BodyState& b = d.bodies[0];
    const double th = core::rotation_error(Quat::Identity(), b.orientation).norm();
    return 0.5 * m * b.linear_velocity.squaredNorm() + 0.5 * k * b.position.squaredNorm() +
           0.5 * i0 * b.angular_velocity.squaredNorm() + 0.5 * k_r * th * th;
  };
  double e_prev = energy();
  const double e0 = e_prev;
  for (int i = 0; i < 300; ++i) {
    core::step(model, d);
    ASSERT_EQ(d.status, core::kStepOk) << i;
    const double e = energy();
    // Rotation: θu is not exactly linear in the twist increments (quaternion
    // exponential), so allow rounding-size growth relative to E0.
    ASSERT_LE(e, e_prev + 1e-9 * e0) << i;
    e_prev = e;
  }
  EXPECT_LT(e_prev, 1e-6 * e0);
}

TEST(Integrator, TrapezoidalStepDoesNotAllocate) {
  core::Model m = single_body(core::Integrator::kTrapezoidal, 1e-3, 0.2, 1e-3 * Mat3::Identity(),
                              {1e3, 5.0, 1.0, 0.05});
  core::Data d = core::make_data(m);
  d.target.position = Vec3(0.01, 0.0, 0.0);
  numen::test::AllocationGuard guard;
  for (int i = 0; i < 1000; ++i) core::step(m, d);
  EXPECT_EQ(guard.count(), 0);
  EXPECT_EQ(d.status, core::kStepOk);
}

TEST(Integrator, TrapezoidalWithFirstOrderCouplingIsRefused) {
  core::Model m = single_body(core::Integrator::kTrapezoidal, 1e-3, 0.2, 1e-3 * Mat3::Identity(),
                              {1e3, 5.0, 1.0, 0.05});
  m.coupling_mode = core::CouplingMode::kFirstOrder;
  const std::string err = core::finalize_model(m);
  EXPECT_NE(err.find("trapezoidal"), std::string::npos) << err;
  EXPECT_NE(err.find("first-order"), std::string::npos) << err;
}

TEST(Integrator, LinearlyImplicitStepIsBackwardEulerOnTheLinearOscillator) {
  // For linear forces the linearised step is exactly backward Euler:
  // v1 = (m v0 − h k x0) / (m + h γ + h² k), x1 = x0 + h v1 (target at
  // rest at the origin). Catches a wrong right-hand side that a
  // convergence-order test alone would accept.
  const double m = 0.3, k = 250.0, gamma = 1.7, h = 2e-3;
  core::Model model = single_body(core::Integrator::kLinearlyImplicitEuler, h, m, 0.01 * Mat3::Identity(),
                                  {k, gamma, 0.0, 0.0});
  core::Data d = core::make_data(model);
  d.target = core::Pose{};
  double x = 0.04, v = -0.3;
  d.bodies[0].position.x() = x;
  d.bodies[0].linear_velocity.x() = v;
  for (int i = 0; i < 500; ++i) {
    core::step(model, d);
    v = (m * v - h * k * x) / (m + h * gamma + h * h * k);
    x += h * v;
    ASSERT_NEAR(d.bodies[0].position.x(), x, 1e-14) << i;
    ASSERT_NEAR(d.bodies[0].linear_velocity.x(), v, 1e-13) << i;
  }
}

TEST(Integrator, FreeFallIsExactForTheVelocity) {
  for (auto integ : {core::Integrator::kLinearlyImplicitEuler, core::Integrator::kSymplecticEuler}) {
    core::Model m = single_body(integ, 1e-3, 2.0, 0.01 * Mat3::Identity(), {});
    m.gravity = Vec3(0.0, 0.0, -9.81);
    m.initial_held_body = -1;
    core::Data d = core::make_data(m);
    for (int i = 0; i < 1000; ++i) core::step(m, d);
    EXPECT_NEAR(d.bodies[0].linear_velocity.z(), -9.81, 1e-10) << name(integ);
    // x_n = −g h² n(n+1)/2 for v-then-x Euler.
    EXPECT_NEAR(d.bodies[0].position.z(), -9.81 * 1e-6 * 1000.0 * 1001.0 / 2.0, 1e-9) << name(integ);
  }
}

TEST(Integrator, ImplicitIsStableOnAStiffCouplingWhereSymplecticDiverges) {
  // k = 1e7 N/m on m = 0.01 kg: ω_n h = 31.6 ≫ 2 at h = 1 ms.
  const double m = 0.01, k = 1e7, gamma = core::damping_from_ratio(0.7, m, k);
  const double k_r = 1e3, i0 = 1e-6, gamma_r = core::damping_from_ratio(0.7, i0, k_r);
  ASSERT_GT(std::sqrt(k / m) * 1e-3, 30.0);
  for (auto integ : {core::Integrator::kLinearlyImplicitEuler, core::Integrator::kSymplecticEuler}) {
    const core::Model model = single_body(integ, 1e-3, m, i0 * Mat3::Identity(), {k, gamma, k_r, gamma_r});
    core::Data d = core::make_data(model);
    const Vec3 x0(0.01, -0.02, 0.005);
    d.bodies[0].position = x0;
    d.bodies[0].orientation = rot(0.5, Vec3(1, 1, 0));
    double max_norm = 0.0;
    for (int i = 0; i < 200; ++i) {
      core::step(model, d);
      max_norm = std::max(max_norm, d.bodies[0].position.norm());
    }
    const double final_err = d.bodies[0].position.norm();
    const double final_angle = core::rotation_error(Quat::Identity(), d.bodies[0].orientation).norm();
    std::printf("[stiff %-10s] max |x| %.3e (|x0| %.3e), final |x| %.3e, final angle %.3e, nonfinite steps %lld\n",
                name(integ), max_norm, x0.norm(), final_err, final_angle,
                static_cast<long long>(d.nonfinite_steps));
    if (integ == core::Integrator::kLinearlyImplicitEuler) {
      EXPECT_LE(max_norm, x0.norm());
      EXPECT_LT(final_err, 1e-12);
      EXPECT_LT(final_angle, 1e-9);
      EXPECT_EQ(d.nonfinite_steps, 0);
    } else {
      // Diverges: either huge or rejected as non-finite by step()'s checks.
      EXPECT_TRUE(max_norm > 1e6 * x0.norm() || d.nonfinite_steps > 0);
    }
  }
  // The symplectic amplification per step explains it: |1 − hγ/m − h²k/m| ≫ 1.
  const double h = 1e-3;
  EXPECT_GT(std::abs(1.0 - h * gamma / m - h * h * k / m), 2.0);
}

namespace {

/// Three free bodies in a row along z with contacts: 0–static plane,
/// 1 on 0, 2 on 1; body 1 coupled. Contacts are filled by hand.
core::Model stack_model(core::Integrator integ) {
  core::Model m;
  m.dt = 2e-3;
  m.integrator = integ;
  m.material_pairs = {core::MaterialPair{2e4, 15.0, 3.0}};
  core::BodyModel b;
  b.mass = 0.2;
  b.inertia_body = Vec3(2e-4, 3e-4, 4e-4).asDiagonal();
  for (int i = 0; i < 3; ++i) {
    b.initial_pose.position = Vec3(0.01 * i, -0.005 * i, 0.05 + 0.1 * i);
    b.initial_pose.orientation = rot(0.2 * i, Vec3(1, 0, 1));
    b.initial_twist.linear = Vec3(0.05, -0.02 * i, -0.1);
    b.initial_twist.angular = Vec3(0.3, -0.2 * i, 0.5);
    m.bodies.push_back(b);
  }
  m.bodies[1].coupling = {300.0, 5.0, 0.5, 0.02};
  m.initial_held_body = 1;
  m.solver.tolerance = 1e-13;
  EXPECT_EQ(core::finalize_model(m), "");
  return m;
}

void fill_stack_contacts(core::Data& d) {
  const auto& s = d.bodies;
  auto add = [&](int a, int b, const Vec3& p, const Vec3& n, double depth) {
    core::Contact& c = d.contacts[static_cast<std::size_t>(d.num_contacts++)];
    c = core::Contact{};
    c.body_a = a;
    c.body_b = b;
    c.position = p;
    c.normal = n.normalized();
    c.depth = depth;
    c.material_pair = 0;
  };
  d.num_contacts = 0;
  add(0, -1, s[0].position + Vec3(0.02, 0.0, -0.05), Vec3::UnitZ(), 2e-3);
  add(0, -1, s[0].position + Vec3(-0.02, 0.01, -0.05), Vec3::UnitZ(), 1e-3);
  add(1, 0, 0.5 * (s[0].position + s[1].position) + Vec3(0.01, 0, 0), Vec3(0.1, 0.0, 1.0), 1.5e-3);
  add(2, 1, 0.5 * (s[1].position + s[2].position), Vec3(0.0, -0.2, 1.0), 1e-3);
}

Eigen::MatrixXd dense_operator(const core::Model& m, const core::Data& d) {
  const int n = 6 * m.num_bodies();
  Eigen::MatrixXd a(n, n);
  std::vector<Vec6> in(static_cast<std::size_t>(m.num_bodies())), out(in.size());
  for (int j = 0; j < n; ++j) {
    for (auto& v : in) v.setZero();
    in[static_cast<std::size_t>(j / 6)](j % 6) = 1.0;
    core::apply_implicit_system(m, d, in, out);
    for (int i = 0; i < n; ++i) a(i, j) = out[static_cast<std::size_t>(i / 6)](i % 6);
  }
  return a;
}

}  // namespace

TEST(Integrator, MatrixFreeOperatorEqualsDenseMassMinusHDMinusH2K) {
  const core::Model m = stack_model(core::Integrator::kLinearlyImplicitEuler);
  core::Data d = core::make_data(m);
  fill_stack_contacts(d);
  core::compute_forces(m, d);
  core::prepare_implicit_step(m, d);
  core::build_implicit_system(m, d);
  const double h = m.dt;
  const int n = 6 * m.num_bodies();
  // Dense reference: M − h D − h² K from the pair blocks of contact_stiffness_damping.
  Eigen::MatrixXd ref = Eigen::MatrixXd::Zero(n, n);
  for (int i = 0; i < m.num_bodies(); ++i) {
    ref.block<3, 3>(6 * i, 6 * i) = m.bodies[static_cast<std::size_t>(i)].mass * Mat3::Identity();
    ref.block<3, 3>(6 * i + 3, 6 * i + 3) =
        core::world_inertia(d.bodies[static_cast<std::size_t>(i)].orientation,
                            m.bodies[static_cast<std::size_t>(i)].inertia_body);
  }
  const core::CouplingGains& g = m.bodies[1].coupling;
  ref.block<3, 3>(6, 6) += (h * g.gamma_t + h * h * g.k_t) * Mat3::Identity();
  ref.block<3, 3>(9, 9) += (h * g.gamma_r + h * h * g.k_r) * Mat3::Identity();
  for (int c = 0; c < d.num_contacts; ++c) {
    const core::Contact& ct = d.contacts[static_cast<std::size_t>(c)];
    const core::ContactTerm& t = d.scratch->solver.contact_terms[static_cast<std::size_t>(c)];
    ASSERT_TRUE(t.active);
    Mat12 k, dmp;
    core::contact_stiffness_damping(ct.normal, t.r_a, t.r_b, true, m.material_pairs[0], k, dmp);
    const Mat12 a = -h * dmp - h * h * k;
    const int ia = 6 * ct.body_a;
    ref.block<6, 6>(ia, ia) += a.block<6, 6>(0, 0);
    if (ct.body_b >= 0) {
      const int ib = 6 * ct.body_b;
      ref.block<6, 6>(ia, ib) += a.block<6, 6>(0, 6);
      ref.block<6, 6>(ib, ia) += a.block<6, 6>(6, 0);
      ref.block<6, 6>(ib, ib) += a.block<6, 6>(6, 6);
    }
  }
  const Eigen::MatrixXd a = dense_operator(m, d);
  EXPECT_LT((a - ref).norm(), 1e-13 * ref.norm());
  EXPECT_LT((a - a.transpose()).norm(), 1e-14 * a.norm());
  // Preconditioner blocks are the diagonal blocks of A.
  for (int i = 0; i < m.num_bodies(); ++i)
    EXPECT_LT((d.scratch->solver.block[static_cast<std::size_t>(i)] - a.block<6, 6>(6 * i, 6 * i)).norm(),
              1e-13 * a.norm());
}

TEST(Integrator, ConjugateGradientMatchesADenseSolveWithBodyBodyContacts) {
  const core::Model m = stack_model(core::Integrator::kLinearlyImplicitEuler);
  core::Data d = core::make_data(m);
  fill_stack_contacts(d);
  core::compute_forces(m, d);
  core::prepare_implicit_step(m, d);
  core::build_implicit_system(m, d);
  ASSERT_TRUE(core::solve_implicit_system(m, d));
  const int n = 6 * m.num_bodies();
  Eigen::VectorXd b(n), x(n);
  for (int i = 0; i < m.num_bodies(); ++i) {
    b.segment<6>(6 * i) = d.scratch->solver.rhs[static_cast<std::size_t>(i)];
    x.segment<6>(6 * i) = d.scratch->solver.delta[static_cast<std::size_t>(i)];
  }
  const Eigen::VectorXd ref = dense_operator(m, d).llt().solve(b);
  std::printf("[pcg] body-body contacts: %d iterations, residual %.2e, |x - x_dense|/|x| %.2e\n",
              d.solver_iterations, d.solver_residual, (x - ref).norm() / ref.norm());
  EXPECT_LT((x - ref).norm(), 1e-10 * ref.norm());
  EXPECT_GT(d.solver_iterations, 1);
  EXPECT_LE(d.solver_iterations, 12);
  EXPECT_LE(d.solver_residual, m.solver.tolerance);
}

TEST(Integrator, ConjugateGradientEndsInOneIterationWithoutBodyBodyContacts) {
  const core::Model m = stack_model(core::Integrator::kLinearlyImplicitEuler);
  core::Data d = core::make_data(m);
  fill_stack_contacts(d);
  d.num_contacts = 2;  // keep only the two static contacts of body 0
  core::compute_forces(m, d);
  core::integrate(m, d);
  EXPECT_EQ(d.solver_iterations, 1);
  EXPECT_LE(d.solver_residual, m.solver.tolerance);
  EXPECT_EQ(d.status & core::kSolverNotConverged, 0u);
}

TEST(Integrator, SolverReportsNonConvergenceAtMaxIterations) {
  core::Model m = stack_model(core::Integrator::kLinearlyImplicitEuler);
  m.solver.max_iterations = 1;
  core::Data d = core::make_data(m);
  fill_stack_contacts(d);
  core::compute_forces(m, d);
  core::integrate(m, d);
  EXPECT_EQ(d.solver_iterations, 1);
  EXPECT_GT(d.solver_residual, m.solver.tolerance);
  EXPECT_TRUE(d.status & core::kSolverNotConverged);
}

TEST(Integrator, BrokenDiagonalFactorGivesANonFiniteResultNotASilentlyForceFreeStep) {
  // A non-positive pivot leaves NaN in a block's Cholesky factor. The solve must
  // then return a non-finite Δu (so that step() rolls the step back), not stop
  // with Δu = 0 and let every body coast without its forces.
  core::Model m = stack_model(core::Integrator::kLinearlyImplicitEuler);
  core::Data d = core::make_data(m);
  fill_stack_contacts(d);
  core::compute_forces(m, d);
  core::prepare_implicit_step(m, d);
  core::build_implicit_system(m, d);
  d.scratch->solver.block_factor[0].inv_diag(0) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(core::solve_implicit_system(m, d));
  EXPECT_FALSE(d.scratch->solver.delta[0].allFinite());
  EXPECT_TRUE(std::isnan(d.solver_residual));
}

TEST(Integrator, StageCallsWithBodyBodyContactsDoNotAllocate) {
  for (auto integ : {core::Integrator::kLinearlyImplicitEuler, core::Integrator::kSymplecticEuler,
                     core::Integrator::kTrapezoidal}) {
    const core::Model m = stack_model(integ);
    core::Data d = core::make_data(m);
    numen::test::AllocationGuard guard;
    for (int i = 0; i < 1000; ++i) {
      core::reset_data(m, d);  // keep the hand-made contacts meaningful
      fill_stack_contacts(d);
      core::compute_forces(m, d);
      core::integrate(m, d);
    }
    EXPECT_EQ(guard.count(), 0) << name(integ);
  }
}

TEST(Integrator, FastSpinAboutTheIntermediateAxisStaysBounded) {
  // Asymmetric inertia, 100 rad/s about the intermediate axis plus a small
  // perturbation: the unstable (tumbling) axis. 10 s at 1 ms.
  const Mat3 ib = Vec3(1e-3, 2e-3, 3e-3).asDiagonal();
  core::Model m = single_body(core::Integrator::kLinearlyImplicitEuler, 1e-3, 0.5, ib, {});
  m.initial_held_body = -1;
  m.bodies[0].initial_twist.angular = Vec3(0.1, 100.0, 0.1);
  ASSERT_EQ(core::finalize_model(m), "");
  for (auto integ : {core::Integrator::kLinearlyImplicitEuler, core::Integrator::kSymplecticEuler}) {
    m.integrator = integ;
    core::Data d = core::make_data(m);
    const double e0 = core::kinetic_energy(m.bodies[0], d.bodies[0]);
    const Vec3 l0 = core::world_inertia(d.bodies[0].orientation, ib) * d.bodies[0].angular_velocity;
    double e_max = e0, e_min = e0;
    bool finite = true;
    for (int i = 0; i < 10000; ++i) {
      core::step(m, d);
      finite = finite && core::state_is_finite(d.bodies[0]) && d.status == core::kStepOk;
      const double e = core::kinetic_energy(m.bodies[0], d.bodies[0]);
      e_max = std::max(e_max, e);
      e_min = std::min(e_min, e);
    }
    const Vec3 l1 = core::world_inertia(d.bodies[0].orientation, ib) * d.bodies[0].angular_velocity;
    std::printf("[spin %-10s] KE0 %.4f J, KE in [%.4f, %.4e] J over 10 s, |L1|/|L0| %.4f, angle(L0,L1) %.3e rad\n",
                name(integ), e0, e_min, e_max, l1.norm() / l0.norm(),
                std::acos(std::min(1.0, l0.normalized().dot(l1.normalized()))));
    if (integ == core::Integrator::kLinearlyImplicitEuler) {
      EXPECT_TRUE(finite);
      EXPECT_LE(e_max, e0 * (1.0 + 1e-9));  // never gains energy
      // Backward Euler on the gyroscopic term dissipates (|L1|² = L0·L1 for
      // the exact implicit step): about 90 % of the energy over these 10 s of
      // tumbling at ωh = 0.1. Bounded and alive, as Catto's scheme promises.
      EXPECT_GT(e_min, 0.05 * e0);
      EXPECT_LE(l1.norm(), l0.norm());
      EXPECT_LT(std::acos(std::min(1.0, l0.normalized().dot(l1.normalized()))), 0.2);
    }
  }
}
