// Tests of core/net_solve: the coupled linearly implicit system of bodies and
// nodes (net_solve.hpp) assembled from the header's formulas and the step's
// states (tests/support/net_system_sparse.hpp, shared with the peer
// benchmark; densified here) — mass and inertia, coupling springs, gyroscopic
// split, ties (c = hγ + h²k, J_i = [I, −[ρ]×]), springs (S = α d̂d̂ᵀ + β I),
// node contacts on a plane and on a body (W = α n nᵀ + β I) — and solved with Eigen,
// against the solver: without joints Eisenstat's SSOR-preconditioned CG (a
// free rigid component, warm-started after real steps, an imposed rigid
// component (kDirect: Δu = 0), several nets, a body–body contact next to a
// node–body contact), whose splitting A = (D̃+L) + (D̃+Lᵀ) + (D − 2D̃) and
// preconditioned product are checked against the dense matrix; with a
// revolute joint the arrowhead-preconditioned projected CG (dense KKT solve);
// on the benchmark's ball with the contacts step() finds, the sparse system
// against the solver and Eigen's sparse LDLᵀ, and a repeated solve from the
// restored warm start (what the peer benchmark times) bit for bit.

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <Eigen/Eigenvalues>
#include <Eigen/SparseCholesky>
#include <cmath>
#include <cstdio>
#include <vector>

#include "build_features.hpp"
#include "deformable_ball.hpp"
#include "net_system_sparse.hpp"
#include "numen/core/collision.hpp"
#include "numen/core/contact_force.hpp"
#include "numen/core/coupling.hpp"
#include "numen/core/data.hpp"
#include "numen/core/integrator.hpp"
#include "numen/core/net_forces.hpp"
#include "numen/core/mesh.hpp"
#include "numen/core/model.hpp"
#include "numen/core/rigid_body.hpp"
#include "numen/core/step.hpp"

#include "scratch/data_scratch.hpp"
#include "solver/implicit_system.hpp"
#include "articulation/joint_system.hpp"
#include "net/net_solve.hpp"
#include "net_states.hpp"
#include "rotation.hpp"

namespace core = numen::core;
using core::Mat3;
using core::Quat;
using core::Vec3;
using Eigen::MatrixXd;
using Eigen::VectorXd;

namespace {

using numen::test::at;
using numen::test::rot;

enum class NetVariant { kFree, kJointed, kImposed, kThreeNets };

/// Body 0: the rigid component of an icosphere net (no spheres), spinning;
/// body 1: a free probe the net touches; with kJointed, body 2: a handle
/// (the device's body) carrying body 0 on a revolute joint.
core::Model scene(NetVariant v) {
  core::Model m;
  m.dt = 2e-3;
  m.gravity = Vec3(0.0, 0.0, -9.81);
  m.coupling_mode =
      v == NetVariant::kImposed ? core::CouplingMode::kDirect : core::CouplingMode::kGodObject;
  m.solver.tolerance = 1e-12;
  m.solver.max_iterations = 500;
  m.material_names = {"hard", "net"};
  m.material_pairs = {core::MaterialPair{1e4, 20.0, 0.5}, core::MaterialPair{3e3, 4.0, 0.3},
                      core::MaterialPair{3e3, 4.0, 0.3}, core::MaterialPair{1e3, 1.0, 0.0}};
  core::Obstacle floor;
  floor.name = "floor";
  floor.type = core::ShapeType::kPlane;
  floor.pose.position = Vec3(0, 0, -1.0);  // far: the test writes the node contacts itself
  m.obstacles = {floor};
  core::BodyModel b;
  b.name = "core";
  b.mass = 0.2;
  b.inertia_body = Vec3(2e-4, 3e-4, 4e-4).asDiagonal();
  b.initial_pose = core::Pose{Vec3(0.01, -0.02, 0.1), rot(0.4, Vec3(1, 2, 3))};
  b.initial_twist.linear = Vec3(0.05, -0.02, 0.01);
  b.initial_twist.angular = Vec3(1.5, -0.7, 2.0);
  b.coupling = {800.0, core::damping_from_ratio(0.8, 0.35, 800.0), 0.6, 0.02};
  core::BodyModel probe;
  probe.name = "probe";
  probe.mass = 0.5;
  probe.inertia_body = Vec3(1e-3, 1e-3, 2e-3).asDiagonal();
  probe.initial_pose.position = Vec3(0.1, -0.02, 0.1);
  probe.initial_twist.linear = Vec3(-0.03, 0.0, 0.02);
  probe.initial_twist.angular = Vec3(0.0, 0.5, -0.3);
  m.bodies = {b, probe};
  m.initial_held_body = 0;
  if (v == NetVariant::kJointed) {
    core::BodyModel handle = b;
    handle.name = "handle";
    handle.mass = 0.3;
    // Joint anchors coincide at the start: core = handle + R (0, 0, −0.1).
    handle.initial_pose = b.initial_pose;
    handle.initial_pose.position =
        b.initial_pose.position + b.initial_pose.orientation * Vec3(0, 0, 0.1);
    handle.initial_twist = b.initial_twist;
    m.bodies.push_back(handle);
    m.initial_held_body = 2;
    core::JointModel j;
    j.name = "wrist";
    j.type = core::JointType::kRevolute;
    j.parent = 2;
    j.child = 0;
    j.frame_parent = core::Pose{Vec3(0, 0, -0.05), rot(0.3, Vec3::UnitX())};
    j.frame_child = core::Pose{Vec3(0, 0, 0.05), rot(0.3, Vec3::UnitX())};
    m.joints = {j};
  }
  core::NetSettings s;
  s.name = "bag";
  s.body = 0;
  s.material = 1;
  s.mass = 0.15;
  s.stiffness = 60.0;
  s.damping = 0.2;
  s.bending_stiffness = 10.0;
  s.bending_damping = 0.05;
  s.tie_stiffness = 150.0;
  s.tie_damping = 0.4;
  EXPECT_EQ(core::add_net(m, core::make_icosphere(0.05, 1), s), "");
  if (v == NetVariant::kThreeNets) {
    // A second net on the same rigid component (a tip above the bag) and a
    // third on the probe: several nets' ties on one body's Schur block.
    core::TriangleMesh tip = core::make_icosphere(0.02, 0);
    core::transform_mesh(tip, Vec3::Ones(), core::Pose{Vec3(0.0, 0.0, 0.08), Quat::Identity()});
    core::NetSettings t = s;
    t.name = "tip";
    t.mass = 0.03;
    t.tie_stiffness = 300.0;
    t.tie_damping = 0.2;
    EXPECT_EQ(core::add_net(m, tip, t), "");
    core::NetSettings u = s;
    u.name = "skin";
    u.body = 1;
    u.material = 0;
    u.mass = 0.05;
    u.tie_stiffness = 80.0;
    EXPECT_EQ(core::add_net(m, core::make_icosphere(0.03, 0), u), "");
  }
  EXPECT_EQ(core::finalize_model(m), "");
  return m;
}

/// Two node contacts on a plane (the two lowest nodes) and one with body 1
/// (the node nearest to it), written by hand in place of detect_node_contacts.
/// With `shared_node`, that node also has a second contact with body 1 and one with body 2 (the
/// jointed variant's handle): the arrowhead preconditioner groups a node's contacts by body and
/// leaves out the cross term of a node on two bodies.
void write_node_contacts(const core::Model& m, core::Data& d, bool shared_node = false) {
  int low0 = -1, low1 = -1, near = -1;
  for (int i = 0; i < m.num_nodes(); ++i) {
    const double z = d.nodes[at(i)].position.z();
    if (low0 < 0 || z < d.nodes[at(low0)].position.z()) {
      low1 = low0;
      low0 = i;
    } else if (low1 < 0 || z < d.nodes[at(low1)].position.z()) {
      low1 = i;
    }
    if (near < 0 || (d.nodes[at(i)].position - d.bodies[1].position).norm() <
                        (d.nodes[at(near)].position - d.bodies[1].position).norm())
      near = i;
  }
  d.num_node_contacts = 3;
  for (int k = 0; k < 2; ++k) {
    core::NodeContact& c = d.node_contacts[at(k)];
    c = core::NodeContact{};
    c.node = k == 0 ? low0 : low1;
    c.obstacle = 0;
    c.material_pair = 1;
    c.normal = k == 0 ? Vec3::UnitZ() : Vec3(0.1, 0.0, 1.0).normalized();
    c.depth = k == 0 ? 2e-3 : 1e-3;
    c.position = d.nodes[at(c.node)].position - 0.01 * c.normal;
  }
  core::NodeContact& c = d.node_contacts[2];
  c = core::NodeContact{};
  c.node = near;
  c.body_b = 1;
  c.sphere_b = 0;
  c.material_pair = 3;
  c.normal = (d.nodes[at(near)].position - d.bodies[1].position).normalized();
  c.depth = 1.5e-3;
  c.position = d.nodes[at(near)].position - 0.005 * c.normal;
  if (!shared_node) return;
  d.num_node_contacts = 5;
  for (int k = 3; k < 5; ++k) {
    core::NodeContact& e = d.node_contacts[at(k)];
    e = c;
    e.body_b = k == 3 ? 1 : 2;
    e.normal = (c.normal + (k == 3 ? Vec3(0.3, -0.2, 0.1) : Vec3(-0.2, 0.1, 0.4))).normalized();
    e.depth = k == 3 ? 0.8e-3 : 1.2e-3;
    e.position = d.nodes[at(near)].position - (k == 3 ? 0.004 : 0.006) * e.normal;
  }
}

/// A body–body contact between the probe (body 1, side a) and the net's rigid
/// component (body 0), written by hand in place of detect_contacts (the
/// rigid component has no spheres): off-diagonal body blocks in A.
void write_body_contact(core::Data& d) {
  const Vec3 pa = d.bodies[1].position, pb = d.bodies[0].position;
  d.num_contacts = 1;
  core::Contact& c = d.contacts[0];
  c = core::Contact{};
  c.body_a = 1;
  c.body_b = 0;
  c.sphere_a = 0;
  c.sphere_b = 0;
  c.material_pair = 0;
  c.normal = (pa - pb).normalized();
  c.depth = 1e-3;
  c.position = 0.5 * (pa + pb) + Vec3(0.0, 0.01, -0.005);  // off the line of centres: torques
}

/// The step's inputs the reference system is built from (after the imposed
/// pose of kDirect, before the forces stage): net_system_sparse.hpp.
using Snapshot = numen::test::NetSystemInputs;

/// The stages of one implicit step up to the solve, with hand-written node
/// contacts. Returns the snapshot; the solve's result is in d.
Snapshot staged_solve(const core::Model& m, core::Data& d, bool* converged,
                      bool body_contact = false, bool shared_node = false) {
  d.status = core::kStepOk;
  core::impose_direct_target(m, d);
  core::detect_contacts(m, d);
  if (body_contact) write_body_contact(d);
  write_node_contacts(m, d, shared_node);
  Snapshot s = numen::test::take_net_system_inputs(d);
  d.scratch->solver.system_step = core::linearized_system_step(m);  // as stage_net_system()
  core::compute_forces(m, d);
  core::linearize_nets(m, d, d.scratch->solver.system_step);
  core::prepare_implicit_step(m, d);
  core::build_implicit_system(m, d);
  core::build_net_system(m, d);
  *converged = core::solve_net_system(m, d);
  return s;
}

/// The dense A = M − hD − h²K and b = h (f0 + h K u0) + M (u* − u0) over
/// [Δu bodies (6 each); Δv nodes (3 each)] from net_solve.hpp and
/// integrator.hpp, computed from the snapshot only (no solver scratch):
/// numen::test::assemble_net_system() (the formulas, shared with the peer
/// benchmark), densified. Rows of imposed bodies are identity with b = 0.
struct DenseSystem {
  MatrixXd a;
  VectorXd b;
  std::vector<double> spring_alpha, spring_beta;  // for a cross-check of SweepSpring
};

DenseSystem dense_system(const core::Model& m, const Snapshot& s) {
  numen::test::NetSystem sys = numen::test::assemble_net_system(m, s);
  return DenseSystem{MatrixXd(sys.a), std::move(sys.b), std::move(sys.spring_alpha),
                     std::move(sys.spring_beta)};
}

/// Checks shared by the three variants: the solver's spring and contact
/// weights, the body blocks of A (SolverScratch::block), convergence.
void check_scratch(const core::Model& m, const core::Data& d, const DenseSystem& ref,
                   bool converged) {
  EXPECT_TRUE(converged);
  EXPECT_GT(d.solver_iterations, 0);
  EXPECT_LE(d.solver_residual, m.solver.tolerance);
  EXPECT_EQ(d.status & core::kSolverNotConverged, 0u);
  ASSERT_EQ(d.scratch->net.sweep_springs.size(), ref.spring_alpha.size());
  for (std::size_t e = 0; e < ref.spring_alpha.size(); ++e) {
    const core::SweepSpring& t = d.scratch->net.sweep_springs[at(d.scratch->net.spring_slot[e])];
    EXPECT_NEAR(t.weight_axial, ref.spring_alpha[e], 1e-15) << e;
    EXPECT_NEAR(t.weight_isotropic, ref.spring_beta[e], 1e-15) << e;
  }
  int stretched = 0, compressed = 0;
  for (std::size_t e = 0; e < ref.spring_beta.size(); ++e)
    (ref.spring_beta[e] > 0.0 ? stretched : compressed)++;
  EXPECT_GT(stretched, 10);
  EXPECT_GT(compressed, 10);
  for (int c = 0; c < d.num_node_contacts; ++c) EXPECT_TRUE(d.node_contacts[at(c)].active) << c;
  // Diagonal body blocks of A (with the ties' and node–body contacts' terms).
  for (int k = 0; k < m.num_bodies(); ++k) {
    if (d.scratch->solver.imposed[at(k)]) continue;
    const Eigen::Matrix<double, 6, 6> blk = ref.a.block<6, 6>(6 * k, 6 * k);
    EXPECT_LT((d.scratch->solver.block[at(k)] - blk).norm(), 1e-12 * blk.norm())
        << "body " << k << "\n"
        << d.scratch->solver.block[at(k)] << "\n"
        << blk;
  }
  // Node diagonal blocks.
  for (int i = 0; i < m.num_nodes(); ++i) {
    const int r = 6 * m.num_bodies() + 3 * i;
    const Mat3 blk = ref.a.block<3, 3>(r, r);
    EXPECT_LT((d.scratch->net.block[at(i)] - blk).norm(), 1e-12 * blk.norm()) << "node " << i;
  }
}

}  // namespace

TEST(NetSolve, FreeRigidComponentMatchesTheDenseSolve) {
  const core::Model m = scene(NetVariant::kFree);
  core::Data d = core::make_data(m);
  numen::test::perturb_nodes(d, 3e-3, 0.05);
  d.target = core::Pose{Vec3(0.02, 0.0, 0.12), rot(0.5, Vec3(1, 2, 2.5))};
  d.target_twist = core::Twist{Vec3(0.1, 0.0, 0.0), Vec3(0.0, 0.3, 0.0)};
  bool converged = false;
  const Snapshot s = staged_solve(m, d, &converged);
  const DenseSystem ref = dense_system(m, s);
  check_scratch(m, d, ref, converged);
  EXPECT_LT((ref.a - ref.a.transpose()).norm(), 1e-14 * ref.a.norm());
  const Eigen::LLT<MatrixXd> llt(ref.a);
  ASSERT_EQ(llt.info(), Eigen::Success) << "A must be symmetric positive definite";
  const VectorXd x_ref = llt.solve(ref.b);
  const VectorXd x = numen::test::net_system_unknowns(m, d);
  const double err = (x - x_ref).norm() / x_ref.norm();
  std::printf(
      "[net solve free] %d iterations, residual %.2e, |x - x_dense|/|x| %.2e, |A x - b|/|b| %.2e\n",
      d.solver_iterations, d.solver_residual, err, (ref.a * x - ref.b).norm() / ref.b.norm());
  EXPECT_LT(err, 1e-9);
  EXPECT_LT((ref.a * x - ref.b).norm(), 1e-11 * ref.b.norm());
  // Both parts of the solution matter: the body moves, the nodes deform.
  EXPECT_GT(x_ref.head<6>().norm(), 1e-4);
  EXPECT_GT(x_ref.tail(3 * m.num_nodes()).norm(), 1e-4);
}

TEST(NetSolve, WarmStartedSolveAfterRealStepsMatchesTheDenseSolve) {
  const core::Model m = scene(NetVariant::kFree);
  core::Data d = core::make_data(m);
  numen::test::perturb_nodes(d, 2e-3, 0.05);
  for (int k = 0; k < 30; ++k) {
    d.target.position.x() += 2e-4;
    core::step(m, d);
    ASSERT_EQ(d.status, core::kStepOk) << k;
  }
  bool any_warm = false;
  for (const Vec3& v : d.scratch->net.delta) any_warm = any_warm || !v.isZero(0.0);
  EXPECT_TRUE(any_warm);
  bool converged = false;
  const Snapshot s = staged_solve(m, d, &converged);
  const DenseSystem ref = dense_system(m, s);
  check_scratch(m, d, ref, converged);
  const VectorXd x_ref = ref.a.llt().solve(ref.b);
  const double err = (numen::test::net_system_unknowns(m, d) - x_ref).norm() / x_ref.norm();
  std::printf("[net solve warm] %d iterations, |x - x_dense|/|x| %.2e\n", d.solver_iterations, err);
  EXPECT_LT(err, 1e-9);
}

namespace {

/// The jointed variant after a few real steps, staged and solved (shared_node: three contacts on
/// one node, two bodies), against the dense KKT solve: [A Gᵀ; G 0] [Δ; y] = [b; c] with G the joint
/// rows at the step's start (Data::articulation.rows) and c their Baumgarte right-hand side.
void check_jointed_against_kkt(bool shared_node, const char* label) {
  const core::Model m = scene(NetVariant::kJointed);
  core::Data d = core::make_data(m);
  // A few real steps first: joint rows with a previous Δu, warm start, drift.
  for (int k = 0; k < 10; ++k) {
    d.target.position.z() += 1e-4;
    core::step(m, d);
    ASSERT_EQ(d.status, core::kStepOk) << k;
  }
  numen::test::perturb_nodes(d, 3e-3, 0.05);
  bool converged = false;
  const Snapshot s = staged_solve(m, d, &converged, false, shared_node);
  const DenseSystem ref = dense_system(m, s);
  check_scratch(m, d, ref, converged);
  const core::JointModel& jm = m.joints[0];
  const core::JointRows& rows = d.scratch->articulation.rows[0];
  const int nr = jm.num_rows;
  ASSERT_EQ(nr, 5);
  const int n = static_cast<int>(ref.b.size());
  MatrixXd g = MatrixXd::Zero(nr, n);
  g.block(0, 6 * jm.child, nr, 6) = rows.g_child.topRows(nr);
  g.block(0, 6 * jm.parent, nr, 6) = rows.g_parent.topRows(nr);
  const VectorXd c = d.joints[0].baumgarte_rhs.head(nr);
  MatrixXd kkt = MatrixXd::Zero(n + nr, n + nr);
  kkt.topLeftCorner(n, n) = ref.a;
  kkt.topRightCorner(n, nr) = g.transpose();
  kkt.bottomLeftCorner(nr, n) = g;
  VectorXd rhs(n + nr);
  rhs << ref.b, c;
  const VectorXd sol = kkt.fullPivLu().solve(rhs);
  const VectorXd x_ref = sol.head(n);
  const VectorXd y_ref = sol.tail(nr);
  const VectorXd x = numen::test::net_system_unknowns(m, d);
  const double err = (x - x_ref).norm() / x_ref.norm();
  const VectorXd lambda_ref = -y_ref / m.dt;
  const VectorXd lambda = d.joints[0].multiplier.head(nr);
  std::printf(
      "[net solve %s] %d iterations, residual %.2e, |x - x_kkt|/|x| %.2e, |G x - c| %.2e, "
      "|λ - λ_kkt|/|λ| %.2e\n",
      label, d.solver_iterations, d.solver_residual, err, (g * x - c).norm(),
      (lambda - lambda_ref).norm() / lambda_ref.norm());
  EXPECT_LT(err, 1e-9);
  EXPECT_LT((g * x - c).norm(), 1e-10 * (1.0 + c.norm()));
  EXPECT_GT(c.norm(), 0.0);
  EXPECT_LT((lambda - lambda_ref).norm(), 1e-7 * lambda_ref.norm());
  // Stationarity of the KKT system with the solver's own multipliers.
  const VectorXd y = -m.dt * lambda;
  EXPECT_LT((ref.a * x + g.transpose() * y - ref.b).norm(), 1e-9 * ref.b.norm());

  // The arrowhead preconditioner, densely: P = L diag(Ŝ, N) Lᵀ, L = [I, E N⁻¹; 0, I], E the
  // body–node blocks of A (ties, node–body contacts), N the nodes' 3×3 blocks, Ŝ the body blocks
  // of A_bb − E N⁻¹ Eᵀ. On the joints' null space (G Z = 0) the spectrum of P⁻¹A lies in (0, 2):
  // the solve's last Richardson step x += P⁻¹ r cannot increase the A-norm error.
  const int nbd = 6 * m.num_bodies();
  const int nnd = n - nbd;
  MatrixXd nblk = MatrixXd::Zero(nnd, nnd);
  for (int i = 0; i < nnd; i += 3) nblk.block<3, 3>(i, i) = ref.a.block<3, 3>(nbd + i, nbd + i);
  const MatrixXd e = ref.a.block(0, nbd, nbd, nnd);
  const MatrixXd ninv = nblk.inverse();
  const MatrixXd schur = ref.a.topLeftCorner(nbd, nbd) - e * ninv * e.transpose();
  MatrixXd shat = MatrixXd::Zero(nbd, nbd);
  for (int b = 0; b < nbd; b += 6) shat.block<6, 6>(b, b) = schur.block<6, 6>(b, b);
  MatrixXd lower = MatrixXd::Identity(n, n);
  lower.block(0, nbd, nbd, nnd) = e * ninv;
  MatrixXd mid = MatrixXd::Zero(n, n);
  mid.topLeftCorner(nbd, nbd) = shat;
  mid.bottomRightCorner(nnd, nnd) = nblk;
  const MatrixXd p = lower * mid * lower.transpose();
  Eigen::FullPivLU<MatrixXd> lu(g);
  const MatrixXd z = lu.kernel();
  ASSERT_EQ(z.cols(), n - nr);
  Eigen::GeneralizedSelfAdjointEigenSolver<MatrixXd> eig(z.transpose() * ref.a * z,
                                                         z.transpose() * p * z);
  ASSERT_EQ(eig.info(), Eigen::Success);
  const double lo = eig.eigenvalues().minCoeff(), hi = eig.eigenvalues().maxCoeff();
  std::printf("[net solve %s] spectrum of P⁻¹A on the joints' null space: [%.4f, %.4f]\n", label,
              lo, hi);
  EXPECT_GT(lo, 0.0);
  EXPECT_LT(hi, 2.0);
}

}  // namespace

TEST(NetSolve, JointedRigidComponentMatchesTheDenseKktSolve) {
  NUMEN_REQUIRE_ARTICULATION();
  check_jointed_against_kkt(false, "jointed");
}

// The arrowhead preconditioner eliminates the node–body contacts' blocks too (build_net_system):
// a node with two contacts on the probe and one on the handle (which the joint ties to the net's
// rigid component) still gives the KKT solution.
TEST(NetSolve, JointedSolveWithANodeOnTwoBodiesMatchesTheDenseKktSolve) {
  NUMEN_REQUIRE_ARTICULATION();
  check_jointed_against_kkt(true, "jointed, one node on two bodies");
}

TEST(NetSolve, ImposedRigidComponentHasNoUnknownAndTheNodesMatchTheDenseSolve) {
  const core::Model m = scene(NetVariant::kImposed);
  core::Data d = core::make_data(m);
  numen::test::perturb_nodes(d, 3e-3, 0.05);
  d.target = core::Pose{Vec3(0.02, -0.01, 0.11), rot(0.5, Vec3(1, 2, 2.5))};
  d.target_twist = core::Twist{Vec3(0.2, 0.0, -0.1), Vec3(0.5, 0.3, 0.0)};
  bool converged = false;
  const Snapshot s = staged_solve(m, d, &converged);
  ASSERT_TRUE(d.scratch->solver.imposed[0]);
  EXPECT_FALSE(d.scratch->solver.in_solve[0]);
  EXPECT_TRUE(d.scratch->solver.delta[0].isZero(0.0)) << d.scratch->solver.delta[0].transpose();
  EXPECT_EQ(s.bodies[0].position, d.target.position);
  const DenseSystem ref = dense_system(m, s);
  check_scratch(m, d, ref, converged);
  const VectorXd x_ref = ref.a.llt().solve(ref.b);
  const VectorXd x = numen::test::net_system_unknowns(m, d);
  const double err = (x - x_ref).norm() / x_ref.norm();
  std::printf("[net solve imposed] %d iterations, |x - x_dense|/|x| %.2e\n", d.solver_iterations,
              err);
  EXPECT_LT(err, 1e-9);
  // A whole step keeps the imposed body at the target.
  core::Data d2 = core::make_data(m);
  d2.target = d.target;
  d2.target_twist = d.target_twist;
  core::step(m, d2);
  EXPECT_EQ(d2.bodies[0].position, d.target.position);
  EXPECT_TRUE(d2.scratch->solver.delta[0].isZero(0.0));
}

TEST(NetSolve, ReportsNonConvergenceAtMaxIterations) {
  core::Model m = scene(NetVariant::kFree);
  m.solver.max_iterations = 1;
  ASSERT_EQ(core::finalize_model(m), "");
  core::Data d = core::make_data(m);
  numen::test::perturb_nodes(d, 3e-3, 0.05);
  bool converged = true;
  staged_solve(m, d, &converged);
  EXPECT_FALSE(converged);
  EXPECT_EQ(d.solver_iterations, 1);
  EXPECT_GT(d.solver_residual, m.solver.tolerance);
  // Through step(): the status bit, and the iterate is still used (finite).
  core::Data d2 = core::make_data(m);
  numen::test::perturb_nodes(d2, 3e-3, 0.05);
  core::step(m, d2);
  EXPECT_TRUE(d2.status & core::kSolverNotConverged);
  EXPECT_EQ(d2.status & core::kNonFinite, 0u);
}

TEST(NetSolve, SeveralNetsOnOneBodyAndOnTheProbeMatchTheDenseSolve) {
  const core::Model m = scene(NetVariant::kThreeNets);
  ASSERT_EQ(m.num_nets(), 3);
  core::Data d = core::make_data(m);
  numen::test::perturb_nodes(d, 3e-3, 0.05);
  d.target = core::Pose{Vec3(0.02, 0.0, 0.12), rot(0.5, Vec3(1, 2, 2.5))};
  bool converged = false;
  const Snapshot s = staged_solve(m, d, &converged);
  const DenseSystem ref = dense_system(m, s);
  check_scratch(m, d, ref, converged);
  const VectorXd x_ref = ref.a.llt().solve(ref.b);
  const double err = (numen::test::net_system_unknowns(m, d) - x_ref).norm() / x_ref.norm();
  std::printf("[net solve three nets] %d iterations, |x - x_dense|/|x| %.2e\n", d.solver_iterations,
              err);
  EXPECT_LT(err, 1e-9);
}

namespace {

using Vec6 = Eigen::Matrix<double, 6, 1>;

/// A dense vector over [bodies; nodes] split into the solver's spans.
struct Split {
  std::vector<Vec6> b;
  std::vector<Vec3> n;
};

Split split(const core::Model& m, const VectorXd& v) {
  Split s{std::vector<Vec6>(at(m.num_bodies())), std::vector<Vec3>(at(m.num_nodes()))};
  for (int k = 0; k < m.num_bodies(); ++k) s.b[at(k)] = v.segment<6>(6 * k);
  for (int i = 0; i < m.num_nodes(); ++i) s.n[at(i)] = v.segment<3>(6 * m.num_bodies() + 3 * i);
  return s;
}

VectorXd join(const Split& s) {
  VectorXd v(6 * static_cast<int>(s.b.size()) + 3 * static_cast<int>(s.n.size()));
  for (std::size_t k = 0; k < s.b.size(); ++k) v.segment<6>(6 * static_cast<int>(k)) = s.b[k];
  for (std::size_t i = 0; i < s.n.size(); ++i)
    v.segment<3>(6 * static_cast<int>(s.b.size()) + 3 * static_cast<int>(i)) = s.n[i];
  return v;
}

/// The splitting of net_solve.hpp from the dense A: D̃ (6×6 body and 3×3
/// node diagonal blocks), D (D̃ plus the body–body off-diagonal blocks), L
/// (strictly lower blocks below the body–body part, the nodes taken in the
/// sweep order Model::node_sweep_order: node i's row holds the node–body
/// blocks and the blocks of the nodes before i in that order).
struct Splitting {
  MatrixXd d_tilde, d, l;
};

Splitting dense_splitting(const core::Model& m, const core::Data& data, const MatrixXd& a) {
  const int nb6 = 6 * m.num_bodies();
  const int dim = static_cast<int>(a.rows());
  Splitting s{MatrixXd::Zero(dim, dim), MatrixXd::Zero(dim, dim), MatrixXd::Zero(dim, dim)};
  for (int k = 0; k < m.num_bodies(); ++k)
    s.d_tilde.block<6, 6>(6 * k, 6 * k) = a.block<6, 6>(6 * k, 6 * k);
  for (int r = nb6; r < dim; r += 3) s.d_tilde.block<3, 3>(r, r) = a.block<3, 3>(r, r);
  s.d = s.d_tilde;
  s.d.topLeftCorner(nb6, nb6) = a.topLeftCorner(nb6, nb6);
  const auto position = [&](int node) { return data.scratch->net.sweep_position[at(node)]; };
  for (int i = 0; i < m.num_nodes(); ++i) {
    const int r = nb6 + 3 * i;
    s.l.block(r, 0, 3, nb6) = a.block(r, 0, 3, nb6);
    for (int j = 0; j < m.num_nodes(); ++j)
      if (position(j) < position(i))
        s.l.block<3, 3>(r, nb6 + 3 * j) = a.block<3, 3>(r, nb6 + 3 * j);
  }
  return s;
}

/// The free scene with a body–body contact (probe on the rigid component)
/// and a node contact with the probe, staged up to the solve.
struct Staged {
  core::Model m;
  core::Data d;
  Snapshot snap;
  DenseSystem ref;
  bool converged = false;
};

/// `delay`: SolverSettings::error_estimate_delay (0: the residual rule); `error_tolerance`:
/// SolverSettings::error_tolerance (≤ 0: `tolerance`).
Staged staged_body_contact(double tolerance = 1e-12,
                           int delay = core::SolverSettings{}.error_estimate_delay,
                           int max_iterations = 500, double error_tolerance = 0.0) {
  Staged st{scene(NetVariant::kFree), {}, {}, {}, false};
  st.m.solver.tolerance = tolerance;
  st.m.solver.error_tolerance = error_tolerance;
  st.m.solver.error_estimate_delay = delay;
  st.m.solver.max_iterations = max_iterations;
  st.d = core::make_data(st.m);
  numen::test::perturb_nodes(st.d, 3e-3, 0.05);
  st.d.target = core::Pose{Vec3(0.02, 0.0, 0.12), rot(0.5, Vec3(1, 2, 2.5))};
  st.snap = staged_solve(st.m, st.d, &st.converged, true);
  st.ref = dense_system(st.m, st.snap);
  return st;
}

}  // namespace

TEST(NetSolve, EisenstatSplittingAndPreconditionedProductMatchTheDenseMatrix) {
  Staged st = staged_body_contact();
  const core::Model& m = st.m;
  core::Data& d = st.d;
  ASSERT_EQ(d.scratch->solver.num_cross_contacts, 1);  // a body–body block in D
  ASSERT_TRUE(d.node_contacts[2].active);
  ASSERT_EQ(d.node_contacts[2].body_b, 1);  // a node–body block in L
  const MatrixXd& a = st.ref.a;
  const int dim = static_cast<int>(a.rows());
  const Splitting sp = dense_splitting(m, d, a);
  EXPECT_GT(sp.l.norm(), 0.0);
  EXPECT_GT((sp.d - sp.d_tilde).norm(), 0.0);
  const MatrixXd lower = sp.d_tilde + sp.l;                        // D̃ + L
  const MatrixXd upper = lower.transpose();                        // D̃ + Lᵀ
  const MatrixXd rest = sp.d - 2.0 * sp.d_tilde;                   // D − 2D̃
  EXPECT_LT((lower + upper + rest - a).norm(), 1e-15 * a.norm());  // the splitting itself

  // The sweeps column by column: (D̃+L)⁻¹, (D̃+Lᵀ)⁻¹ and G = I + (D − 2D̃)(D̃+Lᵀ)⁻¹.
  MatrixXd forward(dim, dim), backward(dim, dim), g(dim, dim);
  for (int j = 0; j < dim; ++j) {
    const Split e = split(m, VectorXd::Unit(dim, j));
    Split y = e, t = e, gs = e;
    core::net_forward_sweep(m, d, e.b, e.n, y.b, y.n);
    core::net_backward_sweep(m, d, e.b, e.n, t.b, t.n, gs.b, gs.n);
    forward.col(j) = join(y);
    backward.col(j) = join(t);
    g.col(j) = join(gs);
  }
  const double scale = a.norm();
  const MatrixXd lower_sweep = forward.inverse();
  const MatrixXd upper_sweep = backward.inverse();
  const MatrixXd rest_sweep = (g - MatrixXd::Identity(dim, dim)) * upper_sweep;
  const double e_lower = (lower_sweep - lower).norm() / scale;
  const double e_upper = (upper_sweep - upper).norm() / scale;
  const double e_rest = (rest_sweep - rest).norm() / scale;
  const double e_sum = (lower_sweep + upper_sweep + rest_sweep - a).norm() / scale;
  std::printf(
      "[eisenstat splitting] |(D+L) - dense| %.1e, |(D+L') - dense| %.1e, |D-2D~ - dense| %.1e, "
      "|sum - A| %.1e (relative to |A|)\n",
      e_lower, e_upper, e_rest, e_sum);
  EXPECT_LT(e_lower, 1e-12);
  EXPECT_LT(e_upper, 1e-12);
  EXPECT_LT(e_rest, 1e-12);
  EXPECT_LT(e_sum, 1e-12);

  // K q = (D̃+L)⁻¹ A (D̃+Lᵀ)⁻¹ q and t = (D̃+Lᵀ)⁻¹ q for a generic q.
  VectorXd q(dim);
  for (int j = 0; j < dim; ++j) q(j) = std::sin(0.37 * j + 0.2) * (j < 12 ? 0.1 : 1e-3);
  const Split qs = split(m, q);
  Split t = qs, kq = qs;
  core::apply_net_preconditioned(m, d, qs.b, qs.n, t.b, t.n, kq.b, kq.n);
  const VectorXd t_ref = upper.partialPivLu().solve(q);
  const VectorXd kq_ref = lower.partialPivLu().solve(a * t_ref);
  const double e_t = (join(t) - t_ref).norm() / t_ref.norm();
  const double e_kq = (join(kq) - kq_ref).norm() / kq_ref.norm();
  std::printf("[eisenstat product] |t - t_dense|/|t| %.1e, |Kq - Kq_dense|/|Kq| %.1e\n", e_t, e_kq);
  EXPECT_LT(e_t, 1e-12);
  EXPECT_LT(e_kq, 1e-12);
}

TEST(NetSolve, ReportsTheResidualInTheNormOfThePreconditioner) {
  // The residual rule (error_estimate_delay 0), at a loose tolerance, so that the
  // recurrence's residual is the true one.
  Staged st = staged_body_contact(1e-4, 0);
  const core::Model& m = st.m;
  const core::Data& d = st.d;
  EXPECT_TRUE(st.converged);
  const MatrixXd& a = st.ref.a;
  const Splitting sp = dense_splitting(m, d, a);
  const MatrixXd lower = sp.d_tilde + sp.l;
  // M = (D̃+L) D̃⁻¹ (D̃+Lᵀ), symmetric positive definite.
  const MatrixXd precond = lower * sp.d_tilde.inverse() * lower.transpose();
  const Eigen::LLT<MatrixXd> llt(precond);
  ASSERT_EQ(llt.info(), Eigen::Success);
  const VectorXd& b = st.ref.b;
  const VectorXd r = b - a * numen::test::net_system_unknowns(m, d);
  // The reference is b's size in the block-Jacobi norm ‖b‖_{D̃⁻¹} (net_solve.hpp).
  const double rel_m = std::sqrt(r.dot(llt.solve(r)) / b.dot(sp.d_tilde.llt().solve(b)));
  const double rel_2 = r.norm() / b.norm();
  std::printf(
      "[net solve residual] %d iterations, reported %.4e, |r|_M^-1/|b|_D~^-1 %.4e, |r|/|b| %.4e\n",
      d.solver_iterations, d.solver_residual, rel_m, rel_2);
  EXPECT_LE(d.solver_residual, m.solver.tolerance);
  EXPECT_GT(d.solver_residual, 0.0);
  EXPECT_NEAR(d.solver_residual, rel_m, 1e-6 * rel_m);
}

TEST(NetSolve, ReportsTheEnergyNormErrorEstimateOfTheIterateTheDelayBack) {
  // The error rule: Data::solver_residual = η_k = √(Σ_{j=k}^{k+d−1} α_j ρ_j / bᵀx_{k+d}) of
  // Eisenstat's CG, whose Â-norm is the A-norm of the original unknowns. Against the dense
  // A and its solution: η_k² bᵀx_{k+d} = ‖x* − x_k‖²_A − ‖x* − x_{k+d}‖²_A, x_k from the same
  // solve stopped d iterations earlier (deterministic: the same iterates).
  constexpr int kDelay = 2;
  constexpr double kTolerance = 1e-5;
  Staged st = staged_body_contact(kTolerance, kDelay);
  ASSERT_TRUE(st.converged);
  const int iterations = st.d.solver_iterations;
  ASSERT_GT(iterations, kDelay);
  Staged early = staged_body_contact(kTolerance, kDelay, iterations - kDelay);
  EXPECT_FALSE(early.converged);
  const MatrixXd& a = st.ref.a;
  const VectorXd& b = st.ref.b;
  const VectorXd exact = a.llt().solve(b);
  const VectorXd x = numen::test::net_system_unknowns(st.m, st.d);
  const VectorXd x_k = numen::test::net_system_unknowns(early.m, early.d);
  const auto energy = [&a](const VectorXd& v) { return v.dot(a * v); };
  const double e_k = energy(exact - x_k), e_last = energy(exact - x);
  const double eta = st.d.solver_residual;
  const double x_norm = std::sqrt(energy(exact));
  std::printf(
      "[net solve error estimate] %d iterations, reported %.4e, |x*-x_k|_A/|x*|_A %.4e, "
      "returned |x*-x_k+d|_A/|x*|_A %.4e\n",
      iterations, eta, std::sqrt(e_k) / x_norm, std::sqrt(e_last) / x_norm);
  EXPECT_LE(eta, kTolerance);
  EXPECT_GT(eta, 0.0);
  EXPECT_NEAR(eta * eta * b.dot(x), e_k - e_last, 1e-6 * (e_k - e_last));
  EXPECT_LE(eta * x_norm, std::sqrt(e_k) * (1.0 + 1e-6));  // a lower bound of x_k's error
  EXPECT_LE(std::sqrt(e_last), std::sqrt(e_k));             // the returned iterate is better
}

TEST(NetSolve, ErrorToleranceStopsTheErrorRuleInPlaceOfTheTolerance) {
  // SolverSettings::error_tolerance sets the energy-norm error rule's tolerance apart from
  // `tolerance` (which the jointed solve's ‖r‖/‖b‖ keeps): the same staged solve stops at the
  // error tolerance, looser or tighter than `tolerance`, and ≤ 0 leaves `tolerance`.
  const Staged tight = staged_body_contact(1e-10);
  const Staged loose = staged_body_contact(1e-10, 1, 500, 1e-3);
  const Staged unset = staged_body_contact(1e-3);
  const Staged tightened = staged_body_contact(1e-3, 1, 500, 1e-10);
  ASSERT_TRUE(tight.converged && loose.converged && unset.converged && tightened.converged);
  std::printf("[net solve error tolerance] iterations: 1e-10 %d, error_tolerance 1e-3 %d\n",
              tight.d.solver_iterations, loose.d.solver_iterations);
  EXPECT_LE(loose.d.solver_residual, 1e-3);
  EXPECT_GT(loose.d.solver_residual, 1e-10);
  EXPECT_LT(loose.d.solver_iterations, tight.d.solver_iterations);
  EXPECT_EQ(loose.d.solver_iterations, unset.d.solver_iterations);  // as tolerance = 1e-3
  EXPECT_EQ(loose.d.solver_residual, unset.d.solver_residual);
  EXPECT_EQ(tightened.d.solver_iterations, tight.d.solver_iterations);
  EXPECT_EQ(tightened.d.solver_residual, tight.d.solver_residual);
}

TEST(NetSolve, BodyContactAndNodeContactWithAProbeMatchTheDenseSolve) {
  Staged st = staged_body_contact();
  const core::Model& m = st.m;
  const core::Data& d = st.d;
  ASSERT_EQ(d.scratch->solver.num_cross_contacts, 1);
  ASSERT_TRUE(d.node_contacts[2].active);
  check_scratch(m, d, st.ref, st.converged);
  const VectorXd x_ref = st.ref.a.llt().solve(st.ref.b);
  const VectorXd x = numen::test::net_system_unknowns(m, d);
  const double err = (x - x_ref).norm() / x_ref.norm();
  std::printf("[net solve body contact] %d iterations, |x - x_dense|/|x| %.2e\n",
              d.solver_iterations, err);
  EXPECT_LT(err, 1e-9);
  EXPECT_LT((st.ref.a * x - st.ref.b).norm(), 1e-11 * st.ref.b.norm());
  EXPECT_GT(x_ref.segment<6>(6).norm(), 1e-4);  // the probe moves
}

namespace {

/// The benchmark's ball (162 nodes, tolerance 1e-12) after 300 steps of its
/// circling target (contacts with the floor active), staged up to the solve
/// of step 300.
struct StagedBall {
  core::Model m;
  core::Data d;
  Snapshot snap;
};

StagedBall staged_ball() {
  StagedBall st{numen::test::make_deformable_ball(2, 1e-3, 1e-12, 1000), {}, {}};
  st.d = core::make_data(st.m);
  const std::int64_t k =
      numen::test::run_deformable_ball(st.m, st.d, 0, numen::test::kBallWarmUpSteps);
  numen::test::set_deformable_ball_target(st.m, st.d, k);
  st.snap = numen::test::stage_net_system(st.m, st.d);
  return st;
}

}  // namespace

TEST(NetSolve, BallSystemAssembledSparselyMatchesTheSolverAndEigensLdlt) {
  StagedBall st = staged_ball();
  const core::Model& m = st.m;
  core::Data& d = st.d;
  ASSERT_GT(d.num_node_contacts, 3);  // pressed on the floor: contact blocks in A
  const bool converged = core::solve_net_system(m, d);
  const numen::test::NetSystem sys = numen::test::assemble_net_system(m, st.snap);
  const int dim = 6 * m.num_bodies() + 3 * m.num_nodes();
  ASSERT_EQ(sys.a.rows(), dim);
  ASSERT_EQ(sys.b.size(), dim);
  const Eigen::SparseMatrix<double> asym = sys.a - Eigen::SparseMatrix<double>(sys.a.transpose());
  EXPECT_LT(asym.norm(), 1e-14 * sys.a.norm());
  // Sparse, both triangles stored: the body's 6×6 block, per node its 3×3
  // block and its tie blocks with the body (2 × 18), per spring its two
  // off-diagonal 3×3 blocks; the floor contacts only add to node blocks.
  EXPECT_EQ(sys.a.nonZeros(), 36 + 2 * 18 * m.num_nodes() + 9 * m.num_nodes() +
                                  18 * static_cast<int>(m.net_springs.size()));
  // The solver's weights and diagonal blocks, and its solution of this A x = b.
  check_scratch(m, d, dense_system(m, st.snap), converged);
  const VectorXd x = numen::test::net_system_unknowns(m, d);
  const double res = (sys.a * x - sys.b).norm() / sys.b.norm();
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(sys.a);
  ASSERT_EQ(ldlt.info(), Eigen::Success);
  EXPECT_GT(ldlt.vectorD().minCoeff(), 0.0);  // positive definite
  const VectorXd x_ldlt = ldlt.solve(sys.b);
  const double err = (x - x_ldlt).norm() / x_ldlt.norm();
  std::printf(
      "[net solve ball 162] %d contacts, %d iterations, |A x - b|/|b| %.2e, "
      "|x - x_ldlt|/|x| %.2e\n",
      d.num_node_contacts, d.solver_iterations, res, err);
  EXPECT_LT(res, 1e-12);
  EXPECT_LT(err, 1e-10);
  EXPECT_LT((sys.a * x_ldlt - sys.b).norm(), 1e-13 * sys.b.norm());
}

TEST(NetSolve, RepeatedSolveFromTheRestoredWarmStartIsBitIdentical) {
  StagedBall st = staged_ball();
  core::Model m = st.m;
  m.solver.tolerance = 1e-3;  // the shipped setting: the warm start matters
  core::Data& d = st.d;
  const std::vector<Vec3> warm = d.scratch->net.delta;
  bool any_warm = false;
  for (const Vec3& v : warm) any_warm = any_warm || !v.isZero(0.0);
  ASSERT_TRUE(any_warm);
  ASSERT_TRUE(core::solve_net_system(m, d));
  const VectorXd first = numen::test::net_system_unknowns(m, d);
  const int iterations = d.solver_iterations;
  // A solve from zero takes more iterations: the warm start is used.
  for (Vec3& v : d.scratch->net.delta) v.setZero();
  ASSERT_TRUE(core::solve_net_system(m, d));
  EXPECT_GT(d.solver_iterations, iterations);
  d.scratch->net.delta = warm;
  ASSERT_TRUE(core::solve_net_system(m, d));
  EXPECT_EQ(d.solver_iterations, iterations);
  const VectorXd second = numen::test::net_system_unknowns(m, d);
  for (Eigen::Index j = 0; j < first.size(); ++j) EXPECT_EQ(first(j), second(j)) << j;
}
