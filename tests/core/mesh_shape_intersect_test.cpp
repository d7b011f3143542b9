// Tests of core/mesh_shape_intersect: the triangle–triangle test on crossing, touching, disjoint
// and coplanar pairs; no self-intersection on the generated closed meshes; a tetrahedron poking
// through another's face gives exactly its three side faces against that face; the tree's count
// equals the brute-force count over every pair on two interpenetrating spheres.
#include "numen/core/mesh_shape_intersect.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdint>

#include "numen/core/mesh.hpp"
#include "numen/core/mesh_shape.hpp"

namespace {

using numen::core::build_mesh_shape;
using numen::core::find_self_intersections;
using numen::core::MeshSelfIntersections;
using numen::core::MeshShape;
using numen::core::TriangleMesh;
using numen::core::triangles_intersect;
using numen::core::Vec3;

MeshShape tree_shape(const TriangleMesh& mesh) {
  MeshShape s;
  numen::core::MeshShapeOptions o;
  o.band = 0.0;  // the tree only
  EXPECT_EQ(build_mesh_shape(mesh, s, o), "");
  return s;
}

/// `b` appended to `a` (its vertex indices shifted).
TriangleMesh joined_meshes(TriangleMesh a, const TriangleMesh& b) {
  const int shift = static_cast<int>(a.vertices.size());
  a.vertices.insert(a.vertices.end(), b.vertices.begin(), b.vertices.end());
  for (auto t : b.triangles) a.triangles.push_back({t[0] + shift, t[1] + shift, t[2] + shift});
  return a;
}

/// A tetrahedron with outward winding.
TriangleMesh outward_tetrahedron(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& apex) {
  TriangleMesh m;
  m.vertices = {p0, p1, p2, apex};
  // Base (p0, p1, p2) counter-clockwise seen from the apex: the base faces away from it.
  const bool ccw = (p1 - p0).cross(p2 - p0).dot(apex - p0) > 0.0;
  m.triangles = ccw ? std::vector<std::array<int, 3>>{{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {2, 0, 3}}
                    : std::vector<std::array<int, 3>>{{0, 1, 2}, {0, 3, 1}, {1, 3, 2}, {2, 3, 0}};
  return m;
}

TEST(MeshShapeIntersect, TriangleTriangleCases) {
  const Vec3 a0(0, 0, 0), a1(1, 0, 0), a2(0, 1, 0);
  // Crossing: a vertical triangle through the middle.
  EXPECT_TRUE(triangles_intersect(a0, a1, a2, Vec3(0.2, 0.2, -1), Vec3(0.3, 0.2, 1), Vec3(0.2, 0.3, 1)));
  // Above, disjoint; beside, disjoint (the plane crossed outside the triangle).
  EXPECT_FALSE(triangles_intersect(a0, a1, a2, Vec3(0, 0, 0.1), Vec3(1, 0, 0.1), Vec3(0, 1, 0.5)));
  EXPECT_FALSE(triangles_intersect(a0, a1, a2, Vec3(2, 2, -1), Vec3(3, 2, 1), Vec3(2, 3, 1)));
  // Touching: a vertex on the face.
  EXPECT_TRUE(triangles_intersect(a0, a1, a2, Vec3(0.2, 0.2, 0), Vec3(0.3, 0.2, 1), Vec3(0.2, 0.3, 1)));
  // Coplanar: overlapping edges, one inside the other, apart.
  EXPECT_TRUE(triangles_intersect(a0, a1, a2, Vec3(0.5, -0.5, 0), Vec3(0.5, 0.8, 0), Vec3(2, 0, 0)));
  EXPECT_TRUE(triangles_intersect(a0, a1, a2, Vec3(0.1, 0.1, 0), Vec3(0.2, 0.1, 0), Vec3(0.1, 0.2, 0)));
  EXPECT_FALSE(triangles_intersect(a0, a1, a2, Vec3(1, 1, 0), Vec3(2, 1, 0), Vec3(1, 2, 0)));
  // Symmetric.
  EXPECT_TRUE(triangles_intersect(Vec3(0.2, 0.2, -1), Vec3(0.3, 0.2, 1), Vec3(0.2, 0.3, 1), a0, a1, a2));
}

TEST(MeshShapeIntersect, GeneratedClosedMeshesDoNotIntersectThemselves) {
  EXPECT_EQ(find_self_intersections(tree_shape(numen::core::make_icosphere(0.05, 4))).count, 0);
  EXPECT_EQ(find_self_intersections(tree_shape(numen::core::make_torus(0.04, 0.015, 64, 32))).count, 0);
  EXPECT_EQ(find_self_intersections(tree_shape(numen::core::make_box(Vec3(0.03, 0.02, 0.01), 3))).count, 0);
}

TEST(MeshShapeIntersect, ApexThroughAFaceGivesItsThreeSideFaces) {
  // B's apex (0.2, 0.2, 0.1) is inside A, its base 1 below A's face z = 0: B's three side faces
  // cross that face, nothing else meets.
  const TriangleMesh a = outward_tetrahedron(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1));
  const TriangleMesh b = outward_tetrahedron(Vec3(0.1, 0.1, -1), Vec3(0.35, 0.1, -1), Vec3(0.1, 0.35, -1),
                                     Vec3(0.2, 0.2, 0.1));
  const MeshSelfIntersections x = find_self_intersections(tree_shape(joined_meshes(a, b)));
  EXPECT_EQ(x.count, 3);
  // The first pair: A's base (vertices 0, 1, 2) and a side face of B (apex 7).
  std::array<int, 3> base = x.first_a, side = x.first_b;
  if (std::count(side.begin(), side.end(), 7) == 0) std::swap(base, side);
  std::sort(base.begin(), base.end());
  EXPECT_EQ(base, (std::array<int, 3>{0, 1, 2}));
  EXPECT_EQ(std::count(side.begin(), side.end(), 7), 1);
  // Apart: none.
  const TriangleMesh far = outward_tetrahedron(Vec3(3, 0, 0), Vec3(4, 0, 0), Vec3(3, 1, 0), Vec3(3, 0, 1));
  EXPECT_EQ(find_self_intersections(tree_shape(joined_meshes(a, far))).count, 0);
}

TEST(MeshShapeIntersect, TreeCountEqualsBruteForceOnTwoSpheres) {
  TriangleMesh b = numen::core::make_icosphere(0.05, 2);
  for (Vec3& v : b.vertices) v += Vec3(0.06, 0.01, 0.005);
  const MeshShape s = tree_shape(joined_meshes(numen::core::make_icosphere(0.05, 2), b));
  std::int64_t brute = 0;
  for (int i = 0; i < s.num_triangles(); ++i)
    for (int j = i + 1; j < s.num_triangles(); ++j) {
      const auto& A = s.triangles[static_cast<std::size_t>(i)];
      const auto& B = s.triangles[static_cast<std::size_t>(j)];
      bool shared = false;
      for (int u : A)
        for (int w : B) shared |= u == w;
      const auto v = [&](int k) -> const Vec3& { return s.vertices[static_cast<std::size_t>(k)]; };
      if (!shared && triangles_intersect(v(A[0]), v(A[1]), v(A[2]), v(B[0]), v(B[1]), v(B[2])))
        ++brute;
    }
  EXPECT_GT(brute, 20);
  EXPECT_EQ(find_self_intersections(s).count, brute);
}

}  // namespace
