/// @file mesh.cpp
/// Built-in triangle meshes, validation, net topology and lumped areas (see
/// mesh.hpp). Load time only; every function allocates.

#include "numen/core/mesh.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <numbers>
#include <tuple>
#include <unordered_map>

namespace numen::core {
namespace {

/// Index of a std::vector as a size_t (indices are checked before use).
inline std::size_t at(int i) { return static_cast<std::size_t>(i); }

/// `x` in %g format (std::to_string would print a tiny area as 0.000000).
std::string number(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", x);
  return buf;
}

/// Key of the undirected edge (a, b) for hash maps.
inline std::uint64_t edge_key(int a, int b) {
  const auto lo = static_cast<std::uint64_t>(std::min(a, b));
  const auto hi = static_cast<std::uint64_t>(std::max(a, b));
  return (lo << 32) | hi;
}

/// (v1 − v0) × (v2 − v0) of triangle t: twice its area along its outward normal.
inline Vec3 doubled_normal(const TriangleMesh& mesh, const std::array<int, 3>& t) {
  const Vec3& v0 = mesh.vertices[at(t[0])];
  return (mesh.vertices[at(t[1])] - v0).cross(mesh.vertices[at(t[2])] - v0);
}

/// One side of one triangle: the undirected edge (lo < hi), the triangle and
/// the vertex opposite to the edge in it. Sorting groups a mesh's edges.
struct HalfEdge {
  int lo;
  int hi;
  int triangle;
  int opposite;
  bool operator<(const HalfEdge& o) const {
    return std::tie(lo, hi, triangle) < std::tie(o.lo, o.hi, o.triangle);
  }
};

/// The three sides of every triangle, sorted by (edge, triangle).
std::vector<HalfEdge> sorted_half_edges(const TriangleMesh& mesh) {
  std::vector<HalfEdge> h;
  h.reserve(3 * mesh.triangles.size());
  for (int t = 0; t < mesh.num_triangles(); ++t) {
    const auto& tri = mesh.triangles[at(t)];
    for (int k = 0; k < 3; ++k) {
      const int a = tri[at(k)];
      const int b = tri[at((k + 1) % 3)];
      h.push_back({std::min(a, b), std::max(a, b), t, tri[at((k + 2) % 3)]});
    }
  }
  std::sort(h.begin(), h.end());
  return h;
}

}  // namespace

TriangleMesh make_icosphere(double radius, int subdivisions) {
  TriangleMesh mesh;
  if (!(radius > 0.0) || !std::isfinite(radius) || subdivisions < 0 || subdivisions > 6) {
    return mesh;
  }
  // Regular icosahedron from three orthogonal golden rectangles, on the unit sphere.
  const double p = std::numbers::phi;
  mesh.vertices = {Vec3(-1, p, 0), Vec3(1, p, 0), Vec3(-1, -p, 0), Vec3(1, -p, 0),
                   Vec3(0, -1, p), Vec3(0, 1, p), Vec3(0, -1, -p), Vec3(0, 1, -p),
                   Vec3(p, 0, -1), Vec3(p, 0, 1), Vec3(-p, 0, -1), Vec3(-p, 0, 1)};
  for (Vec3& v : mesh.vertices) v.normalize();
  mesh.triangles = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                    {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                    {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                    {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (int s = 0; s < subdivisions; ++s) {
    std::unordered_map<std::uint64_t, int> midpoint;  // edge → new vertex
    midpoint.reserve(mesh.triangles.size() * 3 / 2);
    auto mid = [&](int a, int b) {
      const auto [it, inserted] = midpoint.try_emplace(edge_key(a, b), mesh.num_vertices());
      if (inserted) {
        mesh.vertices.push_back((mesh.vertices[at(a)] + mesh.vertices[at(b)]).normalized());
      }
      return it->second;
    };
    std::vector<std::array<int, 3>> finer;
    finer.reserve(4 * mesh.triangles.size());
    for (const auto& [a, b, c] : mesh.triangles) {
      const int ab = mid(a, b);
      const int bc = mid(b, c);
      const int ca = mid(c, a);
      finer.push_back({a, ab, ca});
      finer.push_back({b, bc, ab});
      finer.push_back({c, ca, bc});
      finer.push_back({ab, bc, ca});
    }
    mesh.triangles = std::move(finer);
  }
  for (Vec3& v : mesh.vertices) v *= radius;
  return mesh;
}

TriangleMesh make_capsule(double radius, double half_length, int segments, int rings,
                          int cylinder_rings) {
  TriangleMesh mesh;
  if (!(radius > 0.0) || !std::isfinite(radius) || !(half_length >= 0.0) ||
      !std::isfinite(half_length) || segments < 3 || rings < 1 || cylinder_rings < 0) {
    return mesh;
  }
  const double h = half_length;
  const double quarter = 0.5 * std::numbers::pi;
  // Rings from top to bottom as (z, ring radius).
  std::vector<std::pair<double, double>> ring_z_rho;
  for (int k = rings - 1; k >= 1; --k) {  // upper hemisphere, above the equator
    const double lat = quarter * k / rings;
    ring_z_rho.emplace_back(h + radius * std::sin(lat), radius * std::cos(lat));
  }
  ring_z_rho.emplace_back(h, radius);  // upper equator
  if (h > 0.0) {
    for (int i = 1; i <= cylinder_rings; ++i) {
      ring_z_rho.emplace_back(h - 2.0 * h * i / (cylinder_rings + 1), radius);
    }
    ring_z_rho.emplace_back(-h, radius);  // lower equator
  }
  for (int k = 1; k <= rings - 1; ++k) {  // lower hemisphere, below the equator
    const double lat = quarter * k / rings;
    ring_z_rho.emplace_back(-h - radius * std::sin(lat), radius * std::cos(lat));
  }

  const int num_rings = static_cast<int>(ring_z_rho.size());
  mesh.vertices.reserve(at(2 + num_rings * segments));
  mesh.vertices.emplace_back(0.0, 0.0, h + radius);  // top pole
  for (const auto& [z, rho] : ring_z_rho) {
    for (int j = 0; j < segments; ++j) {
      const double a = 2.0 * std::numbers::pi * j / segments;
      mesh.vertices.emplace_back(rho * std::cos(a), rho * std::sin(a), z);
    }
  }
  const int bottom = mesh.num_vertices();
  mesh.vertices.emplace_back(0.0, 0.0, -h - radius);  // bottom pole

  auto ring = [&](int r, int j) { return 1 + r * segments + (j % segments); };
  mesh.triangles.reserve(at(2 * segments * num_rings));
  for (int j = 0; j < segments; ++j) mesh.triangles.push_back({0, ring(0, j), ring(0, j + 1)});
  for (int r = 0; r + 1 < num_rings; ++r) {
    for (int j = 0; j < segments; ++j) {
      const int a0 = ring(r, j), a1 = ring(r, j + 1);
      const int b0 = ring(r + 1, j), b1 = ring(r + 1, j + 1);
      mesh.triangles.push_back({a0, b0, b1});
      mesh.triangles.push_back({a0, b1, a1});
    }
  }
  for (int j = 0; j < segments; ++j) {
    mesh.triangles.push_back({bottom, ring(num_rings - 1, j + 1), ring(num_rings - 1, j)});
  }
  return mesh;
}

TriangleMesh make_torus(double major_radius, double minor_radius, int segments, int sides) {
  TriangleMesh mesh;
  if (!(minor_radius > 0.0) || !(major_radius > minor_radius) || !std::isfinite(major_radius) ||
      segments < 3 || sides < 3)
    return mesh;
  const double two_pi = 2.0 * std::numbers::pi;
  mesh.vertices.reserve(static_cast<std::size_t>(segments) * static_cast<std::size_t>(sides));
  for (int i = 0; i < segments; ++i) {
    const double u = two_pi * i / segments;
    for (int j = 0; j < sides; ++j) {
      const double v = two_pi * j / sides;
      const double ring = major_radius + minor_radius * std::cos(v);
      mesh.vertices.emplace_back(ring * std::cos(u), ring * std::sin(u),
                                 minor_radius * std::sin(v));
    }
  }
  const auto at = [&](int i, int j) { return (i % segments) * sides + (j % sides); };
  mesh.triangles.reserve(2 * mesh.vertices.size());
  for (int i = 0; i < segments; ++i)
    for (int j = 0; j < sides; ++j) {
      // Around the tube (v) and the axis (u): (∂/∂u × ∂/∂v) points outward.
      const int a = at(i, j), b = at(i + 1, j), c = at(i + 1, j + 1), d = at(i, j + 1);
      mesh.triangles.push_back({a, b, c});
      mesh.triangles.push_back({a, c, d});
    }
  return mesh;
}

TriangleMesh make_box(const Vec3& half_extents, int subdivisions) {
  return make_box(half_extents, std::array<int, 3>{subdivisions, subdivisions, subdivisions});
}

TriangleMesh make_box(const Vec3& half_extents, const std::array<int, 3>& subdivisions) {
  TriangleMesh mesh;
  if (!half_extents.allFinite() || !(half_extents.minCoeff() > 0.0) ||
      *std::min_element(subdivisions.begin(), subdivisions.end()) < 0) {
    return mesh;
  }
  // Grid points are the surface points of the integer lattice [0, m_x] × [0, m_y] × [0, m_z],
  // m_d = subdivisions[d] + 1; a map from lattice point to vertex shares them between faces.
  std::array<int, 3> m{};
  for (int d = 0; d < 3; ++d) m[at(d)] = subdivisions[at(d)] + 1;
  std::unordered_map<std::int64_t, int> index;
  auto vertex = [&](const std::array<int, 3>& l) {
    const std::int64_t key =
        (static_cast<std::int64_t>(l[0]) * (m[1] + 1) + l[1]) * (m[2] + 1) + l[2];
    const auto [it, inserted] = index.try_emplace(key, mesh.num_vertices());
    if (inserted) {
      Vec3 x;
      for (int d = 0; d < 3; ++d) {
        x[d] = half_extents[d] * (2.0 * l[at(d)] / m[at(d)] - 1.0);
      }
      mesh.vertices.push_back(x);
    }
    return it->second;
  };
  for (int axis = 0; axis < 3; ++axis) {
    const int u = (axis + 1) % 3;  // e_u × e_v = e_axis
    const int v = (axis + 2) % 3;
    for (int side = 0; side < 2; ++side) {  // − face, then + face
      for (int i = 0; i < m[at(u)]; ++i) {
        for (int j = 0; j < m[at(v)]; ++j) {
          auto corner = [&](int di, int dj) {
            std::array<int, 3> l{};
            l[at(axis)] = side * m[at(axis)];
            l[at(u)] = i + di;
            l[at(v)] = j + dj;
            return vertex(l);
          };
          const int p00 = corner(0, 0), p10 = corner(1, 0);
          const int p11 = corner(1, 1), p01 = corner(0, 1);
          if (side == 1) {  // counter-clockwise in (u, v) is outward
            mesh.triangles.push_back({p00, p10, p11});
            mesh.triangles.push_back({p00, p11, p01});
          } else {
            mesh.triangles.push_back({p00, p11, p10});
            mesh.triangles.push_back({p00, p01, p11});
          }
        }
      }
    }
  }
  return mesh;
}

std::string validate_mesh(const TriangleMesh& mesh) {
  if (mesh.triangles.empty()) return "mesh has no triangle";
  const int n = mesh.num_vertices();
  for (int i = 0; i < n; ++i) {
    if (!mesh.vertices[at(i)].allFinite()) return "vertex " + std::to_string(i) + " is not finite";
  }
  for (int t = 0; t < mesh.num_triangles(); ++t) {
    const auto& tri = mesh.triangles[at(t)];
    for (const int k : tri) {
      if (k < 0 || k >= n) {
        return "triangle " + std::to_string(t) + ": vertex index " + std::to_string(k) +
               " out of range [0, " + std::to_string(n) + ")";
      }
    }
    if (tri[0] == tri[1] || tri[1] == tri[2] || tri[2] == tri[0]) {
      return "triangle " + std::to_string(t) + " repeats a vertex (" + std::to_string(tri[0]) +
             ", " + std::to_string(tri[1]) + ", " + std::to_string(tri[2]) + ")";
    }
  }
  Vec3 lo = mesh.vertices[0];
  Vec3 hi = lo;
  for (const Vec3& v : mesh.vertices) {
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  const double min_area = 1e-12 * (hi - lo).squaredNorm();
  for (int t = 0; t < mesh.num_triangles(); ++t) {
    const double area = 0.5 * doubled_normal(mesh, mesh.triangles[at(t)]).norm();
    if (!(area > min_area)) {
      return "triangle " + std::to_string(t) + " is degenerate (area " + number(area) +
             " m^2, at most " + number(min_area) + ")";
    }
  }
  const std::vector<HalfEdge> h = sorted_half_edges(mesh);
  for (std::size_t b = 0; b < h.size();) {
    std::size_t e = b + 1;
    while (e < h.size() && h[e].lo == h[b].lo && h[e].hi == h[b].hi) ++e;
    if (e - b > 2) {
      std::string who;
      for (std::size_t k = b; k < e; ++k)
        who += (k > b ? ", " : "") + std::to_string(h[k].triangle);
      return "edge (" + std::to_string(h[b].lo) + ", " + std::to_string(h[b].hi) +
             ") is shared by " + std::to_string(e - b) + " triangles (" + who +
             "), at most 2 allowed";
    }
    b = e;
  }
  std::vector<char> used(at(n), 0);
  for (const auto& tri : mesh.triangles) {
    for (const int k : tri) used[at(k)] = 1;
  }
  for (int i = 0; i < n; ++i) {
    if (!used[at(i)]) return "vertex " + std::to_string(i) + " is not used by any triangle";
  }
  return "";
}

MeshTopology build_mesh_topology(const TriangleMesh& mesh) {
  MeshTopology topo;
  const std::vector<HalfEdge> h = sorted_half_edges(mesh);
  // Edge groups: [begin, end) ranges of h with the same edge.
  std::vector<std::pair<std::size_t, std::size_t>> groups;
  for (std::size_t b = 0; b < h.size();) {
    std::size_t e = b + 1;
    while (e < h.size() && h[e].lo == h[b].lo && h[e].hi == h[b].hi) ++e;
    groups.emplace_back(b, e);
    topo.edges.emplace_back(h[b].lo, h[b].hi);
    if (e - b == 1) ++topo.boundary_edges;
    b = e;
  }
  std::unordered_map<std::uint64_t, char> seen;  // bending pairs already taken
  for (const auto& [b, e] : groups) {
    if (e - b != 2) continue;
    const int o0 = h[b].opposite;
    const int o1 = h[b + 1].opposite;
    if (o0 == o1) continue;
    const std::pair<int, int> pair(std::min(o0, o1), std::max(o0, o1));
    if (std::binary_search(topo.edges.begin(), topo.edges.end(), pair)) continue;
    if (!seen.try_emplace(edge_key(o0, o1), 1).second) continue;
    topo.bending_pairs.push_back(pair);
  }
  return topo;
}

std::vector<double> vertex_areas(const TriangleMesh& mesh) {
  const int n = mesh.num_vertices();
  std::vector<double> area(at(n), 0.0);
  for (const auto& tri : mesh.triangles) {
    if (std::any_of(tri.begin(), tri.end(), [n](int k) { return k < 0 || k >= n; })) continue;
    const double third = doubled_normal(mesh, tri).norm() / 6.0;
    for (const int k : tri) area[at(k)] += third;
  }
  return area;
}

std::vector<double> mean_incident_edge_length(const TriangleMesh& mesh,
                                              const MeshTopology& topology) {
  const int n = mesh.num_vertices();
  std::vector<double> sum(at(n), 0.0);
  std::vector<int> count(at(n), 0);
  for (const auto& [a, b] : topology.edges) {
    if (a < 0 || b < 0 || a >= n || b >= n) continue;
    const double len = (mesh.vertices[at(a)] - mesh.vertices[at(b)]).norm();
    sum[at(a)] += len;
    sum[at(b)] += len;
    ++count[at(a)];
    ++count[at(b)];
  }
  for (int i = 0; i < n; ++i) {
    if (count[at(i)] > 0) sum[at(i)] /= count[at(i)];
  }
  return sum;
}

void transform_mesh(TriangleMesh& mesh, const Vec3& scale, const Pose& pose) {
  const Mat3 rotation = pose.orientation.normalized().toRotationMatrix();
  for (Vec3& v : mesh.vertices) v = rotation * scale.cwiseProduct(v) + pose.position;
  if (scale.prod() < 0.0) {
    for (auto& tri : mesh.triangles) std::swap(tri[1], tri[2]);
  }
}

}  // namespace numen::core
