// Tests of core/mesh_shape: the tree-and-grid signed distance equals the brute-force one over
// every triangle (icosphere, torus, random points), the sign matches the analytic solid, the build
// refuses open, inconsistently and inward wound meshes, and a query never allocates.
#include "numen/core/mesh_shape.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <utility>

#include "alloc_counter.hpp"
#include "numen/core/mesh.hpp"
#include "sanitizer.hpp"

namespace {

using numen::core::build_mesh_shape;
using numen::core::make_icosphere;
using numen::core::make_torus;
using numen::core::mesh_signed_distance;
using numen::core::mesh_signed_distance_brute;
using numen::core::MeshDistance;
using numen::core::MeshShape;
using numen::core::TriangleMesh;
using numen::core::Vec3;

MeshShape built(const TriangleMesh& mesh) {
  MeshShape s;
  const std::string err = build_mesh_shape(mesh, s);
  EXPECT_EQ(err, "");
  return s;
}

/// Analytic signed distance of a torus (R, r) around z.
double torus_distance(const Vec3& p, double R, double r) {
  const double q = std::hypot(p.x(), p.y()) - R;
  return std::hypot(q, p.z()) - r;
}

/// Random points in the box [lo, hi]; the query with an infinite reach against brute force.
void expect_matches_brute(const MeshShape& s, const Vec3& lo, const Vec3& hi, int n,
                          unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  // A quarter of the points under the sanitizers: each is a brute force over every triangle
  // (the icosphere's 2 000 took most of its 56 s under ASan+UBSan); the query's code is the same
  // for every point.
  if (numen::test::under_sanitizer()) n /= 4;
  for (int i = 0; i < n; ++i) {
    const Vec3 p = lo + Vec3(u(rng), u(rng), u(rng)).cwiseProduct(hi - lo);
    const MeshDistance ref = mesh_signed_distance_brute(s, p);
    MeshDistance got;
    ASSERT_TRUE(mesh_signed_distance(s, p, std::numeric_limits<double>::infinity(), got)) << i;
    ASSERT_NEAR(got.distance, ref.distance, 1e-12) << "point " << i;
    ASSERT_NEAR((got.point - ref.point).norm(), 0.0, 1e-12) << "point " << i;
    ASSERT_NEAR(got.normal.norm(), 1.0, 1e-12);
    // A finite reach: reported exactly when the distance is below it.
    const double reach = 0.005;
    MeshDistance near;
    ASSERT_EQ(mesh_signed_distance(s, p, reach, near), ref.distance < reach) << i;
  }
}

TEST(MeshShape, IcosphereMatchesBruteForceAndTheSphere) {
  const double radius = 0.05;
  const MeshShape s = built(make_icosphere(radius, 4));  // 5120 triangles
  ASSERT_EQ(s.num_triangles(), 5120);
  expect_matches_brute(s, Vec3::Constant(-0.07), Vec3::Constant(0.07), 2000, 1);
  // The sign is the sphere's away from the surface (chord error 0.05·(1 − cos(θ/2)) ≪ 1 mm).
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> u(-0.07, 0.07);
  for (int i = 0; i < 2000; ++i) {
    const Vec3 p(u(rng), u(rng), u(rng));
    const double exact = p.norm() - radius;
    if (std::abs(exact) < 1e-3) continue;
    MeshDistance d;
    ASSERT_TRUE(mesh_signed_distance(s, p, 1.0, d));
    EXPECT_EQ(d.distance > 0.0, exact > 0.0) << p.transpose();
    EXPECT_NEAR(d.distance, exact, 2e-4) << p.transpose();
  }
}

TEST(MeshShape, TorusMatchesBruteForceAndTheTorus) {
  const double R = 0.04, r = 0.015;
  const MeshShape s = built(make_torus(R, r, 64, 32));  // 4096 triangles
  expect_matches_brute(s, Vec3(-0.06, -0.06, -0.02), Vec3(0.06, 0.06, 0.02), 2000, 3);
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(-0.06, 0.06);
  for (int i = 0; i < 2000; ++i) {
    const Vec3 p(u(rng), u(rng), u(rng) / 3.0);
    const double exact = torus_distance(p, R, r);
    if (std::abs(exact) < 1e-3) continue;
    MeshDistance d;
    ASSERT_TRUE(mesh_signed_distance(s, p, 1.0, d));
    EXPECT_EQ(d.distance > 0.0, exact > 0.0) << p.transpose();  // the hole is outside
  }
}

TEST(MeshShape, PointsOnVerticesAndEdgesGetTheFeatureSign) {
  // Just outside and inside every vertex along its position (the closest feature is a vertex or
  // an edge, where a face normal alone would give the wrong sign): the pseudo-normals decide.
  const MeshShape s = built(make_icosphere(1.0, 2));
  for (const Vec3& v : s.vertices) {
    MeshDistance out, in;
    ASSERT_TRUE(mesh_signed_distance(s, 1.001 * v, 1.0, out));
    ASSERT_TRUE(mesh_signed_distance(s, 0.999 * v, 1.0, in));
    EXPECT_NEAR(out.distance, 0.001, 1e-12);  // the vertex itself is closest
    // Inside, a face next to the vertex is closer than the vertex.
    EXPECT_LT(in.distance, 0.0);
    EXPECT_GT(in.distance, -0.001);
    EXPECT_GT(out.normal.dot(v), 0.99);
    EXPECT_GT(in.normal.dot(v), 0.95);  // outward: pushes the inside point out
  }
}

TEST(MeshShape, FarAndNonFinitePointsAreNotReported) {
  const MeshShape s = built(make_icosphere(0.05, 2));
  MeshDistance d;
  EXPECT_FALSE(mesh_signed_distance(s, Vec3(0.2, 0.0, 0.0), 0.01, d));
  EXPECT_FALSE(mesh_signed_distance(s, Vec3(0.0, 0.0, 0.058), 0.005, d));  // in the box, 8 mm off
  EXPECT_FALSE(mesh_signed_distance(s, Vec3(NAN, 0.0, 0.0), 1.0, d));
  EXPECT_TRUE(mesh_signed_distance(s, Vec3::Zero(), 0.0, d));  // inside: any reach
  EXPECT_NEAR(d.distance, -0.05, 0.05 * (1.0 - std::cos(0.32)));
}

TEST(MeshShape, QueryDoesNotAllocate) {
  const MeshShape s = built(make_torus(0.04, 0.015, 64, 32));
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-0.06, 0.06);
  std::vector<Vec3> points(1000);
  for (Vec3& p : points) p = Vec3(u(rng), u(rng), u(rng));
  double sum = 0.0;
  numen::test::AllocationGuard guard;
  for (const Vec3& p : points) {
    MeshDistance d;
    if (mesh_signed_distance(s, p, 0.01, d)) sum += d.distance;
  }
  EXPECT_EQ(guard.count(), 0);
  EXPECT_TRUE(std::isfinite(sum));
}

TEST(MeshShape, BuildRefusesOpenInconsistentAndInwardMeshes) {
  MeshShape s;
  TriangleMesh open = make_icosphere(1.0, 1);
  open.triangles.pop_back();
  // validate_mesh() would call the unused vertex first: keep every vertex used.
  std::string err = build_mesh_shape(open, s);
  EXPECT_NE(err.find("open: 3 boundary edges"), std::string::npos) << err;

  TriangleMesh flipped_one = make_icosphere(1.0, 1);
  std::swap(flipped_one.triangles[0][1], flipped_one.triangles[0][2]);
  err = build_mesh_shape(flipped_one, s);
  EXPECT_NE(err.find("wind inconsistently"), std::string::npos) << err;

  TriangleMesh inward = make_icosphere(1.0, 1);
  for (auto& t : inward.triangles) std::swap(t[1], t[2]);
  err = build_mesh_shape(inward, s);
  EXPECT_NE(err.find("wind inward"), std::string::npos) << err;

  TriangleMesh bad = make_icosphere(1.0, 1);
  bad.vertices[3].x() = NAN;
  EXPECT_NE(build_mesh_shape(bad, s), "");
}

TEST(MeshShape, TreeIsBalancedAndMemoryIsCounted) {
  MeshShape s;  // the tree alone (no narrow band): 10000 triangles
  numen::core::MeshShapeOptions tree_only;
  tree_only.band = 0.0;
  ASSERT_EQ(build_mesh_shape(make_torus(0.04, 0.015, 100, 50), s, tree_only), "");
  EXPECT_EQ(s.num_triangles(), 10000);
  EXPECT_LE(s.tree_depth, 13);  // ⌈log2(10000 / 4)⌉ + 1
  EXPECT_GT(s.memory_bytes(), 10000u * 100u);
  EXPECT_LT(s.memory_bytes(), 10000u * 400u);
}

}  // namespace
