/// @file compare_net_simplifiers.cpp
/// Measures the two simplifiers Debian 12 packages for making an organ's coarse simulation net
/// out of a fine surface (docs/fine-surface.md): CGAL 5.5's
/// Surface_mesh_simplification (edge collapse, link condition) with Lindstrom–Turk cost and
/// placement ("CGAL", what numen uses) and with Garland–Heckbert plane quadrics ("CGAL-GH"), and
/// meshoptimizer 0.18's meshopt_simplify (edge collapse onto existing vertices, quadric error).
/// Not part of the build: a measurement, run by hand.
///
///     python3 sim/data/make_fine_ellipsoid.py 32 > /tmp/e20k.obj    # 20 480 triangles
///     python3 sim/data/make_fine_ellipsoid.py 100 > /tmp/e200k.obj  # 200 000 triangles
///     g++ -O2 -std=c++20 -DNDEBUG -DCGAL_EIGEN3_ENABLED -I/usr/include/eigen3 \
///         sim/data/compare_net_simplifiers.cpp -lmeshoptimizer -o /tmp/compare_net_simplifiers
///     /tmp/compare_net_simplifiers 1024 /tmp/e20k.obj /tmp/e200k.obj
///
/// Per mesh and simplifier, one line: wall and thread CPU time (medians of 5 runs, the mesh already in memory,
/// conversions in and out included), the net's node and triangle counts against the target,
/// closed (every edge in exactly two triangles, each direction once) and vertex-manifold (one
/// fan per vertex), the smallest triangle angle, the largest per-triangle longest/shortest edge
/// ratio and the net's longest/shortest edge, and the distance from every fine vertex to the
/// net's surface (max and mean, mm; CGAL's AABB tree).
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Simple_cartesian.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/Count_stop_predicate.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/GarlandHeckbert_plane_policies.h>
#include <CGAL/Surface_mesh_simplification/edge_collapse.h>
#include <meshoptimizer.h>
#include <time.h>

namespace {

using Kernel = CGAL::Simple_cartesian<double>;
using Point = Kernel::Point_3;
using Tri = std::array<int, 3>;

struct Surface {
  std::vector<Point> v;
  std::vector<Tri> t;
};

Surface read_obj(const char* path) {
  Surface s;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream ls(line);
    std::string tag;
    ls >> tag;
    if (tag == "v") {
      double x, y, z;
      ls >> x >> y >> z;
      s.v.emplace_back(x, y, z);
    } else if (tag == "f") {
      Tri t;
      for (int& i : t) {
        std::string w;
        ls >> w;
        i = std::stoi(w) - 1;
      }
      s.t.push_back(t);
    }
  }
  return s;
}

using Mesh = CGAL::Surface_mesh<Point>;

/// CGAL's edge collapse to `nodes` vertices, Lindstrom–Turk (`garland_heckbert` false, CGAL's
/// default policies) or Garland–Heckbert plane quadrics.
Surface simplify_cgal(const Surface& fine, int nodes, bool garland_heckbert) {
  Mesh m;
  std::vector<Mesh::Vertex_index> vi;
  for (const Point& p : fine.v) vi.push_back(m.add_vertex(p));
  for (const Tri& t : fine.t) m.add_face(vi[t[0]], vi[t[1]], vi[t[2]]);
  const long e0 = static_cast<long>(m.number_of_edges());
  // A collapse takes one vertex and three edges away from a closed manifold surface.
  const long stop = e0 - 3L * (static_cast<long>(fine.v.size()) - nodes) + 1;
  CGAL::Surface_mesh_simplification::Count_stop_predicate<Mesh> until(static_cast<std::size_t>(stop));
  if (garland_heckbert) {
    CGAL::Surface_mesh_simplification::GarlandHeckbert_plane_policies<Mesh, Kernel> gh(m);
    CGAL::Surface_mesh_simplification::edge_collapse(
        m, until, CGAL::parameters::get_cost(gh.get_cost()).get_placement(gh.get_placement()));
  } else {
    CGAL::Surface_mesh_simplification::edge_collapse(m, until);
  }
  m.collect_garbage();
  Surface out;
  for (Mesh::Vertex_index v : m.vertices()) out.v.push_back(m.point(v));
  for (Mesh::Face_index f : m.faces()) {
    Tri t;
    int k = 0;
    for (Mesh::Vertex_index v : m.vertices_around_face(m.halfedge(f))) t[k++] = static_cast<int>(v);
    out.t.push_back(t);
  }
  return out;
}

Surface simplify_meshopt(const Surface& fine, int nodes) {
  std::vector<float> pos;
  for (const Point& p : fine.v)
    for (int k = 0; k < 3; ++k) pos.push_back(static_cast<float>(p[k]));
  std::vector<unsigned> idx;
  for (const Tri& t : fine.t)
    for (int i : t) idx.push_back(static_cast<unsigned>(i));
  std::vector<unsigned> dst(idx.size());
  const std::size_t target = 3u * (2u * static_cast<std::size_t>(nodes) - 4u);  // F = 2V − 4
  float err = 0.0f;
  const std::size_t n = meshopt_simplify(dst.data(), idx.data(), idx.size(), pos.data(), fine.v.size(),
                                         3 * sizeof(float), target, 1.0f, 0, &err);
  Surface out;
  std::vector<int> remap(fine.v.size(), -1);
  for (std::size_t i = 0; i < n; i += 3) {
    Tri t;
    for (int k = 0; k < 3; ++k) {
      int& r = remap[dst[i + k]];
      if (r < 0) {
        r = static_cast<int>(out.v.size());
        out.v.push_back(fine.v[dst[i + k]]);
      }
      t[k] = r;
    }
    out.t.push_back(t);
  }
  return out;
}

/// CPU time of the calling thread (s): the simplifier's cost, whatever else the machine runs.
double thread_cpu_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

double dist(const Point& a, const Point& b) { return std::sqrt(CGAL::squared_distance(a, b)); }

void report(const char* name, const Surface& fine, int nodes, std::vector<double> times,
            std::vector<double> cpu, const Surface& net) {
  // Closed: each directed edge once and its reverse once. Vertex-manifold: one fan per vertex.
  std::map<std::pair<int, int>, int> directed;
  for (const Tri& t : net.t)
    for (int k = 0; k < 3; ++k) ++directed[{t[k], t[(k + 1) % 3]}];
  bool closed = true;
  for (const auto& [e, c] : directed)
    if (c != 1 || directed.count({e.second, e.first}) == 0 || directed.at({e.second, e.first}) != 1)
      closed = false;
  bool manifold = closed;
  if (closed) {  // walk each vertex's fan: next triangle across the edge (v, w)
    std::map<std::pair<int, int>, int> next;  // directed edge (v, a) → the third vertex b
    for (const Tri& t : net.t)
      for (int k = 0; k < 3; ++k) next[{t[k], t[(k + 1) % 3]}] = t[(k + 2) % 3];
    std::vector<int> valence(net.v.size(), 0);
    for (const auto& [e, c] : directed) ++valence[static_cast<std::size_t>(e.first)];
    std::vector<char> seen(net.v.size(), 0);
    for (const Tri& t : net.t) {
      const int v = t[0];
      if (seen[static_cast<std::size_t>(v)]) continue;
      seen[static_cast<std::size_t>(v)] = 1;
      int a = t[1], steps = 0;
      do {
        a = next.at({v, a});  // triangle (v, a, b): the next one around v starts at b
        ++steps;
      } while (a != t[1] && steps <= valence[static_cast<std::size_t>(v)]);
      if (steps != valence[static_cast<std::size_t>(v)]) manifold = false;
    }
  }
  double min_angle = 180.0, worst_ratio = 1.0, shortest = 1e9, longest = 0.0;
  for (const Tri& t : net.t) {
    const Point &a = net.v[t[0]], &b = net.v[t[1]], &c = net.v[t[2]];
    const double la = dist(b, c), lb = dist(c, a), lc = dist(a, b);
    const double lo = std::min({la, lb, lc}), hi = std::max({la, lb, lc});
    shortest = std::min(shortest, lo);
    longest = std::max(longest, hi);
    worst_ratio = std::max(worst_ratio, hi / lo);
    const double angle_a = std::acos(std::clamp((lb * lb + lc * lc - la * la) / (2 * lb * lc), -1.0, 1.0));
    const double angle_b = std::acos(std::clamp((la * la + lc * lc - lb * lb) / (2 * la * lc), -1.0, 1.0));
    const double angle_c = std::numbers::pi - angle_a - angle_b;
    min_angle = std::min({min_angle, angle_a * 180 / std::numbers::pi, angle_b * 180 / std::numbers::pi,
                          angle_c * 180 / std::numbers::pi});
  }
  std::vector<Kernel::Triangle_3> tris;
  for (const Tri& t : net.t) tris.emplace_back(net.v[t[0]], net.v[t[1]], net.v[t[2]]);
  using Prim = CGAL::AABB_triangle_primitive<Kernel, std::vector<Kernel::Triangle_3>::iterator>;
  CGAL::AABB_tree<CGAL::AABB_traits<Kernel, Prim>> tree(tris.begin(), tris.end());
  tree.accelerate_distance_queries();
  double dmax = 0.0, dsum = 0.0;
  for (const Point& p : fine.v) {
    const double d = std::sqrt(tree.squared_distance(p));
    dmax = std::max(dmax, d);
    dsum += d;
  }
  std::sort(times.begin(), times.end());
  std::sort(cpu.begin(), cpu.end());
  std::printf("%-9s %7zu tris  %8.1f ms wall %8.1f ms CPU  nodes %5zu/%d  tris %5zu  closed %-3s manifold %-3s  "
              "min angle %5.1f deg  worst tri edge ratio %5.2f  longest/shortest edge %5.2f  "
              "fine->net max %.3f mm mean %.3f mm\n",
              name, fine.t.size(), times[times.size() / 2] * 1e3, cpu[cpu.size() / 2] * 1e3, net.v.size(), nodes, net.t.size(),
              closed ? "yes" : "NO", manifold ? "yes" : "NO", min_angle, worst_ratio, longest / shortest,
              dmax * 1e3, dsum / static_cast<double>(fine.v.size()) * 1e3);
}

template <class F>
void measure(const char* name, const Surface& fine, int nodes, F simplify) {
  std::vector<double> times, cpu;
  Surface net;
  for (int r = 0; r < 5; ++r) {
    const auto t0 = std::chrono::steady_clock::now();
    const double c0 = thread_cpu_seconds();
    net = simplify(fine, nodes);
    cpu.push_back(thread_cpu_seconds() - c0);
    times.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
  report(name, fine, nodes, times, cpu, net);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: compare_net_simplifiers NODES MESH.obj...\n");
    return 2;
  }
  const int nodes = std::atoi(argv[1]);
  for (int i = 2; i < argc; ++i) {
    const Surface fine = read_obj(argv[i]);
    measure("CGAL", fine, nodes, [](const Surface& f, int n) { return simplify_cgal(f, n, false); });
    measure("CGAL-GH", fine, nodes, [](const Surface& f, int n) { return simplify_cgal(f, n, true); });
    measure("meshopt", fine, nodes, simplify_meshopt);
  }
}
