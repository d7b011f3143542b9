/// @file thread_contacts_test.cpp
/// The thread's contacts (core/src/thread/thread_contacts.cpp): the friction between two strands
/// (ThreadModel::self_friction) as the Newton system gets it, against Coulomb's law (what it does
/// to a knot: tests/core/thread_knot_test.cpp); a body's spheres against the segments, found by
/// runs of segments (kThreadSegmentRun) as one by one.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <utility>
#include <vector>

#include "linalg/thread_band.hpp"
#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/step.hpp"
#include "numen/core/thread.hpp"
#include "scratch/thread_scratch.hpp"
#include "thread/thread_terms.hpp"
#include "thread_scenes.hpp"

namespace numen {
namespace {

using core::Mat3;
using core::Vec3;

/// What pair_terms() found.
struct PairTerms {
  Vec3 force = Vec3::Zero();
  Mat3 matrix = Mat3::Zero();
  Vec3 force_on_other = Vec3::Zero();
  int touching = 0;
};

/// Segment 1 (nodes 1–2, along x) lying on segment 5 (nodes 5–6, along y) `depth` deeper than
/// their two radii, segment 1's nodes sliding at `slide` (m/s, along x) over the still segment
/// 5: the self-contact terms (add_thread_self_contacts()) of a 10-segment thread of the
/// material's stiffness `k` and μ `mu`, h = 1 ms. Returns the force on segment 1 (the sum of its
/// two blocks' right-hand side, divided by h) and its blocks' matrix (the sum of the four 3×3
/// blocks of nodes 1 and 2, divided by h), the force on segment 5 likewise, and whether the pair
/// touched.
PairTerms pair_terms(double k, double mu, double depth, double slide) {
  core::Model m;
  m.material_names = {"silk"};
  core::MaterialPair pair;
  pair.stiffness = k;
  m.material_pairs = {pair};
  core::ThreadModel t;
  t.segments = 10;
  t.self_friction = mu;
  EXPECT_EQ(core::finalize_thread(t, 0, 1), "");
  core::ThreadScratch scratch;
  scratch.resize(t, 0, 0);
  const double z = 2.0 * t.radius - depth;  // segment 1 above segment 5 by less than 2 r
  std::vector<Vec3> x(11, Vec3(0.0, 0.0, -1.0)), v(11, Vec3::Zero());
  x[1] = Vec3(-0.5e-3, 0.0, z);
  x[2] = Vec3(0.5e-3, 0.0, z);
  x[5] = Vec3(0.0, -0.5e-3, 0.0);
  x[6] = Vec3(0.0, 0.5e-3, 0.0);
  v[1] = v[2] = Vec3(slide, 0.0, 0.0);
  scratch.num_self_pairs = 1;
  scratch.self_pairs[0] = core::ThreadSelfPair{1, 5, 0.5, 0.5, Vec3::UnitZ()};
  const double h = 1e-3;
  scratch.band.clear();
  PairTerms out;
  out.touching = core::add_thread_self_contacts(m, t, x, v, scratch, h, scratch.band);
  const core::ThreadBand& b = scratch.band;
  out.force = (b.rhs[2] + b.rhs[3]) / h;
  out.force_on_other = (b.rhs[6] + b.rhs[7]) / h;
  out.matrix = (b.diag[2] + b.diag[3] + b.lower1[3] + b.lower1[3].transpose()) / h;
  return out;
}

// Sliding faster than kThreadSelfSlipSpeed: the normal force k d and Coulomb's μ k d against the
// sliding; slower, viscous μ k d / v_slip per m/s; the reaction on the other strand opposite;
// the friction's damping doubled in the strand's own blocks (each side against the other as
// given, as the normal stiffness), and nothing of it with μ = 0.
TEST(ThreadContacts, TheFrictionBetweenStrandsIsCoulombs) {
  const double k = 1e5, mu = 0.3, depth = 20e-6, h = 1e-3;
  const double normal = k * depth;  // 2 N
  const PairTerms fast = pair_terms(k, mu, depth, 0.01);
  EXPECT_EQ(fast.touching, 1);
  EXPECT_NEAR(fast.force.z(), normal, 1e-9 * normal);
  EXPECT_NEAR(fast.force.x(), -mu * normal, 1e-9 * normal);
  EXPECT_NEAR(fast.force.y(), 0.0, 1e-12);
  EXPECT_NEAR((fast.force + fast.force_on_other).norm(), 0.0, 1e-9 * normal);
  const double c = mu * normal / 0.01;  // N·s/m
  EXPECT_NEAR(fast.matrix(0, 0), 2.0 * c, 1e-9 * c);
  EXPECT_NEAR(fast.matrix(1, 1), 2.0 * c, 1e-9 * c);
  EXPECT_NEAR(fast.matrix(2, 2), 2.0 * h * k, 1e-9 * h * k);  // the normal stiffness, h k doubled
  const PairTerms slow = pair_terms(k, mu, depth, 0.25 * core::kThreadSelfSlipSpeed);
  EXPECT_NEAR(slow.force.x(), -0.25 * mu * normal, 1e-9 * normal);
  const PairTerms none = pair_terms(k, 0.0, depth, 0.01);
  EXPECT_EQ(none.force.x(), 0.0);
  EXPECT_NEAR(none.matrix(0, 0), 0.0, 1e-12);
  const PairTerms apart = pair_terms(k, mu, -1e-6, 0.01);  // not touching: nothing
  EXPECT_EQ(apart.touching, 0);
  EXPECT_EQ(apart.force.norm(), 0.0);
}

// A straight 24-segment thread (three runs of kThreadSegmentRun) and an anchored body's spheres
// just above it: on the node between two runs (segments 7 and 8), within a segment of the
// middle run (15), on the node between the last two runs (segments 15 and 16), on the last
// segment (23), and on segment 1, next to the thread's tie to that body (the 3 segments next to
// a tie do not touch the tied body). The first step finds the contacts a sphere-by-segment test
// of every pair finds: 6.
TEST(ThreadContacts, ABodysSpheresFindTheSegmentsTheyTouchAcrossTheRuns) {
  ASSERT_EQ(core::kThreadSegmentRun, 8);  // the spheres below sit on its runs' edges
  core::ThreadModel t;
  t.segments = 24;
  t.length = 0.024;  // 1 mm segments
  const double ls = t.length / t.segments;
  const double r = 0.3 * ls, lift = 0.2 * ls;
  const std::vector<double> at = {8.0, 15.5, 16.0, 23.5, 1.5};  // along the thread, in segments
  core::Model m = test::thread_model(t, [&](core::Model& mm) {
    const int b = test::add_thread_test_body(mm, 0.01, 1e-6, Vec3::Zero(), 0.0);
    core::BodyModel& body = mm.bodies[static_cast<std::size_t>(b)];
    body.anchored = true;
    body.sphere_begin = static_cast<int>(mm.body_spheres.size());
    body.sphere_count = static_cast<int>(at.size());
    for (const double a : at) mm.body_spheres.push_back({Vec3(a * ls, 0.0, lift), r});
    mm.threads[0].tie_start.body = b;
    mm.threads[0].tie_start.point = Vec3::Zero();
    mm.threads[0].tie_end.body = -1;
    mm.threads[0].tie_end.point = Vec3(t.length, 0.0, 0.0);
  });
  core::Data d = core::make_data(m);
  // Every pair, one by one: the segment's closest point within the sphere's radius and the
  // thread's, but for the tied body's 3 segments next to the tie.
  const std::vector<Vec3> x = d.threads[0].position;
  int expected = 0;
  for (const double a : at) {
    const Vec3 c(a * ls, 0.0, lift);
    for (int s = 3; s < t.segments; ++s) {
      const Vec3 p = x[static_cast<std::size_t>(s)], q = x[static_cast<std::size_t>(s) + 1];
      const double u = std::clamp((c - p).dot(q - p) / (q - p).squaredNorm(), 0.0, 1.0);
      expected += (p + u * (q - p) - c).norm() < r + m.threads[0].radius;
    }
  }
  EXPECT_EQ(expected, 6);  // 2 + 1 + 2 + 1 + 0
  core::step(m, d);
  EXPECT_EQ(d.threads[0].output.body_contacts, expected);
}

// A sphere a segment touched in the last step and no longer touches at this step's start is kept
// as a contact (core/src/thread/thread_contacts.cpp; docs/thread.md "Contacts with bodies"): a
// thread coming at it at 1.5 m/s from 0.09 mm away (as a taut thread straightens where a jaw has
// just receded: the suturing scene at 25.010 s) stops short of its surface (within the step's
// Newton iterations, which run out here with or without it: a free thread's nodes at 1.5 m/s). The
// same sphere at the same gap, never touched before, is found only at the next step's start,
// 1.07 mm deep.
TEST(ThreadContacts, ASphereTouchedInTheLastStepStopsTheThreadComingBackAtIt) {
  core::ThreadModel t;
  t.segments = 40;
  t.length = 0.04;
  t.start = Vec3::Zero();
  const double radius = 2e-3;
  core::Model m = test::thread_model(t, [&](core::Model& mm) {
    mm.threads[0].tie_end.body = -1;
    mm.threads[0].tie_end.point = Vec3(t.length, 0.0, 0.0);
    test::add_thread_test_body(mm, 1e3, 1.0, Vec3(0.02, 0.0, -0.1), radius);  // heavy: the thread moves it by nothing
  });
  const double rt = m.threads[0].radius;
  // `touch_first`: a first step with the sphere's top 0.01 mm into the thread; else with it far.
  const auto run = [&](bool touch_first) {
    core::Data d = core::make_data(m);
    d.bodies[0].position = touch_first ? Vec3(0.02, 0.0, -radius - rt + 0.01e-3) : Vec3(0.02, 0.0, -0.1);
    core::step(m, d);
    EXPECT_EQ(d.threads[0].output.body_contacts, touch_first ? 2 : 0);
    // Then 0.09 mm below the thread's lowest point, the thread's middle coming down at 1.5 m/s.
    double lowest = 0.0;
    for (const Vec3& x : d.threads[0].position) lowest = std::min(lowest, x.z());
    d.bodies[0].position = Vec3(0.02, 0.0, lowest - radius - rt - 0.09e-3);
    for (int i = 15; i <= 25; ++i) d.threads[0].velocity[static_cast<std::size_t>(i)] = Vec3(0.0, 0.0, -1.5);
    core::step(m, d);
    EXPECT_EQ(d.status & core::kNonFinite, 0u);
    const int kept = d.threads[0].output.kept_contacts;
    double depth = 0.0;
    const core::ThreadState& st = d.threads[0];
    for (int sgm = 0; sgm < t.segments; ++sgm) {
      const Vec3 p = st.position[static_cast<std::size_t>(sgm)], q = st.position[static_cast<std::size_t>(sgm) + 1];
      const double u = std::clamp((d.bodies[0].position - p).dot(q - p) / (q - p).squaredNorm(), 0.0, 1.0);
      depth = std::max(depth, radius + rt - (p + u * (q - p) - d.bodies[0].position).norm());
    }
    const double moved = lowest - d.threads[0].position[20].z();  // the middle's way down (m)
    std::printf("%s: the middle %.4f mm down, %.4f mm into the sphere, %d kept contacts pushing at "
                "the step's end, %d Newton iterations (converged %d)\n",
                touch_first ? "touched before" : "never touched", 1e3 * moved, 1e3 * depth, kept,
                d.threads[0].output.iterations, d.threads[0].output.converged ? 1 : 0);
    return std::pair{moved, depth};
  };
  const auto [moved, depth] = run(true);
  EXPECT_LT(depth, 0.05e-3) << "m: the kept contact stops it at the sphere";
  EXPECT_LT(moved, 0.1e-3) << "m: at most the 0.09 mm gap and the penalty's depth";
  const auto [moved_never, depth_never] = run(false);
  EXPECT_GT(depth_never, 0.5e-3) << "m: without the contact the step carries it in";
  EXPECT_GT(moved_never, 1e-3);
}

}  // namespace
}  // namespace numen
