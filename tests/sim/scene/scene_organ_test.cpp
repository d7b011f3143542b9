// Tests of deformable organs in scene files (docs/scenes.md, "Deformable god-objects and
// organs"): `anchored = true` bodies, a [[deformable]] on one, its located errors, the load-time
// warning when an organ starts inside the tool (naming both), and the shipped default scene
// (sim/scenes/default.toml): the lattice scene (lattice.toml) with its sphere lattice replaced
// by the deformable organ, where the recorded hand goes into it.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "build_features.hpp"
#include "numen/sim/input/input_error.hpp"
#include "numen/sim/scene/scene.hpp"
#include "scene_text.hpp"
#include "temp_dir.hpp"

namespace {

using numen::core::Vec3;
using numen::sim::InputError;
using numen::sim::load_scene;
using numen::sim::Scene;
using numen::test::column_of;
using numen::test::line_of;
using numen::test::load_error;
using numen::test::replace;
using numen::test::TempDir;

/// kMiniScene (a 10 mm ball held by a pose tracker at the origin) with an anchored organ: an
/// icosphere net of radius 20 mm, 40 mm below the ball.
std::string mini_organ() {
  return replace(numen::test::kMiniScene, "[[obstacle]]", R"([[material]]
name = "tissue"

[[body]]
name = "organ_core"
mass = 0.1
inertia = [1.0e-4, 1.0e-4, 1.0e-4]
material = "tissue"
anchored = true
position = [0.0, 0.0, -0.04]

[[deformable]]
name = "liver"
body = "organ_core"
mesh = "icosphere"
radius = 0.02
mass = 0.05
stiffness = 200.0
tie_stiffness = 100.0

[[obstacle]])");
}

/// The signed depth (m) of `p` below the closed surface of `net` at rest (> 0 inside): the
/// distance to the nearest rest node, signed by the winding number of its triangles.
double depth_below_rest_surface(const Scene& s, int net_index, const Vec3& p) {
  const numen::core::Model& m = s.model;
  const numen::core::NetModel& net = m.nets[static_cast<std::size_t>(net_index)];
  const numen::core::Pose& pose = m.bodies[static_cast<std::size_t>(net.body)].initial_pose;
  std::vector<Vec3> rest;
  for (int i = 0; i < net.node_count; ++i)
    rest.push_back(pose.position + pose.orientation * m.node_rest[static_cast<std::size_t>(net.node_begin + i)]);
  double nearest = 1e9;  // over the surface's nodes (a material net's interior nodes left out)
  for (const auto& t : s.net_triangles[static_cast<std::size_t>(net_index)])
    for (const int v : t) nearest = std::min(nearest, (rest[static_cast<std::size_t>(v)] - p).norm());
  double omega = 0.0;
  for (const auto& t : s.net_triangles[static_cast<std::size_t>(net_index)]) {
    const Vec3 a = rest[static_cast<std::size_t>(t[0])] - p, b = rest[static_cast<std::size_t>(t[1])] - p,
               c = rest[static_cast<std::size_t>(t[2])] - p;
    const double la = a.norm(), lb = b.norm(), lc = c.norm();
    omega += 2.0 * std::atan2(a.dot(b.cross(c)), la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb);
  }
  return std::abs(omega / (4.0 * std::numbers::pi)) > 0.5 ? nearest : -nearest;
}

bool has_warning(const Scene& s, const std::string& phrase) {
  return std::any_of(s.warnings.begin(), s.warnings.end(),
                     [&](const std::string& w) { return w.find(phrase) != std::string::npos; });
}

}  // namespace

TEST(OrganLoader, AnchoredBodyCarriesTheOrgansNet) {
  NUMEN_REQUIRE_DEFORMABLE();
  TempDir dir;
  const Scene s = load_scene(dir.write("organ.toml", mini_organ()));
  ASSERT_EQ(s.model.num_bodies(), 2);
  EXPECT_FALSE(s.model.bodies[0].anchored);
  EXPECT_TRUE(s.model.bodies[1].anchored);
  ASSERT_EQ(s.model.num_nets(), 1);
  EXPECT_EQ(s.model.nets[0].body, 1);
  EXPECT_EQ(s.model.nets[0].node_count, 162);
  EXPECT_FALSE(has_warning(s, "starts inside")) << s.warnings.front();
}

TEST(OrganLoader, OrganStartingInsideTheToolIsWarnedNamingBoth) {
  NUMEN_REQUIRE_DEFORMABLE();
  TempDir dir;
  // The organ around the ball: the ball's centre inside its closed rest surface.
  const Scene inside = load_scene(dir.write(
      "a.toml", replace(mini_organ(), "position = [0.0, 0.0, -0.04]", "position = [0.0, 0.0, 0.0]")));
  ASSERT_TRUE(has_warning(inside, "deformable \"liver\" starts inside body \"tool\""));
  EXPECT_TRUE(has_warning(inside, "1 of its 1 spheres' centres lie inside the organ's rest surface"));
  // Touching its surface from outside: the ball overlaps node spheres.
  const Scene touching = load_scene(dir.write(
      "b.toml", replace(mini_organ(), "position = [0.0, 0.0, -0.04]", "position = [0.0, 0.0, -0.028]")));
  EXPECT_TRUE(has_warning(touching, "deformable \"liver\" starts inside body \"tool\": its spheres "
                                    "overlap the organ's node spheres"));
}

TEST(OrganLoaderErrors, AnchoredBodyTakesNoCouplingLinkOrVelocity) {
  NUMEN_REQUIRE_DEFORMABLE();
  TempDir dir;
  const std::string coupling = replace(mini_organ(), "position = [0.0, 0.0, -0.04]\n",
                                       "position = [0.0, 0.0, -0.04]\n[body.coupling]\nstiffness = 10.0\n");
  const InputError a = load_error(dir, coupling);
  EXPECT_EQ(a.key(), "body[1].coupling") << a.what();
  EXPECT_NE(a.message().find("is anchored (a static body held where it starts): it takes no coupling"),
            std::string::npos) << a.what();
  const InputError b = load_error(
      dir, replace(mini_organ(), "anchored = true\n", "anchored = true\nlinear_velocity = [0.1, 0.0, 0.0]\n"));
  EXPECT_EQ(b.key(), "body[1].linear_velocity") << b.what();
  const InputError c = load_error(dir, replace(mini_organ(), "anchored = true", "anchored = 1"));
  EXPECT_EQ(c.key(), "body[1].anchored") << c.what();
}

TEST(OrganLoaderErrors, NoDeviceHoldsAnAnchoredBody) {
  NUMEN_REQUIRE_DEFORMABLE();
  const std::string text = replace(mini_organ(), "attach = \"tool\"", "attach = \"organ_core\"");
  TempDir dir;
  const InputError e = load_error(dir, text);
  EXPECT_EQ(e.key(), "device.attach") << e.what();
  EXPECT_EQ(e.line(), line_of(text, "attach = \"organ_core\""));
  EXPECT_EQ(e.column(), column_of(text, "attach = \"organ_core\"", "\"organ_core\""));
  EXPECT_NE(e.message().find("body \"organ_core\" is anchored"), std::string::npos) << e.what();
}

TEST(OrganLoaderErrors, AnchoredCoreWithSpheresIsRejectedAsAnOrgansCore) {
  NUMEN_REQUIRE_DEFORMABLE();
  const std::string text =
      replace(mini_organ(), "anchored = true\n", "anchored = true\nspheres = [[0.0, 0.0, 0.0, 0.01]]\n");
  TempDir dir;
  const InputError e = load_error(dir, text);
  EXPECT_EQ(e.key(), "deformable[0].body") << e.what();
  EXPECT_NE(e.message().find("the anchored rigid component of a deformable organ"), std::string::npos)
      << e.what();
}

TEST(OrganShippedScene, TheDeformableOrganTakesTheLatticesPlaceAndTheHandGoesIntoIt) {
  NUMEN_REQUIRE_ARTICULATION();
  NUMEN_REQUIRE_DEFORMABLE();
  const std::string dir = std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/";
  const Scene def = load_scene(dir + "lattice.toml");
  const Scene s = load_scene(dir + "default.toml");
  EXPECT_EQ(s.name, "default");
  EXPECT_TRUE(s.warnings.empty()) << s.warnings.front();
  // lattice.toml's obstacles but the lattice, and the organ's rigid core surface (a mesh under
  // the net); its bodies plus the organ's anchored core.
  ASSERT_EQ(s.model.obstacles.size(), 2u);
  EXPECT_EQ(s.model.obstacles[0].name, "tissue");
  EXPECT_EQ(s.model.obstacles[1].name, "organ_core_surface");
  EXPECT_EQ(s.model.obstacles[1].type, numen::core::ShapeType::kMesh);
  ASSERT_EQ(s.model.num_bodies(), def.model.num_bodies() + 1);
  const numen::core::BodyModel& core_body = s.model.bodies.back();
  EXPECT_EQ(core_body.name, "organ_core");
  EXPECT_TRUE(core_body.anchored);
  EXPECT_EQ(core_body.sphere_count, 0);
  const numen::core::Obstacle& lattice = def.model.obstacles[1];
  ASSERT_EQ(lattice.name, "organ");
  EXPECT_LT((core_body.initial_pose.position - lattice.pose.position).norm(), 1e-12);
  EXPECT_LT(core_body.initial_pose.orientation.angularDistance(lattice.pose.orientation), 1e-9);
  EXPECT_LT((s.model.obstacles[1].pose.position - lattice.pose.position).norm(), 1e-12);
  EXPECT_LT(s.model.obstacles[1].pose.orientation.angularDistance(lattice.pose.orientation), 1e-9);
  // The core lies 2.2-3.2 mm under the rest surface (the scaled mesh, docs/organs.md): every
  // vertex of its mesh inside the rest surface, its nearest rest surface node (within a mean
  // edge of the 500-node net of the nearest surface point) 2 mm to 3.2 mm + an edge away.
  const numen::core::Obstacle& core_surface = s.model.obstacles[1];
  double shallowest = 1.0, deepest_vertex = 0.0;
  for (const Vec3& v : s.model.meshes[static_cast<std::size_t>(core_surface.mesh)].vertices) {
    const double d = depth_below_rest_surface(s, 0, core_surface.pose.position + core_surface.pose.orientation * v);
    shallowest = std::min(shallowest, d);
    deepest_vertex = std::max(deepest_vertex, d);
  }
  std::printf("[   info   ] core surface: its vertices %.2f-%.2f mm from the nearest rest node, inside\n",
              1e3 * shallowest, 1e3 * deepest_vertex);
  ASSERT_EQ(s.net_loads.size(), 1u);
  const double edge = s.net_loads[0].material_constants.surface_mean_edge;
  EXPECT_GT(shallowest, 0.002);
  EXPECT_LT(deepest_vertex, 0.0032 + edge) << "mean edge " << edge;
  ASSERT_EQ(s.model.num_nets(), 1);
  EXPECT_EQ(s.model.nets[0].name, "organ");
  EXPECT_EQ(s.model.nets[0].node_count - s.net_loads[0].interior_nodes, 500);
  EXPECT_EQ(s.model.nets[0].face_count, 2 * 500 - 4) << "a closed surface";
  // The recorded tip (the hand) goes 10-20 mm below the organ's rest surface, as below the
  // lattice's (15 mm).
  double deepest = -1.0;
  std::size_t inside = 0;
  for (std::size_t k = 0; k < s.trajectory.size(); ++k) {
    const double d = depth_below_rest_surface(s, 0, s.trajectory[k].pose.position);
    deepest = std::max(deepest, d);
    inside += d > 0.0 ? 1 : 0;
  }
  std::printf("[   info   ] recorded tip: %zu of %zu samples inside the organ, deepest %.1f mm\n",
              inside, s.trajectory.size(), 1e3 * deepest);
  EXPECT_GT(deepest, 0.010);
  EXPECT_LT(deepest, 0.020);
  EXPECT_GT(inside, 30u);
}

TEST(OrganLoader, AnOrganRunsMultirate) {
  NUMEN_REQUIRE_DEFORMABLE();
  const std::string text =
      replace(mini_organ(), "[device]", "[multirate]\nscene_dt = 0.01\nmargin = 0.01\n\n[device]");
  TempDir dir;
  const Scene s = load_scene(dir.write("mr.toml", text));
  ASSERT_TRUE(s.multirate.has_value());
  EXPECT_EQ(s.model.num_nets(), 1);
}
