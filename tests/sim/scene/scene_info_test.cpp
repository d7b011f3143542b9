// Tests of sim/scene_info: `numen info` on the shipped scenes — sizes from the
// Model, stages equal to those step() runs, bytes equal to what make_data()
// asked the allocator for, the device's CANopen nodes as the scene configures them.
#include "numen/sim/scene/scene_info.hpp"

#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "alloc_counter.hpp"
#include "build_features.hpp"
#include "mesh_text.hpp"
#include "numen/core/capacity.hpp"
#include "numen/core/data.hpp"
#include "numen/core/features.hpp"
#include "numen/core/grasp.hpp"
#include "numen/core/mesh_shape.hpp"
#include "numen/core/needle_puncture.hpp"
#include "numen/core/net_surface_map.hpp"  // NetSurfacePoint
#include "numen/core/step.hpp"
#include "numen/core/step_stages.hpp"
#include "numen/core/thread.hpp"
#include "numen/hal/features.hpp"
#include "numen/sim/scene/scene.hpp"
#include "scene_text.hpp"
#include "temp_dir.hpp"

namespace core = numen::core;
namespace sim = numen::sim;

namespace {

/// The shipped scenes this build can load (lattice, default, phantom and endobag have
/// joints; deformable, endobag and default nets; mouse names its event codes, which libevdev resolves).
std::vector<std::string> shipped_scenes() {
  std::vector<std::string> out{"construction", "admittance"};
  if (numen::hal::kWithEvdev) out.push_back("mouse");
  if (core::kWithArticulation) out.insert(out.end(), {"lattice", "phantom", "peg_transfer"});
  if (core::kWithDeformable) out.push_back("deformable");
  if (core::kWithArticulation && core::kWithDeformable) out.insert(out.end(), {"endobag", "default", "suturing"});
  return out;
}

std::string shipped_path(const std::string& name) {
  return std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/" + name + ".toml";
}

}  // namespace

TEST(SceneInfo, SizesAreTheModelsCounts) {
  for (const std::string& name : shipped_scenes()) {
    const sim::Scene scene = sim::load_scene(shipped_path(name));
    const core::Model& m = scene.model;
    const sim::SceneInfo i = sim::describe_scene(scene);
    EXPECT_EQ(i.name, scene.name);
    EXPECT_EQ(i.bodies, m.num_bodies()) << name;
    EXPECT_EQ(i.joints, m.num_joints()) << name;
    EXPECT_EQ(i.nets, m.num_nets()) << name;
    EXPECT_EQ(i.nodes, m.num_nodes()) << name;
    EXPECT_EQ(i.obstacles, static_cast<int>(m.obstacles.size())) << name;
    EXPECT_EQ(i.body_spheres, static_cast<int>(m.body_spheres.size())) << name;
    EXPECT_EQ(i.contact_capacity, core::contact_capacity(m)) << name;
    // With nets: the penalty contacts' room, then the grasp springs', the needles' puncture ties'
    // and the threads' eyelet and tissue contact springs' (make_data()).
    const int room = core::kMaxNodeContacts + m.num_grasps() * core::kMaxGraspNodes * core::kGraspSpringsPerNode +
                     m.num_needles() * core::kMaxNeedlePunctures * core::kNeedleTieSprings +
                     m.num_threads() * (core::kMaxThreadEyelets * core::kThreadEyeletTieSprings +
                                        core::kMaxThreadTissueContacts * core::kThreadTissueContactSprings);
    EXPECT_EQ(i.node_contact_capacity, m.num_nodes() > 0 ? room : 0) << name;
  }
}

TEST(SceneInfo, StagesAreThoseStepRuns) {
  for (const std::string& name : shipped_scenes()) {
    const sim::Scene scene = sim::load_scene(shipped_path(name));
    const sim::SceneInfo i = sim::describe_scene(scene);
    core::Data d = core::make_data(scene.model);
    core::step(scene.model, d);
    const auto table = core::step_stage_table();
    ASSERT_EQ(i.stages.size(), table.size());
    for (std::size_t k = 0; k < table.size(); ++k) {
      EXPECT_EQ(i.stages[k].name, table[k].name);
      EXPECT_EQ(i.stages[k].runs, (d.stages_run & table[k].stage) != 0) << name << ": " << table[k].name;
      EXPECT_EQ(i.stages[k].skipped_why.empty(), i.stages[k].runs) << name << ": " << table[k].name;
    }
  }
}

TEST(SceneInfo, DataBytesAreWhatMakeDataAllocated) {
  for (const std::string& name : shipped_scenes()) {
    const sim::Scene scene = sim::load_scene(shipped_path(name));
    const sim::SceneInfo i = sim::describe_scene(scene);
    const std::int64_t before = numen::test::allocated_bytes();
    const core::Data d = core::make_data(scene.model);
    const auto allocated = static_cast<std::size_t>(numen::test::allocated_bytes() - before);
    EXPECT_EQ(i.data_bytes.sizeof_data, sizeof(core::Data));
    // Nets sort their springs with one temporary array of num_nodes ints (NetScratch::resize).
    const std::size_t temporary =
        static_cast<std::size_t>(scene.model.num_nodes()) * sizeof(std::int32_t);
    EXPECT_EQ(allocated, i.data_bytes.heap_bytes() + temporary) << name;
  }
}

TEST(SceneInfo, ReportAndJsonNameEveryStageAndGroup) {
  const sim::SceneInfo i = sim::describe_scene(sim::load_scene(shipped_path("construction")));
  const std::string text = sim::format_scene_info(i);
  const nlohmann::json json = nlohmann::json::parse(sim::format_scene_info_json(i));
  ASSERT_EQ(json.at("stages").size(), i.stages.size());
  for (std::size_t k = 0; k < i.stages.size(); ++k) {
    const sim::StageLine& s = i.stages[k];
    EXPECT_NE(text.find(s.name), std::string::npos) << s.name;
    EXPECT_EQ(json.at("stages").at(k).at("name"), s.name);
    EXPECT_EQ(json.at("stages").at(k).at("runs"), s.runs) << s.name;
    EXPECT_EQ(json.at("stages").at(k).at("skipped_why"), s.skipped_why) << s.name;
    if (!s.runs) {
      std::string line = "skipped: ";
      line += s.skipped_why;
      EXPECT_NE(text.find(line), std::string::npos) << s.name;
    }
  }
  for (const core::BufferGroupBytes& g : i.data_bytes.groups)
    EXPECT_EQ(json.at("data_bytes").at("groups").at(g.group), g.heap_bytes) << g.group;
  EXPECT_EQ(json.at("data_bytes").at("heap"), i.data_bytes.heap_bytes());
  EXPECT_EQ(json.at("sizes").at("bodies"), i.bodies);
  EXPECT_EQ(json.at("name"), i.name);
}

TEST(SceneInfo, JsonEscapesNamesAndReplacesBytesThatAreNotUtf8) {
  sim::SceneInfo i = sim::describe_scene(sim::load_scene(shipped_path("construction")));
  i.name = "quote \" backslash \\ tab \t bad \xff end";
  const std::string out = sim::format_scene_info_json(i);
  ASSERT_TRUE(nlohmann::json::accept(out)) << out;
  EXPECT_EQ(nlohmann::json::parse(out).at("name"),
            "quote \" backslash \\ tab \t bad \xef\xbf\xbd end");
}

// The device part (what tests/interop/lib/scene.js reads instead of the scene file): every axis
// of a managed-stack device is served by exactly one node, with the node id and the DCF (an
// absolute path to a file that exists) the scene gave it; text and JSON agree.
TEST(SceneInfo, DeviceNodesAreTheScenesCanopenAxes) {
  for (const std::string& name : shipped_scenes()) {
    const sim::Scene scene = sim::load_scene(shipped_path(name));
    const sim::SceneInfo i = sim::describe_scene(scene);
    const nlohmann::json device = nlohmann::json::parse(sim::format_scene_info_json(i)).at("device");
    const std::string text = sim::format_scene_info(i);
    EXPECT_EQ(device.at("name"), scene.device.name) << name;
    EXPECT_EQ(device.at("managed"), scene.device.canopen.managed) << name;
    ASSERT_EQ(device.at("axes").size(), scene.device.axes.size()) << name;
    for (std::size_t a = 0; a < scene.device.axes.size(); ++a) {
      EXPECT_EQ(device.at("axes").at(a).at("name"), scene.device.axes[a].name) << name;
      EXPECT_EQ(device.at("axes").at(a).at("rated_torque"), scene.device.axes[a].rated_torque) << name;
    }
    if (!scene.device.canopen.managed) {
      EXPECT_TRUE(device.at("nodes").empty()) << name;
      continue;
    }
    std::vector<int> served(scene.device.canopen.axes.size(), 0);
    for (const nlohmann::json& n : device.at("nodes")) {
      const int id = n.at("node_id");
      const std::string dcf = n.at("dcf");
      std::string line = "    node ";  // the text's line of the node
      line += std::to_string(id);
      line += ':';
      for (int a : n.at("axes")) {
        line += ' ';
        line += device.at("axes").at(a).at("name").get<std::string>();
      }
      if (dcf.empty()) {
        line += " (no DCF)\n";
      } else {
        line += ", DCF ";
        line += dcf;
        line += '\n';
      }
      EXPECT_NE(text.find(line), std::string::npos) << name << ": no line '" << line << "' in\n" << text;
      for (int a : n.at("axes")) {
        ++served.at(static_cast<std::size_t>(a));
        const numen::hal::CanopenAxisConfig& c = scene.device.canopen.axes[static_cast<std::size_t>(a)];
        EXPECT_EQ(c.node_id, id) << name << " axis " << a;
        EXPECT_EQ(c.dcf != nullptr, !dcf.empty()) << name << " axis " << a;
      }
      if (!dcf.empty()) {
        EXPECT_TRUE(std::filesystem::path(dcf).is_absolute()) << dcf;
        EXPECT_TRUE(std::filesystem::exists(dcf)) << dcf;
      }
    }
    for (std::size_t a = 0; a < served.size(); ++a) EXPECT_EQ(served[a], 1) << name << " axis " << a;
  }
}

// Each mesh with its memory: a mesh obstacle (sim/scenes/mesh.toml), a mesh body
// (tests/data/mesh_body.toml), a net's surface (deformable.toml; the default scene has an organ
// net and a mesh obstacle, its rigid core), its bytes the shape's own count; the Model's
// "meshes" group their sum; text and JSON agree.
TEST(SceneInfo, EachMeshWithItsTrianglesAndBytes) {
  std::vector<std::string> paths{shipped_path("mesh"),
                                 std::string(NUMEN_TEST_DATA_DIR) + "/mesh_body.toml"};
  if (core::kWithDeformable) paths.push_back(shipped_path("deformable"));
  if (core::kWithArticulation && core::kWithDeformable) paths.push_back(shipped_path("default"));
  std::vector<std::string> kinds;
  for (const std::string& path : paths) {
    const sim::Scene scene = sim::load_scene(path);
    const core::Model& m = scene.model;
    const sim::SceneInfo i = sim::describe_scene(scene);
    const std::string text = sim::format_scene_info(i);
    const nlohmann::json json = nlohmann::json::parse(sim::format_scene_info_json(i));
    std::size_t shapes = m.meshes.capacity() * sizeof(core::MeshShape);
    std::size_t nets_with_faces = 0;
    for (const core::NetModel& n : m.nets) nets_with_faces += n.face_count > 0 ? 1 : 0;
    ASSERT_EQ(i.meshes.size(), m.meshes.size() + nets_with_faces) << path;
    ASSERT_EQ(json.at("meshes").size(), i.meshes.size()) << path;
    for (std::size_t k = 0; k < i.meshes.size(); ++k) {
      const sim::MeshLine& l = i.meshes[k];
      kinds.push_back(l.kind);
      const nlohmann::json& jl = json.at("meshes").at(k);
      EXPECT_EQ(jl.at("kind"), l.kind);
      EXPECT_EQ(jl.at("name"), l.name);
      EXPECT_EQ(jl.at("triangles"), l.triangles);
      EXPECT_EQ(jl.at("vertices"), l.vertices);
      EXPECT_EQ(jl.at("heap"), l.heap);
      EXPECT_EQ(jl.at("band_heap"), l.band_heap);
      EXPECT_EQ(jl.at("band_width_m"), l.band_width_m);
      EXPECT_EQ(jl.at("band_note"), l.band_note);
      std::string line = "  mesh " + l.kind + " " + l.name + ": " + std::to_string(l.triangles) +
                         " triangles, " + std::to_string(l.vertices);
      EXPECT_NE(text.find(line), std::string::npos) << path << ": no '" << line << "' in\n" << text;
      if (l.kind == "net") {
        const auto n = std::find_if(m.nets.begin(), m.nets.end(),
                                    [&](const core::NetModel& x) { return x.name == l.name; });
        ASSERT_NE(n, m.nets.end()) << l.name;
        EXPECT_EQ(l.triangles, n->face_count);
        // A material net's surface: its nodes but those inside (default.toml's organ).
        const sim::NetLoad& load = scene.net_loads[static_cast<std::size_t>(n - m.nets.begin())];
        EXPECT_EQ(l.vertices, n->node_count - load.interior_nodes);
        EXPECT_EQ(l.heap, static_cast<std::size_t>(n->face_count) * 3 * sizeof(int));
        EXPECT_EQ(l.band_heap, 0u);
        continue;
      }
      int index = -1;  // the shape of the obstacle or body of that name
      for (const core::Obstacle& o : m.obstacles)
        if (l.kind == "obstacle" && o.name == l.name) index = o.mesh;
      for (const core::BodyModel& b : m.bodies)
        if (l.kind == "body" && b.name == l.name) index = b.mesh;
      ASSERT_GE(index, 0) << path << ": " << l.kind << " " << l.name;
      const core::MeshShape& s = m.meshes[static_cast<std::size_t>(index)];
      EXPECT_EQ(l.triangles, s.num_triangles());
      EXPECT_EQ(l.vertices, static_cast<int>(s.vertices.size()));
      EXPECT_EQ(l.heap, s.memory_bytes());
      EXPECT_EQ(l.band_heap, core::mesh_band_bytes(s.band));
      EXPECT_GT(l.band_heap, 0u) << path;  // the shipped meshes have a band
      EXPECT_LT(l.band_heap, l.heap);
      EXPECT_EQ(l.band_width_m, s.band.width);
      EXPECT_GT(l.band_width_m, 0.0);
      shapes += l.heap;
    }
    EXPECT_EQ(i.model_bytes.groups[4].group, std::string("meshes"));
    EXPECT_EQ(i.model_bytes.groups[4].heap_bytes, shapes) << path;
    EXPECT_EQ(json.at("model_bytes").at("groups").at("meshes"), shapes) << path;
  }
  EXPECT_NE(std::find(kinds.begin(), kinds.end(), "obstacle"), kinds.end());
  EXPECT_NE(std::find(kinds.begin(), kinds.end(), "body"), kinds.end());
  if (core::kWithDeformable) {
    EXPECT_NE(std::find(kinds.begin(), kinds.end(), "net"), kinds.end());
  }
}

TEST(SceneInfo, ASceneWithoutMeshesListsNone) {
  const sim::SceneInfo i = sim::describe_scene(sim::load_scene(shipped_path("construction")));
  EXPECT_TRUE(i.meshes.empty());
  EXPECT_TRUE(nlohmann::json::parse(sim::format_scene_info_json(i)).at("meshes").empty());
  EXPECT_EQ(sim::format_scene_info(i).find("  mesh "), std::string::npos);
}

// An organ whose net was simplified from its mesh file: the net's line, then how it was made
// (from how many vertices and triangles, to how many nodes by which rule, in what CPU time), the
// fine surface on it, its largest distance off the net and the map's bytes; --json the same.
TEST(SceneInfo, ASimplifiedOrgansNetAndFineSurface) {
  NUMEN_REQUIRE_DEFORMABLE();
  numen::test::TempDir dir;
  dir.write("fine.obj", numen::test::fine_ellipsoid_obj(4));
  const sim::Scene scene =
      sim::load_scene(dir.write("organ.toml", numen::test::with_organ_mesh_file("fine.obj")));
  const sim::SceneInfo i = sim::describe_scene(scene);
  const auto l = std::find_if(i.meshes.begin(), i.meshes.end(),
                              [](const sim::MeshLine& x) { return x.kind == "net"; });
  ASSERT_NE(l, i.meshes.end());
  EXPECT_EQ(l->vertices, sim::kDefaultNetNodes);
  EXPECT_EQ(l->triangles, 2 * sim::kDefaultNetNodes - 4);
  EXPECT_TRUE(l->simplified);
  EXPECT_EQ(l->nodes_from, "default");
  EXPECT_EQ(l->mesh_vertices, 2562);
  EXPECT_EQ(l->mesh_triangles, 5120);
  EXPECT_EQ(l->fine_vertices, 2562);
  EXPECT_EQ(l->fine_triangles, 5120);
  EXPECT_GT(l->fine_max_distance_m, 0.0);  // core::net_surface_max_offset()
  EXPECT_LT(l->fine_max_distance_m, 0.5e-3);
  EXPECT_GT(l->simplify_cpu_s, 0.0);
  // Embeddings, fine triangles, and per net triangle its list's start and its fine triangles.
  EXPECT_GE(l->map_heap, 2562 * sizeof(core::NetSurfacePoint) + 5120 * 3 * sizeof(int) +
                             static_cast<std::size_t>(l->triangles + 5120) * sizeof(int));
  const std::string text = sim::format_scene_info(i);
  EXPECT_NE(text.find("  mesh net organ: 2044 triangles, 1024 nodes, "), std::string::npos) << text;
  EXPECT_NE(text.find("    simplified from its mesh file (2562 vertices, 5120 triangles) to 1024 "
                      "nodes (the default net size) in "),
            std::string::npos)
      << text;
  EXPECT_NE(text.find(" s of CPU; fine surface 2562 vertices, 5120 triangles, up to "),
            std::string::npos)
      << text;
  const nlohmann::json json = nlohmann::json::parse(sim::format_scene_info_json(i));
  const nlohmann::json& load = json.at("meshes").at(0).at("net_load");
  EXPECT_TRUE(load.at("simplified").get<bool>());
  EXPECT_EQ(load.at("nodes_from"), "default");
  EXPECT_EQ(load.at("mesh_vertices"), 2562);
  EXPECT_EQ(load.at("mesh_triangles"), 5120);
  EXPECT_EQ(load.at("fine_vertices"), 2562);
  EXPECT_EQ(load.at("fine_triangles"), 5120);
  EXPECT_EQ(load.at("fine_max_distance_m").get<double>(), l->fine_max_distance_m);
  EXPECT_EQ(load.at("simplify_cpu_s").get<double>(), l->simplify_cpu_s);
  EXPECT_EQ(load.at("map_heap").get<std::size_t>(), l->map_heap);
}

// `numen info` prints the load's wall-clock time (as the command timed load_scene()) and how many
// simplified nets came from their cache file; untimed (describe_scene() alone), neither.
TEST(SceneInfo, TheLoadsWallClockTimeAndTheNetsReadFromTheirCache) {
  NUMEN_REQUIRE_DEFORMABLE();
  numen::test::TempDir dir;
  dir.write("fine.obj", numen::test::fine_ellipsoid_obj(4));
  const std::string path = dir.write(
      "organ.toml", numen::test::with_organ_mesh_file("fine.obj", "cache = \"fine.nmnet\""));
  sim::SceneInfo made = sim::describe_scene(sim::load_scene(path));
  EXPECT_LT(made.load_wall_s, 0.0);
  EXPECT_EQ(sim::format_scene_info(made).find("  load: "), std::string::npos);
  EXPECT_FALSE(nlohmann::json::parse(sim::format_scene_info_json(made)).contains("load"));
  // The text's load line when the load took `wall_s`.
  const auto expect_load_line = [](sim::SceneInfo& info, double wall_s, const std::string& line) {
    info.load_wall_s = wall_s;
    const std::string text = sim::format_scene_info(info);
    EXPECT_NE(text.find("  load: " + line + "\n"), std::string::npos) << text;
  };
  expect_load_line(made, 2.5,
                   "2.500 s wall clock; organ nets simplified from a mesh file: 1, of which 0 "
                   "read from their cache file");
  sim::SceneInfo read = sim::describe_scene(sim::load_scene(path));  // from the cache file now
  expect_load_line(read, 0.25,
                   "0.250 s wall clock; organ nets simplified from a mesh file: 1, of which 1 "
                   "read from its cache file");
  const nlohmann::json json = nlohmann::json::parse(sim::format_scene_info_json(read));
  EXPECT_EQ(json.at("load").at("wall_s").get<double>(), 0.25);
  EXPECT_EQ(json.at("load").at("nets_simplified"), 1);
  EXPECT_EQ(json.at("load").at("nets_from_cache"), 1);
}

// `numen info` lists every device (docs/scenes.md, "Several devices"): the peg transfer's two,
// each with its CANopen nodes, the bodies its links drive and its grasper; text and JSON agree.
TEST(SceneInfo, EveryDeviceIsListedWithItsNodesBodiesAndGrasper) {
  NUMEN_REQUIRE_ARTICULATION();
  const sim::Scene scene = sim::load_scene(shipped_path("peg_transfer"));
  const sim::SceneInfo i = sim::describe_scene(scene);
  ASSERT_EQ(i.devices.size(), 2u);
  EXPECT_EQ(i.devices[0].name, "left");
  EXPECT_EQ(i.devices[1].name, "right");
  EXPECT_EQ(i.devices[1].kind, "trocar instrument");
  EXPECT_EQ(i.devices[1].axes, 5);
  EXPECT_EQ(i.devices[0].node_ids, (std::vector<int>{1, 2, 3, 4, 5}));
  EXPECT_EQ(i.devices[1].node_ids, (std::vector<int>{6, 7, 8, 9, 10}));
  EXPECT_EQ(i.devices[0].bodies, (std::vector<std::string>{"tube_l", "sleeve_l", "jaw_1_l", "jaw_2_l"}));
  EXPECT_EQ(i.devices[1].bodies, (std::vector<std::string>{"sleeve_r", "tube_r", "jaw_1_r", "jaw_2_r"}));
  EXPECT_EQ(i.devices[0].graspers, (std::vector<std::string>{"left_grasper"}));
  EXPECT_EQ(i.devices[1].graspers, (std::vector<std::string>{"right_grasper"}));
  const std::string text = sim::format_scene_info(i);
  EXPECT_NE(text.find("  devices: 2\n    left: trocar instrument, 5 axes, nodes 1 2 3 4 5; drives tube_l sleeve_l "
                      "jaw_1_l jaw_2_l; grasper left_grasper\n    right: "),
            std::string::npos)
      << text;
  const nlohmann::json j = nlohmann::json::parse(sim::format_scene_info_json(i));
  ASSERT_EQ(j.at("devices").size(), 2u);
  EXPECT_EQ(j.at("devices")[1].at("graspers")[0], "right_grasper");
  EXPECT_EQ(j.at("devices")[1].at("node_ids").size(), 5u);
  // A scene of one device lists it alone.
  EXPECT_EQ(sim::describe_scene(sim::load_scene(shipped_path("construction"))).devices.size(), 1u);
}

// An organ given by its material: `numen info` prints the constants derived from it and its
// contact law's (E*, the strain stiffening, the load patch), and `--json` carries them as the
// net's "material" object (docs/tissue.md, "What `numen info` reports").
TEST(SceneInfo, AnOrganGivenByItsMaterialReportsItsConstants) {
  NUMEN_REQUIRE_DEFORMABLE();
  numen::test::TempDir dir;
  const std::string keys =
      "mesh = \"box\"\nhalf_extents = [0.02, 0.02, 0.01]\nsubdivisions = 6\nyoungs_modulus_kpa = 80.0\n"
      "poisson_ratio = 0.4\nrayleigh_stiffness = 0.001\nsupport_length = 0.02\nstrain_stiffening = 1.5\n";
  const sim::Scene scene =
      sim::load_scene(dir.write("organ.toml", numen::test::indentation_bench_scene(keys, 0.0025, 1e-3)));
  const sim::SceneInfo i = sim::describe_scene(scene);
  const std::string text = sim::format_scene_info(i);
  EXPECT_NE(text.find("    given by its material (docs/tissue.md): "), std::string::npos) << text;
  EXPECT_NE(text.find("; contact E* 95.24 kPa, strain stiffening b 1.5, load patch radius "), std::string::npos)
      << text;
  const nlohmann::json json = nlohmann::json::parse(sim::format_scene_info_json(i));
  const auto mesh = std::find_if(json.at("meshes").begin(), json.at("meshes").end(),
                                 [](const nlohmann::json& m) { return m.contains("material"); });
  ASSERT_NE(mesh, json.at("meshes").end());
  const nlohmann::json& m = mesh->at("material");
  EXPECT_NEAR(m.at("contact_modulus_pa").get<double>(), 80e3 / (1.0 - 0.4 * 0.4), 1e-6);
  EXPECT_EQ(m.at("strain_stiffening").get<double>(), 1.5);
  EXPECT_EQ(m.at("load_patch_radius_m").get<double>(), scene.model.nets[0].load_patch_radius);
  EXPECT_GT(m.at("interior_nodes").get<int>(), 0);
  EXPECT_GT(m.at("tetrahedra").get<int>(), 0);
}
