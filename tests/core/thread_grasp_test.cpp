// Tests of a thread in a grasper's jaws (core/src/grasp/grasp_thread.cpp: which nodes the jaws
// take; core/src/thread/thread_grasp.cpp: their springs in the thread's implicit step;
// docs/thread.md "The thread in the jaws"): the jaws close on a thread lying on a plane and
// lift it, the held node follows them and the rest of the thread follows it, the tension next to
// the jaws is the grip's pull, opening lets it go (it falls freely from where it was let go), a
// pull past the grip's limit slips, and holding allocates nothing.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>

#include "alloc_counter.hpp"
#include "grasper_rig.hpp"
#include "numen/core/data.hpp"
#include "numen/core/grasp.hpp"
#include "numen/core/model.hpp"
#include "numen/core/step.hpp"
#include "numen/core/thread.hpp"

namespace {

namespace core = numen::core;
using core::Vec3;

using numen::test::kGraspDeg;
/// The grasper's hinge above the plane (m): its jaws' tip spheres (1.5 mm, 11 mm below the
/// hinge) come down on the plane as the jaws close past 27° and meet the thread on it below ~9°.
constexpr double kHingeZ = 0.0122;
/// The jaws' opening once closed on the thread (rad).
constexpr double kClosed = 4 * kGraspDeg;

/// Bodies 0–2: numen::test::add_grasper() pointing down, its hinge at z = kHingeZ above the
/// plane z = 0, its jaws open 60° (close below 30°, open above 40°, springs 2000 N/m, 2 N·s/m,
/// `max_force`). One thread "suture": the default 3-0 silk, 30 mm in 20 segments of 1.5 mm,
/// lying along x on the plane from x = −15 mm + `shift` (node 10 under the jaws at x = 0 when
/// `shift` is 0), its start tied to the world there (`tied`) or free, drag `drag` (N·s/m²).
/// Gravity; dt 1 ms; one material (2·10⁴ N/m, 10 N·s/m, viscous friction 0.5 N·s/m).
core::Model thread_grasp_rig(double max_force, bool tied, double drag = 1e-3, double shift = 0.0) {
  core::Model m;
  m.dt = 1e-3;
  m.material_names = {"steel"};
  m.material_pairs = {core::MaterialPair{2e4, 10.0, 0.5}};
  numen::test::add_grasper(m, Vec3(0, 0, kHingeZ + 0.04), 60 * kGraspDeg, max_force);
  core::Obstacle floor;
  floor.type = core::ShapeType::kPlane;
  m.obstacles.push_back(floor);
  core::ThreadModel th;
  th.name = "suture";
  th.length = 0.03;
  th.segments = 20;
  th.damping = drag;
  th.start = Vec3(-0.015 + shift, 0, th.radius);
  th.direction = Vec3::UnitX();
  th.tie_start.body = tied ? -1 : -2;
  th.tie_start.point = th.start;
  m.threads.push_back(th);
  const std::string err = core::finalize_model(m);
  EXPECT_EQ(err, "");
  return m;
}

/// Steps `steps` times with the jaws at `theta` closing at `rate` (rad/s) down to kClosed and the
/// hand at `hand(t)` (t: seconds into the call; the tube's target and its velocity); `each`
/// after each step. Returns false on a non-finite step.
bool drive(const core::Model& m, core::Data& d, int steps, double& theta, double rate,
           const std::function<Vec3(double, Vec3&)>& hand, const std::function<void(int)>& each = {}) {
  for (int s = 0; s < steps; ++s) {
    const double r = theta > kClosed || rate > 0.0 ? rate : 0.0;
    numen::test::set_grasper_opening(d, theta, r);
    theta = rate < 0.0 ? std::max(kClosed, theta + r * m.dt) : theta + r * m.dt;
    Vec3 v = Vec3::Zero();
    const Vec3 at = hand(s * m.dt, v);
    numen::test::set_grasper_target(d, at, v);
    core::step(m, d);
    if (d.status & core::kNonFinite) {
      ADD_FAILURE() << "non-finite step " << s;
      return false;
    }
    if (each) each(s);
  }
  return true;
}

const Vec3 kHand(0, 0, kHingeZ + 0.04);

/// The hand still at kHand.
Vec3 still(double, Vec3& v) {
  v.setZero();
  return kHand;
}

/// The hand moved by `by` (m) from kHand over 0.5 s (a cosine ramp), then held.
std::function<Vec3(double, Vec3&)> ramp(const Vec3& by) {
  return [by](double t, Vec3& v) {
    const double u = std::min(t, 0.5);
    v = u < 0.5 ? Vec3(by * 0.5 * M_PI / 0.5 * std::sin(M_PI * u / 0.5)) : Vec3::Zero();
    return Vec3(kHand + by * 0.5 * (1 - std::cos(M_PI * u / 0.5)));
  };
}

/// Closes the jaws from 60° at 100°/s to kClosed, the hand still, and lets them rest 0.1 s.
/// Returns the step index of the grasp (−1: none); `opening`: the jaws' opening then (rad).
int close_on_thread(const core::Model& m, core::Data& d, double& theta, double* opening = nullptr) {
  int grasped = -1;
  drive(m, d, 660, theta, -100 * kGraspDeg, still, [&](int s) {
    if (d.grasps[0].event != core::GraspEvent::kGrasp) return;
    grasped = s;
    if (opening != nullptr) *opening = d.grasps[0].opening;
  });
  return grasped;
}

/// The mean of a held node's two jaw points (world, m): where its springs pull it.
Vec3 jaw_mean_point(const core::Model& m, const core::Data& d, const core::GraspThreadNode& held) {
  Vec3 p = Vec3::Zero();
  for (std::size_t j = 0; j < 2; ++j) {
    const core::BodyState& jaw = d.bodies[static_cast<std::size_t>(m.grasps[0].jaws[j])];
    p += 0.5 * (jaw.position + jaw.orientation * held.jaw_points[j]);
  }
  return p;
}

TEST(ThreadGrasp, TheJawsTakeTheThreadAndLiftIt) {
  const core::Model m = thread_grasp_rig(5.0, false);
  core::Data d = core::make_data(m);
  double theta = 60 * kGraspDeg, opening_at_grasp = 0.0;
  const int grasped = close_on_thread(m, d, theta, &opening_at_grasp);
  ASSERT_GE(grasped, 0) << "the jaws never took the thread";
  const core::GraspState& g = d.grasps[0];
  ASSERT_EQ(g.thread, 0);
  EXPECT_EQ(g.body, -1);
  EXPECT_EQ(g.net, -1);
  ASSERT_GE(g.num_thread_nodes, 1);
  EXPECT_LE(g.num_thread_nodes, core::kMaxGraspThreadNodes);
  ASSERT_GE(g.logged, 1);
  EXPECT_EQ(g.log[0].event, core::GraspEvent::kGrasp);
  EXPECT_EQ(g.log[0].thread, 0);
  EXPECT_EQ(g.log[0].body, -1);
  EXPECT_EQ(g.log[0].nodes, g.num_thread_nodes);
  const core::ThreadState& t = d.threads[0];
  const std::vector<Vec3> before = t.position;
  double lag = 0.0;
  int jaw_contacts = 0;
  ASSERT_TRUE(drive(m, d, 800, theta, 0.0, ramp(Vec3(0, 0, 0.015)), [&](int) {
    for (int k = 0; k < g.num_thread_nodes; ++k) {
      const core::GraspThreadNode& held = g.thread_nodes[static_cast<std::size_t>(k)];
      lag = std::max(lag, (t.position[static_cast<std::size_t>(held.node)] - jaw_mean_point(m, d, held)).norm());
    }
    jaw_contacts += t.output.body_contacts;  // the jaws are the only bodies with spheres
  }));
  ASSERT_EQ(g.thread, 0) << "let go on the way up";
  const int mid = g.thread_nodes[static_cast<std::size_t>(g.num_thread_nodes / 2)].node;
  const double rise = t.position[static_cast<std::size_t>(mid)].z() - before[static_cast<std::size_t>(mid)].z();
  double lowest = 1.0, spread = 0.0;
  for (std::size_t i = 0; i < t.position.size(); ++i) {
    lowest = std::min(lowest, t.position[i].z());
    spread = std::max(spread, std::abs(t.position[i].z() - before[i].z() - rise));
  }
  std::printf(
      "[ figures  ] grasp at %.2f deg, %d nodes held (%d..%d); held node within %.4f mm of its "
      "jaw points over the lift; rise %.3f mm, the others' rise within %.4f mm of it, lowest node "
      "%.3f mm; stretch %.2e; jaw contacts while held %d; grip pull %.3e N\n",
      opening_at_grasp / kGraspDeg, g.num_thread_nodes, g.thread_nodes[0].node,
      g.thread_nodes[static_cast<std::size_t>(g.num_thread_nodes - 1)].node, lag * 1e3, rise * 1e3,
      spread * 1e3, lowest * 1e3, t.output.max_stretch, jaw_contacts, g.grip_force);
  EXPECT_LT(lag, 0.05e-3);          // the held node follows its jaw points within 0.05 mm
  EXPECT_GT(rise, 0.012);           // lifted 12–15 mm (the tube's coupling gives a little)
  EXPECT_LT(spread, 0.5e-3);        // the rest of the thread rose with it, to 0.5 mm
  EXPECT_GT(lowest, 0.010);         // all of it off the plane
  EXPECT_LT(t.output.max_stretch, 1e-3);
  EXPECT_EQ(jaw_contacts, 0);       // the jaws' contacts next to the held nodes are off
  // Held still, the jaws carry the thread's weight, ρ A L g.
  const core::ThreadModel& th = m.threads[0];
  const double weight = th.density * M_PI * th.radius * th.radius * th.length * 9.81;
  std::printf("[ figures  ] the grip's pull %.4e N, the thread's weight %.4e N\n", g.grip_force, weight);
  EXPECT_NEAR(g.grip_force, weight, 0.01 * weight);
}

// A grasper with `thread = false` (GraspModel::thread; the scene key of [[grasp]]) closes on the
// same thread and takes nothing: its jaws press on it through their contacts.
TEST(ThreadGrasp, AGrasperWithoutThreadGraspingTakesNothing) {
  core::Model m = thread_grasp_rig(5.0, false);
  m.grasps[0].thread = false;
  ASSERT_EQ(core::finalize_model(m), "");
  core::Data d = core::make_data(m);
  double theta = 60 * kGraspDeg;
  int touching = 0;
  drive(m, d, 660, theta, -100 * kGraspDeg, still,
        [&](int) { touching += d.threads[0].output.body_contacts > 0; });
  EXPECT_EQ(d.grasps[0].grasps, 0);
  EXPECT_EQ(d.grasps[0].thread, -1);
  EXPECT_GT(touching, 0) << "the jaws never reached the thread: the test checks nothing";
}

/// How far node `n`'s sphere (the thread's radius) is out of reach of jaw `j`'s nearest sphere
/// (m; < 0: within reach).
double node_gap(const core::Model& m, const core::Data& d, int j, int n) {
  const core::BodyModel& bm = m.bodies[static_cast<std::size_t>(m.grasps[0].jaws[static_cast<std::size_t>(j)])];
  const core::BodyState& bs = d.bodies[static_cast<std::size_t>(m.grasps[0].jaws[static_cast<std::size_t>(j)])];
  double gap = 1.0;
  for (int k = bm.sphere_begin; k < bm.sphere_begin + bm.sphere_count; ++k) {
    const core::Sphere& sp = m.body_spheres[static_cast<std::size_t>(k)];
    const Vec3 c = bs.position + bs.orientation * sp.center;
    gap = std::min(gap, (d.threads[0].position[static_cast<std::size_t>(n)] - c).norm() - sp.radius - m.threads[0].radius);
  }
  return gap;
}

TEST(ThreadGrasp, TheJawsTakeAThreadPinchedBetweenTwoNodes) {
  // The thread shifted half a segment (0.75 mm) along itself: the jaws meet it between nodes 9
  // and 10. The grasp starts when both touch the segment (the thread's own contact test), while
  // no node's sphere is yet within reach of both jaws (a rule on the nodes would wait for the
  // jaws to squeeze deeper); lifted 15 mm, the thread follows.
  const core::Model m = thread_grasp_rig(5.0, false, 1e-3, 0.00075);
  core::Data d = core::make_data(m);
  double theta = 60 * kGraspDeg, opening = 0.0, nearest_gap = 1.0;
  int grasped = -1;
  ASSERT_TRUE(drive(m, d, 660, theta, -100 * kGraspDeg, still, [&](int s) {
    if (d.grasps[0].event != core::GraspEvent::kGrasp) return;
    grasped = s;
    opening = d.grasps[0].opening;
    for (int n = 0; n <= m.threads[0].segments; ++n)
      nearest_gap = std::min(nearest_gap, std::max(node_gap(m, d, 0, n), node_gap(m, d, 1, n)));
  }));
  ASSERT_GE(grasped, 0) << "the jaws never took the thread";
  const core::GraspState& g = d.grasps[0];
  ASSERT_EQ(g.thread, 0);
  const double z0 = d.threads[0].position[10].z();
  ASSERT_TRUE(drive(m, d, 800, theta, 0.0, ramp(Vec3(0, 0, 0.015))));
  ASSERT_EQ(g.thread, 0);
  std::printf(
      "[ figures  ] between two nodes: grasp at %.2f deg, %d nodes held (%d..%d); at the grasp the "
      "node nearest both jaws was %.3f mm out of a jaw sphere's reach; lifted %.3f mm\n",
      opening / kGraspDeg, g.num_thread_nodes, g.thread_nodes[0].node,
      g.thread_nodes[static_cast<std::size_t>(g.num_thread_nodes - 1)].node, nearest_gap * 1e3,
      (d.threads[0].position[10].z() - z0) * 1e3);
  EXPECT_GT(nearest_gap, 0.0);
  EXPECT_GT(d.threads[0].position[10].z() - z0, 0.012);
}

TEST(ThreadGrasp, TheTensionNextToTheJawsIsTheGripsPull) {
  // The thread's start tied to the world 15 mm behind the jaws; the hand pulls 3 mm along the
  // thread and holds: the thread between tie and jaws taut, its tension the grip's pull.
  const core::Model m = thread_grasp_rig(5.0, true);
  core::Data d = core::make_data(m);
  double theta = 60 * kGraspDeg;
  ASSERT_GE(close_on_thread(m, d, theta), 0);
  const core::GraspState& g = d.grasps[0];
  ASSERT_EQ(g.thread, 0);
  ASSERT_TRUE(drive(m, d, 1000, theta, 0.0, ramp(Vec3(0.003, 0, 0))));
  ASSERT_EQ(g.thread, 0) << "slipped";
  const core::ThreadModel& th = m.threads[0];
  const core::ThreadState& t = d.threads[0];
  const auto first = static_cast<std::size_t>(g.thread_nodes[0].node);  // the held node nearest the tie
  ASSERT_GE(first, 1u);
  const double tension = th.stretch_stiffness * ((t.position[first] - t.position[first - 1]).norm() - th.rest_segment);
  Vec3 pull = Vec3::Zero();
  for (int k = 0; k < g.num_thread_nodes; ++k) pull += g.thread_nodes[static_cast<std::size_t>(k)].force;
  std::printf("[ figures  ] tension next to the jaws %.5f N, the grip's pull on the thread %.5f N "
              "(the jaws' reaction), grip_force %.5f N, relative difference %.2e\n",
              tension, pull.norm(), g.grip_force, std::abs(tension - pull.norm()) / pull.norm());
  EXPECT_GT(tension, 0.5);  // taut
  EXPECT_NEAR(tension, pull.norm(), 0.01 * pull.norm());
  EXPECT_NEAR(g.grip_force, pull.norm(), 1e-9);
}

TEST(ThreadGrasp, OpeningTheJawsLetsTheThreadFallFromWhereItWas) {
  // Lifted 15 mm, no drag: opened at 200°/s, the thread is let go past 40° and falls freely from
  // where it was (its nodes follow the step's free fall from their state at the release).
  const core::Model m = thread_grasp_rig(5.0, false, 0.0);
  core::Data d = core::make_data(m);
  double theta = 60 * kGraspDeg;
  ASSERT_GE(close_on_thread(m, d, theta), 0);
  ASSERT_TRUE(drive(m, d, 700, theta, 0.0, ramp(Vec3(0, 0, 0.015))));
  ASSERT_EQ(d.grasps[0].thread, 0);
  const int node = d.grasps[0].thread_nodes[0].node;
  const auto n = static_cast<std::size_t>(node);
  Vec3 x = Vec3::Zero(), v = Vec3::Zero();
  int released = -1;
  double let_go_at = 0.0;
  const auto lifted = ramp(Vec3(0, 0, 0.015));
  const auto held_up = [&](double, Vec3& vel) { return lifted(1.0, vel); };
  double drift = 0.0;
  int after = 0;
  for (int s = 0; s < 400 && after < 30; ++s) {
    const Vec3 x_before = d.threads[0].position[n], v_before = d.threads[0].velocity[n];
    ASSERT_TRUE(drive(m, d, 1, theta, 200 * kGraspDeg, held_up));
    if (released < 0 && d.grasps[0].event == core::GraspEvent::kRelease) {
      released = s;
      let_go_at = d.grasps[0].opening;
      x = x_before;
      v = v_before;
    }
    if (released < 0) continue;
    // The step's free fall: v += h g, x += h v (backward Euler under gravity alone).
    v += m.dt * m.gravity;
    x += m.dt * v;
    drift = std::max(drift, (d.threads[0].position[n] - x).norm());
    ++after;
  }
  ASSERT_GE(released, 0) << "never let go";
  EXPECT_EQ(d.grasps[0].releases, 1);
  EXPECT_EQ(d.grasps[0].thread, -1);
  EXPECT_EQ(d.grasps[0].log[static_cast<std::size_t>(d.grasps[0].logged - 1)].thread, 0);
  std::printf(
      "[ figures  ] let go at %.1f deg; over the 30 ms after, node %d within %.2e mm of free fall "
      "from where it was let go (it fell %.2f mm)\n",
      let_go_at / kGraspDeg, node, drift * 1e3, 0.5 * 9.81 * 0.03 * 0.03 * 1e3);
  EXPECT_LT(drift, 0.01e-3);
}

TEST(ThreadGrasp, APullPastTheGripsLimitSlips) {
  // A 0.5 N grip pulled 4 mm along the tied thread (3 mm pulls 0.74 N, above): the pull passes
  // 0.5 N and the thread slips out; the jaws, still closed, are not armed again and do not take
  // it back.
  const core::Model m = thread_grasp_rig(0.5, true);
  core::Data d = core::make_data(m);
  double theta = 60 * kGraspDeg;
  ASSERT_GE(close_on_thread(m, d, theta), 0);
  ASSERT_TRUE(drive(m, d, 1000, theta, 0.0, ramp(Vec3(0.004, 0, 0))));
  const core::GraspState& g = d.grasps[0];
  EXPECT_EQ(g.slips, 1);
  EXPECT_EQ(g.grasps, 1);
  EXPECT_EQ(g.thread, -1);
  EXPECT_FALSE(g.armed);
  ASSERT_GE(g.logged, 2);
  const core::GraspRecord& slip = g.log[1];
  EXPECT_EQ(slip.event, core::GraspEvent::kSlip);
  EXPECT_EQ(slip.thread, 0);
  EXPECT_GT(slip.grip_force, 0.5);
  EXPECT_LT(slip.grip_force, 0.6);  // caught in the step after the pull passed the limit
  std::printf("[ figures  ] grasp at %.3f s, slip at %.3f s, pull %.3f N (limit 0.5 N); thread tension at the end %.3f N\n",
              g.log[0].time, slip.time, slip.grip_force, d.threads[0].output.max_tension);
}

TEST(ThreadGrasp, HoldingAThreadAllocatesNothing) {
  const core::Model m = thread_grasp_rig(5.0, false);
  core::Data d = core::make_data(m);
  double theta = 60 * kGraspDeg;
  ASSERT_GE(close_on_thread(m, d, theta), 0);
  ASSERT_TRUE(drive(m, d, 600, theta, 0.0, ramp(Vec3(0, 0, 0.015))));  // lifted, held still
  ASSERT_EQ(d.grasps[0].thread, 0);
  numen::test::AllocationGuard guard;
  for (int s = 0; s < 200; ++s) core::step(m, d);
  EXPECT_EQ(guard.count(), 0);
  EXPECT_EQ(d.grasps[0].thread, 0);
}

}  // namespace
