// Tests of core/mesh: built-in shapes (counts, closedness, Euler characteristic,
// outward winding, areas and volumes against closed form), validate_mesh's
// errors, net topology (edges, bending pairs), lumped areas, mean incident edge
// lengths and transform_mesh.
#include "numen/core/mesh.hpp"
#include "net_states.hpp"
#include "test_constants.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <numeric>
#include <set>
#include <string>
#include <vector>

namespace {

using numen::core::build_mesh_topology;
using numen::core::make_box;
using numen::core::make_capsule;
using numen::core::make_icosphere;
using numen::core::mean_incident_edge_length;
using numen::core::MeshTopology;
using numen::core::Pose;
using numen::core::Quat;
using numen::core::transform_mesh;
using numen::core::TriangleMesh;
using numen::core::validate_mesh;
using numen::core::Vec3;
using numen::core::vertex_areas;

using numen::test::kPi;
using numen::test::at;

double area(const TriangleMesh& m) {
  double a = 0.0;
  for (const auto& t : m.triangles) {
    a += 0.5 * (m.vertices[at(t[1])] - m.vertices[at(t[0])])
                   .cross(m.vertices[at(t[2])] - m.vertices[at(t[0])])
                   .norm();
  }
  return a;
}

/// Signed volume (divergence theorem); > 0 for a closed mesh wound outward.
double signed_volume(const TriangleMesh& m) {
  double v = 0.0;
  for (const auto& t : m.triangles) {
    v += m.vertices[at(t[0])].dot(m.vertices[at(t[1])].cross(m.vertices[at(t[2])])) / 6.0;
  }
  return v;
}

Vec3 centre(const TriangleMesh& m) {
  Vec3 c = Vec3::Zero();
  for (const Vec3& v : m.vertices) c += v;
  return c / m.num_vertices();
}

/// Every triangle's normal points away from the centre of a convex mesh.
void expect_outward(const TriangleMesh& m) {
  const Vec3 c = centre(m);
  for (int i = 0; i < m.num_triangles(); ++i) {
    const auto& t = m.triangles[at(i)];
    const Vec3& a = m.vertices[at(t[0])];
    const Vec3& b = m.vertices[at(t[1])];
    const Vec3& d = m.vertices[at(t[2])];
    const Vec3 n = (b - a).cross(d - a);
    const Vec3 g = (a + b + d) / 3.0;
    ASSERT_GT(n.dot(g - c), 0.0) << "triangle " << i;
  }
  EXPECT_GT(signed_volume(m), 0.0);
}

/// Valid, closed (every edge in exactly 2 triangles, each direction once),
/// Euler characteristic 2.
void expect_closed_sphere_like(const TriangleMesh& m) {
  ASSERT_EQ(validate_mesh(m), "");
  const MeshTopology topo = build_mesh_topology(m);
  EXPECT_EQ(topo.boundary_edges, 0);
  std::map<std::pair<int, int>, int> directed;
  std::map<std::pair<int, int>, int> undirected;
  for (const auto& t : m.triangles) {
    for (int k = 0; k < 3; ++k) {
      const int a = t[at(k)];
      const int b = t[at((k + 1) % 3)];
      ++directed[{a, b}];
      ++undirected[{std::min(a, b), std::max(a, b)}];
    }
  }
  for (const auto& [e, n] : undirected) EXPECT_EQ(n, 2) << e.first << "-" << e.second;
  for (const auto& [e, n] : directed) {
    EXPECT_EQ(n, 1) << "directed edge " << e.first << "->" << e.second << " (consistent winding)";
    EXPECT_EQ(directed.count({e.second, e.first}), 1u);
  }
  EXPECT_EQ(topo.edges.size(), undirected.size());
  const int chi = m.num_vertices() - static_cast<int>(topo.edges.size()) + m.num_triangles();
  EXPECT_EQ(chi, 2);
  EXPECT_EQ(2 * static_cast<int>(topo.edges.size()), 3 * m.num_triangles());
}

/// No two vertices at the same place (shared, not duplicated).
void expect_no_duplicate_vertices(const TriangleMesh& m, double tol) {
  for (int i = 0; i < m.num_vertices(); ++i) {
    for (int j = i + 1; j < m.num_vertices(); ++j) {
      ASSERT_GT((m.vertices[at(i)] - m.vertices[at(j)]).norm(), tol) << i << " " << j;
    }
  }
}

// --- icosphere ---------------------------------------------------------------

TEST(MeshIcosphere, VertexAndTriangleCounts) {
  const int expected[] = {12, 42, 162, 642, 2562};
  for (int s = 0; s <= 4; ++s) {
    const TriangleMesh m = make_icosphere(1.0, s);
    EXPECT_EQ(m.num_vertices(), expected[s]) << "s = " << s;
    EXPECT_EQ(m.num_triangles(), 20 << (2 * s)) << "s = " << s;
  }
  EXPECT_EQ(make_icosphere(1.0, 6).num_vertices(), 10 * 4096 + 2);
}

TEST(MeshIcosphere, ClosedOutwardOnTheSphere) {
  for (int s = 0; s <= 4; ++s) {
    SCOPED_TRACE("s = " + std::to_string(s));
    const double r = 0.03;
    const TriangleMesh m = make_icosphere(r, s);
    expect_closed_sphere_like(m);
    expect_outward(m);
    for (const Vec3& v : m.vertices) EXPECT_NEAR(v.norm(), r, 1e-15);
    if (s <= 2) expect_no_duplicate_vertices(m, 1e-6 * r);
  }
}

TEST(MeshIcosphere, AreaAndVolumeConvergeToTheSphere) {
  const double r = 0.05;
  const double sphere_area = 4.0 * kPi * r * r;
  const double sphere_volume = 4.0 / 3.0 * kPi * r * r * r;
  double previous = std::numeric_limits<double>::infinity();
  for (int s = 0; s <= 5; ++s) {
    const TriangleMesh m = make_icosphere(r, s);
    const double rel = (sphere_area - area(m)) / sphere_area;
    // Inscribed: always below the sphere, the error shrinking about 4× per level.
    EXPECT_GT(rel, 0.0) << "s = " << s;
    EXPECT_LT(rel, 0.3 / std::pow(3.5, s)) << "s = " << s;
    EXPECT_LT(rel, previous) << "s = " << s;
    previous = rel;
    const double rel_v = (sphere_volume - signed_volume(m)) / sphere_volume;
    EXPECT_GT(rel_v, 0.0);
    EXPECT_LT(rel_v, 0.5 / std::pow(3.5, s)) << "s = " << s;
  }
  // Regular icosahedron of circumradius r: area 5√3 a², a = r / sin(2π/5).
  const double a = r / std::sin(2.0 * kPi / 5.0);
  EXPECT_NEAR(area(make_icosphere(r, 0)), 5.0 * std::sqrt(3.0) * a * a, 1e-15);
}

TEST(MeshIcosphere, Deterministic) {
  const TriangleMesh a = make_icosphere(1.0, 3);
  const TriangleMesh b = make_icosphere(1.0, 3);
  EXPECT_EQ(a.triangles, b.triangles);
  ASSERT_EQ(a.vertices.size(), b.vertices.size());
  for (std::size_t i = 0; i < a.vertices.size(); ++i) EXPECT_EQ(a.vertices[i], b.vertices[i]);
}

TEST(MeshIcosphere, InvalidArgumentsGiveAnEmptyMesh) {
  EXPECT_EQ(make_icosphere(0.0, 1).num_triangles(), 0);
  EXPECT_EQ(make_icosphere(-1.0, 1).num_triangles(), 0);
  EXPECT_EQ(make_icosphere(1.0, -1).num_triangles(), 0);
  EXPECT_EQ(make_icosphere(1.0, 7).num_triangles(), 0);
  EXPECT_NE(validate_mesh(make_icosphere(1.0, 7)), "");
}

// --- capsule -----------------------------------------------------------------

TEST(MeshCapsule, CountsClosedOutward) {
  struct Case {
    double half_length;
    int segments, rings, cylinder_rings;
  };
  for (const Case c : {Case{0.02, 3, 1, 0}, Case{0.02, 8, 3, 0}, Case{0.02, 12, 4, 5},
                       Case{0.0, 8, 3, 2}, Case{0.0, 3, 1, 0}}) {
    SCOPED_TRACE(testing::Message() << "h " << c.half_length << " seg " << c.segments << " rings "
                                    << c.rings << " cyl " << c.cylinder_rings);
    const TriangleMesh m = make_capsule(0.01, c.half_length, c.segments, c.rings, c.cylinder_rings);
    const int rings_total = c.half_length > 0.0 ? 2 * c.rings + c.cylinder_rings : 2 * c.rings - 1;
    EXPECT_EQ(m.num_vertices(), 2 + c.segments * rings_total);
    EXPECT_EQ(m.num_triangles(), 2 * c.segments * rings_total);
    expect_closed_sphere_like(m);
    expect_outward(m);
    expect_no_duplicate_vertices(m, 1e-9);
  }
}

TEST(MeshCapsule, VerticesOnTheSurface) {
  const double r = 0.01, h = 0.03;
  const TriangleMesh m = make_capsule(r, h, 16, 5, 3);
  for (const Vec3& v : m.vertices) {
    const double zc = std::clamp(v.z(), -h, h);  // nearest point on the axis segment
    EXPECT_NEAR((v - Vec3(0, 0, zc)).norm(), r, 1e-15);
  }
  EXPECT_EQ(m.vertices.front(), Vec3(0, 0, h + r));
  EXPECT_EQ(m.vertices.back(), Vec3(0, 0, -h - r));
}

TEST(MeshCapsule, AreaAndVolumeAgainstClosedForm) {
  const double r = 0.01, h = 0.04;
  const double exact_area = 4.0 * kPi * r * r + 4.0 * kPi * r * h;
  const double exact_volume = 4.0 / 3.0 * kPi * r * r * r + 2.0 * kPi * r * r * h;
  const TriangleMesh coarse = make_capsule(r, h, 16, 4, 2);
  const TriangleMesh fine = make_capsule(r, h, 64, 16, 2);
  const double coarse_err = (exact_area - area(coarse)) / exact_area;
  const double fine_err = (exact_area - area(fine)) / exact_area;
  EXPECT_GT(fine_err, 0.0);
  EXPECT_LT(fine_err, 0.003);
  EXPECT_LT(fine_err, coarse_err / 8.0);  // O(1/n²): 4× finer, ≥ 8× better
  const double fine_verr = (exact_volume - signed_volume(fine)) / exact_volume;
  EXPECT_GT(fine_verr, 0.0);
  EXPECT_LT(fine_verr, 0.004);
  // The cylinder part alone is exact up to the polygon: n sin(2π/n)/(2π) of 2πr·2h...
  const TriangleMesh sphere = make_capsule(r, 0.0, 64, 16, 0);
  const TriangleMesh capsule = make_capsule(r, h, 64, 16, 0);
  const double n = 64.0;
  const double cylinder = n * 2.0 * r * std::sin(kPi / n) * 2.0 * h;  // side quads, flat
  EXPECT_NEAR(area(capsule) - area(sphere), cylinder, 1e-15);
}

TEST(MeshCapsule, InvalidArgumentsGiveAnEmptyMesh) {
  EXPECT_EQ(make_capsule(0.0, 0.1, 8, 2, 0).num_triangles(), 0);
  EXPECT_EQ(make_capsule(0.1, -0.1, 8, 2, 0).num_triangles(), 0);
  EXPECT_EQ(make_capsule(0.1, 0.1, 2, 2, 0).num_triangles(), 0);
  EXPECT_EQ(make_capsule(0.1, 0.1, 8, 0, 0).num_triangles(), 0);
  EXPECT_EQ(make_capsule(0.1, 0.1, 8, 2, -1).num_triangles(), 0);
}

// --- box ---------------------------------------------------------------------

TEST(MeshBox, CountsClosedOutward) {
  for (int s = 0; s <= 3; ++s) {
    SCOPED_TRACE("s = " + std::to_string(s));
    const TriangleMesh m = make_box(Vec3(0.01, 0.02, 0.03), s);
    const int k = s + 2;  // grid points per face side
    EXPECT_EQ(m.num_vertices(), 6 * k * k - 12 * k + 8);
    EXPECT_EQ(m.num_triangles(), 12 * (s + 1) * (s + 1));
    expect_closed_sphere_like(m);
    expect_outward(m);
    expect_no_duplicate_vertices(m, 1e-9);
  }
}

TEST(MeshBox, AreaAndVolumeExact) {
  const Vec3 h(0.01, 0.02, 0.03);
  for (int s = 0; s <= 3; ++s) {
    const TriangleMesh m = make_box(h, s);
    const double exact_area = 8.0 * (h.x() * h.y() + h.y() * h.z() + h.z() * h.x());
    EXPECT_NEAR(area(m), exact_area, 1e-15);
    EXPECT_NEAR(signed_volume(m), 8.0 * h.prod(), 1e-17);
    for (const Vec3& v : m.vertices) {
      EXPECT_NEAR((v.cwiseAbs() - h).cwiseAbs().minCoeff(), 0.0, 1e-17);  // on a face
      EXPECT_TRUE((v.cwiseAbs().array() <= h.array() + 1e-17).all());
    }
  }
}

TEST(MeshBox, SubdividedPerAxisIsClosedOutwardWithTheGridsOnItsFaces) {
  const Vec3 h(0.012, 0.010, 0.004);
  for (const std::array<int, 3> n : {std::array<int, 3>{23, 23, 2}, std::array<int, 3>{0, 3, 1},
                                     std::array<int, 3>{4, 0, 0}}) {
    SCOPED_TRACE(std::to_string(n[0]) + ", " + std::to_string(n[1]) + ", " + std::to_string(n[2]));
    const TriangleMesh m = make_box(h, n);
    EXPECT_EQ(m.num_vertices(), (n[0] + 2) * (n[1] + 2) * (n[2] + 2) - n[0] * n[1] * n[2]);
    EXPECT_EQ(m.num_triangles(), 4 * ((n[0] + 1) * (n[1] + 1) + (n[1] + 1) * (n[2] + 1) +
                                      (n[2] + 1) * (n[0] + 1)));
    expect_closed_sphere_like(m);
    expect_outward(m);
    expect_no_duplicate_vertices(m, 1e-9);
    EXPECT_NEAR(area(m), 8.0 * (h.x() * h.y() + h.y() * h.z() + h.z() * h.x()), 1e-15);
    EXPECT_NEAR(signed_volume(m), 8.0 * h.prod(), 1e-17);
    // Each axis's vertices lie on its own grid: 2 h_d / (n_d + 1) apart.
    for (const Vec3& v : m.vertices)
      for (int d = 0; d < 3; ++d) {
        const double cells = (v[d] + h[d]) / (2.0 * h[d] / (n[static_cast<std::size_t>(d)] + 1));
        EXPECT_NEAR(cells, std::round(cells), 1e-9) << "axis " << d;
      }
  }
  // One count for all three axes is the uniform box, vertex for vertex.
  const TriangleMesh uniform = make_box(h, 3), same = make_box(h, std::array<int, 3>{3, 3, 3});
  ASSERT_EQ(uniform.num_vertices(), same.num_vertices());
  for (int i = 0; i < uniform.num_vertices(); ++i)
    EXPECT_EQ(uniform.vertices[static_cast<std::size_t>(i)], same.vertices[static_cast<std::size_t>(i)]);
  EXPECT_EQ(uniform.triangles, same.triangles);
}

TEST(MeshBox, InvalidArgumentsGiveAnEmptyMesh) {
  EXPECT_EQ(make_box(Vec3(0.1, 0.0, 0.1), 0).num_triangles(), 0);
  EXPECT_EQ(make_box(Vec3(0.1, 0.1, 0.1), -1).num_triangles(), 0);
  EXPECT_EQ(make_box(Vec3(0.1, 0.1, 0.1), std::array<int, 3>{2, -1, 2}).num_triangles(), 0);
}

// --- validate_mesh -----------------------------------------------------------

/// A unit tetrahedron wound outward.
TriangleMesh tetrahedron() {
  TriangleMesh m;
  m.vertices = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)};
  m.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  return m;
}

TEST(MeshValidate, AcceptsValidMeshes) {
  EXPECT_EQ(validate_mesh(tetrahedron()), "");
  TriangleMesh open;  // a single triangle: open meshes are allowed
  open.vertices = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)};
  open.triangles = {{0, 1, 2}};
  EXPECT_EQ(validate_mesh(open), "");
  EXPECT_EQ(build_mesh_topology(open).boundary_edges, 3);
}

TEST(MeshValidate, NoTriangle) {
  TriangleMesh m;
  EXPECT_NE(validate_mesh(m).find("no triangle"), std::string::npos);
  m.vertices = {Vec3(0, 0, 0)};
  EXPECT_NE(validate_mesh(m).find("no triangle"), std::string::npos);
}

TEST(MeshValidate, IndexOutOfRange) {
  TriangleMesh m = tetrahedron();
  m.triangles[2][1] = 4;
  const std::string e = validate_mesh(m);
  EXPECT_NE(e.find("triangle 2"), std::string::npos) << e;
  EXPECT_NE(e.find("4"), std::string::npos) << e;
  m.triangles[2][1] = -1;
  EXPECT_NE(validate_mesh(m).find("triangle 2"), std::string::npos);
}

TEST(MeshValidate, NonFiniteVertex) {
  TriangleMesh m = tetrahedron();
  m.vertices[3].y() = std::numeric_limits<double>::quiet_NaN();
  std::string e = validate_mesh(m);
  EXPECT_NE(e.find("vertex 3"), std::string::npos) << e;
  m.vertices[3].y() = std::numeric_limits<double>::infinity();
  e = validate_mesh(m);
  EXPECT_NE(e.find("vertex 3"), std::string::npos) << e;
}

TEST(MeshValidate, RepeatedIndex) {
  TriangleMesh m = tetrahedron();
  m.triangles[1] = {0, 3, 3};
  const std::string e = validate_mesh(m);
  EXPECT_NE(e.find("triangle 1"), std::string::npos) << e;
  EXPECT_NE(e.find("repeat"), std::string::npos) << e;
}

TEST(MeshValidate, DegenerateArea) {
  TriangleMesh m = tetrahedron();
  m.vertices.push_back(Vec3(2, 0, 0));  // collinear with 0 and 1
  m.triangles.push_back({0, 1, 4});
  std::string e = validate_mesh(m);
  EXPECT_NE(e.find("triangle 4"), std::string::npos) << e;
  EXPECT_NE(e.find("degenerate"), std::string::npos) << e;
  // Relative to the mesh's size: nearly collinear (area 1e-14 m² in a 1 m mesh).
  m.vertices[4] = Vec3(2, 2e-14, 0);
  e = validate_mesh(m);
  EXPECT_NE(e.find("triangle 4"), std::string::npos) << e;
  // A well-shaped but tiny mesh is fine.
  TriangleMesh tiny = tetrahedron();
  for (Vec3& v : tiny.vertices) v *= 1e-6;
  EXPECT_EQ(validate_mesh(tiny), "");
}

TEST(MeshValidate, EdgeSharedByThreeTriangles) {
  TriangleMesh m;
  m.vertices = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, -1, 0), Vec3(0, 0, 1)};
  m.triangles = {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}};
  const std::string e = validate_mesh(m);
  EXPECT_NE(e.find("edge (0, 1)"), std::string::npos) << e;
  EXPECT_NE(e.find("3 triangles"), std::string::npos) << e;
}

TEST(MeshValidate, UnusedVertex) {
  TriangleMesh m = tetrahedron();
  m.vertices.insert(m.vertices.begin() + 2, Vec3(5, 5, 5));
  for (auto& t : m.triangles) {
    for (int& k : t) k += (k >= 2) ? 1 : 0;
  }
  const std::string e = validate_mesh(m);
  EXPECT_NE(e.find("vertex 2"), std::string::npos) << e;
  EXPECT_NE(e.find("not used"), std::string::npos) << e;
}

// --- topology ----------------------------------------------------------------

TEST(MeshTopology, EdgesSortedUnique) {
  const TriangleMesh m = make_icosphere(1.0, 2);
  const MeshTopology topo = build_mesh_topology(m);
  ASSERT_EQ(topo.edges.size(), 480u);
  for (std::size_t i = 0; i < topo.edges.size(); ++i) {
    EXPECT_LT(topo.edges[i].first, topo.edges[i].second);
    if (i > 0) {
      EXPECT_LT(topo.edges[i - 1], topo.edges[i]);
    }
  }
}

/// Bending pairs: (min, max), unique, never an edge, opposite to an edge.
void expect_bending_pairs_sane(const TriangleMesh& m, const MeshTopology& topo) {
  const std::set<std::pair<int, int>> edges(topo.edges.begin(), topo.edges.end());
  std::set<std::pair<int, int>> seen;
  for (const auto& p : topo.bending_pairs) {
    EXPECT_LT(p.first, p.second);
    EXPECT_EQ(edges.count(p), 0u);
    EXPECT_TRUE(seen.insert(p).second) << "repeated pair";
  }
  EXPECT_LE(topo.bending_pairs.size(), topo.edges.size());
  // Each pair is opposite to an edge shared by two triangles (a, b, p) and (b, a, q).
  std::set<std::pair<int, int>> opposite;
  std::map<std::pair<int, int>, std::vector<int>> by_edge;
  for (const auto& t : m.triangles) {
    for (int k = 0; k < 3; ++k) {
      const int a = t[at(k)];
      const int b = t[at((k + 1) % 3)];
      by_edge[{std::min(a, b), std::max(a, b)}].push_back(t[at((k + 2) % 3)]);
    }
  }
  for (const auto& [e, o] : by_edge) {
    if (o.size() == 2) opposite.insert({std::min(o[0], o[1]), std::max(o[0], o[1])});
  }
  for (const auto& p : topo.bending_pairs) EXPECT_EQ(opposite.count(p), 1u);
}

TEST(MeshTopology, BendingPairsOfClosedMeshes) {
  // Icosphere: no two triangles' opposite vertices are adjacent or repeat, so
  // one bending pair per edge.
  for (int s = 0; s <= 3; ++s) {
    const TriangleMesh m = make_icosphere(1.0, s);
    const MeshTopology topo = build_mesh_topology(m);
    EXPECT_EQ(topo.bending_pairs.size(), topo.edges.size()) << "s = " << s;
    expect_bending_pairs_sane(m, topo);
  }
  // Tetrahedron: every opposite pair is an edge → no bending pair.
  const MeshTopology tet = build_mesh_topology(tetrahedron());
  EXPECT_EQ(tet.edges.size(), 6u);
  EXPECT_EQ(tet.bending_pairs.size(), 0u);
  // Octahedron: 12 edges, whose opposite pairs are the 3 antipodal pairs, each
  // reached from 4 edges → 3 bending pairs, duplicates skipped.
  TriangleMesh oct;
  oct.vertices = {Vec3(1, 0, 0),  Vec3(-1, 0, 0), Vec3(0, 1, 0),
                  Vec3(0, -1, 0), Vec3(0, 0, 1),  Vec3(0, 0, -1)};
  oct.triangles = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4},
                   {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  expect_closed_sphere_like(oct);
  expect_outward(oct);
  const MeshTopology ot = build_mesh_topology(oct);
  EXPECT_EQ(ot.edges.size(), 12u);
  // In the order of the edges: edge (0, 2) → (4, 5), (0, 3) → (4, 5) skipped, (0, 4) → (2, 3)...
  ASSERT_EQ(ot.bending_pairs.size(), 3u);
  EXPECT_EQ(ot.bending_pairs[0], (std::pair<int, int>(4, 5)));
  EXPECT_EQ(ot.bending_pairs[1], (std::pair<int, int>(2, 3)));
  EXPECT_EQ(ot.bending_pairs[2], (std::pair<int, int>(0, 1)));
  // Capsule: one per edge as well.
  const TriangleMesh capsule = make_capsule(1.0, 1.0, 8, 3, 1);
  const MeshTopology ct = build_mesh_topology(capsule);
  EXPECT_EQ(ct.bending_pairs.size(), ct.edges.size());
  expect_bending_pairs_sane(capsule, ct);
  // Cube (12 triangles, 18 edges): across each face diagonal, the face's other
  // diagonal (6); across the 12 cube edges, pairs that are face diagonals
  // (edges, skipped), repeat a face's other diagonal, or one body diagonal.
  const TriangleMesh cube = make_box(Vec3(1, 2, 3), 0);
  const MeshTopology cubet = build_mesh_topology(cube);
  EXPECT_EQ(cubet.edges.size(), 18u);
  EXPECT_EQ(cubet.bending_pairs.size(), 7u);
  expect_bending_pairs_sane(cube, cubet);
  int body_diagonals = 0;
  for (const auto& [a, b] : cubet.bending_pairs) {
    const Vec3 d = (cube.vertices[at(a)] - cube.vertices[at(b)]).cwiseAbs();
    body_diagonals += (d.array() > 0.0).all() ? 1 : 0;
  }
  EXPECT_EQ(body_diagonals, 1);
  const TriangleMesh box = make_box(Vec3(1, 2, 3), 2);
  expect_bending_pairs_sane(box, build_mesh_topology(box));
}

TEST(MeshTopology, OpenStripHasBoundaryAndOneBendingPair) {
  TriangleMesh m;  // a unit square as two triangles
  m.vertices = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0)};
  m.triangles = {{0, 1, 2}, {0, 2, 3}};
  ASSERT_EQ(validate_mesh(m), "");
  const MeshTopology topo = build_mesh_topology(m);
  EXPECT_EQ(topo.edges.size(), 5u);
  EXPECT_EQ(topo.boundary_edges, 4);
  ASSERT_EQ(topo.bending_pairs.size(), 1u);
  EXPECT_EQ(topo.bending_pairs[0], (std::pair<int, int>(1, 3)));
}

// --- areas and edge lengths --------------------------------------------------

TEST(MeshVertexAreas, SumToTheMeshAreaAndAreUniformOnTheBox) {
  const TriangleMesh sphere = make_icosphere(0.02, 3);
  const std::vector<double> a = vertex_areas(sphere);
  ASSERT_EQ(a.size(), sphere.vertices.size());
  EXPECT_NEAR(std::accumulate(a.begin(), a.end(), 0.0), area(sphere), 1e-16);
  for (double x : a) EXPECT_GT(x, 0.0);

  TriangleMesh square;  // two right triangles of area 1/2
  square.vertices = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0)};
  square.triangles = {{0, 1, 2}, {0, 2, 3}};
  const std::vector<double> s = vertex_areas(square);
  EXPECT_NEAR(s[0], 1.0 / 3.0, 1e-15);
  EXPECT_NEAR(s[1], 1.0 / 6.0, 1e-15);
  EXPECT_NEAR(s[2], 1.0 / 3.0, 1e-15);
  EXPECT_NEAR(s[3], 1.0 / 6.0, 1e-15);
}

TEST(MeshMeanIncidentEdgeLength, OnTheCubeAndTheSquare) {
  TriangleMesh square;
  square.vertices = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0)};
  square.triangles = {{0, 1, 2}, {0, 2, 3}};
  const std::vector<double> l = mean_incident_edge_length(square, build_mesh_topology(square));
  ASSERT_EQ(l.size(), 4u);
  EXPECT_NEAR(l[0], (2.0 + std::sqrt(2.0)) / 3.0, 1e-15);  // two sides and the diagonal
  EXPECT_NEAR(l[1], 1.0, 1e-15);
  EXPECT_NEAR(l[2], (2.0 + std::sqrt(2.0)) / 3.0, 1e-15);
  EXPECT_NEAR(l[3], 1.0, 1e-15);

  const TriangleMesh sphere = make_icosphere(1.0, 0);
  const double edge = 1.0 / std::sin(2.0 * kPi / 5.0);
  for (double x : mean_incident_edge_length(sphere, build_mesh_topology(sphere))) {
    EXPECT_NEAR(x, edge, 1e-14);
  }
}

// --- transform_mesh ----------------------------------------------------------

TEST(MeshTransform, ScaleThenPose) {
  TriangleMesh m = make_box(Vec3(1, 1, 1), 1);
  const TriangleMesh original = m;
  Pose pose;
  pose.position = Vec3(0.1, -0.2, 0.3);
  pose.orientation = Quat(Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()));
  const Vec3 scale(0.01, 0.02, 0.03);
  transform_mesh(m, scale, pose);
  EXPECT_EQ(m.triangles, original.triangles);
  for (std::size_t i = 0; i < m.vertices.size(); ++i) {
    const Vec3 expected =
        pose.orientation * scale.cwiseProduct(original.vertices[i]) + pose.position;
    EXPECT_LT((m.vertices[i] - expected).norm(), 1e-15);
  }
  EXPECT_NEAR(signed_volume(m), 8.0 * scale.prod(), 1e-15);
  expect_outward(m);
}

TEST(MeshTransform, NegativeScaleKeepsOutwardWinding) {
  const Vec3 scales[] = {Vec3(-1, 1, 1), Vec3(1, -2, 1), Vec3(1, 1, -0.5), Vec3(-1, -1, -1),
                         Vec3(-1, -1, 1)};
  for (const Vec3& scale : scales) {
    SCOPED_TRACE(testing::Message() << "scale " << scale.transpose());
    for (TriangleMesh m : {make_icosphere(0.02, 2), make_capsule(0.01, 0.02, 10, 3, 1),
                           make_box(Vec3(0.01, 0.02, 0.03), 1)}) {
      const double volume = signed_volume(m);
      Pose pose;
      pose.position = Vec3(1, 2, 3);
      pose.orientation = Quat(Eigen::AngleAxisd(-1.1, Vec3(0, 1, 1).normalized()));
      transform_mesh(m, scale, pose);
      expect_closed_sphere_like(m);
      expect_outward(m);
      EXPECT_NEAR(signed_volume(m), volume * std::abs(scale.prod()), 1e-12);
    }
  }
}

}  // namespace
