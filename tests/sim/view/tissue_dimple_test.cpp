// Tests of sim/src/view/tissue_dimple: the tools' dimples on an organ given by its material as
// the OpenIGTLink surfaces draw them (docs/openigtlink.md, "The organs"); the page's copy has
// its own tests (tissue_dimple_test.mjs) on the same cases.
#include "view/tissue_dimple.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "alloc_counter.hpp"

namespace {

using numen::core::Vec3;
using numen::sim::DimpleSphere;

/// A flat square grid of (2n + 1)² vertices `h` apart in z = 0 and their normals +z.
struct Grid {
  std::vector<Vec3> points, normals;
  std::vector<double> moves;
};
Grid flat_grid(int n, double h) {
  Grid g;
  for (int j = -n; j <= n; ++j)
    for (int i = -n; i <= n; ++i) {
      g.points.emplace_back(i * h, j * h, 0.0);
      g.normals.push_back(Vec3::UnitZ());
    }
  g.moves.resize(g.points.size());
  return g;
}

}  // namespace

TEST(TissueDimple, HertzsSurfaceIsTheDepthUnderTheCentreHalfAtTheRimAndFallsAsOneOverRho) {
  const double r = 0.0025, depth = 0.001, a = std::sqrt(r * depth);
  EXPECT_DOUBLE_EQ(numen::sim::hertz_surface_displacement(0.0, r, depth), depth);
  EXPECT_NEAR(numen::sim::hertz_surface_displacement(a, r, depth), depth / 2, 1e-15);
  EXPECT_NEAR(numen::sim::hertz_surface_displacement(a * (1 + 1e-9), r, depth), depth / 2, 1e-12);
  const double far = 100 * a;  // (4 / 3π) δ a / ρ
  EXPECT_NEAR(numen::sim::hertz_surface_displacement(far, r, depth) / (4 / (3 * std::numbers::pi) * depth * a / far),
              1.0, 1e-3);
  double last = HUGE_VAL;
  for (double rho = 0; rho < 10 * a; rho += a / 50) {
    const double u = numen::sim::hertz_surface_displacement(rho, r, depth);
    EXPECT_LT(u, last) << rho;
    EXPECT_GT(u, 0.0) << rho;
    last = u;
  }
  EXPECT_EQ(numen::sim::hertz_surface_displacement(a, r, 0.0), 0.0);
}

TEST(TissueDimple, ASpherePressedIntoAFlatSurfaceDimplesItAndNoVertexIsLeftInside) {
  const double r = 0.0025, depth = 0.001;
  Grid g = flat_grid(60, 0.0002);
  const std::vector<Vec3> before = g.points;
  const std::vector<DimpleSphere> spheres{{Vec3(0, 0, r - depth), r}};
  std::uint64_t allocations = 0;
  double largest = 0.0;
  {
    numen::test::AllocationGuard guard;
    largest = numen::sim::press_tissue_dimples(g.points, g.normals, spheres, g.moves);
    allocations = guard.count();
  }
  EXPECT_EQ(allocations, 0u);
  EXPECT_NEAR(largest, depth, 1e-15);
  const double a = std::sqrt(r * depth), reach = numen::sim::kDimpleReachRadii * a;
  const double floor = numen::sim::hertz_surface_displacement(reach, r, depth);
  for (std::size_t k = 0; k < g.points.size(); ++k) {
    const Vec3& p = g.points[k];
    EXPECT_EQ(p.x(), before[k].x());  // along the normal only
    EXPECT_EQ(p.y(), before[k].y());
    EXPECT_GE((p - spheres[0].centre).norm(), r - 1e-15) << k;
    const double rho = std::hypot(p.x(), p.y());
    if (rho >= reach) {
      EXPECT_EQ(p.z(), 0.0) << rho;
    } else if (rho > 1.05 * a) {
      EXPECT_NEAR(-p.z(), numen::sim::hertz_surface_displacement(rho, r, depth) - floor, 1e-15) << rho;
    }
  }
}

TEST(TissueDimple, ASurfaceFacingAwayOrASphereOutOfReachIsLeftAlone) {
  const double r = 0.0025;
  Grid g = flat_grid(10, 0.0005);
  for (Vec3& n : g.normals) n = -Vec3::UnitZ();  // the underside
  const std::vector<Vec3> before = g.points;
  EXPECT_EQ(numen::sim::press_tissue_dimples(g.points, g.normals, std::vector<DimpleSphere>{{Vec3(0, 0, r + 1e-4), r}},
                                             g.moves),
            0.0);
  EXPECT_EQ(g.points, before);
  EXPECT_EQ(numen::sim::press_tissue_dimples(g.points, g.normals, {}, g.moves), 0.0);
  EXPECT_EQ(g.points, before);
}

TEST(TissueDimple, TwoSpheresSideBySideEachVertexTakesTheDeeperAndIsInsideNeither) {
  const double r = 0.0015, depth = 0.0006;
  Grid g = flat_grid(80, 0.0001);
  const std::vector<DimpleSphere> spheres{{Vec3(-0.001, 0, r - depth), r}, {Vec3(0.001, 0, r - depth), r}};
  numen::sim::press_tissue_dimples(g.points, g.normals, spheres, g.moves);
  for (const Vec3& p : g.points) {
    for (const DimpleSphere& s : spheres) EXPECT_GE((p - s.centre).norm(), r - 1e-15);
    EXPECT_LE(-p.z(), depth + 1e-15);
  }
}

TEST(TissueDimple, VertexNormalsAreTheirTrianglesAreaWeightedNormals) {
  const std::vector<Vec3> points{Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(5, 5, 5)};
  const std::vector<std::array<std::uint32_t, 3>> triangles{{0, 1, 2}};
  std::vector<Vec3> normals(points.size());
  numen::sim::vertex_normals(points, triangles, normals);
  for (int v = 0; v < 3; ++v) EXPECT_TRUE(normals[static_cast<std::size_t>(v)].isApprox(Vec3::UnitZ())) << v;
  EXPECT_EQ(normals[3], Vec3::Zero());  // a vertex of no triangle
}
