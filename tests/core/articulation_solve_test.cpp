// Tests of the linear-time KKT solve of an articulation (core/src/scratch/articulation_solve.hpp,
// Baraff 1996) against the dense reference and against the residual of an independently
// assembled H, with known bodies (including re-rooting at a joint grounded from below),
// disabled joints, singular rows, and allocation-free factor + solve. The topology:
// articulation_test.cpp.
#include "scratch/articulation_solve.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include "alloc_counter.hpp"
#include "articulation_forests.hpp"
#include "numen/core/articulation.hpp"
#include "numen/core/joint.hpp"
#include "numen/core/model.hpp"
#include "sanitizer.hpp"

namespace core = numen::core;
using core::JointVector;
using core::Mat3;
using core::Mat6;
using core::Vec6;

namespace {

using namespace numen::test::articulation_forests;

/// Symmetric positive definite body block: mass 0.01..10 kg, random inertia
/// (principal moments 1e-3..1 kg·m², random axes), plus a random SPD coupling.
Mat6 random_body_block(Rng& rng) {
  const double mass = std::pow(10.0, uniform(rng, -2.0, 1.0));
  const Eigen::MatrixXd r = random_orthogonal(rng, 3);
  const Eigen::Vector3d moments(std::pow(10.0, uniform(rng, -3.0, 0.0)),
                                std::pow(10.0, uniform(rng, -3.0, 0.0)),
                                std::pow(10.0, uniform(rng, -3.0, 0.0)));
  Mat6 a = Mat6::Zero();
  a.topLeftCorner<3, 3>() = mass * Mat3::Identity();
  a.bottomRightCorner<3, 3>() = r * moments.asDiagonal() * r.transpose();
  Mat6 b;
  for (int i = 0; i < 6; ++i)
    for (int j = 0; j < 6; ++j) b(i, j) = gauss(rng) / std::sqrt(6.0);
  a += 0.5 * std::min(mass, moments.minCoeff()) * b * b.transpose();
  return 0.5 * (a + a.transpose());
}

/// Random full-row-rank m×6 rows (singular values 0.5..2), zero below row m.
core::JointJacobian random_rows(Rng& rng, int m) {
  const Eigen::MatrixXd u = random_orthogonal(rng, m);
  const Eigen::MatrixXd v = random_orthogonal(rng, 6);
  Eigen::VectorXd s(m);
  for (int i = 0; i < m; ++i) s(i) = uniform(rng, 0.5, 2.0);
  core::JointJacobian g = core::JointJacobian::Zero();
  g.topRows(m) = u * s.asDiagonal() * v.topRows(m);
  return g;
}

/// One system: model, body blocks, scratch (rows, known) and right-hand side.
struct System {
  core::Model model;
  std::vector<Mat6> blocks;
  core::ArticulationScratch scratch;
  std::vector<Vec6> b;
  std::vector<JointVector> c;
};

void fill_random_system(Rng& rng, System& s) {
  const core::Model& m = s.model;
  s.scratch.resize(m);
  s.blocks.assign(static_cast<std::size_t>(m.num_bodies()), Mat6::Identity());
  s.b.assign(static_cast<std::size_t>(m.num_bodies()), Vec6::Zero());
  s.c.assign(static_cast<std::size_t>(m.num_joints()), JointVector::Zero());
  for (int i = 0; i < m.num_bodies(); ++i) {
    const auto k = static_cast<std::size_t>(i);
    s.blocks[k] = random_body_block(rng);
    for (int r = 0; r < 6; ++r) s.b[k](r) = gauss(rng);
  }
  for (int j = 0; j < m.num_joints(); ++j) {
    const auto k = static_cast<std::size_t>(j);
    const core::JointModel& jm = m.joints[k];
    core::JointRows& rows = s.scratch.rows[k];
    rows.count = jm.num_rows;
    rows.g_child = random_rows(rng, jm.num_rows);
    rows.g_parent = jm.parent >= 0 ? random_rows(rng, jm.num_rows) : core::JointJacobian::Zero();
    for (int r = 0; r < 6; ++r) s.c[k](r) = gauss(rng);  // rows ≥ num_rows must be ignored
    // Garbage in the unused rows: the solves read rows [0, num_rows) only.
    for (int r = jm.num_rows; r < core::kMaxJointRows; ++r)
      for (int col = 0; col < 6; ++col) {
        rows.g_child(r, col) = gauss(rng);
        rows.g_parent(r, col) = gauss(rng);
      }
  }
}

void set_random_known(Rng& rng, System& s, int mode) {
  const int nb = s.model.num_bodies();
  std::fill(s.scratch.known.begin(), s.scratch.known.end(), 0);
  if (mode == 1) {
    s.scratch.known[static_cast<std::size_t>(uniform_int(rng, 0, nb - 1))] = 1;
  } else if (mode == 2) {
    for (auto& k : s.scratch.known) k = uniform(rng, 0.0, 1.0) < 0.15 ? 1 : 0;
  }
}

bool is_unknown(const System& s, int body) {
  return body >= 0 && s.scratch.known[static_cast<std::size_t>(body)] == 0;
}
bool is_active(const System& s, const core::JointModel& j) {
  return is_unknown(s, j.child) || is_unknown(s, j.parent);
}

/// Independent check of tree solvability: no component of unknown bodies
/// (joined by joints between unknown bodies) has two joints tying it to the
/// world or to known bodies.
bool tree_solvable(const System& s) {
  const int nb = s.model.num_bodies();
  std::vector<int> comp(static_cast<std::size_t>(nb));
  std::iota(comp.begin(), comp.end(), 0);
  auto find = [&](int b) {
    while (comp[static_cast<std::size_t>(b)] != b) b = comp[static_cast<std::size_t>(b)];
    return b;
  };
  for (const core::JointModel& j : s.model.joints)
    if (is_unknown(s, j.child) && is_unknown(s, j.parent))
      comp[static_cast<std::size_t>(find(j.child))] = find(j.parent);
  std::vector<int> grounded(static_cast<std::size_t>(nb), 0);
  for (const core::JointModel& j : s.model.joints) {
    const bool uc = is_unknown(s, j.child), up = is_unknown(s, j.parent);
    if (uc != up && ++grounded[static_cast<std::size_t>(find(uc ? j.child : j.parent))] > 1)
      return false;
  }
  return true;
}

/// True if some joint has a known child and an unknown parent (the case that
/// needs re-rooting).
bool needs_reroot(const System& s) {
  for (const core::JointModel& j : s.model.joints)
    if (!is_unknown(s, j.child) && is_unknown(s, j.parent)) return true;
  return false;
}

/// Stacked unknowns (bodies, then enabled joints' rows) and the dense H and
/// right-hand side, assembled here independently of the library: H =
/// [[A, Gᵀ], [G, 0]] from a block-diagonal A and a stacked G.
struct Dense {
  Eigen::MatrixXd h;
  Eigen::VectorXd rhs;
  std::vector<int> offset;  // per joint, -1 if disabled
};

Dense assemble(const System& s) {
  const core::Model& m = s.model;
  const int nb = m.num_bodies();
  Dense d;
  int rows = 0;
  for (const core::JointModel& j : m.joints) {
    d.offset.push_back(is_active(s, j) ? rows : -1);
    if (is_active(s, j)) rows += j.num_rows;
  }
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(6 * nb, 6 * nb);
  Eigen::MatrixXd g = Eigen::MatrixXd::Zero(rows, 6 * nb);
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(6 * nb + rows);
  for (int b = 0; b < nb; ++b) {
    const auto k = static_cast<std::size_t>(b);
    a.block(6 * b, 6 * b, 6, 6) = is_unknown(s, b) ? s.blocks[k] : Mat6::Identity();
    if (is_unknown(s, b)) rhs.segment(6 * b, 6) = s.b[k];
  }
  for (int j = 0; j < m.num_joints(); ++j) {
    const auto k = static_cast<std::size_t>(j);
    const core::JointModel& jm = m.joints[k];
    const int o = d.offset[k];
    if (o < 0) continue;
    const int n = jm.num_rows;
    if (is_unknown(s, jm.child))
      g.block(o, 6 * jm.child, n, 6) += s.scratch.rows[k].g_child.topRows(n);
    if (is_unknown(s, jm.parent))
      g.block(o, 6 * jm.parent, n, 6) += s.scratch.rows[k].g_parent.topRows(n);
    rhs.segment(6 * nb + o, n) = s.c[k].head(n);
  }
  d.h = Eigen::MatrixXd::Zero(6 * nb + rows, 6 * nb + rows);
  d.h.topLeftCorner(6 * nb, 6 * nb) = a;
  d.h.topRightCorner(6 * nb, rows) = g.transpose();
  d.h.bottomLeftCorner(rows, 6 * nb) = g;
  d.rhs = rhs;
  for (int& o : d.offset)
    if (o >= 0) o += 6 * nb;
  return d;
}

Eigen::VectorXd stack(const System& s, const Dense& d, const std::vector<Vec6>& x,
                      const std::vector<JointVector>& y) {
  Eigen::VectorXd z = Eigen::VectorXd::Zero(d.h.rows());
  for (int b = 0; b < s.model.num_bodies(); ++b)
    z.segment(6 * b, 6) = x[static_cast<std::size_t>(b)];
  for (int j = 0; j < s.model.num_joints(); ++j) {
    const auto k = static_cast<std::size_t>(j);
    if (d.offset[k] >= 0) z.segment(d.offset[k], s.model.joints[k].num_rows) =
                              y[k].head(s.model.joints[k].num_rows);
  }
  return z;
}

struct Solution {
  std::vector<Vec6> x;
  std::vector<JointVector> y;
  bool ok = false;
};

Solution solve_tree(System& s) {
  Solution out;
  out.x.assign(static_cast<std::size_t>(s.model.num_bodies()), Vec6::Constant(7.0));
  out.y.assign(static_cast<std::size_t>(s.model.num_joints()), JointVector::Constant(7.0));
  out.ok = core::factor_articulation(s.model, s.blocks, s.scratch);
  core::solve_articulation(s.model, s.scratch, s.b, s.c, out.x, out.y);
  return out;
}

Solution solve_dense(const System& s) {
  Solution out;
  out.x.assign(static_cast<std::size_t>(s.model.num_bodies()), Vec6::Constant(7.0));
  out.y.assign(static_cast<std::size_t>(s.model.num_joints()), JointVector::Constant(7.0));
  core::solve_articulation_dense(s.model, s.scratch, s.blocks, s.b, s.c, out.x, out.y);
  out.ok = true;
  return out;
}

bool all_finite(const Solution& sol) {
  for (const Vec6& v : sol.x)
    if (!v.allFinite()) return false;
  for (const JointVector& v : sol.y)
    if (!v.allFinite()) return false;
  return true;
}

/// Checks the structural zeros: known bodies' x, disabled joints' y and the
/// rows ≥ num_rows of every y are exactly 0.
void expect_structural_zeros(const System& s, const Solution& sol) {
  for (int b = 0; b < s.model.num_bodies(); ++b)
    if (!is_unknown(s, b)) {
      EXPECT_EQ(sol.x[static_cast<std::size_t>(b)], Vec6::Zero()) << "body " << b;
    }
  for (int j = 0; j < s.model.num_joints(); ++j) {
    const auto k = static_cast<std::size_t>(j);
    const core::JointModel& jm = s.model.joints[k];
    const int from = is_active(s, jm) ? jm.num_rows : 0;
    for (int r = from; r < core::kMaxJointRows; ++r)
      EXPECT_EQ(sol.y[k](r), 0.0) << "joint " << j << " row " << r;
  }
}

/// ‖z_tree − z_ref‖∞ / ‖z_ref‖∞ and the relative residual of the tree
/// solution in the independently assembled H.
struct Errors {
  double vs_dense = 0.0;
  double residual = 0.0;
};

Errors compare(const System& s, const Solution& tree, const Solution& dense) {
  const Dense d = assemble(s);
  const Eigen::VectorXd zt = stack(s, d, tree.x, tree.y);
  const Eigen::VectorXd zd = stack(s, d, dense.x, dense.y);
  Errors e;
  // (All-known systems solve to exactly 0: guard the 0/0.)
  const double diff = (zt - zd).lpNorm<Eigen::Infinity>();
  e.vs_dense = diff == 0.0 ? 0.0 : diff / zd.lpNorm<Eigen::Infinity>();
  const double hn = d.h.cwiseAbs().rowwise().sum().maxCoeff();
  const double res = (d.h * zt - d.rhs).lpNorm<Eigen::Infinity>();
  e.residual = res == 0.0 ? 0.0
                          : res / (hn * zt.lpNorm<Eigen::Infinity>() +
                                   d.rhs.lpNorm<Eigen::Infinity>());
  return e;
}

/// A small free chain b0 ← j0 ← b1 ← j1 ← b2 (b_{i+1} child of j_i, parent b_i).
System chain_system(Rng& rng, int nb, bool to_world) {
  System s;
  s.model = bodies_only(nb);
  if (to_world) s.model.joints.push_back(joint("ground", -1, 0, core::JointType::kSpherical));
  for (int b = 1; b < nb; ++b)
    s.model.joints.push_back(joint(numbered("j", static_cast<std::size_t>(b)), b - 1, b,
                                   b % 2 ? core::JointType::kRevolute : core::JointType::kTrocar));
  EXPECT_EQ(core::build_articulation_topology(s.model), "");
  fill_random_system(rng, s);
  return s;
}

}  // namespace

// ------------------------------------------------------------------- solve --

TEST(ArticulationSolve, MatchesDenseOnRandomTrees) {
  Rng rng(2024);
  int compared = 0, rerooted = 0, refused = 0, with_known = 0;
  double worst = 0.0, worst_residual = 0.0;
  for (Shape shape : {Shape::kChain, Shape::kStar, Shape::kRandom}) {
    for (int nb : {1, 2, 3, 4, 6, 9, 14, 20, 30, 50}) {
      // The dense reference of 30 and 50 bodies (O(n³)) takes most of the test's 75 s under
      // ASan+UBSan; chains, stars, random trees, re-rooting, known bodies and refused loops all
      // come with 20 bodies and fewer, which the sanitizers check.
      if (numen::test::under_sanitizer() && nb > 20) continue;
      for (int seed = 0; seed < 3; ++seed) {
        System s;
        s.model = random_forest(rng, shape, nb);
        ASSERT_EQ(core::build_articulation_topology(s.model), "");
        fill_random_system(rng, s);
        // Several known sets on one scratch: factor must not depend on the last one.
        for (int mode = 0; mode < 3; ++mode) {
          set_random_known(rng, s, mode);
          SCOPED_TRACE(std::string(name(shape)) + " bodies " + std::to_string(nb) + " seed " +
                       std::to_string(seed) + " known mode " + std::to_string(mode));
          const Solution tree = solve_tree(s);
          if (!tree_solvable(s)) {
            EXPECT_FALSE(tree.ok);
            EXPECT_FALSE(all_finite(tree));
            ++refused;
            continue;
          }
          ASSERT_TRUE(tree.ok);
          ASSERT_TRUE(all_finite(tree));
          expect_structural_zeros(s, tree);
          const Solution dense = solve_dense(s);
          expect_structural_zeros(s, dense);
          const Errors e = compare(s, tree, dense);
          EXPECT_LT(e.vs_dense, 1e-10);
          EXPECT_LT(e.residual, 1e-12);
          worst = std::max(worst, e.vs_dense);
          worst_residual = std::max(worst_residual, e.residual);
          ++compared;
          if (needs_reroot(s)) ++rerooted;
          if (std::count(s.scratch.known.begin(), s.scratch.known.end(), 1) > 0) ++with_known;
        }
      }
    }
  }
  std::printf("compared %d (with known bodies %d, re-rooted %d), refused loops %d; worst "
              "relative difference %.2e, worst relative residual %.2e\n",
              compared, with_known, rerooted, refused, worst, worst_residual);
  EXPECT_GT(compared, 60);
  EXPECT_GT(rerooted, 5);
  EXPECT_GT(refused, 0);
}

TEST(ArticulationSolve, SatisfiesTheConstraintsAndTheDynamics) {
  // G x = c for every joint and A x + Gᵀ y = b for every body, term by term.
  Rng rng(5);
  System s = chain_system(rng, 5, true);
  const Solution sol = solve_tree(s);
  ASSERT_TRUE(sol.ok);
  const core::Model& m = s.model;
  std::vector<Vec6> force(5);
  for (int b = 0; b < 5; ++b) force[static_cast<std::size_t>(b)] = s.blocks[static_cast<std::size_t>(b)] * sol.x[static_cast<std::size_t>(b)];
  for (int j = 0; j < m.num_joints(); ++j) {
    const auto k = static_cast<std::size_t>(j);
    const core::JointModel& jm = m.joints[k];
    const int n = jm.num_rows;
    Eigen::VectorXd gx = s.scratch.rows[k].g_child.topRows(n) * sol.x[static_cast<std::size_t>(jm.child)];
    if (jm.parent >= 0) gx += s.scratch.rows[k].g_parent.topRows(n) * sol.x[static_cast<std::size_t>(jm.parent)];
    EXPECT_LT((gx - s.c[k].head(n)).lpNorm<Eigen::Infinity>(), 1e-12) << jm.name;
    force[static_cast<std::size_t>(jm.child)] += s.scratch.rows[k].g_child.topRows(n).transpose() * sol.y[k].head(n);
    if (jm.parent >= 0)
      force[static_cast<std::size_t>(jm.parent)] += s.scratch.rows[k].g_parent.topRows(n).transpose() * sol.y[k].head(n);
  }
  for (int b = 0; b < 5; ++b)
    EXPECT_LT((force[static_cast<std::size_t>(b)] - s.b[static_cast<std::size_t>(b)]).lpNorm<Eigen::Infinity>(), 1e-12);
}

TEST(ArticulationSolve, KnownChildOfAFreeBodyReRootsAtItsJoint) {
  // b0 ← j1 ← b1 (known) ← j2 ← b2: j1 only touches b0 this step, and b2
  // hangs from the known b1 through j2. Both are solvable trees; a static
  // elimination would have j1 as a leaf with a zero pivot.
  Rng rng(7);
  System s = chain_system(rng, 3, false);
  s.scratch.known = {0, 1, 0};
  const Solution tree = solve_tree(s);
  ASSERT_TRUE(tree.ok);
  const Solution dense = solve_dense(s);
  const Errors e = compare(s, tree, dense);
  EXPECT_LT(e.vs_dense, 1e-12);
  EXPECT_LT(e.residual, 1e-12);
  expect_structural_zeros(s, tree);
  EXPECT_EQ(s.scratch.joint_active, (std::vector<std::uint8_t>{1, 1}));
  // The joint j1 (node of joint 0) is the root of b0's component this step.
  const int j1 = s.model.articulation.joint_node[0];
  EXPECT_EQ(s.scratch.elimination_parent[static_cast<std::size_t>(j1)], -1);
  EXPECT_EQ(s.scratch.elimination_parent[static_cast<std::size_t>(s.model.articulation.body_node[0])], j1);
  // And back to all-unknown on the same scratch.
  s.scratch.known = {0, 0, 0};
  const Solution again = solve_tree(s);
  ASSERT_TRUE(again.ok);
  EXPECT_LT(compare(s, again, solve_dense(s)).vs_dense, 1e-12);
}

TEST(ArticulationSolve, LongReRootedPathWithSideBranches) {
  // A random tree whose deepest leaf is known: the whole path to the top is
  // reversed, with branches hanging off it.
  Rng rng(99);
  int rerooted = 0;
  for (int trial = 0; trial < 20; ++trial) {
    System s;
    s.model = random_forest(rng, Shape::kRandom, 25);
    ASSERT_EQ(core::build_articulation_topology(s.model), "");
    fill_random_system(rng, s);
    // Known: every leaf body (child of a joint, parent of none) of one tree.
    std::vector<int> is_parent(25, 0);
    for (const core::JointModel& j : s.model.joints)
      if (j.parent >= 0) is_parent[static_cast<std::size_t>(j.parent)] = 1;
    std::fill(s.scratch.known.begin(), s.scratch.known.end(), 0);
    for (int b = 0; b < 25; ++b)
      if (!is_parent[static_cast<std::size_t>(b)] && s.model.articulation.body_tree[static_cast<std::size_t>(b)] == 0) {
        s.scratch.known[static_cast<std::size_t>(b)] = 1;
        break;  // one leaf
      }
    const Solution tree = solve_tree(s);
    if (!tree_solvable(s)) {
      EXPECT_FALSE(tree.ok);
      continue;
    }
    ASSERT_TRUE(tree.ok) << trial;
    const Errors e = compare(s, tree, solve_dense(s));
    EXPECT_LT(e.vs_dense, 1e-10) << trial;
    EXPECT_LT(e.residual, 1e-12) << trial;
    if (needs_reroot(s)) ++rerooted;
  }
  EXPECT_GT(rerooted, 5);
}

TEST(ArticulationSolve, LoopThroughTheWorldAndAKnownBodyIsRefused) {
  // world ← ground ← b0 ← j1 ← b1 (known), then b1 ← j2 ← b2: b0 is held by
  // two grounded joints (a loop through the world and b1), not a tree. The
  // system itself is regular (2 + 2 rows on b0's 6 unknowns): the dense
  // reference solves it; the tree solve refuses it, in b0's component only.
  Rng rng(3);
  System s;
  s.model = bodies_only(3);
  s.model.joints = {joint("ground", -1, 0, core::JointType::kTrocar),
                    joint("j1", 0, 1, core::JointType::kTrocar),
                    joint("j2", 1, 2, core::JointType::kSpherical)};
  ASSERT_EQ(core::build_articulation_topology(s.model), "");
  fill_random_system(rng, s);
  s.scratch.known = {0, 1, 0};
  ASSERT_FALSE(tree_solvable(s));
  const Solution tree = solve_tree(s);
  EXPECT_FALSE(tree.ok);
  EXPECT_FALSE(tree.x[0].allFinite());
  EXPECT_FALSE(tree.y[0].head(2).allFinite());
  EXPECT_FALSE(tree.y[1].head(2).allFinite());
  EXPECT_EQ(tree.x[1], Vec6::Zero());  // the known body stays exact
  const Solution dense = solve_dense(s);
  ASSERT_TRUE(all_finite(dense));
  const Dense d = assemble(s);
  const Eigen::VectorXd zd = stack(s, d, dense.x, dense.y);
  EXPECT_LT((d.h * zd - d.rhs).lpNorm<Eigen::Infinity>(), 1e-10);
  // b2's component (grounded by j2 on the known b1) is solved normally.
  EXPECT_LT((tree.x[2] - dense.x[2]).lpNorm<Eigen::Infinity>(),
            1e-10 * std::max(1.0, dense.x[2].lpNorm<Eigen::Infinity>()));
  EXPECT_LT((tree.y[2] - dense.y[2]).lpNorm<Eigen::Infinity>(),
            1e-10 * std::max(1.0, dense.y[2].lpNorm<Eigen::Infinity>()));
}

TEST(ArticulationSolve, DisabledJointHasZeroMultiplier) {
  // world ← ground ← b0 (known) ← j1 ← b1 (known) ← j2 ← b2 and a free b3.
  Rng rng(17);
  System s;
  s.model = bodies_only(4);
  s.model.joints = {joint("ground", -1, 0, core::JointType::kTrocar), joint("j1", 0, 1, core::JointType::kFixed),
                    joint("j2", 1, 2, core::JointType::kSpherical), joint("j3", 2, 3, core::JointType::kCylindrical)};
  ASSERT_EQ(core::build_articulation_topology(s.model), "");
  fill_random_system(rng, s);
  s.scratch.known = {1, 1, 0, 0};
  const Solution tree = solve_tree(s);
  ASSERT_TRUE(tree.ok);
  EXPECT_EQ(s.scratch.joint_active, (std::vector<std::uint8_t>{0, 0, 1, 1}));
  EXPECT_EQ(tree.y[0], JointVector::Zero());
  EXPECT_EQ(tree.y[1], JointVector::Zero());
  EXPECT_EQ(tree.x[0], Vec6::Zero());
  EXPECT_EQ(tree.x[1], Vec6::Zero());
  const Errors e = compare(s, tree, solve_dense(s));
  EXPECT_LT(e.vs_dense, 1e-12);
  EXPECT_LT(e.residual, 1e-12);
  expect_structural_zeros(s, tree);
}

TEST(ArticulationSolve, SingularRowsFailWithNonFiniteOutput) {
  Rng rng(23);
  for (int variant = 0; variant < 3; ++variant) {
    SCOPED_TRACE(variant);
    // Two trees: a chain with a defective joint, and an independent pair.
    System s;
    s.model = bodies_only(5);
    s.model.joints = {joint("ground", -1, 0, core::JointType::kSpherical),
                      joint("j1", 0, 1, core::JointType::kRevolute),
                      joint("j2", 1, 2, core::JointType::kTrocar),
                      joint("other", 3, 4, core::JointType::kFixed)};
    ASSERT_EQ(core::build_articulation_topology(s.model), "");
    fill_random_system(rng, s);
    core::JointRows& r = s.scratch.rows[1];
    if (variant == 0) {  // a zero row
      r.g_child.row(2).setZero();
      r.g_parent.row(2).setZero();
    } else if (variant == 1) {  // a duplicated row
      r.g_child.row(4) = r.g_child.row(1);
      r.g_parent.row(4) = r.g_parent.row(1);
    } else {  // a body block that is not positive definite
      s.blocks[2](3, 3) = -1.0;
    }
    const Solution tree = solve_tree(s);
    EXPECT_FALSE(tree.ok);
    for (int b = 0; b < 3; ++b) EXPECT_FALSE(tree.x[static_cast<std::size_t>(b)].allFinite()) << b;
    for (int j = 0; j < 3; ++j) EXPECT_FALSE(tree.y[static_cast<std::size_t>(j)].head(2).allFinite()) << j;
    // The other tree is unaffected.
    const Solution dense = solve_dense(s);
    for (int b = 3; b < 5; ++b) {
      const auto k = static_cast<std::size_t>(b);
      EXPECT_LT((tree.x[k] - dense.x[k]).lpNorm<Eigen::Infinity>(),
                1e-10 * std::max(1.0, dense.x[k].lpNorm<Eigen::Infinity>()));
    }
    EXPECT_TRUE(tree.y[3].allFinite());
  }
}

TEST(ArticulationSolve, FactorAndSolveDoNotAllocate) {
  Rng rng(31);
  System s;
  s.model = random_forest(rng, Shape::kRandom, 40);
  ASSERT_EQ(core::build_articulation_topology(s.model), "");
  fill_random_system(rng, s);
  std::vector<Vec6> x(40);
  std::vector<JointVector> y(static_cast<std::size_t>(s.model.num_joints()));
  int rerooted = 0;
  for (int trial = 0; trial < 10; ++trial) {
    set_random_known(rng, s, trial % 3);
    if (needs_reroot(s)) ++rerooted;
    numen::test::AllocationGuard guard;
    (void)core::factor_articulation(s.model, s.blocks, s.scratch);
    core::solve_articulation(s.model, s.scratch, s.b, s.c, x, y);
    EXPECT_EQ(guard.count(), 0) << trial;
  }
  EXPECT_GT(rerooted, 0);
}

TEST(ArticulationSolve, ResizeSizesEveryBuffer) {
  core::Model m = bodies_only(3);
  m.joints = {joint("a", 0, 1, core::JointType::kTrocar), joint("b", -1, 0)};
  ASSERT_EQ(core::build_articulation_topology(m), "");
  core::ArticulationScratch s;
  s.resize(m);
  EXPECT_EQ(s.rows.size(), 2u);
  EXPECT_EQ(s.rows[0].count, 2);
  EXPECT_EQ(s.rows[1].count, 5);
  EXPECT_EQ(s.known, (std::vector<std::uint8_t>{0, 0, 0}));
  EXPECT_EQ(s.joint_active.size(), 2u);
  for (std::size_t n : {s.off_diagonal.size(), s.factor.size(), s.coupling.size(), s.work.size(),
                        s.elimination_parent.size(), s.reroot.size()})
    EXPECT_EQ(n, 5u);
}
