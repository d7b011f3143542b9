#pragma once
/// @file articulation_forests.hpp
/// Random joint forests shared by the articulation tests (articulation_test.cpp: the topology;
/// articulation_solve_test.cpp: the KKT solve): a seeded generator, joints of every row count,
/// bodies without joints, and forests of chains, stars or random trees.

#include <algorithm>
#include <numeric>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Dense>

#include "numen/core/joint.hpp"
#include "numen/core/model.hpp"

namespace numen::test::articulation_forests {

using Rng = std::mt19937_64;

inline double uniform(Rng& rng, double lo, double hi) {
  return std::uniform_real_distribution<double>(lo, hi)(rng);
}
inline int uniform_int(Rng& rng, int lo, int hi) {  // inclusive
  return std::uniform_int_distribution<int>(lo, hi)(rng);
}
inline double gauss(Rng& rng) { return std::normal_distribution<double>(0.0, 1.0)(rng); }

inline Eigen::MatrixXd random_orthogonal(Rng& rng, int n) {
  Eigen::MatrixXd a(n, n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) a(i, j) = gauss(rng);
  return Eigen::HouseholderQR<Eigen::MatrixXd>(a).householderQ();
}

/// prefix + number (a helper: GCC 12 warns falsely (-Wrestrict) on
/// "literal" + std::string temporaries).
inline std::string numbered(const char* prefix, std::size_t i) {
  std::string s(prefix);
  s += std::to_string(i);
  return s;
}

/// (type, prescribed) pairs covering 2..6 rows.
struct TypeChoice {
  core::JointType type;
  bool prescribed;
};
constexpr TypeChoice kTypes[] = {
    {core::JointType::kTrocar, false},    {core::JointType::kSpherical, false},
    {core::JointType::kCylindrical, false}, {core::JointType::kRevolute, false},
    {core::JointType::kPrismatic, false}, {core::JointType::kRevolute, true},
    {core::JointType::kPrismatic, true},  {core::JointType::kFixed, false},
};

inline core::JointModel joint(const std::string& name, int parent, int child,
                              core::JointType type = core::JointType::kRevolute,
                              bool prescribed = false) {
  core::JointModel j;
  j.name = name;
  j.type = type;
  j.parent = parent;
  j.child = child;
  j.prescribed = prescribed;
  j.num_rows = core::joint_row_count(type, prescribed);
  return j;
}

inline core::Model bodies_only(int n) {
  core::Model m;
  for (int b = 0; b < n; ++b) {
    core::BodyModel body;
    body.name = numbered("b", static_cast<std::size_t>(b));
    m.bodies.push_back(body);
  }
  return m;
}

enum class Shape { kChain, kStar, kRandom };
inline const char* name(Shape s) {
  return s == Shape::kChain ? "chain" : s == Shape::kStar ? "star" : "random";
}

/// A random forest of `nb` bodies in 1..4 trees of the given shape, body and
/// joint indices shuffled, about half the trees hung from the world.
inline core::Model random_forest(Rng& rng, Shape shape, int nb) {
  core::Model m = bodies_only(nb);
  std::vector<int> perm(static_cast<std::size_t>(nb));
  std::iota(perm.begin(), perm.end(), 0);
  std::shuffle(perm.begin(), perm.end(), rng);
  const int trees = uniform_int(rng, 1, std::min(4, nb));
  std::vector<int> cuts = {0, nb};
  for (int t = 1; t < trees; ++t) cuts.push_back(uniform_int(rng, 1, nb - 1));
  std::sort(cuts.begin(), cuts.end());
  std::vector<std::pair<int, int>> edges;  // (parent, child)
  for (std::size_t t = 0; t + 1 < cuts.size(); ++t) {
    const int lo = cuts[t], hi = cuts[t + 1];
    if (lo == hi) continue;
    for (int i = lo + 1; i < hi; ++i) {
      int p = 0;
      switch (shape) {
        case Shape::kChain: p = i - 1; break;
        case Shape::kStar: p = lo; break;
        case Shape::kRandom: p = uniform_int(rng, lo, i - 1); break;
      }
      edges.emplace_back(perm[static_cast<std::size_t>(p)], perm[static_cast<std::size_t>(i)]);
    }
    if (uniform(rng, 0.0, 1.0) < 0.5) edges.emplace_back(-1, perm[static_cast<std::size_t>(lo)]);
  }
  std::shuffle(edges.begin(), edges.end(), rng);
  for (std::size_t e = 0; e < edges.size(); ++e) {
    const TypeChoice tc = kTypes[uniform_int(rng, 0, 7)];
    m.joints.push_back(joint(numbered("j", e), edges[e].first, edges[e].second, tc.type,
                             tc.prescribed));
  }
  return m;
}

}  // namespace numen::test::articulation_forests
