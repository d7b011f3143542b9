// Narrow phase (core/src/contact/narrowphase.cpp): contact geometry of a sphere
// against sphere, plane, box and capsule on hand-computed cases, including the
// degenerate ones (coincident centres, centre inside a box, centre on a
// capsule's axis), which must give a finite unit normal.

#include <gtest/gtest.h>

#include <cmath>

#include "contact/narrowphase.hpp"

namespace numen::core {
namespace {

constexpr double kTol = 1e-12;

void expect_vec(const Vec3& actual, const Vec3& expected, double tol = kTol) {
  EXPECT_NEAR(actual.x(), expected.x(), tol)
      << "actual " << actual.transpose() << " expected " << expected.transpose();
  EXPECT_NEAR(actual.y(), expected.y(), tol)
      << "actual " << actual.transpose() << " expected " << expected.transpose();
  EXPECT_NEAR(actual.z(), expected.z(), tol)
      << "actual " << actual.transpose() << " expected " << expected.transpose();
}

void expect_unit(const Vec3& n) {
  ASSERT_TRUE(n.allFinite());
  EXPECT_NEAR(n.norm(), 1.0, 1e-14);
}

// ---- sphere / sphere -------------------------------------------------------

TEST(NarrowSphereSphere, OverlapAlongZ) {
  ContactGeometry g;
  ASSERT_TRUE(sphere_sphere(Vec3(0, 0, 1.5), 1.0, Vec3::Zero(), 1.0, Vec3::Zero(), g));
  EXPECT_NEAR(g.depth, 0.5, kTol);
  expect_vec(g.normal, Vec3::UnitZ());
  // Deepest point of a: z = 0.5; surface of b: z = 1; middle 0.75.
  expect_vec(g.position, Vec3(0, 0, 0.75));
}

TEST(NarrowSphereSphere, ObliqueUnequalRadii) {
  // a at (3, 4, 0) r 2, b at origin r 4: d = 5, depth 1, n = (0.6, 0.8, 0).
  ContactGeometry g;
  ASSERT_TRUE(sphere_sphere(Vec3(3, 4, 0), 2.0, Vec3::Zero(), 4.0, Vec3::Zero(), g));
  EXPECT_NEAR(g.depth, 1.0, kTol);
  expect_vec(g.normal, Vec3(0.6, 0.8, 0));
  // surface of b at 4 n = (2.4, 3.2, 0); deepest point of a at 3 n; middle 3.5 n.
  expect_vec(g.position, 3.5 * Vec3(0.6, 0.8, 0));
}

TEST(NarrowSphereSphere, SeparatedOrTouchingGivesNoContact) {
  ContactGeometry g;
  EXPECT_FALSE(
      sphere_sphere(Vec3(0, 0, 2.0), 1.0, Vec3::Zero(), 1.0, Vec3::Zero(), g));  // touching
  EXPECT_FALSE(sphere_sphere(Vec3(0, 3.0, 0), 1.0, Vec3::Zero(), 1.0, Vec3::Zero(), g));
  EXPECT_FALSE(spheres_overlap(Vec3(0, 0, 2.0), 1.0, Vec3::Zero(), 1.0));
  EXPECT_TRUE(spheres_overlap(Vec3(0, 0, 1.999), 1.0, Vec3::Zero(), 1.0));
}

TEST(NarrowSphereSphere, CoincidentCentresUseTheFallback) {
  ContactGeometry g;
  ASSERT_TRUE(sphere_sphere(Vec3(1, 2, 3), 0.5, Vec3(1, 2, 3), 0.25, Vec3(3, 0, 0), g));
  expect_unit(g.normal);
  expect_vec(g.normal, Vec3::UnitX());
  EXPECT_NEAR(g.depth, 0.75, kTol);
  // surface of b at c + 0.25 x, deepest point of a at c − 0.5 x: middle c − 0.125 x.
  expect_vec(g.position, Vec3(1 - 0.125, 2, 3));
}

TEST(NarrowSphereSphere, CoincidentCentresWithoutFallbackPushUp) {
  ContactGeometry g;
  ASSERT_TRUE(sphere_sphere(Vec3::Zero(), 1.0, Vec3::Zero(), 1.0, Vec3::Zero(), g));
  expect_unit(g.normal);
  expect_vec(g.normal, Vec3::UnitZ());
  EXPECT_NEAR(g.depth, 2.0, kTol);
  expect_vec(g.position, Vec3::Zero());
}

// ---- sphere / plane --------------------------------------------------------

TEST(NarrowSpherePlane, TiltedNormal) {
  const double th = 0.3;
  const Vec3 n(0.0, std::sin(th), std::cos(th));
  const Vec3 t(std::cos(0.7), -std::sin(0.7) * std::cos(th), std::sin(0.7) * std::sin(th));  // ⟂ n
  ASSERT_NEAR(t.dot(n), 0.0, 1e-15);
  const Vec3 p(1, 2, 3);
  const Vec3 c = p + 0.3 * n + 0.4 * t;
  ContactGeometry g;
  ASSERT_TRUE(sphere_plane(c, 0.5, p, n, g));
  EXPECT_NEAR(g.depth, 0.2, kTol);
  expect_vec(g.normal, n);
  // surface point p + 0.4 t, deepest point of the sphere p + 0.4 t − 0.2 n.
  expect_vec(g.position, p + 0.4 * t - 0.1 * n);
}

TEST(NarrowSpherePlane, CentreBelowTheSurfaceStillPushesAlongTheNormal) {
  ContactGeometry g;
  ASSERT_TRUE(sphere_plane(Vec3(5, 5, -2), 0.5, Vec3::Zero(), Vec3::UnitZ(), g));
  EXPECT_NEAR(g.depth, 2.5, kTol);
  expect_vec(g.normal, Vec3::UnitZ());
  expect_vec(g.position, Vec3(5, 5, -1.25));
}

TEST(NarrowSpherePlane, AboveOrTouchingGivesNoContact) {
  ContactGeometry g;
  EXPECT_FALSE(sphere_plane(Vec3(0, 0, 0.5), 0.5, Vec3::Zero(), Vec3::UnitZ(), g));
  EXPECT_FALSE(sphere_plane(Vec3(0, 0, 2.0), 0.5, Vec3::Zero(), Vec3::UnitZ(), g));
}

// ---- sphere / box -------------------------------------------------------------

TEST(NarrowSphereBox, FaceRegion) {
  ContactGeometry g;
  ASSERT_TRUE(
      sphere_box(Vec3(1.5, 0.5, 0.5), 1.0, Vec3::Zero(), Mat3::Identity(), Vec3(1, 2, 3), g));
  EXPECT_NEAR(g.depth, 0.5, kTol);
  expect_vec(g.normal, Vec3::UnitX());
  expect_vec(g.position, Vec3(0.75, 0.5, 0.5));
}

TEST(NarrowSphereBox, EdgeRegion) {
  ContactGeometry g;
  ASSERT_TRUE(
      sphere_box(Vec3(1.3, 2.4, 0.0), 1.0, Vec3::Zero(), Mat3::Identity(), Vec3(1, 2, 3), g));
  EXPECT_NEAR(g.depth, 0.5, kTol);
  expect_vec(g.normal, Vec3(0.6, 0.8, 0.0));
  expect_vec(g.position, Vec3(1, 2, 0) - 0.25 * Vec3(0.6, 0.8, 0.0));
}

TEST(NarrowSphereBox, CentreInsideIsPushedOutThroughTheNearestFace) {
  ContactGeometry g;
  ASSERT_TRUE(sphere_box(Vec3(0.8, 0, 0), 0.5, Vec3::Zero(), Mat3::Identity(), Vec3(1, 2, 3), g));
  expect_unit(g.normal);
  expect_vec(g.normal, Vec3::UnitX());
  EXPECT_NEAR(g.depth, 0.7, kTol);  // 0.2 to the face + radius
  // face point (1, 0, 0); deepest point 0.3; middle 0.65.
  expect_vec(g.position, Vec3(0.65, 0, 0));

  ASSERT_TRUE(
      sphere_box(Vec3(0.3, -1.9, 1.0), 0.5, Vec3::Zero(), Mat3::Identity(), Vec3(1, 2, 3), g));
  expect_vec(g.normal, -Vec3::UnitY());
  EXPECT_NEAR(g.depth, 0.6, kTol);
  expect_vec(g.position, Vec3(0.3, -2.0 + 0.3, 1.0));
}

TEST(NarrowSphereBox, CentreAtTheCentreOfACubeTiesToPlusX) {
  ContactGeometry g;
  ASSERT_TRUE(sphere_box(Vec3(2, 3, 4), 0.25, Vec3(2, 3, 4), Mat3::Identity(), Vec3(1, 1, 1), g));
  expect_unit(g.normal);
  expect_vec(g.normal, Vec3::UnitX());
  EXPECT_NEAR(g.depth, 1.25, kTol);
}

TEST(NarrowSphereBox, RotatedBox) {
  // Box axes rotated 90° about z: its local x is the world y.
  const Mat3 rot = Eigen::AngleAxisd(M_PI / 2, Vec3::UnitZ()).toRotationMatrix();
  const Vec3 centre(1, 1, 1);
  ContactGeometry g;
  // World y extent of the box is half_extents.x = 1; the sphere sits 1.5 above the centre in y.
  ASSERT_TRUE(sphere_box(centre + Vec3(0, 1.5, 0), 1.0, centre, rot, Vec3(1, 2, 3), g));
  EXPECT_NEAR(g.depth, 0.5, kTol);
  expect_vec(g.normal, Vec3::UnitY());
  expect_vec(g.position, centre + Vec3(0, 0.75, 0));
  // World x extent is half_extents.y = 2: at 2.5 in x with r = 1, depth 0.5 along +x.
  ASSERT_TRUE(sphere_box(centre + Vec3(2.5, 0, 0), 1.0, centre, rot, Vec3(1, 2, 3), g));
  EXPECT_NEAR(g.depth, 0.5, kTol);
  expect_vec(g.normal, Vec3::UnitX());
  // Inside, nearest face is world −x (local −y) at distance 0.1.
  ASSERT_TRUE(sphere_box(centre + Vec3(-1.9, 0, 0), 0.2, centre, rot, Vec3(1, 2, 3), g));
  expect_vec(g.normal, -Vec3::UnitX());
  EXPECT_NEAR(g.depth, 0.3, kTol);
}

TEST(NarrowSphereBox, OutsideGivesNoContact) {
  ContactGeometry g;
  EXPECT_FALSE(sphere_box(Vec3(2.0, 0, 0), 1.0, Vec3::Zero(), Mat3::Identity(), Vec3(1, 2, 3), g));
  EXPECT_FALSE(sphere_box(Vec3(1.8, 2.8, 0), 1.0, Vec3::Zero(), Mat3::Identity(), Vec3(1, 2, 3),
                          g));  // corner gap
}

// ---- sphere / capsule ------------------------------------------------------

TEST(NarrowSphereCapsule, SideOfTheSegment) {
  ContactGeometry g;
  ASSERT_TRUE(sphere_capsule(Vec3(0.8, 0, 0.3), 0.5, Vec3::Zero(), Vec3::UnitZ(), 1.0, 0.5, g));
  EXPECT_NEAR(g.depth, 0.2, kTol);
  expect_vec(g.normal, Vec3::UnitX());
  expect_vec(g.position, Vec3(0.4, 0, 0.3));
}

TEST(NarrowSphereCapsule, BeyondTheEndCap) {
  ContactGeometry g;
  ASSERT_TRUE(sphere_capsule(Vec3(0, 0, 1.7), 0.5, Vec3::Zero(), Vec3::UnitZ(), 1.0, 0.5, g));
  EXPECT_NEAR(g.depth, 0.3, kTol);
  expect_vec(g.normal, Vec3::UnitZ());
  expect_vec(g.position, Vec3(0, 0, 1.35));
  ASSERT_TRUE(sphere_capsule(Vec3(0, 0, -1.7), 0.5, Vec3::Zero(), Vec3::UnitZ(), 1.0, 0.5, g));
  expect_vec(g.normal, -Vec3::UnitZ());
}

TEST(NarrowSphereCapsule, CentreOnTheAxisIsPushedOutPerpendicularly) {
  ContactGeometry g;
  ASSERT_TRUE(sphere_capsule(Vec3(0, 0, 0.2), 0.1, Vec3::Zero(), Vec3::UnitZ(), 1.0, 0.5, g));
  expect_unit(g.normal);
  expect_vec(g.normal, Vec3::UnitX());  // least aligned world axis, x before y
  EXPECT_NEAR(g.depth, 0.6, kTol);
  expect_vec(g.position, Vec3(0.2, 0, 0.2));

  // Axis (1,1,1)/√3: every world axis equally aligned, x chosen and made ⟂.
  const Vec3 axis = Vec3(1, 1, 1).normalized();
  const Vec3 c = Vec3(1, 2, 3) + 0.3 * axis;
  ASSERT_TRUE(sphere_capsule(c, 0.1, Vec3(1, 2, 3), axis, 1.0, 0.5, g));
  expect_unit(g.normal);
  expect_vec(g.normal, Vec3(2, -1, -1) / std::sqrt(6.0));
  EXPECT_NEAR(g.normal.dot(axis), 0.0, kTol);
  EXPECT_NEAR(g.depth, 0.6, kTol);

  // Exactly at an end point of the segment: still a finite perpendicular normal.
  ASSERT_TRUE(sphere_capsule(Vec3(0, 1.0, 0), 0.1, Vec3::Zero(), Vec3::UnitY(), 1.0, 0.5, g));
  expect_unit(g.normal);
  expect_vec(g.normal, Vec3::UnitX());
}

TEST(NarrowSphereCapsule, TiltedAxis) {
  const Vec3 axis = Vec3(0, 0.6, 0.8);
  const Vec3 perp = Vec3(0, 0.8, -0.6);
  const Vec3 centre(1, 1, 1);
  ContactGeometry g;
  ASSERT_TRUE(sphere_capsule(centre + 0.5 * axis + 0.7 * perp, 0.25, centre, axis, 2.0, 0.5, g));
  EXPECT_NEAR(g.depth, 0.05, kTol);
  expect_vec(g.normal, perp);
  expect_vec(g.position, centre + 0.5 * axis + 0.475 * perp);
  EXPECT_FALSE(sphere_capsule(centre + 0.5 * axis + 0.8 * perp, 0.25, centre, axis, 2.0, 0.5, g));
}

}  // namespace
}  // namespace numen::core
