// Tests of core/thread through tissue (thread.hpp "Through tissue"; docs/thread.md "The thread
// through tissue"): an eyelet on a net's material point holds the thread across and drags it along,
// and gives its force back to the tissue (pulled sideways, dragged along), where an eyelet at a
// point the caller moves leaves the tissue alone; a needle driven through the patch hands its
// entry point, once its tail passes it, to the thread tied at its tail, which then slides through
// it; an eyelet the thread's free end slides out of is let go; no allocation.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>

#include "alloc_counter.hpp"
#include "needle_rig.hpp"
#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/needle.hpp"
#include "numen/core/needle_puncture.hpp"
#include "numen/core/step.hpp"
#include "numen/core/thread.hpp"
#include "organ_indentation.hpp"

namespace {

namespace core = numen::core;

/// Where the vertical line through (x, y) meets the patch at rest: its face and weights.
struct PatchPoint {
  int face = -1;
  core::Vec3 weights = core::Vec3::Zero();
};

PatchPoint patch_point(const core::Model& m, const core::Data& d, double x, double y) {
  for (std::size_t f = 0; f < m.net_faces.size(); ++f) {
    const auto& t = m.net_faces[f];
    const core::Vec3& a = d.nodes[static_cast<std::size_t>(t[0])].position;
    const core::Vec3& b = d.nodes[static_cast<std::size_t>(t[1])].position;
    const core::Vec3& c = d.nodes[static_cast<std::size_t>(t[2])].position;
    const double det = (b.x() - a.x()) * (c.y() - a.y()) - (c.x() - a.x()) * (b.y() - a.y());
    const double w1 = ((x - a.x()) * (c.y() - a.y()) - (c.x() - a.x()) * (y - a.y())) / det;
    const double w2 = ((b.x() - a.x()) * (y - a.y()) - (x - a.x()) * (b.y() - a.y())) / det;
    if (w1 >= 0 && w2 >= 0 && w1 + w2 <= 1) return {static_cast<int>(f), core::Vec3(1 - w1 - w2, w1, w2)};
  }
  return {};
}

/// The material point of `p` now (m, world).
core::Vec3 material_point(const core::Model& m, const core::Data& d, const PatchPoint& p) {
  core::Vec3 x = core::Vec3::Zero();
  for (int k = 0; k < 3; ++k)
    x += p.weights[k] * d.nodes[static_cast<std::size_t>(m.net_faces[static_cast<std::size_t>(p.face)][static_cast<std::size_t>(k)])].position;
  return x;
}

/// Distance (m) from `x` to the nearest point of the thread `st`.
double distance_to_thread(const core::ThreadState& st, const core::Vec3& x) {
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i + 1 < st.position.size(); ++i) {
    const core::Vec3 a = st.position[i], ab = st.position[i + 1] - a;
    const double u = std::clamp((x - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
    best = std::min(best, (a + u * ab - x).norm());
  }
  return best;
}

/// The puncture rig's patch (body 0 its anchored core; no needle) with a 40 mm thread of 40
/// segments straight down through the patch at (0.5, 0.5) mm, 20 mm of it above; `top` ties its
/// upper end to that world point (else it is free); its lower end free.
core::Model patch_with_thread(bool top) {
  core::Model m = numen::test::organ::patch_rig_start();
  m.initial_held_body = -1;
  const core::TriangleMesh patch = numen::test::organ::flat_patch(14, 0.002);
  EXPECT_EQ(core::add_net(m, patch, numen::test::organ::organ_net_settings(patch, {})), "");
  core::ThreadModel t;
  t.name = "suture";
  t.length = 0.04;
  t.segments = 40;
  t.start = core::Vec3(5e-4, 5e-4, 0.02);
  t.direction = -core::Vec3::UnitZ();
  t.self_contact = false;
  if (top) {
    t.tie_start.body = -1;
    t.tie_start.point = t.start;
  }
  m.threads.push_back(t);
  EXPECT_EQ(core::finalize_model(m), "");
  return m;
}

/// An eyelet at the patch's point under the thread: on the tissue (`on_tissue`) or at the same
/// point held still by the caller.
void place_eyelet(const core::Model& m, core::Data& d, bool on_tissue, double friction, double drag) {
  const PatchPoint p = patch_point(m, d, 5e-4, 5e-4);
  ASSERT_GE(p.face, 0);
  core::ThreadEyelet& e = d.threads[0].eyelets[0];
  e = core::ThreadEyelet{};
  e.active = true;
  e.position = material_point(m, d, p);
  e.friction = friction;
  e.drag = drag;
  if (on_tissue) {
    e.face = p.face;
    e.weights = p.weights;
  }
}

/// Steps `steps` with a constant force `pull` (N) on the thread's last node; returns how far the
/// patch's material point under the thread moved (m, world). `allocations`: counted over the steps.
core::Vec3 pull_thread(const core::Model& m, core::Data& d, const core::Vec3& pull, int steps,
                       std::uint64_t* allocations = nullptr) {
  const PatchPoint p = patch_point(m, d, 5e-4, 5e-4);
  const core::Vec3 x0 = material_point(m, d, p);
  d.threads[0].external_force.back() = pull;
  numen::test::AllocationGuard guard;
  for (int s = 0; s < steps; ++s) {
    core::step(m, d);
    EXPECT_FALSE(d.status & core::kNonFinite) << "step " << s;
  }
  if (allocations != nullptr) *allocations = guard.count();
  return material_point(m, d, p) - x0;
}

}  // namespace

TEST(ThreadTissue, AnEyeletOnTissuePullsTheTissueSidewaysWithTheThread) {
  // The thread tied above the patch, its lower end pulled sideways (+x) by 0.1 N: it bends at the
  // eyelet, which holds it across; on the tissue the same force pulls the material point along +x,
  // where an eyelet the caller holds still leaves the tissue where it was.
  const core::Model m = patch_with_thread(true);
  core::Data on = core::make_data(m), still = core::make_data(m);
  place_eyelet(m, on, true, 0.0, 0.0);
  place_eyelet(m, still, false, 0.0, 0.0);
  std::uint64_t allocations = 1;
  const core::Vec3 moved = pull_thread(m, on, core::Vec3(0.1, 0, 0), 300, &allocations);
  const core::Vec3 held = pull_thread(m, still, core::Vec3(0.1, 0, 0), 300);
  std::printf("sideways pull 0.1 N: the tissue's point moved (%.4f, %.4f, %.4f) mm on tissue, %.2e mm held "
              "still; eyelet force %.4f N, node springs %d\n",
              moved.x() * 1e3, moved.y() * 1e3, moved.z() * 1e3, held.norm() * 1e3,
              on.threads[0].output.eyelets[0].normal_force, on.num_node_thread_ties);
  EXPECT_EQ(allocations, 0u) << "a thread through tissue allocated";
  EXPECT_GT(moved.x(), 1e-4) << "m: the thread pulled the tissue its way";
  EXPECT_LT(held.norm(), 1e-6) << "m: an eyelet the caller holds gives the tissue nothing";
  EXPECT_GT(on.threads[0].output.eyelets[0].normal_force, 0.05) << "N: the eyelet holds the bend";
  EXPECT_GT(on.num_node_thread_ties, 0);
  EXPECT_EQ(still.num_node_thread_ties, 0);
  EXPECT_LT(distance_to_thread(on.threads[0], on.threads[0].eyelets[0].position), 5e-4)
      << "m: the thread stays through the eyelet";
}

TEST(ThreadTissue, AThreadSlidingThroughDragsTheTissueAlong) {
  // The thread free at both ends, pulled down along itself by 0.05 N: it slides through the
  // eyelet, and the eyelet's drag (the needle's 2 N·s/m) carries the pull to the tissue, which is
  // drawn down; without friction or drag the thread slides through and the tissue stays.
  const core::Model m = patch_with_thread(false);
  core::Data drag = core::make_data(m), free = core::make_data(m);
  place_eyelet(m, drag, true, 0.3, 2.0);
  place_eyelet(m, free, true, 0.0, 0.0);
  const core::Vec3 dragged = pull_thread(m, drag, core::Vec3(0, 0, -0.05), 100);
  const core::Vec3 slid = pull_thread(m, free, core::Vec3(0, 0, -0.05), 100);
  const core::ThreadEyeletOutput& out = drag.threads[0].output.eyelets[0];
  std::printf("pull along 0.05 N: the tissue's point moved %.4f mm down with drag, %.2e mm without; "
              "friction on the thread %.4f N; segment %d\n",
              -dragged.z() * 1e3, -slid.z() * 1e3, out.friction_force, out.segment);
  EXPECT_GT(-dragged.z(), 1e-4) << "m: the sliding thread drew the tissue down";
  EXPECT_LT(std::abs(slid.z()), 0.05 * std::abs(dragged.z())) << "m: without friction the tissue stays";
  EXPECT_LT(out.segment, 19) << "the thread slid down through it (segment 20 was there at first)";
  EXPECT_NEAR(out.friction_force, -0.05, 0.005) << "N: the pull, carried by the drag at the thread's speed";
  EXPECT_EQ(drag.threads[0].eyelets_let_go, 0);
}

TEST(ThreadTissue, AnEyeletTheFreeEndSlidesOutOfIsLetGo) {
  // Pulled down without friction for long enough, the whole thread slides out under the patch:
  // the eyelet lets it go, counted once, and gives the tissue nothing more.
  const core::Model m = patch_with_thread(false);
  core::Data d = core::make_data(m);
  place_eyelet(m, d, true, 0.0, 0.0);
  pull_thread(m, d, core::Vec3(0, 0, -0.05), 400);
  EXPECT_FALSE(d.threads[0].eyelets[0].active);
  EXPECT_EQ(d.threads[0].eyelets_let_go, 1);
  EXPECT_EQ(d.num_node_thread_ties, 0);
  EXPECT_GT(distance_to_thread(d.threads[0], d.threads[0].eyelets[0].position), 0.0);
}

TEST(ThreadTissue, TheNeedlesEntryIsTakenOverByTheThreadAtItsTail) {
  // The puncture rig's needle (26 mm half circle through a 28 × 28 mm patch at 8.3 mm/s) with a
  // 60 mm thread tied at its tail, starting straight up (along the tail's tangent it would start
  // through the patch, which it touches); turned 230°, then pulled up 20 mm at 10 mm/s: once the tail
  // passes the entry the thread takes the point over as an eyelet on the tissue, passes through
  // it, slides through it as the needle is pulled on, and tents the tissue up through friction.
  core::Model m = numen::test::puncture_rig(numen::test::kPunctureThreshold, 60 * numen::test::kPunctureDeg, false, false);
  numen::test::add_tail_thread(m, 0.06, 60);
  ASSERT_EQ(core::finalize_model(m), "");
  ASSERT_EQ(m.threads[0].needle, 0) << "the thread's start is tied to the needle";
  core::Data d = core::make_data(m);
  const double turn = 230 * numen::test::kPunctureDeg, omega = 1.0;
  int taken_step = -1, segment_taken = -1;
  core::Vec3 eyelet_at_take = core::Vec3::Zero();
  std::uint64_t allocations = 0;
  {
    numen::test::AllocationGuard guard;
    for (int s = 0; s < 6500; ++s) {
      const double t = s * m.dt;
      numen::test::puncture_drive(m, d, t, omega, turn);
      const double lift = std::clamp(t - 4.3, 0.0, 2.0) * 0.01;  // after the turn: up 20 mm
      d.target.position.z() += lift;
      if (t > 4.3 && t < 6.3) d.target_twist.linear.z() += 0.01;
      core::step(m, d);
      ASSERT_FALSE(d.status & core::kNonFinite) << "step " << s;
      if (taken_step < 0 && d.threads[0].eyelets_taken > 0) {
        taken_step = s;
        eyelet_at_take = d.threads[0].eyelets[0].position;
      }
      if (taken_step >= 0 && segment_taken < 0 && d.threads[0].output.eyelets[0].segment >= 0)
        segment_taken = d.threads[0].output.eyelets[0].segment;
    }
    allocations = guard.count();
  }
  const core::ThreadState& th = d.threads[0];
  const core::ThreadEyelet& e = th.eyelets[0];
  const core::ThreadEyeletOutput& out = th.output.eyelets[0];
  std::printf("taken over at step %d (%.3f s); eyelet moved %.3f mm since; thread through it %.3f mm away; "
              "segment %d -> %d; friction %.4f N, across %.4f N; node springs %d; tunnels %lld\n",
              taken_step, taken_step * m.dt, (e.position - eyelet_at_take).norm() * 1e3,
              distance_to_thread(th, e.position) * 1e3, segment_taken, out.segment, out.friction_force,
              out.normal_force, d.num_node_thread_ties, static_cast<long long>(d.needles[0].tunnels));
  EXPECT_EQ(allocations, 0u) << "the needle and thread through tissue allocated";
  ASSERT_GE(taken_step, 0) << "the thread took the entry over";
  EXPECT_EQ(th.eyelets_taken, 1);
  EXPECT_EQ(th.eyelets_dropped, 0);
  ASSERT_TRUE(e.active);
  EXPECT_GE(e.face, 0);
  EXPECT_LT(distance_to_thread(th, e.position), 5e-4) << "m: the thread runs through the entry";
  EXPECT_GT(out.segment, segment_taken + 4) << "the thread slid 5 mm or more through the entry";
  EXPECT_GT(d.num_node_thread_ties, 0) << "the tissue feels the thread";
  EXPECT_EQ(d.needles[0].tunnels, 0);
}

TEST(ThreadTissue, AThreadNotTiedToANeedleTakesNothingOver) {
  // The same rig, the thread tied to the world instead: the needle's entry is let go at its tail
  // and nobody takes it (ThreadModel::needle −1).
  core::Model m = numen::test::puncture_rig(numen::test::kPunctureThreshold, 60 * numen::test::kPunctureDeg, false, false);
  core::ThreadModel t;
  t.length = 0.02;
  t.segments = 10;
  t.start = core::Vec3(0.05, 0.05, 0.02);
  t.tie_start.body = -1;
  t.tie_start.point = t.start;
  m.threads.push_back(t);
  ASSERT_EQ(core::finalize_model(m), "");
  EXPECT_EQ(m.threads[0].needle, -1);
  core::Data d = core::make_data(m);
  std::int64_t released_at_tail = 0;
  for (int s = 0; s < 4500; ++s) {
    numen::test::puncture_drive(m, d, s * m.dt, 1.0, 230 * numen::test::kPunctureDeg);
    core::step(m, d);
    released_at_tail += d.needles[0].num_tail_releases;
  }
  EXPECT_GE(released_at_tail, 1) << "the needle let its entry go at its tail";
  EXPECT_EQ(d.threads[0].eyelets_taken, 0);
  EXPECT_EQ(d.num_node_thread_ties, 0);
}
