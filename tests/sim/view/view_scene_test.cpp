// Tests of numen/sim/view/view_scene.hpp: the scene message describes the nets, bodies and
// obstacles of a scene, a mesh obstacle's surface in its frame, and a body's mesh with its pose
// in the body frame (docs/viewer.md, "Scene message").
#include "numen/sim/view/view_scene.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <numbers>
#include <nlohmann/json.hpp>
#include <vector>

#include "build_features.hpp"
#include "fine_surface_organ.hpp"
#include "numen/core/data.hpp"
#include "numen/core/mesh_shape.hpp"
#include "numen/core/model.hpp"
#include "numen/core/needle.hpp"
#include "numen/core/net_surface_map.hpp"
#include "numen/sim/scene/scene.hpp"
#include "scene_text.hpp"
#include "temp_dir.hpp"

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
// A net given by its material says so (`tissue`): the page draws the tools' dimples on it
// (sim/viewer/js/tissue_dimple.js); a net given per spring does not carry the key.
TEST(ViewSceneMessage, MarksAnOrganGivenByItsMaterial) {
  NUMEN_REQUIRE_DEFORMABLE();
  const auto per_spring = parsed_scene_message(numen::sim::load_scene(shipped_scene("deformable.toml")));
  ASSERT_GT(per_spring["nets"].size(), 0u);
  for (const auto& n : per_spring["nets"]) EXPECT_FALSE(n.contains("tissue")) << n["name"];
  numen::test::TempDir dir;
  const std::string organ = "mesh = \"file\"\nfile = \"" + std::string(NUMEN_SOURCE_DIR) +
                            "/sim/data/organ_lobe.obj\"\nyoungs_modulus_kpa = 120.0\npoisson_ratio = 0.45\n"
                            "support_length = 0.02\nnodes = 250\n";
  const auto material = parsed_scene_message(numen::sim::load_scene(
      dir.write("tissue.toml", numen::test::indentation_bench_scene(organ, 0.0025, 1e-3))));
  ASSERT_EQ(material["nets"].size(), 1u);
  EXPECT_EQ(material["nets"][0]["tissue"], true);
}

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

namespace {

/// Fine vertex `i` of a net's scene-message "surface" `s` at the net's node positions `x`
/// (net-local, m), as docs/viewer.md says the page computes it: p = Σ w x + F · offset, the
/// weights divided by their sum, F = [e1, e2, n] of the net triangle in its corner order.
numen::core::Vec3 fine_vertex_from_scene_message(const nlohmann::json& s, int i,
                                                 const std::vector<numen::core::Vec3>& x) {
  const int f = s["face"][static_cast<std::size_t>(i)].get<int>();
  std::array<numen::core::Vec3, 3> c;
  numen::core::Vec3 w, offset;
  for (std::size_t k = 0; k < 3; ++k) {
    c[k] = x[s["net_triangles"][3 * static_cast<std::size_t>(f) + k].get<std::size_t>()];
    w[static_cast<int>(k)] = s["weights"][3 * static_cast<std::size_t>(i) + k].get<double>();
    offset[static_cast<int>(k)] = s["offset"][3 * static_cast<std::size_t>(i) + k].get<double>();
  }
  w /= w.sum();
  const numen::core::Vec3 e1 = (c[1] - c[0]).normalized();
  const numen::core::Vec3 n = (c[1] - c[0]).cross(c[2] - c[0]).normalized();
  return w[0] * c[0] + w[1] * c[1] + w[2] * c[2] + offset[0] * e1 + offset[1] * n.cross(e1) + offset[2] * n;
}

// A net with a fine surface (mapped by hand: tests/support/fine_surface_organ.hpp) carries it
// in its entry's "surface": the net's triangles in the model's corner order, each fine vertex's
// net-local triangle, weights and offset, the fine triangles; from them and the nodes' positions
// the page's formula gives core::net_surface_positions() within the rounding sent (0.3 µm), at
// rest and with the nodes moved. A net without one has no "surface".
TEST(ViewSceneMessage, CarriesANetsFineSurfaceFromWhichThePagePlacesItsVertices) {
  NUMEN_REQUIRE_DEFORMABLE();
  numen::sim::Scene scene =
      numen::sim::load_scene(std::string(NUMEN_TEST_DATA_DIR) + "/node_contacts.toml");
  numen::core::Model& model = scene.model;
  ASSERT_EQ(model.nets.size(), 2u);  // the organ (icosphere 2), the ball (icosphere 1)
  ASSERT_EQ(numen::test::map_fine_icosphere_onto_net(model, 0, 4), "");
  const numen::core::NetModel& net = model.nets[0];
  ASSERT_EQ(net.surface_point_count, 2562);
  ASSERT_EQ(net.surface_face_count, 5120);
  const auto j = parsed_scene_message(scene);
  EXPECT_FALSE(j["nets"][1].contains("surface"));
  ASSERT_TRUE(j["nets"][0].contains("surface"));
  const auto& s = j["nets"][0]["surface"];
  EXPECT_EQ(s["point_count"].get<int>(), net.surface_point_count);
  EXPECT_EQ(s["triangle_count"].get<int>(), net.surface_face_count);
  ASSERT_EQ(s["net_triangles"].size(), 3u * static_cast<std::size_t>(net.face_count));
  for (int f = 0; f < net.face_count; ++f)
    for (int k = 0; k < 3; ++k)
      ASSERT_EQ(s["net_triangles"][static_cast<std::size_t>(3 * f + k)].get<int>(),
                model.net_faces[static_cast<std::size_t>(net.face_begin + f)][static_cast<std::size_t>(k)] -
                    net.node_begin);
  ASSERT_EQ(s["face"].size(), 2562u);
  ASSERT_EQ(s["weights"].size(), 3u * 2562u);
  ASSERT_EQ(s["offset"].size(), 3u * 2562u);
  ASSERT_EQ(s["triangles"].size(), 3u * 5120u);
  for (int t = 0; t < net.surface_face_count; ++t)
    for (int k = 0; k < 3; ++k)
      ASSERT_EQ(s["triangles"][static_cast<std::size_t>(3 * t + k)].get<int>(),
                model.net_surface_faces[static_cast<std::size_t>(net.surface_face_begin + t)][static_cast<std::size_t>(k)] -
                    net.surface_point_begin);
  // Rounded as documented: weights to 1e-6, offsets to 1e-7 m (a short number each).
  for (const auto& w : s["weights"]) EXPECT_LE(w.dump().size(), 8u) << w.dump();
  for (const auto& o : s["offset"]) EXPECT_LE(o.dump().size(), 13u) << o.dump();

  numen::core::Data data = numen::core::make_data(model);
  std::vector<numen::core::Vec3> expected(2562);
  for (const double moved : {0.0, 0.002}) {  // at rest, then every node moved by up to 2 mm
    for (int i = 0; i < net.node_count; ++i)
      data.nodes[static_cast<std::size_t>(net.node_begin + i)].position +=
          moved * numen::core::Vec3(std::sin(1.7 * i), std::cos(2.3 * i), std::sin(0.9 * i + 1.0));
    ASSERT_EQ(numen::core::net_surface_positions(model, data, 0, expected), 2562);
    std::vector<numen::core::Vec3> x;
    for (int i = 0; i < net.node_count; ++i) x.push_back(data.nodes[static_cast<std::size_t>(net.node_begin + i)].position);
    double worst = 0.0;
    for (int i = 0; i < 2562; ++i)
      worst = std::max(worst, (fine_vertex_from_scene_message(s, i, x) - expected[static_cast<std::size_t>(i)]).norm());
    EXPECT_LT(worst, 3e-7) << "nodes moved by up to " << moved << " m";
  }
}

}  // namespace

TEST(ViewSceneWarnings, AFineSurfaceTheMessageLeavesOutIsSaid) {
  // What the scene message leaves out is said (numen run --view / --record-view print it): a
  // fine surface above kViewNetSurfaceMaxTriangles goes as its counts, and the page draws the
  // net. Nothing to say for a scene the message carries whole.
  NUMEN_REQUIRE_DEFORMABLE();
  numen::sim::Scene scene =
      numen::sim::load_scene(std::string(NUMEN_TEST_DATA_DIR) + "/node_contacts.toml");
  EXPECT_TRUE(numen::sim::view_scene_warnings(scene).empty());
  ASSERT_EQ(numen::test::map_fine_icosphere_onto_net(scene.model, 0, 3), "");
  EXPECT_TRUE(numen::sim::view_scene_warnings(scene).empty()) << "1 280 fine triangles go whole";
  // The count is all the message and the warning read of a surface that large.
  scene.model.nets[0].surface_face_count = numen::sim::kViewNetSurfaceMaxTriangles + 1;
  const std::vector<std::string> lines = numen::sim::view_scene_warnings(scene);
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_EQ(lines[0], "deformable \"organ\"'s fine surface has 400001 triangles, more than the 400000 "
                      "the view sends: the view draws its 162-node net");
  const auto j = nlohmann::json::parse(numen::sim::view_scene_message(
      scene, numen::sim::view_frame_layout(scene), 30.0));
  EXPECT_FALSE(j["nets"][0]["surface"].contains("triangles"));
  EXPECT_EQ(j["nets"][0]["surface"]["triangle_count"].get<int>(), 400001);
}

// Issue 69: the suturing scene's needle is described by its arc in its body's frame (the page
// draws the wire as a tube there, posed by the frames' body_pose) and its thread by its nodes'
// place in the frames' thread_node; the layout reserves the thread's segments + 1 nodes. A scene
// without either has empty lists and no thread in its frames.
TEST(ViewSceneMessage, CarriesTheNeedlesArcAndTheThreadsNodes) {
  NUMEN_REQUIRE_DEFORMABLE();
  const numen::sim::Scene scene = numen::sim::load_scene(shipped_scene("suturing.toml"));
  const numen::core::Model& m = scene.model;
  ASSERT_EQ(m.needles.size(), 1u);
  ASSERT_EQ(m.threads.size(), 1u);
  const auto layout = numen::sim::view_frame_layout(scene);
  EXPECT_EQ(layout.num_threads, 1u);
  EXPECT_EQ(layout.num_thread_nodes, static_cast<std::uint32_t>(m.threads[0].segments + 1));
  const nlohmann::json j = parsed_scene_message(scene);
  EXPECT_EQ(j["layout"]["threads"], 1);
  EXPECT_EQ(j["layout"]["thread_nodes"], m.threads[0].segments + 1);
  ASSERT_EQ(j["needles"].size(), 1u);
  const nlohmann::json& n = j["needles"][0];
  const numen::core::NeedleModel& needle = m.needles[0];
  EXPECT_EQ(n["name"], "needle");
  EXPECT_EQ(n["body"], needle.body);
  EXPECT_EQ(j["bodies"][static_cast<std::size_t>(needle.body)]["name"], "needle");
  EXPECT_DOUBLE_EQ(n["radius"].get<double>(), 0.026 / std::numbers::pi);
  EXPECT_DOUBLE_EQ(n["arc_angle"].get<double>(), needle.arc_angle);
  EXPECT_DOUBLE_EQ(n["wire_radius"].get<double>(), 0.00035);
  EXPECT_DOUBLE_EQ(n["tail_angle"].get<double>(), -needle.arc_angle / 2);
  EXPECT_DOUBLE_EQ(n["tip_angle"].get<double>(), needle.arc_angle / 2);
  for (int k = 0; k < 3; ++k) EXPECT_DOUBLE_EQ(n["centre"][k].get<double>(), needle.centre[k]);
  // The arc as the page draws it (about centre, radius R, from the tail's angle) goes through the
  // needle's collision spheres, tail first.
  const double R = n["radius"].get<double>(), tail = n["tail_angle"].get<double>();
  const auto& spheres = j["bodies"][static_cast<std::size_t>(needle.body)]["spheres"];
  const auto& first = spheres.front();
  EXPECT_NEAR(first[0].get<double>(), needle.centre.x() + R * std::cos(tail), 1e-9);
  EXPECT_NEAR(first[1].get<double>(), needle.centre.y() + R * std::sin(tail), 1e-9);
  ASSERT_EQ(j["threads"].size(), 1u);
  const nlohmann::json& t = j["threads"][0];
  EXPECT_EQ(t["name"], "suture");
  EXPECT_EQ(t["node_begin"], 0);
  EXPECT_EQ(t["node_count"], m.threads[0].segments + 1);
  EXPECT_DOUBLE_EQ(t["radius"].get<double>(), m.threads[0].radius);
  EXPECT_EQ(t["needle"], 0);
  // The deformable scene: no needle, no thread.
  const numen::sim::Scene plain = numen::sim::load_scene(shipped_scene("deformable.toml"));
  const nlohmann::json k = parsed_scene_message(plain);
  EXPECT_TRUE(k["needles"].empty());
  EXPECT_TRUE(k["threads"].empty());
  EXPECT_EQ(numen::sim::view_frame_layout(plain).num_thread_nodes, 0u);
}
