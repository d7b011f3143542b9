// Tests of core/mesh_shape_band: the narrow band answers every point within its width, with the
// brute-force distance over every triangle (a torus: curved both ways; an icosphere; a subdivided
// box: flat faces, flat edges and vertices, right-angle edges and corners), a band over the
// memory cap is not built and says why, and the band's query does not allocate.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <regex>
#include <string>

#include "alloc_counter.hpp"
#include "mesh/mesh_shape_query.hpp"
#include "numen/core/mesh.hpp"
#include "numen/core/mesh_shape.hpp"
#include "sanitizer.hpp"

namespace {

using numen::core::build_mesh_shape;
using numen::core::MeshDistance;
using numen::core::MeshShape;
using numen::core::MeshShapeOptions;
using numen::core::TriangleMesh;
using numen::core::Vec3;

MeshShape band_shape(const TriangleMesh& mesh, double band, double cell_factor = 1.0) {
  MeshShape s;
  MeshShapeOptions o;
  o.band = band;
  o.cell_factor = cell_factor;
  EXPECT_EQ(build_mesh_shape(mesh, s, o), "");
  return s;
}

/// `n` random points natively, a fifth of them under the sanitizers: each is compared with a
/// brute force over every triangle (the torus's 20 000 points timed out at 300 s under
/// ASan+UBSan), the band's code is the same for every point, and the tests' counts of answered
/// points scale with it.
int points(int n) { return numen::test::under_sanitizer() ? std::max(1, n / 5) : n; }

/// Random points in [lo, hi]: each within the band's width of the surface is answered by the band
/// (band_nearest() true) with the brute-force distance and point; the public query agrees; a point
/// the band answers is within its width. Returns how many points the band answered.
int expect_band_exact(const MeshShape& s, const Vec3& lo, const Vec3& hi, int n, unsigned seed) {
  std::mt19937 rng(seed);
  n = points(n);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  int answered = 0;
  for (int i = 0; i < n; ++i) {
    const Vec3 p = lo + Vec3(u(rng), u(rng), u(rng)).cwiseProduct(hi - lo);
    const MeshDistance ref = numen::core::mesh_signed_distance_brute(s, p);
    numen::core::detail::Nearest near;
    const bool in_band = numen::core::detail::band_nearest(s.band, s, p, near);
    if (std::abs(ref.distance) < s.band.width) {
      EXPECT_TRUE(in_band) << "point " << i << " at " << ref.distance << " m";
      if (!in_band) return answered;
    }
    if (!in_band) continue;
    ++answered;
    const MeshDistance got = numen::core::detail::signed_result(s, p, near);
    EXPECT_LE(std::abs(got.distance), s.band.width);
    EXPECT_NEAR(got.distance, ref.distance, 1e-12) << "point " << i;
    EXPECT_NEAR((got.point - ref.point).norm(), 0.0, 1e-12) << "point " << i;
    MeshDistance pub;
    EXPECT_TRUE(numen::core::mesh_signed_distance(s, p, std::numeric_limits<double>::infinity(), pub));
    EXPECT_NEAR(pub.distance, ref.distance, 1e-12);
  }
  return answered;
}

TEST(MeshShapeBand, TorusBandMatchesBruteForce) {
  const MeshShape s = band_shape(numen::core::make_torus(0.04, 0.015, 64, 32), 0.005);
  ASSERT_GT(s.band.width, 0.0) << s.band.note;
  EXPECT_EQ(s.band.note, "");
  // In the torus's box grown by the band: about half the points are within 5 mm.
  const int answered =
      expect_band_exact(s, Vec3(-0.06, -0.06, -0.021), Vec3(0.06, 0.06, 0.021), 20000, 1);
  EXPECT_GT(answered, points(4000));
}

TEST(MeshShapeBand, IcosphereBandWiderThanTheTrianglesMatchesBruteForce) {
  // 1280 triangles of about 7 mm on a 5 cm sphere, band 2 cm: far points, deep points.
  const MeshShape s = band_shape(numen::core::make_icosphere(0.05, 3), 0.02);
  ASSERT_GT(s.band.width, 0.0) << s.band.note;
  // The shell 3–7 cm around the centre is 39 % of the box.
  const int answered = expect_band_exact(s, Vec3::Constant(-0.075), Vec3::Constant(0.075), 10000, 2);
  EXPECT_GT(answered, points(3500));
}

TEST(MeshShapeBand, BoxWithFlatFacesEdgesAndCornersMatchesBruteForce) {
  // Coplanar triangles (flat edges and vertices), right-angle edges, corners of three faces;
  // coarse cells (3 mean edges) too.
  const TriangleMesh box = numen::core::make_box(Vec3(0.03, 0.02, 0.01), 4);
  for (const double factor : {1.0, 3.0}) {
    const MeshShape s = band_shape(box, 0.006, factor);
    ASSERT_GT(s.band.width, 0.0) << s.band.note;
    const int answered =
        expect_band_exact(s, Vec3(-0.04, -0.03, -0.02), Vec3(0.04, 0.03, 0.02), 10000, 3);
    EXPECT_GT(answered, points(3000));
    // On the surface and at a corner: exact points.
    expect_band_exact(s, Vec3(0.03, 0.02, 0.01), Vec3(0.03, 0.02, 0.01), 1, 4);
    expect_band_exact(s, Vec3(-0.03, -0.01, 0.0), Vec3(-0.03, 0.01, 0.0), 200, 5);
  }
}

TEST(MeshShapeBand, BandOverTheCapIsNotBuiltAndTheTreeAnswers) {
  MeshShape s;
  MeshShapeOptions o;
  o.max_band_bytes = 1000;
  ASSERT_EQ(build_mesh_shape(numen::core::make_torus(0.04, 0.015, 64, 32), s, o), "");
  EXPECT_EQ(s.band.width, 0.0);
  EXPECT_TRUE(s.band.triangles.empty());
  EXPECT_NE(s.band.note.find("over the cap of 0 MB"), std::string::npos) << s.band.note;
  EXPECT_NE(s.band.note.find("every query searches the tree"), std::string::npos);
  const Vec3 p(0.056, 0.0, 0.0);  // 1 mm outside the tube
  MeshDistance d;
  ASSERT_TRUE(numen::core::mesh_signed_distance(s, p, 0.005, d));
  EXPECT_NEAR(d.distance, numen::core::mesh_signed_distance_brute(s, p).distance, 1e-12);
}

// Defect 4 of the mesh reader: a 1 m mesh at scale 1e-30 estimated its 5 mm band at ~10^32 bytes,
// printed through a long long as "-9223372036854775808 MB". Beyond 10^9 MB it is printed with an
// exponent; below, in whole megabytes as before.
TEST(MeshShapeBand, EstimateOfAMeshFarSmallerThanItsBandIsPrintedNotWrapped) {
  TriangleMesh tiny = numen::core::make_icosphere(1.0, 1);
  for (Vec3& v : tiny.vertices) v *= 1e-30;
  MeshShape s;
  ASSERT_EQ(build_mesh_shape(tiny, s, MeshShapeOptions{}), "");
  EXPECT_EQ(s.band.width, 0.0);
  EXPECT_TRUE(std::regex_match(
      s.band.note,
      std::regex(
          R"(no narrow band \(it would take about [1-9]\.[0-9]{2}e\+[0-9]{2,3} MB, over the cap of 256 MB\): every query searches the tree)")))
      << s.band.note;
}

TEST(MeshShapeBand, NoBandWhenItsWidthIsZero) {
  const MeshShape s = band_shape(numen::core::make_icosphere(0.05, 2), 0.0);
  EXPECT_EQ(s.band.width, 0.0);
  EXPECT_EQ(s.band.note, "");
  EXPECT_EQ(numen::core::mesh_band_bytes(s.band), 0u);
}

TEST(MeshShapeBand, BandQueryDoesNotAllocate) {
  const MeshShape s = band_shape(numen::core::make_torus(0.04, 0.015, 64, 32), 0.005);
  std::mt19937 rng(6);
  std::uniform_real_distribution<double> u(-0.06, 0.06);
  std::vector<Vec3> points(1000);
  for (Vec3& p : points) p = Vec3(0.055 + u(rng) / 10.0, u(rng), u(rng) / 10.0);
  int hits = 0;
  numen::test::AllocationGuard guard;
  for (const Vec3& p : points) {
    MeshDistance d;
    hits += numen::core::mesh_signed_distance(s, p, 0.005, d) ? 1 : 0;
  }
  EXPECT_EQ(guard.count(), 0);
  EXPECT_GT(hits, 100);
}

}  // namespace
