// finalize_model(): validation messages name the offending part; derived
// fields are computed.
#include "numen/core/model.hpp"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "numen/core/features.hpp"

namespace core = numen::core;
using core::Vec3;

namespace {

core::Model one_ball() {
  core::Model m;
  m.material_pairs = {core::MaterialPair{}};
  m.body_spheres = {core::Sphere{Vec3(0.0, 0.0, 0.02), 0.01}};
  core::BodyModel b;
  b.name = "ball";
  b.sphere_count = 1;
  m.bodies = {b};
  return m;
}

}  // namespace

TEST(Model, FinalizeComputesDerivedFields) {
  core::Model m = one_ball();
  m.bodies[0].inertia_body = Vec3(1.0, 2.0, 4.0).asDiagonal();
  ASSERT_EQ(core::finalize_model(m), "");
  EXPECT_NEAR(m.bodies[0].bounding_radius, 0.03, 1e-15);
  EXPECT_NEAR(m.bodies[0].inertia_body_inv(2, 2), 0.25, 1e-15);
}

TEST(Model, RejectsBadBodiesNamingThem) {
  core::Model m = one_ball();
  m.bodies[0].mass = -1.0;
  EXPECT_NE(core::finalize_model(m).find("body 'ball': mass"), std::string::npos);
  m = one_ball();
  m.bodies[0].inertia_body(0, 1) = 0.5;  // not symmetric
  EXPECT_NE(core::finalize_model(m).find("symmetric"), std::string::npos);
  m = one_ball();
  m.body_spheres[0].radius = 0.0;
  EXPECT_NE(core::finalize_model(m).find("sphere 0"), std::string::npos);
}

TEST(Model, RejectsANonFiniteErrorTolerance) {
  core::Model m = one_ball();
  m.solver.error_tolerance = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(core::finalize_model(m), "solver error_tolerance must be finite (<= 0: the tolerance)");
  m = one_ball();
  m.solver.error_tolerance = 3e-4;
  EXPECT_EQ(core::finalize_model(m), "");
}

TEST(Model, RejectsBadObstaclesAndStaticSpheres) {
  core::Model m = one_ball();
  core::Obstacle box;
  box.name = "crate";
  box.type = core::ShapeType::kBox;
  box.half_extents = Vec3(0.1, 0.0, 0.1);
  m.obstacles = {box};
  EXPECT_NE(core::finalize_model(m).find("obstacle 'crate': half extents"), std::string::npos);

  m = one_ball();
  core::Obstacle cap;
  cap.name = "rod";
  cap.type = core::ShapeType::kCapsule;
  cap.radius = std::numeric_limits<double>::quiet_NaN();
  m.obstacles = {cap};
  EXPECT_NE(core::finalize_model(m).find("obstacle 'rod': radius"), std::string::npos);

  m = one_ball();
  core::Obstacle set;
  set.name = "organ";
  set.type = core::ShapeType::kSphereSet;
  set.sphere_count = 2;
  m.static_spheres = {core::Sphere{Vec3::Zero(), 0.01},
                      core::Sphere{Vec3(std::numeric_limits<double>::infinity(), 0.0, 0.0), 0.01}};
  m.obstacles = {set};
  EXPECT_NE(core::finalize_model(m).find("static sphere 1"), std::string::npos);

  set.sphere_count = 3;  // past the end of static_spheres
  m.obstacles = {set};
  EXPECT_NE(core::finalize_model(m).find("sphere range"), std::string::npos);
}

TEST(Model, DampingFromRatioIsTwoZetaSqrtMk) {
  EXPECT_NEAR(core::damping_from_ratio(0.85, 0.05, 1000.0), 2.0 * 0.85 * std::sqrt(50.0), 1e-12);
}

TEST(Model, JointsAndNetsNeedTheirBuildOptions) {
  // A build without a part refuses a model that has it (features.hpp), by name.
  core::Model m;
  m.material_names = {"default"};
  m.material_pairs = {core::MaterialPair{}};
  m.bodies.resize(2);
  core::JointModel j;
  j.name = "hinge";
  j.parent = 0;
  j.child = 1;
  m.joints.push_back(j);
  const std::string e = core::finalize_model(m);
  if (core::kWithArticulation)
    EXPECT_EQ(e, "");
  else
    EXPECT_EQ(e, "joints: this build has NUMEN_WITH_ARTICULATION=OFF (no joints)");
}
