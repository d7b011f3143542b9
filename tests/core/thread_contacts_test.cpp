/// @file thread_contacts_test.cpp
/// The thread's self contact (core/src/thread/thread_contacts.cpp): the friction between two
/// strands (ThreadModel::self_friction) as the Newton system gets it, against Coulomb's law (what
/// it does to a knot: tests/core/thread_knot_test.cpp).

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "linalg/thread_band.hpp"
#include "numen/core/model.hpp"
#include "numen/core/thread.hpp"
#include "scratch/thread_scratch.hpp"
#include "thread/thread_terms.hpp"

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

}  // namespace
}  // namespace numen
