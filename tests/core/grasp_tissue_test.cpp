// Tests of core/grasp on tissue: a grasper's jaws close on a deformable net, hold the nodes they
// touch, retract the tissue (the hand feels its pull, Eq. 8), let it go when they open, and let
// it slip past the grip's limit (docs/grasping.md, "Tissue").

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

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
  core::Model m;
  m.dt = 1e-3;
  m.gravity = core::Vec3::Zero();
  m.solver.tolerance = 1e-6;
  m.solver.max_iterations = 200;
  m.material_names = {"steel", "tissue"};
  m.material_pairs.assign(4, core::MaterialPair{2e4, 10.0, 0.0});
  m.bodies.push_back(numen::test::organ::organ_core_body());
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
