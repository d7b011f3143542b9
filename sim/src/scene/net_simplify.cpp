/// @file net_simplify.cpp
/// A coarse net from a fine surface, and the fine vertices' nearest net triangles, with CGAL
/// (net_simplify.hpp). The only file that includes CGAL's headers.

#include "net_simplify.hpp"

#include <array>
#include <cstddef>
#include <string>
#include <vector>

#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Simple_cartesian.h>
#include <CGAL/version.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/Count_stop_predicate.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/LindstromTurk_cost.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/LindstromTurk_placement.h>
#include <CGAL/Surface_mesh_simplification/edge_collapse.h>

namespace numen::sim {
namespace {

using Kernel = CGAL::Simple_cartesian<double>;
using Point = Kernel::Point_3;
using SurfaceMesh = CGAL::Surface_mesh<Point>;
namespace sms = CGAL::Surface_mesh_simplification;

Point point_of(const core::Vec3& v) { return Point(v.x(), v.y(), v.z()); }

}  // namespace

std::string simplify_to_net(const core::TriangleMesh& fine, int nodes, core::TriangleMesh& net) {
  net = core::TriangleMesh{};
  SurfaceMesh m;
  std::vector<SurfaceMesh::Vertex_index> vertex;
  vertex.reserve(fine.vertices.size());
  for (const core::Vec3& v : fine.vertices) vertex.push_back(m.add_vertex(point_of(v)));
  for (std::size_t i = 0; i < fine.triangles.size(); ++i) {
    const auto& t = fine.triangles[i];
    const SurfaceMesh::Face_index f =
        m.add_face(vertex[static_cast<std::size_t>(t[0])], vertex[static_cast<std::size_t>(t[1])],
                   vertex[static_cast<std::size_t>(t[2])]);
    if (f == SurfaceMesh::null_face())
      return "triangle " + std::to_string(i) +
             " (from 0) does not join the ones before it into a manifold, consistently wound "
             "surface (an edge used twice in one direction, or a vertex whose triangles do not "
             "form one fan)";
  }
  // On a closed manifold surface an edge collapse removes one vertex, three edges and two
  // triangles: stopping below E0 − 3 (V0 − nodes) + 1 edges leaves `nodes` vertices.
  const long edges = static_cast<long>(m.number_of_edges());
  const long collapses = static_cast<long>(fine.vertices.size()) - nodes;
  const sms::Count_stop_predicate<SurfaceMesh> stop(static_cast<std::size_t>(edges - 3 * collapses + 1));
  sms::edge_collapse(m, stop,
                     CGAL::parameters::get_cost(sms::LindstromTurk_cost<SurfaceMesh>())
                         .get_placement(sms::LindstromTurk_placement<SurfaceMesh>()));
  m.collect_garbage();  // vertex and face indices 0 .. n − 1 again
  net.vertices.reserve(m.number_of_vertices());
  for (const SurfaceMesh::Vertex_index v : m.vertices()) {
    const Point& p = m.point(v);
    net.vertices.emplace_back(p.x(), p.y(), p.z());
  }
  net.triangles.reserve(m.number_of_faces());
  for (const SurfaceMesh::Face_index f : m.faces()) {
    std::array<int, 3> t{};
    int k = 0;
    for (const SurfaceMesh::Vertex_index v : m.vertices_around_face(m.halfedge(f)))
      if (k < 3) t[static_cast<std::size_t>(k++)] = static_cast<int>(v);
    net.triangles.push_back(t);
  }
  return "";
}

std::uint64_t net_simplifier_version() { return static_cast<std::uint64_t>(CGAL_VERSION_NR); }

std::vector<int> nearest_net_triangles(const core::TriangleMesh& net,
                                       std::span<const core::Vec3> points) {
  std::vector<Kernel::Triangle_3> triangles;
  triangles.reserve(net.triangles.size());
  for (const auto& t : net.triangles)
    triangles.emplace_back(point_of(net.vertices[static_cast<std::size_t>(t[0])]),
                           point_of(net.vertices[static_cast<std::size_t>(t[1])]),
                           point_of(net.vertices[static_cast<std::size_t>(t[2])]));
  using Primitive =
      CGAL::AABB_triangle_primitive<Kernel, std::vector<Kernel::Triangle_3>::const_iterator>;
  CGAL::AABB_tree<CGAL::AABB_traits<Kernel, Primitive>> tree(triangles.cbegin(), triangles.cend());
  tree.accelerate_distance_queries();
  std::vector<int> nearest;
  nearest.reserve(points.size());
  for (const core::Vec3& p : points)
    nearest.push_back(static_cast<int>(tree.closest_point_and_primitive(point_of(p)).second -
                                       triangles.cbegin()));
  return nearest;
}

}  // namespace numen::sim
