// Tests of core/grasp on tissue: a grasper's jaws close on a deformable net, hold the nodes they
// touch, retract the tissue (the hand feels its pull, Eq. 8), let it go when they open, and let
// it slip past the grip's limit (docs/grasping.md, "Tissue").

#include <gtest/gtest.h>

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <vector>

#include "alloc_counter.hpp"
#include "grasper_rig.hpp"
#include "numen/core/data.hpp"
#include "numen/core/grasp.hpp"
#include "numen/core/model.hpp"
#include "numen/core/net_model.hpp"
#include "numen/core/step.hpp"
#include "organ_indentation.hpp"

namespace {

namespace core = numen::core;

/// Body 0, the organ's anchored core at the origin, carrying a flat 20 × 20 mm patch of 2 mm
/// cells in the plane z = 0 (121 nodes, the shipped organ's constants per spring and per node:
/// ties of 100 N/m); bodies 1–3, the grasper of numen::test::add_grasper() above it, its hinge
/// 10.5 mm above the patch so that its jaws' tips dip 2 mm into it; feedback gains equal to the
/// tube's coupling (the hand feels the coupling's force). No gravity. Implicit Euler, 1 ms.
core::Model tissue_rig(double max_force) {
  core::Model m = numen::test::organ::patch_rig_start();
  // Hinge at z = 0.0105: the tube's COM 40 mm above it.
  numen::test::add_grasper(m, core::Vec3(0, 0, 0.0505), 60 * numen::test::kGraspDeg, max_force);
  m.feedback = core::FeedbackGains{m.bodies[1].coupling.k_t, m.bodies[1].coupling.gamma_t,
                                   m.bodies[1].coupling.k_r, m.bodies[1].coupling.gamma_r};
  const core::TriangleMesh patch = numen::test::organ::flat_patch(10, 0.002);
  EXPECT_EQ(core::add_net(m, patch, numen::test::organ::organ_net_settings(patch, {})), "");
  EXPECT_EQ(core::finalize_model(m), "");
  return m;
}

/// Closes the jaws from 60° to 20° in 0.4 s on the patch (the hand still), then lifts the hand
/// `lift` m in 0.5 s and holds 1 s. Returns the step index of the grasp (-1: none).
int close_and_lift(const core::Model& m, core::Data& d, double lift) {
  const double rate = 100 * numen::test::kGraspDeg;
  double theta = 60 * numen::test::kGraspDeg;
  const core::Vec3 start(0, 0, 0.0505);
  int grasped = -1;
  for (int s = 0; s < 1900; ++s) {
    const double r = theta > 20 * numen::test::kGraspDeg ? -rate : 0.0;
    numen::test::set_grasper_opening(d, theta, r);
    theta = std::max(20 * numen::test::kGraspDeg, theta + r * m.dt);
    core::Vec3 at = start, v = core::Vec3::Zero();
    if (s >= 400) {
      const double t = std::min(0.5, (s - 400) * m.dt);
      at.z() += lift * 0.5 * (1 - std::cos(M_PI * t / 0.5));
      v.z() = t < 0.5 ? lift * 0.5 * M_PI / 0.5 * std::sin(M_PI * t / 0.5) : 0.0;
    }
    numen::test::set_grasper_target(d, at, v);
    core::step(m, d);
    if (d.status & core::kNonFinite) {
      ADD_FAILURE() << "non-finite step " << s;
      return grasped;
    }
    if (d.grasps[0].event == core::GraspEvent::kGrasp) grasped = s;
  }
  return grasped;
}

/// The patch's statics from its constants alone, independently of the step: the free nodes'
/// positions minimising the energy of its springs, ½ k (l − L)² (Model::net_springs, structural
/// and bending), and of its zero-length ties, ½ k_tie |x − r|² (the core at the origin, r =
/// Model::node_rest), the held nodes fixed where the grasp holds them now; Newton's method from
/// the rest shape on the dense Hessian (the springs' transverse term kept only where stretched),
/// with a backtracking line search, to a gradient of 1e-10 N. Returns the force the grip must
/// pull the held nodes with to hold them there, Σ ∂E/∂x_held (N, world).
core::Vec3 patch_statics_grip_pull(const core::Model& m, const core::Data& d,
                                   const core::GraspState& g) {
  const core::NetModel& net = m.nets[0];
  const int n = net.node_count;
  std::vector<char> held(static_cast<std::size_t>(n), 0);
  for (int k = 0; k < g.num_nodes; ++k)
    held[static_cast<std::size_t>(g.nodes[static_cast<std::size_t>(k)].node - net.node_begin)] = 1;
  std::vector<core::Vec3> x(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    const auto v = static_cast<std::size_t>(net.node_begin + i);
    x[static_cast<std::size_t>(i)] = held[static_cast<std::size_t>(i)] ? d.nodes[v].position : m.node_rest[v];
  }
  const auto energy_and_derivatives = [&](const std::vector<core::Vec3>& at, Eigen::VectorXd* grad,
                                          Eigen::MatrixXd* hess) {
    double e = 0.0;
    if (grad) grad->setZero(3 * n);
    if (hess) hess->setZero(3 * n, 3 * n);
    for (int i = 0; i < n; ++i) {
      const core::Vec3 u = at[static_cast<std::size_t>(i)] - m.node_rest[static_cast<std::size_t>(net.node_begin + i)];
      e += 0.5 * net.tie_stiffness * u.squaredNorm();
      if (grad) grad->segment<3>(3 * i) += net.tie_stiffness * u;
      if (hess) hess->block<3, 3>(3 * i, 3 * i) += net.tie_stiffness * core::Mat3::Identity();
    }
    for (int s = net.spring_begin; s < net.spring_begin + net.structural_count + net.bending_count; ++s) {
      const core::NetSpring& sp = m.net_springs[static_cast<std::size_t>(s)];
      const int a = sp.node_a - net.node_begin, b = sp.node_b - net.node_begin;
      const core::Vec3 dx = at[static_cast<std::size_t>(b)] - at[static_cast<std::size_t>(a)];
      const double l = dx.norm();
      e += 0.5 * sp.stiffness * (l - sp.rest_length) * (l - sp.rest_length);
      const core::Vec3 dir = dx / l;
      if (grad) {
        const core::Vec3 f = sp.stiffness * (l - sp.rest_length) * dir;
        grad->segment<3>(3 * b) += f;
        grad->segment<3>(3 * a) -= f;
      }
      if (hess) {
        const core::Mat3 nn = dir * dir.transpose();
        const core::Mat3 k = sp.stiffness * (nn + std::max(0.0, 1.0 - sp.rest_length / l) *
                                                      (core::Mat3::Identity() - nn));
        hess->block<3, 3>(3 * a, 3 * a) += k;
        hess->block<3, 3>(3 * b, 3 * b) += k;
        hess->block<3, 3>(3 * a, 3 * b) -= k;
        hess->block<3, 3>(3 * b, 3 * a) -= k;
      }
    }
    return e;
  };
  Eigen::VectorXd grad;
  Eigen::MatrixXd hess;
  for (int iteration = 0; iteration < 100; ++iteration) {
    const double e = energy_and_derivatives(x, &grad, &hess);
    for (int i = 0; i < n; ++i)  // the held nodes are fixed: identity rows, no step
      if (held[static_cast<std::size_t>(i)]) {
        grad.segment<3>(3 * i).setZero();
        hess.middleRows(3 * i, 3).setZero();
        hess.middleCols(3 * i, 3).setZero();
        hess.block<3, 3>(3 * i, 3 * i).setIdentity();
      }
    if (grad.norm() < 1e-10) break;
    const Eigen::VectorXd step = hess.ldlt().solve(-grad);
    double t = 1.0;
    std::vector<core::Vec3> trial(x.size());
    for (int halving = 0; halving < 30; ++halving, t *= 0.5) {
      for (int i = 0; i < n; ++i)
        trial[static_cast<std::size_t>(i)] = x[static_cast<std::size_t>(i)] + t * step.segment<3>(3 * i);
      if (energy_and_derivatives(trial, nullptr, nullptr) <= e) break;
    }
    x = trial;
  }
  energy_and_derivatives(x, &grad, nullptr);
  EXPECT_LT([&] {
    double free_gradient = 0.0;
    for (int i = 0; i < n; ++i)
      if (!held[static_cast<std::size_t>(i)]) free_gradient = std::max(free_gradient, grad.segment<3>(3 * i).norm());
    return free_gradient;
  }(), 1e-8) << "N: the reference statics did not converge";
  core::Vec3 pull = core::Vec3::Zero();
  for (int i = 0; i < n; ++i)
    if (held[static_cast<std::size_t>(i)]) pull += grad.segment<3>(3 * i);
  return pull;
}

}  // namespace

TEST(GraspTissue, TheJawsHoldTheTissueTheyCloseOnAndTheHandFeelsItsPull) {
  const core::Model m = tissue_rig(1e9);
  core::Data d = core::make_data(m);
  const int grasped = close_and_lift(m, d, 0.010);
  ASSERT_GE(grasped, 0) << "the jaws closed on the tissue and never grasped it";
  const core::GraspState& g = d.grasps[0];
  ASSERT_TRUE(g.holding());
  EXPECT_EQ(g.net, 0);
  EXPECT_EQ(g.body, -1);
  EXPECT_GE(g.num_nodes, 2);
  bool jaw1 = false, jaw2 = false;
  double farthest = 0.0, lowest = 1.0;
  for (int k = 0; k < g.num_nodes; ++k) {
    const core::GraspNode& n = g.nodes[static_cast<std::size_t>(k)];
    jaw1 = jaw1 || n.jaw == 2;
    jaw2 = jaw2 || n.jaw == 3;
    const core::BodyState& jaw = d.bodies[static_cast<std::size_t>(n.jaw)];
    const core::Vec3& x = d.nodes[static_cast<std::size_t>(n.node)].position;
    farthest = std::max(farthest, (jaw.position + jaw.orientation * n.jaw_point - x).norm());
    lowest = std::min(lowest, x.z());
  }
  EXPECT_TRUE(jaw1 && jaw2) << "both jaws hold nodes";
  // Retracted: the held nodes went up with the jaws, each within its grip spring's stretch of
  // where it was grasped on its jaw. The hand rose 10 mm; the tube follows it less the
  // coupling's give under the tissue's pull (1000 N/m), and so do the nodes.
  const double tube_rise = d.bodies[1].position.z() - 0.0505;
  std::printf("retraction: tube up %.2f mm, lowest held node at z = %.2f mm, farthest from its jaw point "
              "%.3f mm\n", tube_rise * 1e3, lowest * 1e3, farthest * 1e3);
  EXPECT_LT(farthest, 1e-3) << "m: the tissue slipped in the jaws";
  EXPECT_GT(lowest, 0.4 * tube_rise) << "m: the held tissue did not follow the jaws";
  EXPECT_GT(tube_rise, 0.003);
  // Statics, held still: the grip's pull on the nodes is what the ties take to the core (the
  // net's springs are internal), and the hand feels it through the tube's coupling (Eq. 8,
  // feedback gains = coupling gains): three views of one force.
  core::Vec3 pull = core::Vec3::Zero();
  for (int k = 0; k < g.num_nodes; ++k) pull += g.nodes[static_cast<std::size_t>(k)].force;
  const core::Vec3 ties = d.nets[0].tie_wrench.force;
  std::printf("retraction 10 mm: %d nodes held, grip pull %.4f N, ties %.4f N, feedback %.4f N\n",
              g.num_nodes, pull.z(), ties.z(), d.feedback_wrench.force.z());
  EXPECT_GT(pull.z(), 0.1) << "N: the tissue is pulled up";
  EXPECT_NEAR(ties.z(), pull.z(), 0.01 * pull.z());
  EXPECT_NEAR(d.feedback_wrench.force.z(), -pull.z(), 0.02 * pull.z()) << "the hand feels the tissue pull down";
  // Against the net's constants: the patch's statics with the held nodes where the grip holds
  // them (Newton on the springs' and ties' energy, not the step) asks the same pull of the grip.
  const core::Vec3 statics = patch_statics_grip_pull(m, d, g);
  std::printf("retraction 10 mm: statics of the patch's ties and springs %.6f N against the grip's %.6f N (x %.4f, y %.4f)\n",
              statics.z(), pull.z(), statics.x(), statics.y());
  EXPECT_NEAR(statics.z(), pull.z(), 1e-3 * pull.z()) << "N: the grip's pull is not the net's statics";
  EXPECT_NEAR((statics - pull).norm(), 0.0, 1e-3 * pull.norm());
  // The jaws' own contacts with the held tissue are off: no node contact with them.
  for (int c = 0; c < d.num_node_contacts; ++c) {
    const core::NodeContact& ct = d.node_contacts[static_cast<std::size_t>(c)];
    EXPECT_TRUE(ct.body_b != 2 && ct.body_b != 3) << "a jaw's contact with the held net";
  }
  // Opening past 40° lets it go: the tissue goes back to rest.
  double theta = 20 * numen::test::kGraspDeg;
  int released = -1;
  for (int s = 0; s < 1500; ++s) {
    const double r = theta < 60 * numen::test::kGraspDeg ? 100 * numen::test::kGraspDeg : 0.0;
    numen::test::set_grasper_opening(d, theta, r);
    theta = std::min(60 * numen::test::kGraspDeg, theta + r * m.dt);
    core::step(m, d);
    if (d.grasps[0].event == core::GraspEvent::kRelease) released = s;
  }
  ASSERT_GE(released, 0);
  EXPECT_FALSE(d.grasps[0].holding());
  EXPECT_EQ(d.num_node_grasp_springs, 0);
  EXPECT_LT(d.nets[0].max_tie_stretch, 0.001) << "m: the tissue went back";
}

TEST(GraspTissue, HoldingTissueDoesNotAllocate) {
  const core::Model m = tissue_rig(1e9);
  core::Data d = core::make_data(m);
  ASSERT_GE(close_and_lift(m, d, 0.005), 0);
  numen::test::AllocationGuard guard;
  for (int s = 0; s < 200; ++s) core::step(m, d);
  EXPECT_EQ(guard.count(), 0u);
  EXPECT_TRUE(d.grasps[0].holding());
}

TEST(GraspTissue, APullPastTheGripsLimitSlipsAndSaysSo) {
  // A grip of 0.3 N on tissue pulled up 10 mm: the ties' pull passes it on the way up and the
  // tissue slips out of the jaws, which are not armed again while closed.
  const core::Model m = tissue_rig(0.3);
  core::Data d = core::make_data(m);
  ASSERT_GE(close_and_lift(m, d, 0.010), 0);
  EXPECT_EQ(d.grasps[0].slips, 1);
  EXPECT_EQ(d.grasps[0].grasps, 1) << "not grasped again while the jaws stay closed";
  EXPECT_FALSE(d.grasps[0].holding());
  EXPECT_GT(d.grasps[0].grip_force, 0.3);
  EXPECT_LT(d.nets[0].max_tie_stretch, 0.002) << "m: the tissue fell back";
}
