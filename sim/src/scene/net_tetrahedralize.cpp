/// @file net_tetrahedralize.cpp
/// A tetrahedral mesh of an organ's closed surface net, with CGAL (net_tetrahedralize.hpp). With
/// net_simplify.cpp, the only files that include CGAL's headers.
///
/// Which lattice points lie inside, cheaply. Each triangle scans the lattice points within s of its
/// bounding box, so every point gets its exact distance to the surface where that is under s and
/// the lower bound s elsewhere. A point at distance d has a surface-free ball of radius d around
/// it; two lattice neighbours (a corner and a centre, 0.866·s apart) both at least s/2 from the
/// surface are joined by a segment inside their balls (each of its points within 0.433·s < s/2 of
/// an end), so they lie on one side. The far points thus fall into a few connected sets
/// (union-find: the outside, the inside, a pocket or two), and one exact point-in-surface query
/// per set classifies them all. A cell whose centroid lies in the surface-free ball of one of its
/// lattice vertices (all inside) is inside; the others, mostly cells of surface vertices only,
/// take an exact query each. The lattice is jittered (kLatticeJitter) before the Delaunay: a
/// perfect lattice's coplanar rows and cospherical cubes send every predicate of the incremental
/// insertion to exact arithmetic (a 157 000-point lattice took 3.7 s instead of 0.6 s).

#include "net_tetrahedralize.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <numeric>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include <CGAL/AABB_face_graph_triangle_primitive.h>
#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/Delaunay_triangulation_3.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Side_of_triangle_mesh.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Triangulation_data_structure_3.h>
#include <CGAL/Triangulation_vertex_base_with_info_3.h>

namespace numen::sim {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using SurfaceMesh = CGAL::Surface_mesh<Point>;
using FacePrimitive = CGAL::AABB_face_graph_triangle_primitive<SurfaceMesh>;
using FaceTree = CGAL::AABB_tree<CGAL::AABB_traits<Kernel, FacePrimitive>>;
using SideOf = CGAL::Side_of_triangle_mesh<SurfaceMesh, Kernel, CGAL::Default, FaceTree>;
using VertexBase = CGAL::Triangulation_vertex_base_with_info_3<int, Kernel>;
using Tds = CGAL::Triangulation_data_structure_3<VertexBase>;
using Delaunay = CGAL::Delaunay_triangulation_3<Kernel, Tds>;

Point tet_point_of(const core::Vec3& v) { return Point(v.x(), v.y(), v.z()); }

std::string tet_format_mm(double metres) {
  std::string s = std::to_string(metres * 1e3);
  while (s.size() > 1 && s.back() == '0') s.pop_back();
  if (!s.empty() && s.back() == '.') s.pop_back();
  return s + " mm";
}

/// The integers i with (i + offset)·s in [lo, hi]: the first and how many.
struct LatticeAxis {
  long first = 0;
  long count = 0;
};

LatticeAxis lattice_axis(double lo, double hi, double s, double offset) {
  const double first = std::ceil(lo / s - offset);
  const double last = std::floor(hi / s - offset);
  return {static_cast<long>(first), static_cast<long>(std::max(0.0, last - first + 1.0))};
}

/// Points of the body-centred cubic lattice of spacing `s` over [lo, hi] (a double: no overflow).
double lattice_points(const core::Vec3& lo, const core::Vec3& hi, double s) {
  double n = 0.0;
  for (const double offset : {0.0, 0.5}) {
    double family = 1.0;
    for (int a = 0; a < 3; ++a) {
      const double first = std::ceil(lo[a] / s - offset);
      const double last = std::floor(hi[a] / s - offset);
      family *= std::max(0.0, last - first + 1.0);
    }
    n += family;
  }
  return n;
}

/// One family of lattice points: (i + offset, j + offset, k + offset)·s.
struct LatticeFamily {
  double offset = 0.0;
  std::array<LatticeAxis, 3> axis{};
  long base = 0;  ///< Index of the family's first point among all lattice points.
  long size() const { return axis[0].count * axis[1].count * axis[2].count; }
  long index(long i, long j, long k) const {
    return base + ((k - axis[2].first) * axis[1].count + (j - axis[1].first)) * axis[0].count +
           (i - axis[0].first);
  }
  bool contains(long i, long j, long k) const {
    return i >= axis[0].first && i < axis[0].first + axis[0].count && j >= axis[1].first &&
           j < axis[1].first + axis[1].count && k >= axis[2].first &&
           k < axis[2].first + axis[2].count;
  }
  Point point(long i, long j, long k, double s) const {
    return Point((static_cast<double>(i) + offset) * s, (static_cast<double>(j) + offset) * s,
                 (static_cast<double>(k) + offset) * s);
  }
};

/// Relative size of the lattice's jitter: each kept point moves by up to this times the spacing
/// along each axis, so that no four points are exactly coplanar and no five cospherical (the
/// lattice's rows and cubes are), which would send the Delaunay's predicates to exact arithmetic
/// at every step.
constexpr double kLatticeJitter = 1e-4;

/// A deterministic offset in [−1, 1)³ for lattice point (i, j, k) of family `f` (splitmix64).
core::Vec3 lattice_jitter(std::size_t f, long i, long j, long k) {
  std::uint64_t x = 0x9E3779B97F4A7C15ULL * (f + 1);
  core::Vec3 out;
  for (const long n : {i, j, k}) x = (x ^ static_cast<std::uint64_t>(n)) * 0xBF58476D1CE4E5B9ULL;
  for (int a = 0; a < 3; ++a) {
    x += 0x9E3779B97F4A7C15ULL;
    std::uint64_t z = x;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    z ^= z >> 31;
    out[a] = static_cast<double>(z >> 11) * 0x1.0p-52 - 1.0;
  }
  return out;
}

long find_root(std::vector<long>& parent, long a) {
  while (parent[static_cast<std::size_t>(a)] != a) {
    parent[static_cast<std::size_t>(a)] =
        parent[static_cast<std::size_t>(parent[static_cast<std::size_t>(a)])];
    a = parent[static_cast<std::size_t>(a)];
  }
  return a;
}

void join(std::vector<long>& parent, long a, long b) {
  a = find_root(parent, a);
  b = find_root(parent, b);
  if (a != b) parent[static_cast<std::size_t>(std::max(a, b))] = std::min(a, b);
}

/// The closedness check: "" when every edge is in two triangles (validate_mesh() has refused more).
std::string check_closed(const core::TriangleMesh& surface) {
  std::vector<std::tuple<int, int, int>> edges;  // (low vertex, high vertex, triangle)
  edges.reserve(3 * surface.triangles.size());
  for (std::size_t t = 0; t < surface.triangles.size(); ++t)
    for (int e = 0; e < 3; ++e) {
      const int a = surface.triangles[t][static_cast<std::size_t>(e)];
      const int b = surface.triangles[t][static_cast<std::size_t>((e + 1) % 3)];
      edges.emplace_back(std::min(a, b), std::max(a, b), static_cast<int>(t));
    }
  std::sort(edges.begin(), edges.end());
  std::tuple<int, int, int> open{-1, -1, -1};  // the open edge of the lowest triangle
  for (std::size_t i = 0; i < edges.size();) {
    std::size_t j = i + 1;
    while (j < edges.size() && std::get<0>(edges[j]) == std::get<0>(edges[i]) &&
           std::get<1>(edges[j]) == std::get<1>(edges[i]))
      ++j;
    if (j - i == 1 && (std::get<2>(open) < 0 || std::get<2>(edges[i]) < std::get<2>(open)))
      open = edges[i];
    i = j;
  }
  if (std::get<2>(open) < 0) return "";
  return "the surface is not closed: the edge of vertices " + std::to_string(std::get<0>(open)) +
         " and " + std::to_string(std::get<1>(open)) + " (from 0) is in triangle " +
         std::to_string(std::get<2>(open)) + " only (every edge must be in two triangles)";
}

/// `t` rotated by an even permutation (orientation kept) to start at its smallest index, the
/// other three cycled to put the smallest of them second: one form per oriented tetrahedron.
std::array<int, 4> canonical_tetrahedron(std::array<int, 4> t) {
  const auto first = static_cast<std::size_t>(std::min_element(t.begin(), t.end()) - t.begin());
  if (first == 1) t = {t[1], t[0], t[3], t[2]};
  if (first == 2) t = {t[2], t[3], t[0], t[1]};
  if (first == 3) t = {t[3], t[2], t[1], t[0]};
  while (t[1] > t[2] || t[1] > t[3]) t = {t[0], t[2], t[3], t[1]};
  return t;
}

}  // namespace

std::string tetrahedralize_net(const core::TriangleMesh& surface, double spacing,
                               core::TetrahedralMesh& out) {
  out = core::TetrahedralMesh{};
  const double s = spacing;
  if (!(std::isfinite(s) && s > 0.0))
    return "the lattice spacing " + std::to_string(s) + " m is not a finite number > 0";
  if (std::string err = core::validate_mesh(surface); !err.empty()) return err;
  if (std::string err = check_closed(surface); !err.empty()) return err;

  SurfaceMesh mesh;
  std::vector<SurfaceMesh::Vertex_index> vertex;
  vertex.reserve(surface.vertices.size());
  for (const core::Vec3& v : surface.vertices) vertex.push_back(mesh.add_vertex(tet_point_of(v)));
  for (std::size_t i = 0; i < surface.triangles.size(); ++i) {
    const auto& t = surface.triangles[i];
    if (mesh.add_face(vertex[static_cast<std::size_t>(t[0])],
                      vertex[static_cast<std::size_t>(t[1])],
                      vertex[static_cast<std::size_t>(t[2])]) == SurfaceMesh::null_face())
      return "triangle " + std::to_string(i) +
             " (from 0) is wound against a neighbour, or meets the triangles before it at a vertex "
             "whose triangles do not form one fan: the surface does not bound a volume";
  }
  if (CGAL::Polygon_mesh_processing::does_self_intersect(mesh)) {
    std::vector<std::pair<SurfaceMesh::Face_index, SurfaceMesh::Face_index>> pairs;
    CGAL::Polygon_mesh_processing::self_intersections(mesh, std::back_inserter(pairs));
    std::pair<int, int> first{-1, -1};
    for (const auto& [f, g] : pairs) {
      const std::pair<int, int> p{std::min(static_cast<int>(f), static_cast<int>(g)),
                                  std::max(static_cast<int>(f), static_cast<int>(g))};
      if (first.first < 0 || p < first) first = p;
    }
    return "the surface intersects itself: triangles " + std::to_string(first.first) + " and " +
           std::to_string(first.second) + " (from 0) cross (" + std::to_string(pairs.size()) +
           " pairs in all)";
  }

  // The lattice over the bounding box.
  core::Vec3 lo = surface.vertices.front(), hi = lo;
  for (const core::Vec3& v : surface.vertices) {
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  const double max_points = static_cast<double>(kMaxTetrahedralizeLatticePoints);
  if (const double n = lattice_points(lo, hi, s); n > max_points) {
    double fit = s * std::cbrt(n / max_points);
    while (lattice_points(lo, hi, fit) > max_points) fit *= 1.01;
    return "a lattice spacing of " + tet_format_mm(s) + " lays " +
           std::to_string(static_cast<long long>(n)) +
           " points over the surface's bounding box, "
           "more than " +
           std::to_string(kMaxTetrahedralizeLatticePoints) + ": a spacing of " +
           tet_format_mm(fit) + " or more fits (coarser surface triangles)";
  }
  std::array<LatticeFamily, 2> family{};
  long total = 0;
  for (std::size_t f = 0; f < 2; ++f) {
    family[f].offset = 0.5 * static_cast<double>(f);
    for (int a = 0; a < 3; ++a)
      family[f].axis[static_cast<std::size_t>(a)] = lattice_axis(lo[a], hi[a], s, family[f].offset);
    family[f].base = total;
    total += family[f].size();
  }

  FaceTree tree(faces(mesh).first, faces(mesh).second, mesh);
  tree.build();
  const SideOf side(tree);

  // Each point's clearance: its distance to the surface where that is under s (every triangle
  // scans the points within s of its bounding box), else s (a lower bound).
  const double half = 0.5 * s;
  std::vector<double> clearance(static_cast<std::size_t>(total), s * s);  // squared, then not
  for (const auto& tri : surface.triangles) {
    const core::Vec3& a = surface.vertices[static_cast<std::size_t>(tri[0])];
    const core::Vec3& b = surface.vertices[static_cast<std::size_t>(tri[1])];
    const core::Vec3& c = surface.vertices[static_cast<std::size_t>(tri[2])];
    const Kernel::Triangle_3 triangle(tet_point_of(a), tet_point_of(b), tet_point_of(c));
    const core::Vec3 box_lo = a.cwiseMin(b).cwiseMin(c).array() - s;
    const core::Vec3 box_hi = a.cwiseMax(b).cwiseMax(c).array() + s;
    for (const LatticeFamily& fam : family) {
      std::array<long, 3> first{}, last{};
      for (std::size_t u = 0; u < 3; ++u) {
        const auto [f, n] =
            lattice_axis(box_lo[static_cast<int>(u)], box_hi[static_cast<int>(u)], s, fam.offset);
        first[u] = std::max(f, fam.axis[u].first);
        last[u] = std::min(f + n, fam.axis[u].first + fam.axis[u].count);
      }
      for (long k = first[2]; k < last[2]; ++k)
        for (long j = first[1]; j < last[1]; ++j)
          for (long i = first[0]; i < last[0]; ++i) {
            double& d2 = clearance[static_cast<std::size_t>(fam.index(i, j, k))];
            d2 = std::min(d2, CGAL::squared_distance(fam.point(i, j, k, s), triangle));
          }
    }
  }
  for (double& d : clearance) d = std::sqrt(d);
  std::vector<long> parent(static_cast<std::size_t>(total));
  std::iota(parent.begin(), parent.end(), 0L);
  const LatticeFamily& corners = family[0];
  const LatticeFamily& centres = family[1];
  for (long k = centres.axis[2].first; k < centres.axis[2].first + centres.axis[2].count; ++k)
    for (long j = centres.axis[1].first; j < centres.axis[1].first + centres.axis[1].count; ++j)
      for (long i = centres.axis[0].first; i < centres.axis[0].first + centres.axis[0].count; ++i) {
        const long b = centres.index(i, j, k);
        if (clearance[static_cast<std::size_t>(b)] < half) continue;
        for (long c = 0; c < 8; ++c) {
          const long ci = i + (c & 1), cj = j + ((c >> 1) & 1), ck = k + ((c >> 2) & 1);
          if (!corners.contains(ci, cj, ck)) continue;
          const long a = corners.index(ci, cj, ck);
          if (clearance[static_cast<std::size_t>(a)] >= half) join(parent, a, b);
        }
      }
  // One exact query per connected set (at its first point), then the kept points, jittered.
  std::vector<signed char> root_inside(parent.size(), -1);
  const int nv = surface.num_vertices();
  std::vector<Point> lattice_point;  // the kept points, as CGAL points
  std::vector<double> kept_clearance;
  const double jitter = kLatticeJitter * s;
  for (std::size_t f = 0; f < 2; ++f) {
    const LatticeFamily& fam = family[f];
    for (long k = fam.axis[2].first; k < fam.axis[2].first + fam.axis[2].count; ++k)
      for (long j = fam.axis[1].first; j < fam.axis[1].first + fam.axis[1].count; ++j)
        for (long i = fam.axis[0].first; i < fam.axis[0].first + fam.axis[0].count; ++i) {
          const long at = fam.index(i, j, k);
          if (clearance[static_cast<std::size_t>(at)] < half) continue;
          const long root = find_root(parent, at);
          signed char& inside = root_inside[static_cast<std::size_t>(root)];
          if (inside < 0) inside = side(fam.point(i, j, k, s)) == CGAL::ON_BOUNDED_SIDE ? 1 : 0;
          if (inside == 0) continue;
          const Point q = fam.point(i, j, k, s);
          const core::Vec3 p =
              core::Vec3(q.x(), q.y(), q.z()) + jitter * lattice_jitter(f, i, j, k);
          lattice_point.push_back(tet_point_of(p));
          out.interior.push_back(p);
          // Moved by at most √3 jitter: still inside, its surface-free ball that much smaller.
          kept_clearance.push_back(clearance[static_cast<std::size_t>(at)] - 2.0 * jitter);
        }
  }
  clearance = {};
  parent = {};
  root_inside = {};

  // The Delaunay tetrahedralisation of the surface's vertices and the kept points.
  std::vector<std::pair<Point, int>> points;
  points.reserve(surface.vertices.size() + lattice_point.size());
  for (int v = 0; v < nv; ++v)
    points.emplace_back(tet_point_of(surface.vertices[static_cast<std::size_t>(v)]), v);
  for (std::size_t j = 0; j < lattice_point.size(); ++j)
    points.emplace_back(lattice_point[j], nv + static_cast<int>(j));
  const Delaunay delaunay(points.begin(), points.end());

  const double min_volume = 1e-9 * s * s * s;
  std::vector<std::array<int, 4>> cells;
  for (auto c = delaunay.finite_cells_begin(); c != delaunay.finite_cells_end(); ++c) {
    std::array<int, 4> t{};
    std::array<Point, 4> p;
    for (int a = 0; a < 4; ++a) {
      t[static_cast<std::size_t>(a)] = c->vertex(a)->info();
      p[static_cast<std::size_t>(a)] = c->vertex(a)->point();
    }
    if (std::abs(CGAL::volume(p[0], p[1], p[2], p[3])) <= min_volume) continue;
    const Point centroid = CGAL::centroid(p[0], p[1], p[2], p[3]);
    bool inside = false;
    for (std::size_t a = 0; a < 4 && !inside; ++a) {
      if (t[a] < nv) continue;
      const double r = kept_clearance[static_cast<std::size_t>(t[a] - nv)] * (1.0 - 1e-9);
      inside = CGAL::squared_distance(centroid, p[a]) < r * r;
    }
    if (!inside) inside = side(centroid) == CGAL::ON_BOUNDED_SIDE;
    if (!inside) continue;
    // Delaunay cells are positively oriented; make sure of it whatever the kernel's rounding.
    if (CGAL::orientation(p[0], p[1], p[2], p[3]) == CGAL::NEGATIVE) std::swap(t[2], t[3]);
    cells.push_back(t);
  }
  if (cells.empty()) {
    const std::size_t interior = out.interior.size();
    out = core::TetrahedralMesh{};
    return "no tetrahedron lies inside the surface (" + std::to_string(nv) + " vertices, " +
           std::to_string(interior) + " interior lattice points at a spacing of " +
           tet_format_mm(s) + ")";
  }

  // Every surface vertex in a kept cell; interior points in none dropped (renumbered in order).
  std::vector<char> used(static_cast<std::size_t>(nv) + lattice_point.size(), 0);
  for (const auto& t : cells)
    for (const int n : t) used[static_cast<std::size_t>(n)] = 1;
  std::vector<char> in_delaunay(used.size(), 0);  // a point where another is is not inserted
  for (auto v = delaunay.finite_vertices_begin(); v != delaunay.finite_vertices_end(); ++v)
    in_delaunay[static_cast<std::size_t>(v->info())] = 1;
  for (int v = 0; v < nv; ++v)
    if (!used[static_cast<std::size_t>(v)]) {
      const core::Vec3& x = surface.vertices[static_cast<std::size_t>(v)];
      std::string err = "surface vertex " + std::to_string(v) + " (from 0, at " +
                        tet_format_mm(x.x()) + ", " + tet_format_mm(x.y()) + ", " +
                        tet_format_mm(x.z()) +
                        ") is the corner of no tetrahedron inside the surface";
      err += in_delaunay[static_cast<std::size_t>(v)] ? " (a flat stretch of surface around it)"
                                                      : ": it lies where another vertex does";
      out = core::TetrahedralMesh{};
      return err;
    }
  std::vector<int> renumber(used.size(), -1);
  for (int v = 0; v < nv; ++v) renumber[static_cast<std::size_t>(v)] = v;
  std::vector<core::Vec3> interior;
  interior.reserve(out.interior.size());
  for (std::size_t j = 0; j < out.interior.size(); ++j)
    if (used[static_cast<std::size_t>(nv) + j]) {
      renumber[static_cast<std::size_t>(nv) + j] = nv + static_cast<int>(interior.size());
      interior.push_back(out.interior[j]);
    }
  out.interior = std::move(interior);
  for (auto& t : cells) {
    for (int& n : t) n = renumber[static_cast<std::size_t>(n)];
    t = canonical_tetrahedron(t);
  }
  std::sort(cells.begin(), cells.end());
  out.tetrahedra = std::move(cells);
  out.surface = surface;
  return "";
}

double mean_edge_length(const core::TriangleMesh& mesh) {
  const core::MeshTopology topology = core::build_mesh_topology(mesh);
  double sum = 0.0;
  for (const auto& [a, b] : topology.edges)
    sum += (mesh.vertices[static_cast<std::size_t>(b)] - mesh.vertices[static_cast<std::size_t>(a)])
               .norm();
  return topology.edges.empty() ? 0.0 : sum / static_cast<double>(topology.edges.size());
}

}  // namespace numen::sim
