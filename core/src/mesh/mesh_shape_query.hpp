#pragma once
/// @file mesh_shape_query.hpp
/// Private to numen::core (core/src/mesh). The pieces of a MeshShape's signed-distance query
/// shared by the tree (mesh_shape.cpp) and the narrow band (mesh_shape_band.cpp): the closest point
/// on a segment (Ericson 2005, §5.1.2; the thread's contacts and the jaws' test of a thread use it too)
/// and on a triangle (Ericson 2005, §5.1.5), the running nearest triangle, and the signed result from
/// the feature's angle-weighted pseudo-normal (Bærentzen & Aanæs 2005). No allocation, no exception.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>

#include "numen/core/mesh_shape.hpp"

namespace numen::core::detail {

inline constexpr double kInf = std::numeric_limits<double>::infinity();

/// Parameter u in [0, 1] of the point a + u (b − a) of segment [a, b] nearest to `c` (0 for a
/// segment of zero length): Ericson, Real-Time Collision Detection (2005), §5.1.2.
inline double segment_parameter(const Vec3& a, const Vec3& b, const Vec3& c) noexcept {
  const Vec3 d = b - a;
  const double dd = d.squaredNorm();
  return dd > 0.0 ? std::clamp((c - a).dot(d) / dd, 0.0, 1.0) : 0.0;
}

/// Closest feature of a triangle to a point.
enum Feature : int { kFace = 0, kVertex0, kVertex1, kVertex2, kEdge01, kEdge12, kEdge20 };

/// Closest point to `p` on the triangle (a, b, c), its feature and its barycentric weights
/// `w` (the point is w.x a + w.y b + w.z c; each ≥ 0, sum 1): Ericson, Real-Time Collision
/// Detection (2005), §5.1.5, ClosestPtPointTriangle (Voronoi regions by barycentric tests).
inline Vec3 closest_on_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c,
                                int& feature, Vec3& w) noexcept {
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0.0 && d2 <= 0.0) {
    feature = kVertex0;
    w = Vec3(1.0, 0.0, 0.0);
    return a;
  }
  const Vec3 bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0.0 && d4 <= d3) {
    feature = kVertex1;
    w = Vec3(0.0, 1.0, 0.0);
    return b;
  }
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
    feature = kEdge01;
    const double t = d1 / (d1 - d3);
    w = Vec3(1.0 - t, t, 0.0);
    return a + t * ab;
  }
  const Vec3 cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0.0 && d5 <= d6) {
    feature = kVertex2;
    w = Vec3(0.0, 0.0, 1.0);
    return c;
  }
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
    feature = kEdge20;
    const double t = d2 / (d2 - d6);
    w = Vec3(1.0 - t, 0.0, t);
    return a + t * ac;
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) {
    feature = kEdge12;
    const double t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    w = Vec3(0.0, 1.0 - t, t);
    return b + t * (c - b);
  }
  const double denom = 1.0 / (va + vb + vc);
  feature = kFace;
  const double v = vb * denom, u = vc * denom;
  w = Vec3(1.0 - v - u, v, u);
  return a + ab * v + ac * u;
}

/// Closest point to `p` on the triangle (a, b, c) and its feature (the weights unused).
inline Vec3 closest_on_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c,
                                int& feature) noexcept {
  Vec3 w;
  return closest_on_triangle(p, a, b, c, feature, w);
}

/// Squared distance from p to the box [lo, hi] (0 inside).
inline double box_distance2(const Vec3& p, const Vec3& lo, const Vec3& hi) noexcept {
  const Vec3 d = (lo - p).cwiseMax(p - hi).cwiseMax(0.0);
  return d.squaredNorm();
}

/// Result of the tree search: the closest triangle and feature found below the bound.
struct Nearest {
  double distance2 = kInf;
  Vec3 point = Vec3::Zero();
  int triangle = -1;
  int feature = kFace;
};

/// Triangle t's closest point to p replaces `best` when it is nearer.
inline void consider(const MeshShape& s, const Vec3& p, int t, Nearest& best) noexcept {
  const auto& tri = s.triangles[static_cast<std::size_t>(t)];
  int feature = kFace;
  const Vec3 q = closest_on_triangle(p, s.vertices[static_cast<std::size_t>(tri[0])],
                                     s.vertices[static_cast<std::size_t>(tri[1])],
                                     s.vertices[static_cast<std::size_t>(tri[2])], feature);
  const double d2 = (p - q).squaredNorm();
  if (d2 < best.distance2) {
    best.distance2 = d2;
    best.point = q;
    best.triangle = t;
    best.feature = feature;
  }
}

/// Angle-weighted pseudo-normal of the feature `f` of triangle t.
inline const Vec3& pseudo_normal(const MeshShape& s, int t, int f) noexcept {
  const auto ti = static_cast<std::size_t>(t);
  switch (f) {
    case kVertex0:
    case kVertex1:
    case kVertex2:
      return s.vertex_normals[static_cast<std::size_t>(s.triangles[ti][f - kVertex0])];
    case kEdge01:
    case kEdge12:
    case kEdge20:
      return s.edge_normals[static_cast<std::size_t>(s.triangle_edges[ti][f - kEdge01])];
    default:
      return s.face_normals[ti];
  }
}

/// The signed result of a search that found triangle `n.triangle`.
inline MeshDistance signed_result(const MeshShape& s, const Vec3& p, const Nearest& n) noexcept {
  MeshDistance out;
  const Vec3& pn = pseudo_normal(s, n.triangle, n.feature);
  const Vec3 diff = p - n.point;
  const double d = std::sqrt(n.distance2);
  const bool outside = diff.dot(pn) >= 0.0;
  out.distance = outside ? d : -d;
  out.point = n.point;
  out.triangle = n.triangle;
  if (d > 1e-12 * (1.0 + n.point.norm())) {
    out.normal = (outside ? diff : Vec3(-diff)) / d;
  } else {
    const double len = pn.norm();
    out.normal = len > 0.0 ? Vec3(pn / len) : Vec3(s.face_normals[static_cast<std::size_t>(n.triangle)]);
  }
  return out;
}

/// The narrow band's answer for `p` (mesh frame): true with `out` the nearest triangle when p's
/// cell lists one within the band's width (then it is the exact nearest of the whole mesh:
/// MeshBand); false when p is outside the band's bricks, its cell lists none, or the nearest
/// listed is farther than the width (then |sd(p)| > width, and the tree answers).
inline bool band_nearest(const MeshBand& b, const MeshShape& s, const Vec3& p,
                         Nearest& out) noexcept {
  if (b.width <= 0.0) return false;
  const Vec3 f = (p - b.origin) / b.cell;
  int ix[3];
  for (int k = 0; k < 3; ++k) {
    if (!(f[k] >= 0.0) || !(f[k] < static_cast<double>(b.cells[static_cast<std::size_t>(k)])))
      return false;
    ix[k] = static_cast<int>(f[k]);
  }
  constexpr int kB = kMeshBrickCells;
  const int bx = b.cells[0] / kB, by = b.cells[1] / kB;
  const std::int32_t slot =
      b.brick_slot[static_cast<std::size_t>(ix[0] / kB + bx * (ix[1] / kB + by * (ix[2] / kB)))];
  if (slot < 0) return false;
  const std::size_t local =
      static_cast<std::size_t>(ix[0] % kB + kB * (ix[1] % kB + kB * (ix[2] % kB)));
  const std::uint32_t* begin =
      b.cell_begin.data() + static_cast<std::size_t>(slot) * (kB * kB * kB + 1) + local;
  const std::uint32_t lo = begin[0], hi = begin[1];
  if (lo == hi) return false;
  // Listed in increasing distance d_c from the centre c; d(p, t) ≥ d_c − |p − c|.
  const double delta =
      (p - b.origin - b.cell * Vec3(ix[0] + 0.5, ix[1] + 0.5, ix[2] + 0.5)).norm();
  const double unit = (b.width + std::sqrt(3.0) * b.cell) / 127.0;
  out = Nearest{};
  out.distance2 = b.width * b.width;
  for (std::uint32_t i = lo; i < hi; ++i) {
    const std::int32_t e = b.triangles[i];
    const double low = (e & 127) * unit - delta;
    if (low > 0.0 && low * low >= out.distance2) break;
    consider(s, p, e >> 7, out);
  }
  return out.triangle >= 0;
}

}  // namespace numen::core::detail
