// Tests of numen/sim/view/view_scene.hpp: the scene message describes the nets, bodies and
// obstacles of a scene, a mesh obstacle's surface in its frame, and a body's mesh with its pose
// in the body frame (docs/viewer.md, "Scene message").
#include "numen/sim/view/view_scene.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>

#include "build_features.hpp"
#include "numen/core/mesh_shape.hpp"
#include "numen/core/model.hpp"
#include "numen/sim/scene/scene.hpp"

namespace {

/// The scene message of `scene` at 60 Hz, parsed.
nlohmann::json parsed_scene_message(const numen::sim::Scene& scene) {
  return nlohmann::json::parse(
      numen::sim::view_scene_message(scene, numen::sim::view_frame_layout(scene), 60.0));
}

/// A shipped scene of sim/scenes by its file name.
std::string shipped_scene(const char* file) {
  return (std::filesystem::path(numen::sim::default_scene_path()).parent_path() / file).string();
}

/// Checks that `j` (an obstacle's or a body's "mesh") carries the whole surface of `m`.
void expect_mesh_surface(const nlohmann::json& j, const numen::core::MeshShape& m) {
  EXPECT_EQ(j["triangle_count"].get<int>(), m.num_triangles());
  EXPECT_FALSE(j.contains("aabb"));
  ASSERT_EQ(j["vertices"].size(), 3 * m.vertices.size());
  ASSERT_EQ(j["triangles"].size(), 3 * m.triangles.size());
  for (std::size_t v = 0; v < m.vertices.size(); ++v)
    for (int k = 0; k < 3; ++k)
      ASSERT_EQ(j["vertices"][3 * v + k].get<double>(), m.vertices[v][k]) << "vertex " << v;
  for (std::size_t t = 0; t < m.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k)
      ASSERT_EQ(j["triangles"][3 * t + k].get<int>(), m.triangles[t][k]) << "triangle " << t;
}

TEST(ViewSceneMessage, DescribesTheNetsBodiesAndObstaclesOfTheDeformableScene) {
  NUMEN_REQUIRE_DEFORMABLE();
  const numen::sim::Scene scene = numen::sim::load_scene(shipped_scene("deformable.toml"));
  const auto layout = numen::sim::view_frame_layout(scene);
  const auto j = nlohmann::json::parse(numen::sim::view_scene_message(scene, layout, 60.0));
  EXPECT_EQ(j["version"], numen::sim::kViewSceneVersion);
  EXPECT_EQ(j["bodies"].size(), scene.model.bodies.size());
  EXPECT_EQ(j["obstacles"].size(), scene.model.obstacles.size());
  ASSERT_EQ(j["nets"].size(), scene.model.nets.size());
  ASSERT_GT(j["nets"].size(), 0u);
  const auto& net = j["nets"][0];
  EXPECT_EQ(net["node_count"].get<int>(), scene.model.nets[0].node_count);
  ASSERT_GT(net["triangles"].size(), 0u);
  for (const auto& t : net["triangles"])
    for (int i = 0; i < 3; ++i) {
      EXPECT_GE(t[i].get<int>(), 0);
      EXPECT_LT(t[i].get<int>(), scene.model.nets[0].node_count);
    }
  EXPECT_EQ(j["layout"]["nodes"].get<std::uint32_t>(), layout.num_nodes);
  EXPECT_EQ(j["device"]["axes"].size(), scene.device.axes.size());
  EXPECT_EQ(j["device"]["protocol"], scene.device.canopen.managed ? "managed" : "minimal");
  for (const auto& b : j["bodies"]) EXPECT_FALSE(b.contains("mesh")) << b["name"];
}

// A mesh obstacle goes to the page as its surface: every vertex and triangle of the model's
// mesh, in the obstacle's frame (sim/scenes/mesh.toml).
TEST(ViewSceneMessage, CarriesAMeshObstaclesSurface) {
  const numen::sim::Scene scene = numen::sim::load_scene(shipped_scene("mesh.toml"));
  const auto j = parsed_scene_message(scene);
  int meshes = 0;
  for (std::size_t i = 0; i < scene.model.obstacles.size(); ++i) {
    const numen::core::Obstacle& o = scene.model.obstacles[i];
    if (o.type != numen::core::ShapeType::kMesh) continue;
    ++meshes;
    const auto& jo = j["obstacles"][i];
    EXPECT_EQ(jo["type"], "mesh");
    expect_mesh_surface(jo, scene.model.meshes[static_cast<std::size_t>(o.mesh)]);
  }
  EXPECT_EQ(meshes, 1);
}

// A body's mesh (tests/data/mesh_body.toml: the lobe) goes with its body, at the body's index:
// the mesh's pose in the body frame (the model's BodyModel::mesh_pose, [x, y, z, w]) and its
// surface in the mesh's frame; a body without a mesh (the probe) has none.
TEST(ViewSceneMessage, CarriesABodysMeshWithItsPoseInTheBodyFrame) {
  numen::sim::Scene scene =
      numen::sim::load_scene(std::string(NUMEN_TEST_DATA_DIR) + "/mesh_body.toml");
  const numen::core::Model& model = scene.model;
  ASSERT_EQ(model.bodies.size(), 2u);
  ASSERT_EQ(model.bodies[0].name, "lobe");
  ASSERT_GE(model.bodies[0].mesh, 0);
  ASSERT_LT(model.bodies[1].mesh, 0);
  // A pose other than the file's identity, so that every number is seen to come from the model.
  numen::core::Pose& pose = scene.model.bodies[0].mesh_pose;
  pose.position = numen::core::Vec3(0.001, -0.002, 0.003);
  pose.orientation = numen::core::Quat(0.9, 0.1, -0.3, 0.2).normalized();
  const auto j = parsed_scene_message(scene);
  ASSERT_EQ(j["bodies"].size(), 2u);
  const auto& lobe = j["bodies"][0];
  EXPECT_EQ(lobe["name"], "lobe");
  ASSERT_TRUE(lobe.contains("mesh"));
  const auto& mesh = lobe["mesh"];
  for (int k = 0; k < 3; ++k) EXPECT_EQ(mesh["position"][k].get<double>(), pose.position[k]);
  EXPECT_EQ(mesh["orientation"][0].get<double>(), pose.orientation.x());
  EXPECT_EQ(mesh["orientation"][1].get<double>(), pose.orientation.y());
  EXPECT_EQ(mesh["orientation"][2].get<double>(), pose.orientation.z());
  EXPECT_EQ(mesh["orientation"][3].get<double>(), pose.orientation.w());
  const numen::core::MeshShape& shape =
      model.meshes[static_cast<std::size_t>(model.bodies[0].mesh)];
  EXPECT_EQ(shape.num_triangles(), 1280);  // lobe.obj
  expect_mesh_surface(mesh, shape);
  EXPECT_EQ(lobe["spheres"].size(), 4u);  // its feet stay: the page's toggle
  EXPECT_EQ(j["bodies"][1]["name"], "probe");
  EXPECT_FALSE(j["bodies"][1].contains("mesh"));
}

}  // namespace
