/// @file mesh_shape.cpp
/// Closed meshes as collision shapes: build and signed-distance queries (see mesh_shape.hpp).

#include "numen/core/mesh_shape.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <tuple>

#include "mesh/mesh_shape_query.hpp"

namespace numen::core {
namespace {

using detail::consider;
using detail::Nearest;
using detail::signed_result;

/// Closest triangle to p closer than `bound` (m; +∞: any), nearest child first.
Nearest search(const MeshShape& s, const Vec3& p, double bound) noexcept {
  Nearest best;
  best.distance2 = bound * bound;
  if (s.nodes.empty()) return best;
  constexpr int kStack = 64;  // > tree_depth + 1 for any mesh below 2^40 triangles
  std::int32_t stack[kStack];
  int sp = 0;
  const MeshBvhNode* nodes = s.nodes.data();
  if (detail::box_distance2(p, nodes[0].lo, nodes[0].hi) < best.distance2) stack[sp++] = 0;
  while (sp > 0) {
    const MeshBvhNode& node = nodes[stack[--sp]];
    if (detail::box_distance2(p, node.lo, node.hi) >= best.distance2) continue;
    if (node.count > 0) {
      for (int t = node.index; t < node.index + node.count; ++t) consider(s, p, t, best);
      continue;
    }
    const std::int32_t first = static_cast<std::int32_t>(&node - nodes) + 1;
    const std::int32_t second = node.index;
    const double d_first = detail::box_distance2(p, nodes[first].lo, nodes[first].hi);
    const double d_second = detail::box_distance2(p, nodes[second].lo, nodes[second].hi);
    // Push the farther child first: the nearer one is searched first; when p is in both boxes
    // (both 0), the one whose centre is nearer.
    const bool first_nearer =
        d_first < d_second ||
        (d_first == d_second &&
         (p - 0.5 * (nodes[first].lo + nodes[first].hi)).squaredNorm() <=
             (p - 0.5 * (nodes[second].lo + nodes[second].hi)).squaredNorm());
    const std::int32_t near_child = first_nearer ? first : second;
    const std::int32_t far_child = first_nearer ? second : first;
    const double d_near = first_nearer ? d_first : d_second;
    const double d_far = first_nearer ? d_second : d_first;
    if (d_far < best.distance2 && sp < kStack) stack[sp++] = far_child;
    if (d_near < best.distance2 && sp < kStack) stack[sp++] = near_child;
  }
  return best;
}

/// Builds the subtree over order[begin, end) at node index `at` (already allocated); returns its
/// depth. Median split along the longest axis of the centroids' bounds.
int build_node(MeshShape& s, const std::vector<Vec3>& centroid, const std::vector<Vec3>& tri_lo,
               const std::vector<Vec3>& tri_hi, std::vector<int>& order, int begin, int end,
               std::size_t at) {
  Vec3 lo = Vec3::Constant(detail::kInf), hi = Vec3::Constant(-detail::kInf);
  Vec3 clo = Vec3::Constant(detail::kInf), chi = Vec3::Constant(-detail::kInf);
  for (int i = begin; i < end; ++i) {
    const auto t = static_cast<std::size_t>(order[static_cast<std::size_t>(i)]);
    lo = lo.cwiseMin(tri_lo[t]);
    hi = hi.cwiseMax(tri_hi[t]);
    clo = clo.cwiseMin(centroid[t]);
    chi = chi.cwiseMax(centroid[t]);
  }
  s.nodes[at].lo = lo;
  s.nodes[at].hi = hi;
  if (end - begin <= kMeshLeafSize) {
    s.nodes[at].index = begin;
    s.nodes[at].count = end - begin;
    return 1;
  }
  int axis = 0;
  (chi - clo).maxCoeff(&axis);
  const int mid = begin + (end - begin) / 2;
  std::nth_element(order.begin() + begin, order.begin() + mid, order.begin() + end,
                   [&](int a, int b) {
                     const double ca = centroid[static_cast<std::size_t>(a)][axis];
                     const double cb = centroid[static_cast<std::size_t>(b)][axis];
                     return ca < cb || (ca == cb && a < b);  // deterministic
                   });
  s.nodes.emplace_back();  // first child at at + 1
  const int d1 = build_node(s, centroid, tri_lo, tri_hi, order, begin, mid, at + 1);
  const std::size_t second = s.nodes.size();
  s.nodes.emplace_back();
  const int d2 = build_node(s, centroid, tri_lo, tri_hi, order, mid, end, second);
  s.nodes[at].index = static_cast<std::int32_t>(second);
  s.nodes[at].count = 0;
  return 1 + std::max(d1, d2);
}

/// Checks that every edge has exactly two triangles traversing it in opposite directions, and
/// fills s.triangle_edges / s.edge_normals (needs s.face_normals). "" or the first offence.
std::string build_edges(MeshShape& s) {
  // (min vertex, max vertex, triangle, slot) of every triangle side, sorted.
  std::vector<std::tuple<int, int, int, int>> sides;
  sides.reserve(3 * s.triangles.size());
  for (int t = 0; t < s.num_triangles(); ++t) {
    const auto& tri = s.triangles[static_cast<std::size_t>(t)];
    for (int k = 0; k < 3; ++k) {
      const int a = tri[static_cast<std::size_t>(k)], b = tri[static_cast<std::size_t>((k + 1) % 3)];
      sides.emplace_back(std::min(a, b), std::max(a, b), t, k);
    }
  }
  std::sort(sides.begin(), sides.end());
  s.triangle_edges.assign(s.triangles.size(), {0, 0, 0});
  s.edge_normals.clear();
  s.edge_normals.reserve(sides.size() / 2);
  int boundary = 0;
  std::string first_boundary;
  for (std::size_t i = 0; i < sides.size();) {
    std::size_t j = i + 1;
    while (j < sides.size() && std::get<0>(sides[j]) == std::get<0>(sides[i]) &&
           std::get<1>(sides[j]) == std::get<1>(sides[i]))
      ++j;
    const std::string edge = "edge (" + std::to_string(std::get<0>(sides[i])) + ", " +
                             std::to_string(std::get<1>(sides[i])) + ")";
    if (j - i == 1) {
      if (boundary++ == 0) first_boundary = edge;
    } else if (j - i > 2) {
      return edge + " is shared by " + std::to_string(j - i) + " triangles (not manifold)";
    } else {
      const auto [a0, b0, t0, k0] = sides[i];
      const auto [a1, b1, t1, k1] = sides[i + 1];
      const auto& tri0 = s.triangles[static_cast<std::size_t>(t0)];
      const auto& tri1 = s.triangles[static_cast<std::size_t>(t1)];
      const bool fwd0 = tri0[static_cast<std::size_t>(k0)] == a0;
      const bool fwd1 = tri1[static_cast<std::size_t>(k1)] == a1;
      if (fwd0 == fwd1)
        return "triangles " + std::to_string(t0) + " and " + std::to_string(t1) +
               " wind inconsistently across " + edge + " (both traverse it the same way)";
      const int e = static_cast<int>(s.edge_normals.size());
      s.edge_normals.push_back(s.face_normals[static_cast<std::size_t>(t0)] +
                               s.face_normals[static_cast<std::size_t>(t1)]);
      s.triangle_edges[static_cast<std::size_t>(t0)][static_cast<std::size_t>(k0)] = e;
      s.triangle_edges[static_cast<std::size_t>(t1)][static_cast<std::size_t>(k1)] = e;
    }
    i = j;
  }
  if (boundary > 0)
    return "the surface is open: " + std::to_string(boundary) + " boundary edge" +
           (boundary == 1 ? "" : "s") + " (first: " + first_boundary +
           "), a mesh obstacle needs a closed surface";
  return "";
}

/// The coarse signed-distance grid over the bounds (needs the tree and the normals).
void build_grid(MeshShape& s) {
  const Vec3 ext = s.aabb_max - s.aabb_min;
  const double longest = std::max(ext.maxCoeff(), 1e-12);
  s.grid_cell = longest / kMeshGridCells;
  for (int k = 0; k < 3; ++k)
    s.grid_cells[static_cast<std::size_t>(k)] =
        std::clamp(static_cast<int>(std::ceil(ext[k] / s.grid_cell - 1e-9)), 1, kMeshGridCells);
  const Vec3 span(s.grid_cells[0] * s.grid_cell, s.grid_cells[1] * s.grid_cell,
                  s.grid_cells[2] * s.grid_cell);
  s.grid_origin = 0.5 * (s.aabb_min + s.aabb_max) - 0.5 * span;
  s.grid_distance.assign(static_cast<std::size_t>(s.grid_cells[0]) * s.grid_cells[1] * s.grid_cells[2],
                         0.0f);
  std::size_t i = 0;
  for (int z = 0; z < s.grid_cells[2]; ++z)
    for (int y = 0; y < s.grid_cells[1]; ++y)
      for (int x = 0; x < s.grid_cells[0]; ++x) {
        const Vec3 c = s.grid_origin + s.grid_cell * Vec3(x + 0.5, y + 0.5, z + 0.5);
        const Nearest n = search(s, c, detail::kInf);
        s.grid_distance[i++] = static_cast<float>(signed_result(s, c, n).distance);
      }
}

}  // namespace

std::size_t MeshShape::memory_bytes() const noexcept {
  return vertices.capacity() * sizeof(Vec3) + triangles.capacity() * sizeof(triangles[0]) +
         face_normals.capacity() * sizeof(Vec3) +
         triangle_edges.capacity() * sizeof(triangle_edges[0]) +
         edge_normals.capacity() * sizeof(Vec3) + vertex_normals.capacity() * sizeof(Vec3) +
         nodes.capacity() * sizeof(MeshBvhNode) + grid_distance.capacity() * sizeof(float) +
         mesh_band_bytes(band);
}

void build_mesh_tree(const TriangleMesh& mesh, MeshShape& s) {
  s = MeshShape{};
  s.vertices = mesh.vertices;
  const std::size_t nt = mesh.triangles.size();

  // Tree over the input triangles, then the triangles in leaf order.
  std::vector<Vec3> centroid(nt), tri_lo(nt), tri_hi(nt);
  for (std::size_t t = 0; t < nt; ++t) {
    const auto& tri = mesh.triangles[t];
    const Vec3& a = s.vertices[static_cast<std::size_t>(tri[0])];
    const Vec3& b = s.vertices[static_cast<std::size_t>(tri[1])];
    const Vec3& c = s.vertices[static_cast<std::size_t>(tri[2])];
    centroid[t] = (a + b + c) / 3.0;
    tri_lo[t] = a.cwiseMin(b).cwiseMin(c);
    tri_hi[t] = a.cwiseMax(b).cwiseMax(c);
  }
  std::vector<int> order(nt);
  std::iota(order.begin(), order.end(), 0);
  s.nodes.reserve(2 * (nt / static_cast<std::size_t>(kMeshLeafSize) + 1));
  s.nodes.emplace_back();
  s.tree_depth = build_node(s, centroid, tri_lo, tri_hi, order, 0, static_cast<int>(nt), 0);
  s.nodes.shrink_to_fit();
  s.triangles.resize(nt);
  for (std::size_t i = 0; i < nt; ++i)
    s.triangles[i] = mesh.triangles[static_cast<std::size_t>(order[i])];
  s.aabb_min = s.nodes[0].lo;
  s.aabb_max = s.nodes[0].hi;
}

std::string build_mesh_shape(const TriangleMesh& mesh, MeshShape& s,
                             const MeshShapeOptions& options) {
  const std::string invalid = validate_mesh(mesh);
  if (!invalid.empty()) return invalid;
  build_mesh_tree(mesh, s);
  const std::size_t nt = mesh.triangles.size();

  // Face normals, the signed volume, the angle-weighted vertex normals.
  s.face_normals.resize(nt);
  s.vertex_normals.assign(s.vertices.size(), Vec3::Zero());
  double volume = 0.0;
  for (std::size_t t = 0; t < nt; ++t) {
    const auto& tri = s.triangles[t];
    const Vec3* v[3] = {&s.vertices[static_cast<std::size_t>(tri[0])],
                        &s.vertices[static_cast<std::size_t>(tri[1])],
                        &s.vertices[static_cast<std::size_t>(tri[2])]};
    const Vec3 n = (*v[1] - *v[0]).cross(*v[2] - *v[0]).normalized();
    s.face_normals[t] = n;
    volume += v[0]->dot(v[1]->cross(*v[2])) / 6.0;
    for (int k = 0; k < 3; ++k) {
      const Vec3 e1 = (*v[(k + 1) % 3] - *v[k]).normalized();
      const Vec3 e2 = (*v[(k + 2) % 3] - *v[k]).normalized();
      const double angle = std::acos(std::clamp(e1.dot(e2), -1.0, 1.0));
      s.vertex_normals[static_cast<std::size_t>(tri[static_cast<std::size_t>(k)])] += angle * n;
    }
  }
  const std::string edges = build_edges(s);
  if (!edges.empty()) return edges;
  if (!(volume > 0.0))
    return "the surface encloses a signed volume of " + std::to_string(volume) +
           " m³ (≤ 0): its triangles wind inward, not counter-clockwise seen from outside";
  build_grid(s);
  build_mesh_band(s, options);
  return "";
}

bool mesh_signed_distance(const MeshShape& s, const Vec3& p, double reach,
                          MeshDistance& out) noexcept {
  if (!p.allFinite() || s.nodes.empty()) return false;
  // Outside the bounds is outside the mesh: beyond reach of the box, no contact.
  const double outside2 = detail::box_distance2(p, s.aabb_min, s.aabb_max);
  if (outside2 > 0.0 && outside2 >= reach * reach) return false;
  {
    // The narrow band: exact when the nearest listed triangle is within its width.
    Nearest n;
    if (detail::band_nearest(s.band, s, p, n)) {
      out = signed_result(s, p, n);
      return out.distance < reach;
    }
  }
  double bound = detail::kInf;
  if (outside2 > 0.0) {
    bound = reach;  // outside the mesh: only a distance below reach matters
  } else if (!s.grid_distance.empty()) {
    // |sd(p) − sd(c)| ≤ |p − c| at the cell centre c; float storage: a relative slack.
    int cell[3];
    for (int k = 0; k < 3; ++k)
      cell[k] = std::clamp(static_cast<int>((p[k] - s.grid_origin[k]) / s.grid_cell), 0,
                           s.grid_cells[static_cast<std::size_t>(k)] - 1);
    const Vec3 c = s.grid_origin + s.grid_cell * Vec3(cell[0] + 0.5, cell[1] + 0.5, cell[2] + 0.5);
    const double sdc = s.grid_distance[static_cast<std::size_t>(
        cell[0] + s.grid_cells[0] * (cell[1] + s.grid_cells[1] * cell[2]))];
    const double e = (p - c).norm() + 1e-6 * (std::abs(sdc) + s.grid_cell);
    if (sdc - e >= reach) return false;
    bound = sdc - e > 0.0 ? std::min(reach, sdc + e) : std::abs(sdc) + e;
  }
  const Nearest n = search(s, p, bound);
  if (n.triangle < 0) return false;
  out = signed_result(s, p, n);
  return out.distance < reach;
}

MeshDistance mesh_signed_distance_brute(const MeshShape& s, const Vec3& p) noexcept {
  Nearest best;
  for (int t = 0; t < s.num_triangles(); ++t) {
    consider(s, p, t, best);
  }
  return best.triangle < 0 ? MeshDistance{} : signed_result(s, p, best);
}

}  // namespace numen::core
