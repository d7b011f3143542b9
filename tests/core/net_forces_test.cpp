// Tests of core/net_forces: spring, tie, gravity and node-contact forces
// against hand values and against the header's formulas, the ties' reaction
// on the rigid component (force and torque about its COM), the node contact
// law (= contact_penalty_force, node on side a) and its reaction on a body,
// a finite-difference check of the spring stiffness the implicit solve uses
// (K̃ = (1 − τ) d̂d̂ᵀ + τ I while stretched, axial part only under
// compression), the explicit and implicit node updates, and measure_nets.
#include "numen/core/net_forces.hpp"

#include <Eigen/Eigenvalues>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "numen/core/contact_force.hpp"
#include "numen/core/data.hpp"
#include "numen/core/integrator.hpp"
#include "numen/core/mesh.hpp"
#include "numen/core/model.hpp"
#include "numen/core/rigid_body.hpp"
#include "numen/core/step.hpp"

#include "scratch/data_scratch.hpp"
#include "solver/implicit_system.hpp"
#include "net/net_solve.hpp"
#include "net_states.hpp"
#include "step_deformable_nets.hpp"

namespace core = numen::core;
using core::Mat3;
using core::Quat;
using core::Vec3;

namespace {

using numen::test::at;

/// The linearisation of spring e of Model::net_springs (stored in the sweep order).
core::SweepSpring spring_term(const core::Data& d, int e) {
  return d.scratch->net.sweep_springs[at(d.scratch->net.spring_slot[at(e)])];
}

/// The length of spring e of Model::net_springs at the last compute_net_forces().
double spring_length(const core::Data& d, int e) { return d.scratch->net.spring_length[at(d.scratch->net.spring_slot[at(e)])]; }

using numen::test::deformable_nets::triangle;  // equilateral, in the body's x–y plane

/// Body 0: the rigid component (no spheres) at a general pose and twist;
/// body 1: an obstacle body for node–body contacts. One net on body 0.
core::Model scene(const core::TriangleMesh& mesh, double k = 50.0, double gamma = 0.4,
                  double k_tie = 200.0, double gamma_tie = 0.7) {
  core::Model m;
  m.gravity = Vec3(0.3, -0.2, -9.81);
  m.material_names = {"tool", "tissue"};
  m.material_pairs = {core::MaterialPair{1e3, 5.0, 0.2}, core::MaterialPair{2e3, 3.0, 0.5},
                      core::MaterialPair{2e3, 3.0, 0.5}, core::MaterialPair{5e3, 1.0, 0.0}};
  core::BodyModel b;
  b.name = "core";
  b.mass = 0.3;
  b.inertia_body = Vec3(1e-3, 2e-3, 3e-3).asDiagonal();
  b.initial_pose.position = Vec3(0.05, -0.02, 0.3);
  b.initial_pose.orientation = Quat(Eigen::AngleAxisd(0.6, Vec3(1, -1, 2).normalized()));
  b.initial_twist.linear = Vec3(0.1, 0.2, -0.3);
  b.initial_twist.angular = Vec3(0.5, -1.0, 2.0);
  core::BodyModel other;
  other.name = "other";
  other.mass = 0.5;
  other.initial_pose.position = Vec3(0.0, 0.2, 0.0);
  other.initial_twist.linear = Vec3(-0.2, 0.0, 0.1);
  other.initial_twist.angular = Vec3(0.0, 3.0, -1.0);
  m.bodies = {b, other};
  m.initial_held_body = -1;
  core::NetSettings s;
  s.name = "net";
  s.body = 0;
  s.material = 1;
  s.mass = 0.06;
  s.stiffness = k;
  s.damping = gamma;
  s.bending_stiffness = 0.5 * k;
  s.bending_damping = 0.5 * gamma;
  s.tie_stiffness = k_tie;
  s.tie_damping = gamma_tie;
  EXPECT_EQ(core::add_net(m, mesh, s), "");
  EXPECT_EQ(core::finalize_model(m), "");
  return m;
}

/// Reference explicit force on every node, from net_forces.hpp's formulas.
std::vector<Vec3> reference_forces(const core::Model& m, const core::Data& d,
                                   std::vector<Vec3>* tie_force = nullptr) {
  std::vector<Vec3> f(d.nodes.size());
  for (std::size_t i = 0; i < f.size(); ++i) f[i] = m.node_mass[i] * m.gravity;
  for (const core::NetSpring& s : m.net_springs) {
    const Vec3 dx = d.nodes[at(s.node_b)].position - d.nodes[at(s.node_a)].position;
    const double l = dx.norm();
    const Vec3 n = dx / l;
    const Vec3 dv = d.nodes[at(s.node_b)].velocity - d.nodes[at(s.node_a)].velocity;
    const Vec3 fa = s.stiffness * (l - s.rest_length) * n + s.damping * n.dot(dv) * n;
    f[at(s.node_a)] += fa;
    f[at(s.node_b)] -= fa;
  }
  if (tie_force) tie_force->assign(f.size(), Vec3::Zero());
  for (const core::NetModel& net : m.nets) {
    const core::BodyState& b = d.bodies[at(net.body)];
    for (int v = net.node_begin; v < net.node_begin + net.node_count; ++v) {
      const Vec3 rho = b.orientation * m.node_rest[at(v)];
      const Vec3 a = b.position + rho;
      const Vec3 va = b.linear_velocity + b.angular_velocity.cross(rho);
      const Vec3 t = -net.tie_stiffness * (d.nodes[at(v)].position - a) -
                     net.tie_damping * (d.nodes[at(v)].velocity - va);
      f[at(v)] += t;
      if (tie_force) (*tie_force)[at(v)] = t;
    }
  }
  return f;
}

/// Moves every node off its anchor by a deterministic pseudo-random offset
/// (≤ `dx` per axis) and velocity (≤ `dv`).

/// Forces stage of step() for the current states.
void forces(const core::Model& m, core::Data& d) {
  core::compute_forces(m, d);
  // The implicit solve's linearisation (net_forces.hpp), for the tests that read it.
  core::linearize_nets(m, d, core::linearized_system_step(m));
}

}  // namespace

TEST(NetForces, SpringAndTieForcesAgainstHandValues) {
  // Two nodes on x (a strip of one triangle whose third node sits exactly at
  // its anchor), rigid component at rest at the origin, no gravity.
  core::Model m = scene(triangle(0.1), 50.0, 2.0, 200.0, 0.5);
  m.gravity.setZero();
  m.bodies[0].initial_pose = core::Pose{};
  m.bodies[0].initial_twist = core::Twist{};
  ASSERT_EQ(core::finalize_model(m), "");
  core::Data d = core::make_data(m);
  // Node 0 is at (r, 0, 0), node 1 at (r cos 120°, r sin 120°, 0): spring 0–1 is an edge of length 0.1.
  const Vec3 a0 = d.nodes[0].position, a1 = d.nodes[1].position, a2 = d.nodes[2].position;
  // Stretch the edge 0–1 by 2 cm along itself, node 1 moving away at 0.3 m/s along it.
  const Vec3 u = (a1 - a0).normalized();
  d.nodes[1].position = a1 + 0.02 * u;
  d.nodes[1].velocity = 0.3 * u + Vec3(0, 0, 0.4);  // the z part is transverse: not damped by the spring
  forces(m, d);
  // Spring 0–1: k ΔL + γ d̂·Δv = 50·0.02 + 2·0.3 = 1.6 N along u on node 0.
  // Spring 1–2: node 1 moved by 0.02 u; length change by hand.
  const double l12 = (a2 - d.nodes[1].position).norm();
  const Vec3 u12 = (a2 - d.nodes[1].position) / l12;
  const Vec3 f12_on_1 = (50.0 * (l12 - 0.1) + 2.0 * u12.dot(-d.nodes[1].velocity)) * u12;
  // Tie on node 1: −200·0.02 u − 0.5 v1 = −4 u − 0.5 v1.
  const Vec3 tie1 = -4.0 * u - 0.5 * d.nodes[1].velocity;
  EXPECT_TRUE(d.scratch->net.force[0].isApprox(1.6 * u, 1e-12)) << d.scratch->net.force[0].transpose();
  EXPECT_TRUE(d.scratch->net.force[1].isApprox(-1.6 * u + f12_on_1 + tie1, 1e-12)) << d.scratch->net.force[1].transpose();
  EXPECT_TRUE(d.scratch->net.force[2].isApprox(-f12_on_1, 1e-12));
  // The tie reaction on the rigid component: −tie1 at the anchor a1.
  EXPECT_TRUE(d.nets[0].tie_wrench.force.isApprox(-tie1, 1e-12));
  EXPECT_TRUE(d.nets[0].tie_wrench.torque.isApprox(a1.cross(-tie1), 1e-12));
  EXPECT_TRUE(d.body_wrench[0].force.isApprox(-tie1, 1e-12));
  EXPECT_NEAR(spring_length(d, 0), 0.12, 1e-15);  // edge 0–1, sorted first
  EXPECT_TRUE(spring_term(d, 0).direction.isApprox(u, 1e-14));
}

TEST(NetForces, GeneralStateMatchesTheHeaderFormulasAndTheReactionBalances) {
  const core::Model m = scene(core::make_icosphere(0.04, 1));
  core::Data d = core::make_data(m);
  numen::test::perturb_nodes(d, 3e-3, 0.2);
  d.applied_wrench[0].force = Vec3(1.0, 2.0, 3.0);
  d.applied_wrench[0].torque = Vec3(0.01, -0.02, 0.03);
  forces(m, d);
  std::vector<Vec3> tie;
  const std::vector<Vec3> ref = reference_forces(m, d, &tie);
  double scale = 0.0;
  for (const Vec3& f : ref) scale = std::max(scale, f.norm());
  for (std::size_t i = 0; i < ref.size(); ++i)
    EXPECT_LT((d.scratch->net.force[i] - ref[i]).norm(), 1e-12 * scale) << i;
  // Rigid component: gravity + applied − Σ f_tie, torque −Σ ρ × f_tie about its COM.
  const core::BodyState& b = d.bodies[0];
  Vec3 fr = Vec3::Zero(), tr = Vec3::Zero();
  for (std::size_t i = 0; i < tie.size(); ++i) {
    const Vec3 rho = b.orientation * m.node_rest[i];
    fr -= tie[i];
    tr -= rho.cross(tie[i]);
    EXPECT_TRUE(d.scratch->net.lever[i].isApprox(rho, 1e-14)) << i;
  }
  EXPECT_GT(fr.norm(), 0.1);
  EXPECT_TRUE(d.nets[0].tie_wrench.force.isApprox(fr, 1e-12));
  EXPECT_TRUE(d.nets[0].tie_wrench.torque.isApprox(tr, 1e-12));
  const Vec3 f_body = m.bodies[0].mass * m.gravity + d.applied_wrench[0].force + fr;
  const Vec3 t_body = d.applied_wrench[0].torque + tr;
  EXPECT_TRUE(d.body_wrench[0].force.isApprox(f_body, 1e-12));
  EXPECT_TRUE(d.body_wrench[0].torque.isApprox(t_body, 1e-12));
  // Internal forces cancel: Σ node forces + tie reaction = net gravity.
  Vec3 total = fr;
  for (const Vec3& f : d.scratch->net.force) total += f;
  EXPECT_TRUE(total.isApprox(m.nets[0].mass * m.gravity, 1e-10));
}

TEST(NetForces, SpringBlockAndTieSumsMatchTheirDefinitions) {
  // The sums compute_net_forces() leaves for the implicit system: Σ W_e over
  // each node's springs (both ends, 6 entries) and the ties' Σ ρ, Σ ρρᵀ,
  // Σ Jᵀ (v − v_a) of the rigid component's rows (NetTieSums).
  const core::Model m = scene(core::make_icosphere(0.04, 1));
  ASSERT_NE(m.integrator, core::Integrator::kSymplecticEuler);
  core::Data d = core::make_data(m);
  numen::test::perturb_nodes(d, 3e-3, 0.2);
  forces(m, d);
  std::vector<Mat3> ref(d.nodes.size(), Mat3::Zero());
  for (std::size_t e = 0; e < m.net_springs.size(); ++e) {
    const core::SweepSpring w = spring_term(d, static_cast<int>(e));
    const Mat3 we = w.weight_axial * w.direction * w.direction.transpose() +
                    w.weight_isotropic * Mat3::Identity();
    ref[at(m.net_springs[e].node_a)] += we;
    ref[at(m.net_springs[e].node_b)] += we;
  }
  double scale = 0.0;
  for (const Mat3& r : ref) scale = std::max(scale, r.norm());
  ASSERT_GT(scale, 0.0);
  for (std::size_t i = 0; i < ref.size(); ++i) {
    const double* s = d.scratch->net.spring_block[i].entry;
    const double got[6] = {s[0], s[1], s[2], s[3], s[4], s[5]};
    const double want[6] = {ref[i](0, 0), ref[i](0, 1), ref[i](0, 2),
                            ref[i](1, 1), ref[i](1, 2), ref[i](2, 2)};
    for (int c = 0; c < 6; ++c) EXPECT_NEAR(got[c], want[c], 1e-14 * scale) << i << " " << c;
  }
  const core::BodyState& b = d.bodies[0];
  Vec3 sum_r = Vec3::Zero(), sum_dv = Vec3::Zero(), sum_r_dv = Vec3::Zero();
  Mat3 sum_rr = Mat3::Zero();
  double sum_abs_r = 0.0;  // Σ ρ is ~0 on the icosphere: compared against Σ |ρ|
  for (std::size_t i = 0; i < d.nodes.size(); ++i) {
    const Vec3 rho = b.orientation * m.node_rest[i];
    const Vec3 dv = d.nodes[i].velocity - (b.linear_velocity + b.angular_velocity.cross(rho));
    sum_abs_r += rho.norm();
    sum_r += rho;
    sum_rr += rho * rho.transpose();
    sum_dv += dv;
    sum_r_dv += rho.cross(dv);
  }
  const core::NetTieSums& t = d.scratch->net.tie_sums[0];
  EXPECT_LT((t.lever_sum - sum_r).norm(), 1e-14 * sum_abs_r) << t.lever_sum.transpose();
  EXPECT_TRUE(t.lever_moment.isApprox(sum_rr, 1e-12));
  EXPECT_EQ(t.lever_moment, t.lever_moment.transpose());  // exactly symmetric
  EXPECT_TRUE(t.relative.head<3>().isApprox(sum_dv, 1e-12)) << t.relative.transpose();
  EXPECT_TRUE(t.relative.tail<3>().isApprox(sum_r_dv, 1e-12)) << t.relative.transpose();
  EXPECT_GT(sum_r_dv.norm(), 1e-4);  // the perturbed velocities make every sum non-trivial
}

TEST(NetForces, TheForcesStageGivesTheNetsEnergyAtTheStepsStart) {
  // NetOutput::start_energy: ½ m |v|² + ½ k_tie |x − a|² over the nodes + ½ k (l − L)² over
  // every spring (bending ones included) − Σ m g · x, from the forces stage's own terms (an
  // odd spring out per node included: the icosphere's nodes have 5 or 6 springs of each kind).
  const core::Model m = scene(core::make_icosphere(0.04, 1));
  core::Data d = core::make_data(m);
  numen::test::perturb_nodes(d, 2e-3, 0.2);
  const core::BodyState& b = d.bodies[0];
  const core::NetModel& net = m.nets[0];
  double kinetic = 0.0, elastic = 0.0, gravity = 0.0;
  for (std::size_t i = 0; i < d.nodes.size(); ++i) {
    const Vec3 a = b.position + b.orientation * m.node_rest[i];
    kinetic += 0.5 * m.node_mass[i] * d.nodes[i].velocity.squaredNorm();
    elastic += 0.5 * net.tie_stiffness * (d.nodes[i].position - a).squaredNorm();
    gravity -= m.node_mass[i] * m.gravity.dot(d.nodes[i].position);
  }
  double springs = 0.0;
  for (int e = 0; e < net.structural_count + net.bending_count; ++e) {
    const core::NetSpring& s = m.net_springs[at(e)];
    const double l = (d.nodes[at(s.node_b)].position - d.nodes[at(s.node_a)].position).norm();
    springs += 0.5 * s.stiffness * (l - s.rest_length) * (l - s.rest_length);
  }
  EXPECT_GT(kinetic, 0.0);
  EXPECT_GT(springs, 0.0);
  const double total = kinetic + elastic + springs + gravity;
  forces(m, d);
  EXPECT_NEAR(d.nets[0].start_energy, total, 1e-13 * (kinetic + elastic + springs + std::abs(gravity)));
  // A NaN node is kept.
  d.nodes[7].position.x() = std::numeric_limits<double>::quiet_NaN();
  forces(m, d);
  EXPECT_TRUE(std::isnan(d.nets[0].start_energy));
}

TEST(NetForces, AtRestOnTheRigidComponentOnlyGravityActs) {
  const core::Model m = scene(core::make_icosphere(0.04, 1));
  core::Data d = core::make_data(m);
  forces(m, d);
  // Nodes on their anchors with the anchors' velocities: ties and springs vanish
  // (a rigid motion, including the spin, is not damped by the springs).
  for (std::size_t i = 0; i < d.nodes.size(); ++i)
    EXPECT_LT((d.scratch->net.force[i] - m.node_mass[i] * m.gravity).norm(), 1e-12) << i;
  EXPECT_LT(d.nets[0].tie_wrench.force.norm(), 1e-12);
  EXPECT_LT(d.nets[0].tie_wrench.torque.norm(), 1e-12);
}

TEST(NetForces, NodeContactForceIsThePenaltyLawWithItsReactionOnTheBody) {
  const core::Model m = scene(core::make_icosphere(0.04, 0));
  core::Data d = core::make_data(m);
  numen::test::perturb_nodes(d, 1e-3, 0.3);
  // Three hand-made contacts: node 2 on a static obstacle, node 5 on body 1,
  // node 7 separating so fast that the contact pulls → inactive.
  d.num_node_contacts = 3;
  core::NodeContact& c0 = d.node_contacts[0];
  c0.node = 2;
  c0.body_b = -1;
  c0.obstacle = 0;
  c0.material_pair = 1;
  c0.position = d.nodes[2].position - Vec3(0, 0, 0.01);
  c0.normal = Vec3(0.0, 0.6, 0.8);
  c0.depth = 2e-3;
  core::NodeContact& c1 = d.node_contacts[1];
  c1.node = 5;
  c1.body_b = 1;
  c1.sphere_b = 0;
  c1.material_pair = 3;
  c1.position = d.nodes[5].position + Vec3(0.003, -0.002, 0.001);
  c1.normal = Vec3(1, 2, -2) / 3.0;
  c1.depth = 1e-3;
  core::NodeContact& c2 = d.node_contacts[2];
  c2 = c0;
  c2.node = 7;
  c2.normal = Vec3::UnitZ();
  c2.depth = 1e-4;
  d.nodes[7].velocity = Vec3(0, 0, 5.0);  // k d − c v_n = 2e3·1e-4 − 3·5 < 0
  const std::vector<Vec3> without = reference_forces(m, d);
  forces(m, d);

  // Static contact: v_rel = v_node.
  const core::ContactForceResult r0 =
      core::contact_penalty_force(c0.normal, c0.depth, d.nodes[2].velocity, m.material_pairs[1]);
  EXPECT_TRUE(r0.active);
  EXPECT_EQ(c0.force, r0.force);
  EXPECT_TRUE(c0.active);
  EXPECT_NEAR(c0.normal_velocity, c0.normal.dot(d.nodes[2].velocity), 1e-15);
  EXPECT_TRUE(c0.r_b.isZero(0.0));
  EXPECT_TRUE(d.scratch->net.force[2].isApprox(without[2] + r0.force, 1e-12));
  // By hand: f_n = k d − c v_n, friction −μ v_t.
  const Vec3 v2 = d.nodes[2].velocity;
  const double vn = c0.normal.dot(v2);
  const Vec3 hand = (2e3 * 2e-3 - 3.0 * vn) * c0.normal - 0.5 * (v2 - vn * c0.normal);
  EXPECT_TRUE(r0.force.isApprox(hand, 1e-12));

  // Body contact: v_rel = v_node − (v_b + ω_b × r_b), r_b = point − COM of body 1.
  const core::BodyState& b1 = d.bodies[1];
  const Vec3 r_b = c1.position - b1.position;
  const Vec3 v_rel = d.nodes[5].velocity - (b1.linear_velocity + b1.angular_velocity.cross(r_b));
  const core::ContactForceResult r1 =
      core::contact_penalty_force(c1.normal, c1.depth, v_rel, m.material_pairs[3]);
  ASSERT_TRUE(r1.active);
  EXPECT_EQ(c1.force, r1.force);
  EXPECT_TRUE(c1.r_b.isApprox(r_b, 1e-15));
  EXPECT_NEAR(c1.normal_velocity, c1.normal.dot(v_rel), 1e-15);
  EXPECT_TRUE(d.scratch->net.force[5].isApprox(without[5] + r1.force, 1e-12));
  EXPECT_TRUE(d.body_wrench[1].force.isApprox(m.bodies[1].mass * m.gravity - r1.force, 1e-12));
  EXPECT_TRUE(d.body_wrench[1].torque.isApprox(-r_b.cross(r1.force), 1e-12));

  // Pulling contact: inactive, no force anywhere.
  EXPECT_FALSE(c2.active);
  EXPECT_TRUE(c2.force.isZero(0.0));
  EXPECT_TRUE(d.scratch->net.force[7].isApprox(without[7], 1e-12));
}

namespace {

/// The solve's spring linearisation: S / h² = k K̃ (γ = 0), from the
/// SweepSpring weights after build_net_system (S = α d̂d̂ᵀ + β I).
Mat3 solver_spring_stiffness(const core::Model& m, core::Data& d, int spring) {
  core::compute_forces(m, d);
  core::linearize_nets(m, d, d.scratch->solver.system_step);
  core::prepare_implicit_step(m, d);
  core::build_implicit_system(m, d);
  core::build_net_system(m, d);
  const core::SweepSpring& t = spring_term(d, spring);
  const double h2 = m.dt * m.dt;
  return (t.weight_axial * t.direction * t.direction.transpose() + t.weight_isotropic * Mat3::Identity()) / h2;
}

/// ∂f_b/∂x_a of the spring a–b by central differences of compute_net_forces
/// (node b's force depends on x_a through that spring only). Equals +k K.
Mat3 finite_difference_coupling(const core::Model& m, core::Data& d, int a, int b) {
  Mat3 jac;
  const double eps = 1e-7;
  const Vec3 x = d.nodes[at(a)].position;
  for (int c = 0; c < 3; ++c) {
    d.nodes[at(a)].position = x + eps * Vec3::Unit(c);
    core::compute_forces(m, d);
    const Vec3 fp = d.scratch->net.force[at(b)];
    d.nodes[at(a)].position = x - eps * Vec3::Unit(c);
    core::compute_forces(m, d);
    const Vec3 fm = d.scratch->net.force[at(b)];
    jac.col(c) = (fp - fm) / (2.0 * eps);
  }
  d.nodes[at(a)].position = x;
  return jac;
}

}  // namespace

TEST(NetForces, SpringStiffnessOfTheSolveMatchesFiniteDifferencesWhenStretched) {
  // Undamped springs so that S = h² k K̃ exactly.
  const core::Model m = scene(triangle(0.1), 80.0, 0.0, 200.0, 0.0);
  core::Data d = core::make_data(m);
  // Stretch the edge 0–1 (spring 0) by 30 % and tilt it out of plane.
  const Vec3 a0 = d.nodes[0].position;
  d.nodes[1].position = a0 + 1.3 * (d.nodes[1].position - a0) + Vec3(0.0, 0.0, 0.02);
  const Mat3 fd = finite_difference_coupling(m, d, 0, 1);  // ∂f_1/∂x_0 = k K̃
  const Vec3 dx = d.nodes[1].position - d.nodes[0].position;
  const double l = dx.norm(), big_l = 0.1, k = 80.0;
  ASSERT_GT(l, big_l);
  const double tau = 1.0 - big_l / l;
  const Vec3 n = dx / l;
  const Mat3 documented = k * ((1.0 - tau) * n * n.transpose() + tau * Mat3::Identity());
  EXPECT_LT((fd - documented).norm(), 1e-6 * documented.norm()) << "FD\n" << fd << "\ndoc\n" << documented;
  core::Data dd = d;
  const Mat3 solver = solver_spring_stiffness(m, dd, 0);
  EXPECT_LT((solver - documented).norm(), 1e-9 * documented.norm()) << solver;
  EXPECT_NEAR(spring_term(dd, 0).weight_isotropic, m.dt * m.dt * k * tau, 1e-15);
  // The transverse stiffness is really there: a sideways push is resisted by k τ.
  const Vec3 side = n.cross(Vec3::UnitX()).normalized();
  EXPECT_NEAR(side.dot(fd * side), k * tau, 1e-5 * k);
}

TEST(NetForces, UnderCompressionTheSolveDropsTheNegativeTransverseTerm) {
  const core::Model m = scene(triangle(0.1), 80.0, 0.0, 200.0, 0.0);
  core::Data d = core::make_data(m);
  const Vec3 a0 = d.nodes[0].position;
  d.nodes[1].position = a0 + 0.7 * (d.nodes[1].position - a0) + Vec3(0.0, 0.0, 0.01);
  const Mat3 fd = finite_difference_coupling(m, d, 0, 1);
  const Vec3 dx = d.nodes[1].position - d.nodes[0].position;
  const double l = dx.norm(), big_l = 0.1, k = 80.0;
  ASSERT_LT(l, big_l);
  const Vec3 n = dx / l;
  // The exact Jacobian has τ = 1 − L/l < 0: a negative transverse stiffness.
  const double tau = 1.0 - big_l / l;
  const Mat3 exact = k * ((1.0 - tau) * n * n.transpose() + tau * Mat3::Identity());
  EXPECT_LT((fd - exact).norm(), 1e-6 * exact.norm());
  core::Data dd = d;
  const Mat3 solver = solver_spring_stiffness(m, dd, 0);
  const Mat3 axial = k * n * n.transpose();
  EXPECT_LT((solver - axial).norm(), 1e-9 * k) << solver;
  EXPECT_EQ(spring_term(dd, 0).weight_isotropic, 0.0);
  // Same axial stiffness as the exact Jacobian; transverse 0 instead of k τ < 0.
  EXPECT_NEAR(n.dot(fd * n), k, 1e-5 * k);
  EXPECT_NEAR(n.dot(solver * n), k, 1e-9 * k);
  const Vec3 side = n.cross(Vec3::UnitX()).normalized();
  EXPECT_LT(side.dot(fd * side), -0.1 * k);
  EXPECT_NEAR(side.dot(solver * side), 0.0, 1e-9 * k);
  EXPECT_GE(Eigen::SelfAdjointEigenSolver<Mat3>(solver).eigenvalues().minCoeff(), -1e-9 * k);
}

TEST(NetForces, TieAndDampingJacobiansByFiniteDifferences) {
  // ∂f_i/∂x_i = −k_tie I − Σ k K̃ and ∂f_i/∂v_i = −γ_tie I − Σ γ d̂d̂ᵀ, on the
  // rest shape (τ = 0) of the triangle: each node has two springs.
  const double k = 60.0, gamma = 0.8, k_tie = 150.0, gamma_tie = 0.3;
  // At rest: with relative velocities the damping term has a geometric
  // Jacobian (change of d̂) that the solve neglects by design (net_solve.hpp).
  core::Model m = scene(triangle(0.1), k, gamma, k_tie, gamma_tie);
  m.bodies[0].initial_twist = core::Twist{};
  ASSERT_EQ(core::finalize_model(m), "");
  core::Data d = core::make_data(m);
  const Vec3 x = d.nodes[0].position, v = d.nodes[0].velocity;
  Mat3 kx, kv;
  const double eps = 1e-7;
  for (int c = 0; c < 3; ++c) {
    d.nodes[0].position = x + eps * Vec3::Unit(c);
    core::compute_forces(m, d);
    Vec3 fp = d.scratch->net.force[0];
    d.nodes[0].position = x - eps * Vec3::Unit(c);
    core::compute_forces(m, d);
    kx.col(c) = (fp - d.scratch->net.force[0]) / (2 * eps);
    d.nodes[0].position = x;
    d.nodes[0].velocity = v + eps * Vec3::Unit(c);
    core::compute_forces(m, d);
    fp = d.scratch->net.force[0];
    d.nodes[0].velocity = v - eps * Vec3::Unit(c);
    core::compute_forces(m, d);
    kv.col(c) = (fp - d.scratch->net.force[0]) / (2 * eps);
    d.nodes[0].velocity = v;
  }
  Mat3 ek = -k_tie * Mat3::Identity(), ev = -gamma_tie * Mat3::Identity();
  for (int j : {1, 2}) {
    const Vec3 n = (d.nodes[at(j)].position - x).normalized();
    ek -= k * n * n.transpose();
    ev -= gamma * n * n.transpose();
  }
  EXPECT_LT((kx - ek).norm(), 1e-5 * ek.norm()) << kx;
  EXPECT_LT((kv - ev).norm(), 1e-6 * ev.norm()) << kv;
}

TEST(NetForces, ZeroLengthSpringKeepsItsLastDirection) {
  const core::Model m = scene(triangle(0.1), 50.0, 0.0);
  core::Data d = core::make_data(m);
  core::compute_forces(m, d);
  const Vec3 dir = spring_term(d, 0).direction;
  d.nodes[1].position = d.nodes[0].position;  // spring 0–1 collapses
  core::compute_forces(m, d);
  EXPECT_EQ(spring_term(d, 0).direction, dir);
  EXPECT_EQ(spring_length(d, 0), 0.0);
  for (const Vec3& f : d.scratch->net.force) EXPECT_TRUE(f.allFinite());
  // f_0 = k (0 − L) d̂ + ties + other spring + gravity: the collapsed spring pushes node 0 back along −d̂.
  const double push = -50.0 * 0.1;
  // Remove everything but the collapsed spring from node 0's force.
  const Vec3 x0 = d.nodes[0].position;
  const core::BodyState& b = d.bodies[0];
  const Vec3 anchor = b.position + b.orientation * m.node_rest[0];
  const Vec3 va = b.linear_velocity + b.angular_velocity.cross(b.orientation * m.node_rest[0]);
  const Vec3 ftie = -m.nets[0].tie_stiffness * (x0 - anchor) - m.nets[0].tie_damping * (d.nodes[0].velocity - va);
  const Vec3 d02 = d.nodes[2].position - x0;
  const Vec3 f02 = 50.0 * (d02.norm() - 0.1) * d02.normalized();
  EXPECT_TRUE((d.scratch->net.force[0] - ftie - f02 - m.node_mass[0] * m.gravity).isApprox(push * dir, 1e-10));
}

TEST(NetForces, NodeUpdatesSymplecticAndImplicit) {
  const core::Model m = scene(core::make_icosphere(0.04, 0));
  core::Data d = core::make_data(m);
  numen::test::perturb_nodes(d, 1e-3, 0.1);
  core::compute_forces(m, d);
  const std::vector<core::NodeState> s0 = d.nodes;
  core::integrate_nodes_symplectic(m, d);
  const double h = m.dt;
  for (std::size_t i = 0; i < d.nodes.size(); ++i) {
    const Vec3 v1 = s0[i].velocity + (h / m.node_mass[i]) * d.scratch->net.force[i];
    EXPECT_TRUE(d.nodes[i].velocity.isApprox(v1, 1e-15));
    EXPECT_TRUE(d.nodes[i].position.isApprox(s0[i].position + h * v1, 1e-15));
  }
  d.nodes = s0;
  for (std::size_t i = 0; i < d.nodes.size(); ++i) d.scratch->net.delta[i] = Vec3(0.01 * i, -0.02, 0.3);
  core::integrate_nodes_implicit(m, d);
  for (std::size_t i = 0; i < d.nodes.size(); ++i) {
    const Vec3 v1 = s0[i].velocity + d.scratch->net.delta[i];
    EXPECT_TRUE(d.nodes[i].velocity.isApprox(v1, 1e-15));
    EXPECT_TRUE(d.nodes[i].position.isApprox(s0[i].position + h * v1, 1e-15));
  }
}

TEST(NetForces, MeasureNetsObservables) {
  const core::Model m = scene(core::make_icosphere(0.04, 1));
  core::Data d = core::make_data(m);
  numen::test::perturb_nodes(d, 2e-3, 0.2);
  d.nodes[17].position += Vec3(0.0, 0.01, 0.0);  // the largest stretch
  core::measure_nets(m, d);
  const core::BodyState& b = d.bodies[0];
  double stretch = 0.0, speed = 0.0, ke = 0.0, strain = 0.0;
  for (std::size_t i = 0; i < d.nodes.size(); ++i) {
    stretch = std::max(stretch, (d.nodes[i].position - b.position - b.orientation * m.node_rest[i]).norm());
    speed = std::max(speed, d.nodes[i].velocity.norm());
    ke += 0.5 * m.node_mass[i] * d.nodes[i].velocity.squaredNorm();
  }
  const core::NetModel& net = m.nets[0];
  double bend_strain = 0.0;
  for (int e = 0; e < net.structural_count + net.bending_count; ++e) {
    const core::NetSpring& s = m.net_springs[at(e)];
    const double l = (d.nodes[at(s.node_b)].position - d.nodes[at(s.node_a)].position).norm();
    const double eps = std::abs(l - s.rest_length) / s.rest_length;
    if (e < net.structural_count) {
      strain = std::max(strain, eps);
    } else {
      bend_strain = std::max(bend_strain, eps);
    }
  }
  EXPECT_GT(bend_strain, 0.0);
  EXPECT_NEAR(d.nets[0].max_tie_stretch, stretch, 1e-15);
  EXPECT_GT(stretch, 0.01);
  EXPECT_NEAR(d.nets[0].max_node_speed, speed, 1e-15);
  EXPECT_NEAR(d.nets[0].kinetic_energy, ke, 1e-15);
  EXPECT_NEAR(d.nets[0].max_strain, strain, 1e-14);  // structural springs only
  // The strain is bounded by the ties: |l − L| ≤ |x_a − a_a| + |x_b − a_b|.
  double min_rest = 1.0;
  for (int e = 0; e < net.structural_count; ++e) min_rest = std::min(min_rest, m.net_springs[at(e)].rest_length);
  EXPECT_LE(strain, 2.0 * stretch / min_rest + 1e-12);
}

TEST(NetForces, MeasureNetsDoesNotReportANonFiniteNetAsCalm) {
  // A NaN node (a step about to be rejected) must not give max_tie_stretch =
  // max_node_speed = max_strain = 0 — std::max(m, NaN) would drop the NaN.
  const core::Model m = scene(core::make_icosphere(0.04, 1));
  core::Data d = core::make_data(m);
  d.nodes[40].position.x() = std::numeric_limits<double>::quiet_NaN();
  d.nodes[41].velocity.y() = std::numeric_limits<double>::quiet_NaN();
  core::measure_nets(m, d);
  EXPECT_TRUE(std::isnan(d.nets[0].max_tie_stretch));
  EXPECT_TRUE(std::isnan(d.nets[0].max_node_speed));
  EXPECT_TRUE(std::isnan(d.nets[0].kinetic_energy));
  EXPECT_TRUE(std::isnan(d.nets[0].max_strain));
  // The first node too (the running maximum starts at 0).
  core::Data d0 = core::make_data(m);
  d0.nodes[0].position.z() = std::numeric_limits<double>::quiet_NaN();
  core::measure_nets(m, d0);
  EXPECT_TRUE(std::isnan(d0.nets[0].max_tie_stretch));
  EXPECT_TRUE(std::isnan(d0.nets[0].max_strain));
}
