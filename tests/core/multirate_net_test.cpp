// Tests of the nets of a multirate god-object (core/src/multirate/net_planes.cpp, docs/multirate.md
// "Deformable god-objects"): the god-object model lumps a net onto its rigid component, the
// proximity model grows its node spheres, and the node planes render the net's contacts on the
// component — at the sample what the ties carried, and for a further push the net's own
// quasi-static stiffness, both against the full net model.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstdio>
#include <memory>
#include <vector>

#include "build_features.hpp"
#include "sanitizer.hpp"
#include "deformable_ball.hpp"
#include "numen/core/collision.hpp"
#include "numen/core/contact_force.hpp"
#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/multirate.hpp"
#include "numen/core/net_collision.hpp"
#include "numen/core/step.hpp"

#include "multirate/net.hpp"

namespace core = numen::core;
using core::Vec3;

namespace {

/// The benchmark ball (642 nodes, 200 N/m structural springs, 2000 N/m floor) with ties of
/// `tie_stiffness` (N/m per node; the benchmark's are 5) and without gravity, held by its
/// coupling 5 mm below its resting height until it is at rest on the floor (3 s); its core
/// turned by `orientation` (the nets' rest positions are in the core's frame).
struct SettledBall {
  core::Model model = numen::test::make_deformable_ball(3);
  core::Data data;
  explicit SettledBall(double tie_stiffness, const core::Quat& orientation = core::Quat::Identity()) {
    model.gravity.setZero();
    model.nets[0].tie_stiffness = tie_stiffness;
    model.bodies[0].initial_pose.orientation = orientation;
    EXPECT_EQ(core::finalize_model(model), "");
    data = core::make_data(model);
    data.target.position = Vec3(0.02, 0.0, numen::test::kBallRadius - 0.005);
    data.target.orientation = orientation;
    for (int k = 0; k < 3000; ++k) core::step(model, data);
  }
};

/// The node planes of `ball`'s state (its component is the god-object), detected on the
/// proximity model of `margin` (m), with room for `spring_room` springs at the planes' nodes
/// (−1: Model::node_springs.size(), the room MultirateGodObject gives).
std::unique_ptr<core::ContactPlaneSet> ball_node_planes(const SettledBall& ball, double margin,
                                                        int spring_room = -1) {
  core::Model proximity;
  EXPECT_EQ(core::make_proximity_model(ball.model, 0, margin, proximity), "");
  core::Data pd = core::make_data(proximity);
  pd.bodies = ball.data.bodies;
  pd.nodes = ball.data.nodes;
  core::detect_node_contacts(proximity, pd);
  std::vector<int> slot_of_node(static_cast<std::size_t>(ball.model.num_nodes()), -1);
  std::vector<int> slot_node(core::kMaxContactPlanes), plane_slot(core::kMaxContactPlanes);
  std::vector<core::Mat3> stiffness(core::kMaxContactPlanes);
  std::vector<double> planes_stiffness(core::kMaxContactPlanes), planes_depth(core::kMaxContactPlanes);
  std::vector<Vec3> force(core::kMaxContactPlanes);
  std::vector<std::int32_t> springs(spring_room < 0 ? proximity.node_springs.size()
                                                    : static_cast<std::size_t>(spring_room));
  auto planes = std::make_unique<core::ContactPlaneSet>();
  const std::vector<int> device_body = {0};
  core::detail::build_node_planes(proximity, pd, device_body, margin,
                                  {slot_of_node, slot_node, stiffness, plane_slot, planes_stiffness, planes_depth, force, springs},
                                  *planes);
  return planes;
}

/// The node planes of `ball`'s state (ball_node_planes()), written as contacts of the
/// god-object model `device` at the component's pose shifted by `shift` (m), at rest; returns
/// the planes' total force on the component (N).
Vec3 plane_force(const SettledBall& ball, const core::Model& device, const Vec3& shift, double margin = 0.0) {
  const std::unique_ptr<core::ContactPlaneSet> planes = ball_node_planes(ball, margin);
  EXPECT_GT(planes->count, 10);
  EXPECT_EQ(planes->dropped, 0);
  core::Data d = core::make_god_object_data(device);
  d.bodies[0] = ball.data.bodies[0];
  d.bodies[0].position += shift;
  d.bodies[0].linear_velocity.setZero();
  d.bodies[0].angular_velocity.setZero();
  core::write_plane_contacts(device, *planes, d);
  d.body_wrench[0] = core::Wrench{};
  core::compute_contact_forces(device, d);
  return d.body_wrench[0].force;
}

}  // namespace

TEST(MultirateNet, GodObjectModelLumpsTheNetAndTheProximityModelGrowsItsNodes) {
  NUMEN_REQUIRE_DEFORMABLE();
  const core::Model ball = numen::test::make_deformable_ball(2);
  core::Model device, proximity;
  ASSERT_EQ(core::make_god_object_model(ball, 0, 1e-4, device), "");
  ASSERT_EQ(core::make_proximity_model(ball, 0, 0.004, proximity), "");
  EXPECT_EQ(device.num_nets(), 0);
  EXPECT_EQ(device.num_nodes(), 0);
  // 50 g core + 0.1 kg net; the net's inertia is a thin shell's, (2/3) m r², about any axis.
  EXPECT_NEAR(device.bodies[0].mass, 0.15, 1e-12);
  const double shell = 2.0 / 3.0 * 0.1 * numen::test::kBallRadius * numen::test::kBallRadius;
  for (int a = 0; a < 3; ++a)
    EXPECT_NEAR(device.bodies[0].inertia_body(a, a) - ball.bodies[0].inertia_body(a, a), shell, 0.02 * shell);
  ASSERT_EQ(proximity.num_nodes(), ball.num_nodes());
  for (int i = 0; i < ball.num_nodes(); ++i)
    EXPECT_DOUBLE_EQ(proximity.node_radius[static_cast<std::size_t>(i)],
                     ball.node_radius[static_cast<std::size_t>(i)] + 0.004);
}

// A net off its component's centre of mass would need the lumped body's centre moved: refused.
TEST(MultirateNet, ANetOffItsComponentsCentreOfMassIsRefused) {
  NUMEN_REQUIRE_DEFORMABLE();
  core::Model ball = numen::test::make_deformable_ball(1);
  for (Vec3& r : ball.node_rest) r.x() += 0.01;
  core::Model device;
  const std::string error = core::make_god_object_model(ball, 0, 1e-3, device);
  std::printf("%s\n", error.c_str());
  EXPECT_NE(error.find("net 'ball'"), std::string::npos) << error;
  EXPECT_NE(error.find("6.66"), std::string::npos) << error;  // 0.1 kg · 10 mm / 0.15 kg
}

namespace {

/// The ball with ties of `tie_stiffness` settled on the floor: the force its ties carry to the
/// core and the node planes' (N), and its stiffness for a further 0.2 mm push of the core, the
/// full net's (settled again with the core imposed 0.2 mm lower, kDirect) and the node planes'
/// (N/m).
struct Carried {
  double ties, planes, lateral, net_stiffness, plane_stiffness;
};
Carried carried(double tie_stiffness) {
  const SettledBall ball(tie_stiffness);
  core::Model device;
  EXPECT_EQ(core::make_god_object_model(ball.model, 0, 1e-3, device), "");
  const Vec3 f0 = plane_force(ball, device, Vec3::Zero());
  const double push = 2e-4;
  core::Model held = ball.model;
  held.coupling_mode = core::CouplingMode::kDirect;
  EXPECT_EQ(core::finalize_model(held), "");
  core::Data d = core::make_data(held);
  d.bodies = ball.data.bodies;
  d.nodes = ball.data.nodes;
  d.target.position = ball.data.bodies[0].position - Vec3(0, 0, push);
  d.target.orientation = ball.data.bodies[0].orientation;
  for (int k = 0; k < 3000; ++k) core::step(held, d);
  const double ties = ball.data.nets[0].tie_wrench.force.z();
  Carried c{ties, f0.z(), f0.head<2>().norm(), (d.nets[0].tie_wrench.force.z() - ties) / push,
            (plane_force(ball, device, Vec3(0, 0, -push)).z() - f0.z()) / push};
  std::printf("ties %.0f N/m: at rest the ties carry %.4f N, the node planes give %.4f N (lateral %.1e N); "
              "0.2 mm further the net's stiffness is %.1f N/m, the node planes' %.1f N/m\n",
              tie_stiffness, c.ties, c.planes, c.lateral, c.net_stiffness, c.plane_stiffness);
  return c;
}

}  // namespace

// The ball at rest on the floor: its ties carry the floor's push to the core. The node planes of
// that sample model each contact node as its tie and its springs to neighbours held by the core,
// in series with its contact: they give the core what those carried (k_n e₀), and for a further
// push the series stiffness k k_n / (k + k_n). With ties as stiff as the shipped probe's
// (400 N/m per node against 200 N/m springs) that is the full net's answer within 2 % (force;
// 0.2 % measured) and 10 % (stiffness; 2.4 %). With the benchmark's 5 N/m ties the net is a membrane: the neighbours
// are not held by the core, and the node planes overestimate the force by 34 % and the stiffness
// 4.1× (docs/multirate.md: a limit of the local model, printed here, not asserted).
TEST(MultirateNet, NodePlanesCarryWhatTheTiesCarriedAndTheNetsStiffness) {
  NUMEN_SKIP_UNDER_SANITIZER(
      "four settlings of a 642-node net (12 000 steps) compare figures with the full net, which "
      "is not what a sanitizer checks, and take over 5 min under ASan+UBSan; the node planes' "
      "path runs there in RunMultirate.DeformableScenePeriodNeverAllocates");
  NUMEN_REQUIRE_DEFORMABLE();
  const Carried tied = carried(400.0);
  ASSERT_GT(tied.ties, 0.01);
  EXPECT_NEAR(tied.planes, tied.ties, 0.02 * tied.ties);
  EXPECT_LT(tied.lateral, 0.05 * tied.planes);
  EXPECT_GT(tied.net_stiffness, 0.0);
  EXPECT_NEAR(tied.plane_stiffness, tied.net_stiffness, 0.1 * tied.net_stiffness);
  const Carried membrane = carried(5.0);
  EXPECT_GT(membrane.planes, membrane.ties);  // the limit of the local model (above)
}

// The same at rest with the core turned (0.7 rad about (1, 1, 0): the nodes' centres and rest
// positions are carried in the core's frame) and the planes found on node spheres grown by a
// 1 mm margin (their points at the true surface, their radii the true ones): still what the ties
// carried, within 2 %.
TEST(MultirateNet, NodePlanesOfATurnedCoreFoundWithAMargin) {
  NUMEN_SKIP_UNDER_SANITIZER(
      "a settling of a 642-node net compares figures with the full net (see "
      "MultirateNet.NodePlanesCarryWhatTheTiesCarriedAndTheNetsStiffness)");
  NUMEN_REQUIRE_DEFORMABLE();
  const core::Quat turn(Eigen::AngleAxisd(0.7, Vec3(1, 1, 0).normalized()));
  const SettledBall ball(400.0, turn);
  core::Model device;
  ASSERT_EQ(core::make_god_object_model(ball.model, 0, 1e-3, device), "");
  const double ties = ball.data.nets[0].tie_wrench.force.z();
  const Vec3 f = plane_force(ball, device, Vec3::Zero(), 0.001);
  std::printf("turned core, 1 mm margin: the ties carry %.4f N, the node planes give %.4f N\n", ties, f.z());
  ASSERT_GT(ties, 0.01);
  EXPECT_NEAR(f.z(), ties, 0.02 * ties);
  EXPECT_LT(f.head<2>().norm(), 0.05 * f.z());
}

// A plane set is reused sample after sample: a sphere plane written where a node plane was has
// none of its fields (the node, its scale, its offset).
// The planes read their nodes' springs from Model::node_springs into the scratch's room for
// them: without that room no plane is built, and every one is counted as dropped (the run's
// summary reports multirate.planes_dropped), none silently missing its springs.
TEST(MultirateNet, NodePlanesWithoutRoomForTheirSpringsAreDroppedAndCounted) {
  NUMEN_SKIP_UNDER_SANITIZER("settles a 642-node net over 3 000 steps");
  NUMEN_REQUIRE_DEFORMABLE();
  const SettledBall ball(400.0);
  const std::unique_ptr<core::ContactPlaneSet> full = ball_node_planes(ball, 0.0);
  ASSERT_GT(full->count, 10);
  EXPECT_EQ(full->dropped, 0);
  const std::unique_ptr<core::ContactPlaneSet> short_room = ball_node_planes(ball, 0.0, 1);
  EXPECT_EQ(short_room->count, 0);
  EXPECT_EQ(short_room->dropped, full->count);
}

TEST(MultirateNet, ASpherePlaneKeepsNothingOfTheNodePlaneBeforeIt) {
  core::Model m;
  m.material_names = {"steel"};
  m.material_pairs = {core::MaterialPair{}};
  core::Obstacle floor;
  floor.name = "floor";
  m.obstacles = {floor};
  m.body_spheres = {core::Sphere{Vec3::Zero(), 0.01}};
  core::BodyModel tool;
  tool.name = "tool";
  tool.mass = 0.1;
  tool.inertia_body = Vec3(1e-5, 1e-5, 1e-5).asDiagonal();
  tool.sphere_count = 1;
  tool.initial_pose.position = Vec3(0, 0, 0.009);  // 1 mm into the floor
  m.bodies = {tool};
  ASSERT_EQ(core::finalize_model(m), "");
  core::Data d = core::make_data(m);
  core::detect_contacts(m, d);
  ASSERT_EQ(d.num_contacts, 1);
  auto planes = std::make_unique<core::ContactPlaneSet>();
  core::ContactPlane& p = planes->planes[0];
  p.node = 7;
  p.stiffness_scale = 0.1;
  p.depth_offset = 0.004;
  p.radius = 0.002;
  const std::vector<int> device_body = {0};
  core::build_contact_planes(m, d, device_body, 1e-3, *planes);
  ASSERT_EQ(planes->count, 1);
  EXPECT_EQ(p.node, -1);
  EXPECT_EQ(p.sphere, 0);
  EXPECT_EQ(p.stiffness_scale, 1.0);
  EXPECT_EQ(p.depth_offset, 0.0);
  EXPECT_EQ(p.radius, 0.0);
}

namespace {

/// The look-ahead candidates (NodeContact::engaged) that cut_back_node_contacts() keeps for the
/// 42-node ball's lowest node, at rest on its anchor with `gap` (m) between its sphere and the
/// floor, its core moving at `speed` (m/s) along −z, over a scene step of `step` (s); margin
/// 2 mm. Returns {candidates of the lowest node, its contacts found on the grown spheres}.
std::pair<int, int> lowest_node_candidates(double gap, double speed, double step) {
  core::Model ball = numen::test::make_deformable_ball(1);
  const double margin = 0.002;
  core::Model proximity;
  EXPECT_EQ(core::make_proximity_model(ball, 0, margin, proximity), "");
  core::Data d = core::make_data(proximity);
  int lowest = 0;
  for (int i = 0; i < ball.num_nodes(); ++i)
    if (ball.node_rest[static_cast<std::size_t>(i)].z() < ball.node_rest[static_cast<std::size_t>(lowest)].z()) lowest = i;
  const auto low = static_cast<std::size_t>(lowest);
  d.bodies[0].position = Vec3(0.02, 0.0, -ball.node_rest[low].z() + ball.node_radius[low] + gap);
  d.bodies[0].linear_velocity = Vec3(0.0, 0.0, -speed);
  for (int i = 0; i < ball.num_nodes(); ++i) {
    const auto k = static_cast<std::size_t>(i);
    d.nodes[k].position = d.bodies[0].position + ball.node_rest[k];
    d.nodes[k].velocity.setZero();  // the node lags: its anchor moves, it does not yet
  }
  core::detect_node_contacts(proximity, d);
  int found = 0;
  for (int i = 0; i < d.num_node_contacts; ++i) found += d.node_contacts[static_cast<std::size_t>(i)].node == lowest;
  const std::vector<int> device_body = {0};
  core::detail::cut_back_node_contacts(proximity, d, device_body, margin, 0.0, step);
  int kept = 0;
  for (int i = 0; i < d.num_node_contacts; ++i) {
    const core::NodeContact& c = d.node_contacts[static_cast<std::size_t>(i)];
    if (c.node != lowest) continue;
    EXPECT_TRUE(c.engaged);
    ++kept;
  }
  return {kept, found};
}

}  // namespace

// A node off the surface is a candidate within kLookAheadGap of it, or farther (within the
// margin) when its anchor, carried at the core's twist, is beyond the surface at the step's
// end: its tie pulls it there within the step. At a rate ratio of 1 (step 0) no look-ahead.
TEST(MultirateNet, LookAheadKeepsANodeWhoseAnchorReachesTheSurfaceWithinTheStep) {
  NUMEN_REQUIRE_DEFORMABLE();
  EXPECT_EQ(lowest_node_candidates(0.5e-4, 0.0, 0.01), std::make_pair(1, 1));   // within the gap
  EXPECT_EQ(lowest_node_candidates(0.5e-3, 0.0, 0.01), std::make_pair(0, 1));   // at rest: dropped
  EXPECT_EQ(lowest_node_candidates(0.5e-3, 0.04, 0.01), std::make_pair(0, 1));  // anchor 0.4 mm down
  EXPECT_EQ(lowest_node_candidates(0.5e-3, 0.06, 0.01), std::make_pair(1, 1));  // anchor 0.6 mm down
  EXPECT_EQ(lowest_node_candidates(0.5e-3, 0.06, 0.001), std::make_pair(0, 1)); // a shorter step
  EXPECT_EQ(lowest_node_candidates(0.5e-4, 0.06, 0.0), std::make_pair(0, 1));   // no look-ahead
  EXPECT_EQ(lowest_node_candidates(2.5e-3, 0.5, 0.01), std::make_pair(0, 0));   // beyond the margin
}
