// Tests of sim/scene/net_tetrahedralize (the volume of an organ given by its material): the
// tetrahedra of an icosphere, a box, a torus and the shipped organ fill the enclosed volume
// (within 3 %), use every node, are positively oriented, keep the surface's nodes first and
// unchanged, grow about 8× in interior nodes when the spacing halves and are the same on every
// call; how many surface triangles are tetrahedron faces (conformity) and the time taken are
// printed. An open, inconsistently wound or self-intersecting surface, a bad spacing and a
// lattice too fine are refused with a message naming the problem.
#include "scene/net_tetrahedralize.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <iostream>
#include <limits>
#include <string>
#include <vector>

#include "numen/core/mesh.hpp"
#include "numen/core/net_material.hpp"
#include "numen/sim/scene/mesh_file.hpp"

namespace {

namespace core = numen::core;
using core::TetrahedralMesh;
using core::TriangleMesh;
using core::Vec3;
using numen::sim::mean_edge_length;
using numen::sim::tetrahedralize_net;

/// Volume of tetrahedron `t` of `mesh`, signed: > 0 for a positively oriented one (m³).
double tet_signed_volume(const TetrahedralMesh& mesh, const std::array<int, 4>& t) {
  const Vec3& a = mesh.node(t[0]);
  return (mesh.node(t[1]) - a).dot((mesh.node(t[2]) - a).cross(mesh.node(t[3]) - a)) / 6.0;
}

double tet_total_volume(const TetrahedralMesh& mesh) {
  double v = 0.0;
  for (const auto& t : mesh.tetrahedra) v += tet_signed_volume(mesh, t);
  return v;
}

/// Surface triangles that are a face of some tetrahedron (as vertex sets).
int tet_conforming_triangles(const TetrahedralMesh& mesh) {
  std::vector<std::array<int, 3>> faces;
  faces.reserve(4 * mesh.tetrahedra.size());
  for (const auto& t : mesh.tetrahedra)
    for (int skip = 0; skip < 4; ++skip) {
      std::array<int, 3> f{};
      int k = 0;
      for (int a = 0; a < 4; ++a)
        if (a != skip) f[static_cast<std::size_t>(k++)] = t[static_cast<std::size_t>(a)];
      std::sort(f.begin(), f.end());
      faces.push_back(f);
    }
  std::sort(faces.begin(), faces.end());
  int n = 0;
  for (std::array<int, 3> f : mesh.surface.triangles) {
    std::sort(f.begin(), f.end());
    n += std::binary_search(faces.begin(), faces.end(), f) ? 1 : 0;
  }
  return n;
}

/// The invariants of core::TetrahedralMesh, and the surface kept as given; `spacing` (m) sets the
/// positive-volume floor.
void expect_valid_tetrahedra(const TriangleMesh& surface, const TetrahedralMesh& mesh,
                             double spacing) {
  ASSERT_FALSE(mesh.tetrahedra.empty());
  EXPECT_EQ(mesh.surface.vertices, surface.vertices);
  EXPECT_EQ(mesh.surface.triangles, surface.triangles);
  std::vector<int> uses(static_cast<std::size_t>(mesh.num_nodes()), 0);
  int bad_index = 0, repeated = 0, not_positive = 0;
  for (const auto& t : mesh.tetrahedra) {
    bool in_range = true;
    for (const int n : t) {
      if (n < 0 || n >= mesh.num_nodes()) {
        in_range = false;
        continue;
      }
      ++uses[static_cast<std::size_t>(n)];
    }
    if (!in_range) {
      ++bad_index;
      continue;
    }
    std::array<int, 4> s = t;
    std::sort(s.begin(), s.end());
    if (std::adjacent_find(s.begin(), s.end()) != s.end()) ++repeated;
    if (tet_signed_volume(mesh, t) <= 1e-9 * spacing * spacing * spacing) ++not_positive;
  }
  EXPECT_EQ(bad_index, 0);
  EXPECT_EQ(repeated, 0);
  EXPECT_EQ(not_positive, 0);
  EXPECT_EQ(std::count(uses.begin(), uses.end(), 0), 0) << "nodes in no tetrahedron";
  // Interior nodes strictly inside the surface's bounding box.
  Vec3 lo = surface.vertices.front(), hi = lo;
  for (const Vec3& v : surface.vertices) {
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  for (const Vec3& p : mesh.interior)
    EXPECT_TRUE((p.array() > lo.array()).all() && (p.array() < hi.array()).all()) << p.transpose();
}

/// Tetrahedralises `surface` at `spacing` (expecting success), checks it and prints its figures.
TetrahedralMesh tet_check(const TriangleMesh& surface, double spacing, const char* name) {
  TetrahedralMesh mesh;
  const auto start = std::chrono::steady_clock::now();
  const std::string err = tetrahedralize_net(surface, spacing, mesh);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_EQ(err, "");
  if (!err.empty()) return mesh;
  expect_valid_tetrahedra(surface, mesh, spacing);
  const double enclosed = numen::sim::signed_volume(surface);
  const double volume = tet_total_volume(mesh);
  EXPECT_NEAR(volume / enclosed, 1.0, 0.03) << name;
  const int conforming = tet_conforming_triangles(mesh);
  std::cout << name << ": " << surface.num_vertices() << " surface + " << mesh.interior.size()
            << " interior nodes (2 V / s^3 = " << 2.0 * enclosed / (spacing * spacing * spacing)
            << "), " << mesh.tetrahedra.size() << " tetrahedra, volume "
            << 100.0 * (volume / enclosed - 1.0) << " % off the enclosed, " << conforming << " of "
            << surface.num_triangles() << " surface triangles are tetrahedron faces, "
            << seconds * 1e3 << " ms\n";
  return mesh;
}

TEST(TetrahedralizeNet, IcosphereFillsItsVolume) {
  const TriangleMesh sphere = core::make_icosphere(0.02, 3);
  const double s = mean_edge_length(sphere);
  const TetrahedralMesh mesh = tet_check(sphere, s, "icosphere 20 mm, 3 subdivisions");
  // About the body-centred cubic lattice's 2 V / s³ interior nodes, less the shell within s/2 of
  // the surface.
  const double lattice = 2.0 * numen::sim::signed_volume(sphere) / (s * s * s);
  EXPECT_GT(static_cast<double>(mesh.interior.size()), 0.5 * lattice);
  EXPECT_LT(static_cast<double>(mesh.interior.size()), lattice);
  // A curved surface of irregular triangles: each of them a Delaunay face, so a tetrahedron's.
  EXPECT_EQ(tet_conforming_triangles(mesh), sphere.num_triangles());
}

TEST(TetrahedralizeNet, BoxFillsItsVolume) {
  const TriangleMesh box = core::make_box(Vec3(0.015, 0.01, 0.008), 4);
  // Its faces' quads have four cocircular corners: the Delaunay may split each along the other
  // diagonal than the surface's (no surface triangle is then a tetrahedron face), the volume the
  // same.
  tet_check(box, mean_edge_length(box), "box 30 x 20 x 16 mm, 4 subdivisions");
  // A spacing whose lattice meets the box's faces: points on the surface are dropped.
  tet_check(box, 0.002, "box 30 x 20 x 16 mm, 4 subdivisions, 2 mm lattice");
}

TEST(TetrahedralizeNet, TorusFillsItsVolume) {  // not convex: a hole, saddle-shaped inner rim
  const TriangleMesh torus = core::make_torus(0.02, 0.008, 48, 16);
  tet_check(torus, mean_edge_length(torus), "torus 20 / 8 mm, 48 x 16");
}

TEST(TetrahedralizeNet, InteriorNodesGrowEightfoldWhenTheSpacingHalves) {
  const TriangleMesh sphere = core::make_icosphere(0.02, 3);
  const double s = mean_edge_length(sphere);
  const TetrahedralMesh coarse = tet_check(sphere, s, "icosphere, mean edge");
  const TetrahedralMesh fine = tet_check(sphere, 0.5 * s, "icosphere, half the mean edge");
  ASSERT_FALSE(coarse.interior.empty());
  const double ratio =
      static_cast<double>(fine.interior.size()) / static_cast<double>(coarse.interior.size());
  // 8× the lattice, and a shell within s/2 of the surface left out that is half as thick.
  EXPECT_GT(ratio, 7.0);
  EXPECT_LT(ratio, 11.0);
}

TEST(TetrahedralizeNet, SpacingBeyondTheOrganLeavesTheSurfaceVerticesAlone) {
  const TriangleMesh sphere = core::make_icosphere(0.02, 2);
  const TetrahedralMesh mesh = tet_check(sphere, 1.0, "icosphere, 1 m lattice");
  EXPECT_TRUE(mesh.interior.empty());
}

TEST(TetrahedralizeNet, TwoCallsGiveTheSameMesh) {
  const TriangleMesh sphere = core::make_icosphere(0.02, 3);
  const double s = mean_edge_length(sphere);
  TetrahedralMesh a, b;
  ASSERT_EQ(tetrahedralize_net(sphere, s, a), "");
  ASSERT_EQ(tetrahedralize_net(sphere, s, b), "");
  EXPECT_EQ(a.interior, b.interior);
  EXPECT_EQ(a.tetrahedra, b.tetrahedra);
}

TEST(TetrahedralizeNet, ShippedOrganAtItsMeanEdge) {
  const TriangleMesh organ =
      numen::sim::load_mesh_file(std::string(NUMEN_SOURCE_DIR) + "/sim/data/organ_lobe.obj");
  const TetrahedralMesh mesh =
      tet_check(organ, mean_edge_length(organ), "sim/data/organ_lobe.obj, mean edge");
  EXPECT_EQ(tet_conforming_triangles(mesh), organ.num_triangles());
}

TEST(TetrahedralizeNet, TenThousandVertexSurface) {
  const TriangleMesh sphere = core::make_icosphere(0.02, 5);  // 10 242 vertices
  tet_check(sphere, mean_edge_length(sphere), "icosphere 20 mm, 5 subdivisions");
}

TEST(TetrahedralizeNet, OpenSurfaceIsRefused) {
  TriangleMesh sphere = core::make_icosphere(0.02, 2);
  const std::array<int, 3> removed = sphere.triangles.back();
  sphere.triangles.pop_back();
  TetrahedralMesh mesh;
  const std::string err = tetrahedralize_net(sphere, mean_edge_length(sphere), mesh);
  EXPECT_NE(err.find("not closed"), std::string::npos) << err;
  // The open edge named is one of the removed triangle's.
  bool named = false;
  for (int e = 0; e < 3; ++e) {
    const int a = removed[static_cast<std::size_t>(e)],
              b = removed[static_cast<std::size_t>((e + 1) % 3)];
    named = named || err.find("edge of vertices " + std::to_string(std::min(a, b)) + " and " +
                              std::to_string(std::max(a, b)) + " ") != std::string::npos;
  }
  EXPECT_TRUE(named) << err;
  EXPECT_TRUE(mesh.tetrahedra.empty() && mesh.interior.empty() && mesh.surface.vertices.empty());
}

TEST(TetrahedralizeNet, InconsistentWindingIsRefused) {
  TriangleMesh sphere = core::make_icosphere(0.02, 2);
  std::swap(sphere.triangles[7][1], sphere.triangles[7][2]);
  TetrahedralMesh mesh;
  const std::string err = tetrahedralize_net(sphere, mean_edge_length(sphere), mesh);
  EXPECT_NE(err.find("wound against a neighbour"), std::string::npos) << err;
}

TEST(TetrahedralizeNet, SelfIntersectingSurfaceIsRefused) {
  // Two overlapping spheres in one mesh: closed, every edge in two triangles, but crossing.
  TriangleMesh two = core::make_icosphere(0.02, 2);
  const TriangleMesh other = core::make_icosphere(0.015, 2);
  const int offset = two.num_vertices();
  for (const Vec3& v : other.vertices) two.vertices.push_back(v + Vec3(0.025, 0.0, 0.0));
  for (const auto& t : other.triangles)
    two.triangles.push_back({t[0] + offset, t[1] + offset, t[2] + offset});
  TetrahedralMesh mesh;
  const std::string err = tetrahedralize_net(two, mean_edge_length(two), mesh);
  EXPECT_NE(err.find("intersects itself: triangles "), std::string::npos) << err;
  EXPECT_TRUE(mesh.tetrahedra.empty());
}

TEST(TetrahedralizeNet, BadSpacingIsRefused) {
  const TriangleMesh sphere = core::make_icosphere(0.02, 2);
  for (const double s : {0.0, -0.001, std::numeric_limits<double>::quiet_NaN(),
                         std::numeric_limits<double>::infinity()}) {
    TetrahedralMesh mesh;
    const std::string err = tetrahedralize_net(sphere, s, mesh);
    EXPECT_NE(err.find("spacing"), std::string::npos) << s << ": " << err;
    EXPECT_NE(err.find("not a finite number > 0"), std::string::npos) << s << ": " << err;
  }
}

TEST(TetrahedralizeNet, LatticeTooFineIsRefusedWithASpacingThatFits) {
  const TriangleMesh sphere = core::make_icosphere(0.02, 2);
  TetrahedralMesh mesh;
  const std::string err = tetrahedralize_net(sphere, 1e-5, mesh);
  EXPECT_NE(err.find("more than 2000000"), std::string::npos) << err;
  const std::size_t at = err.find("a spacing of ");
  ASSERT_NE(at, std::string::npos) << err;
  // The spacing named fits: the sphere's 40 mm box takes 2 (40 / s)³ ≤ 2 M points at s ≥ 0.4 mm.
  const double fit_mm = std::stod(err.substr(at + 13));
  EXPECT_GE(fit_mm, 0.39);
  EXPECT_LE(fit_mm, 0.42);
}

TEST(TetrahedralizeNet, NoCellAboveTheVolumeFloorIsRefused) {
  // A corner tetrahedron of 1/6 m³ against a floor of 1e-9 s³ = 1 000 m³ at s = 10 km.
  TriangleMesh tet;
  tet.vertices = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)};
  tet.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  TetrahedralMesh mesh;
  const std::string err = tetrahedralize_net(tet, 1e4, mesh);
  EXPECT_NE(err.find("no tetrahedron lies inside the surface"), std::string::npos) << err;
  EXPECT_TRUE(mesh.tetrahedra.empty() && mesh.interior.empty() && mesh.surface.vertices.empty());
  EXPECT_EQ(tetrahedralize_net(tet, 0.5, mesh), "");  // at a spacing of its size: one tetrahedron
  EXPECT_EQ(mesh.tetrahedra.size(), 1u);
}

TEST(TetrahedralizeNet, MeanEdgeLengthCountsEachEdgeOnce) {
  // A corner tetrahedron: three edges of 1 m, three of √2 m.
  TriangleMesh tet;
  tet.vertices = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)};
  tet.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  EXPECT_NEAR(mean_edge_length(tet), (3.0 + 3.0 * std::sqrt(2.0)) / 6.0, 1e-15);
  EXPECT_EQ(mean_edge_length(TriangleMesh{}), 0.0);
}

}  // namespace
