/// @file mesh_shape_intersect.cpp
/// Self-intersections of a closed mesh through its AABB tree (see mesh_shape_intersect.hpp).

#include "numen/core/mesh_shape_intersect.hpp"

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

namespace numen::core {
namespace {

/// Sign of the orientation determinant det[b − a, c − a, d − a]: > 0 when d is on the side of the
/// plane (a, b, c) its normal (b − a) × (c − a) points to.
int orient(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) noexcept {
  const double v = (b - a).cross(c - a).dot(d - a);
  return (v > 0.0) - (v < 0.0);
}

/// The segment [p, q] and the triangle (a, b, c), not all in one plane: they meet when p and q are
/// not strictly on one side of the triangle's plane and the line pq passes through the triangle
/// (the three orientations of pq against its edges agree, zeros allowed). A segment lying in the
/// plane is left to the other edges' tests (they find the crossing; see the header).
bool segment_crosses(const Vec3& p, const Vec3& q, const Vec3& a, const Vec3& b,
                     const Vec3& c) noexcept {
  const int sp = orient(a, b, c, p), sq = orient(a, b, c, q);
  if (sp * sq > 0 || (sp == 0 && sq == 0)) return false;
  const int s1 = orient(p, q, a, b), s2 = orient(p, q, b, c), s3 = orient(p, q, c, a);
  return (s1 >= 0 && s2 >= 0 && s3 >= 0) || (s1 <= 0 && s2 <= 0 && s3 <= 0);
}

/// 2D orientation sign of (a, b, c) in the plane of axes (i, j).
int orient2(const Vec3& a, const Vec3& b, const Vec3& c, int i, int j) noexcept {
  const double v = (b[i] - a[i]) * (c[j] - a[j]) - (b[j] - a[j]) * (c[i] - a[i]);
  return (v > 0.0) - (v < 0.0);
}

/// Closed segments [a, b] and [c, d] meet, in 2D (axes i, j).
bool segments_meet2(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d, int i,
                    int j) noexcept {
  const int o1 = orient2(a, b, c, i, j), o2 = orient2(a, b, d, i, j);
  const int o3 = orient2(c, d, a, i, j), o4 = orient2(c, d, b, i, j);
  if (o1 * o2 < 0 && o3 * o4 < 0) return true;
  const auto on = [&](const Vec3& p, const Vec3& q, const Vec3& r) {  // r on [p, q], collinear
    return std::min(p[i], q[i]) <= r[i] && r[i] <= std::max(p[i], q[i]) &&
           std::min(p[j], q[j]) <= r[j] && r[j] <= std::max(p[j], q[j]);
  };
  return (o1 == 0 && on(a, b, c)) || (o2 == 0 && on(a, b, d)) || (o3 == 0 && on(c, d, a)) ||
         (o4 == 0 && on(c, d, b));
}

/// p in the closed triangle (a, b, c), in 2D.
bool inside2(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c, int i, int j) noexcept {
  const int s1 = orient2(a, b, p, i, j), s2 = orient2(b, c, p, i, j), s3 = orient2(c, a, p, i, j);
  return (s1 >= 0 && s2 >= 0 && s3 >= 0) || (s1 <= 0 && s2 <= 0 && s3 <= 0);
}

bool bvh_nodes_overlap(const MeshBvhNode& a, const MeshBvhNode& b) noexcept {
  return (a.lo.array() <= b.hi.array()).all() && (b.lo.array() <= a.hi.array()).all();
}

}  // namespace

bool triangles_intersect(const Vec3& a0, const Vec3& a1, const Vec3& a2, const Vec3& b0,
                         const Vec3& b1, const Vec3& b2) noexcept {
  const Vec3* A[3] = {&a0, &a1, &a2};
  const Vec3* B[3] = {&b0, &b1, &b2};
  if (orient(a0, a1, a2, b0) == 0 && orient(a0, a1, a2, b1) == 0 && orient(a0, a1, a2, b2) == 0) {
    // Coplanar: in the plane of the two axes the normal is least along.
    int k = 0;
    (a1 - a0).cross(a2 - a0).cwiseAbs().maxCoeff(&k);
    const int i = (k + 1) % 3, j = (k + 2) % 3;
    for (int e = 0; e < 3; ++e)
      for (int f = 0; f < 3; ++f)
        if (segments_meet2(*A[e], *A[(e + 1) % 3], *B[f], *B[(f + 1) % 3], i, j)) return true;
    return inside2(a0, b0, b1, b2, i, j) || inside2(b0, a0, a1, a2, i, j);
  }
  for (int e = 0; e < 3; ++e) {
    if (segment_crosses(*A[e], *A[(e + 1) % 3], b0, b1, b2)) return true;
    if (segment_crosses(*B[e], *B[(e + 1) % 3], a0, a1, a2)) return true;
  }
  return false;
}

MeshSelfIntersections find_self_intersections(const MeshShape& s) {
  MeshSelfIntersections out;
  if (s.nodes.empty()) return out;
  const auto test = [&](int ta, int tb) {
    const auto& A = s.triangles[static_cast<std::size_t>(ta)];
    const auto& B = s.triangles[static_cast<std::size_t>(tb)];
    for (int a : A)
      for (int b : B)
        if (a == b) return;  // a shared vertex or edge
    const auto v = [&](int i) -> const Vec3& { return s.vertices[static_cast<std::size_t>(i)]; };
    if (!triangles_intersect(v(A[0]), v(A[1]), v(A[2]), v(B[0]), v(B[1]), v(B[2]))) return;
    if (out.count++ == 0) {
      out.first_a = A;
      out.first_b = B;
    }
  };
  const auto second = [&](std::int32_t n) { return s.nodes[static_cast<std::size_t>(n)].index; };
  // Pairs of nodes whose boxes overlap; (n, n) is a node against itself.
  std::vector<std::pair<std::int32_t, std::int32_t>> stack = {{0, 0}};
  while (!stack.empty()) {
    const auto [i, j] = stack.back();
    stack.pop_back();
    const MeshBvhNode& a = s.nodes[static_cast<std::size_t>(i)];
    const MeshBvhNode& b = s.nodes[static_cast<std::size_t>(j)];
    if (i == j) {
      if (a.count > 0) {
        for (int t = a.index; t < a.index + a.count; ++t)
          for (int u = t + 1; u < a.index + a.count; ++u) test(t, u);
      } else {
        stack.push_back({i + 1, i + 1});
        stack.push_back({second(i), second(i)});
        stack.push_back({i + 1, second(i)});
      }
      continue;
    }
    if (!bvh_nodes_overlap(a, b)) continue;
    if (a.count > 0 && b.count > 0) {
      for (int t = a.index; t < a.index + a.count; ++t)
        for (int u = b.index; u < b.index + b.count; ++u) test(t, u);
    } else if (b.count > 0 || (a.count == 0 && (a.hi - a.lo).maxCoeff() >= (b.hi - b.lo).maxCoeff())) {
      stack.push_back({i + 1, j});  // open a (an inner node, the larger or the only one)
      stack.push_back({second(i), j});
    } else {
      stack.push_back({i, j + 1});
      stack.push_back({i, second(j)});
    }
  }
  return out;
}

MeshSelfIntersections find_self_intersections(const TriangleMesh& mesh) {
  if (mesh.triangles.empty()) return {};
  MeshShape tree;
  build_mesh_tree(mesh, tree);
  return find_self_intersections(tree);
}

}  // namespace numen::core
