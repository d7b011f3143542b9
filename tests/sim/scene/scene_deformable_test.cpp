// Tests of sim/scene_deformable (through load_scene): [[deformable]] tables
// compile into core nets (one node per mesh vertex, a structural spring per
// edge, a bending spring per pair of adjacent triangles) tied to a hidden rigid
// component; the shipped deformable and endobag scenes match the mesh
// formulas; the recorded target really goes through the deformable scene's
// post; every error names the file, line, column and dotted key.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include "build_features.hpp"
#include "mesh_text.hpp"
#include "numen/core/mesh.hpp"
#include "numen/core/net_surface_map.hpp"
#include "numen/hal/device/kinematics_factory.hpp"
#include "numen/sim/device/simulated_instrument.hpp"
#include "numen/sim/input/input_error.hpp"
#include "numen/sim/scene/mesh_cache.hpp"
#include "numen/sim/scene/scene.hpp"
#include "scene_text.hpp"
#include "temp_dir.hpp"

namespace {

using numen::test::column_of;
using numen::test::line_of;
using numen::test::load_error;
using numen::test::replace;

using numen::core::Model;
using numen::core::NetModel;
using numen::core::Quat;
using numen::core::Vec3;
using numen::sim::InputError;
using numen::sim::load_scene;
using numen::sim::Scene;
using numen::test::TempDir;

std::string scene_path(const std::string& name) {
  return std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/" + name + ".toml";
}

const Scene& deformable_scene() {
  static const Scene s = load_scene(scene_path("deformable"));
  return s;
}
const Scene& endobag_scene() {
  static const Scene s = load_scene(scene_path("endobag"));
  return s;
}

int body_index(const Model& m, const std::string& name) {
  for (int i = 0; i < m.num_bodies(); ++i)
    if (m.bodies[static_cast<std::size_t>(i)].name == name) return i;
  return -1;
}

/// Node and spring counts of a closed, manifold triangle mesh of V vertices:
/// F = 2V − 4 triangles, E = 3V − 6 edges, one bending pair per edge.
void expect_closed_net_counts(const NetModel& net, const numen::core::TriangleMesh& mesh,
                              int vertices) {
  EXPECT_EQ(net.node_count, vertices);
  EXPECT_EQ(mesh.num_vertices(), vertices);
  EXPECT_EQ(mesh.num_triangles(), 2 * vertices - 4);
  EXPECT_EQ(net.structural_count, 3 * vertices - 6);
  EXPECT_EQ(net.bending_count, 3 * vertices - 6);
  const numen::core::MeshTopology topo = numen::core::build_mesh_topology(mesh);
  EXPECT_EQ(net.structural_count, static_cast<int>(topo.edges.size()));
  EXPECT_EQ(net.bending_count, static_cast<int>(topo.bending_pairs.size()));
  EXPECT_EQ(topo.boundary_edges, 0);
}

// ---------------------------------------------------------------- shipped scenes

TEST(DeformableShippedScene, ProbeIsACapsuleNetOnAHiddenCore) {
  const Scene& s = deformable_scene();
  const Model& m = s.model;
  ASSERT_EQ(m.num_nets(), 1);
  const NetModel& net = m.nets[0];
  EXPECT_EQ(net.name, "probe");
  const int core = body_index(m, "core");
  ASSERT_GE(core, 0);
  EXPECT_EQ(net.body, core);
  EXPECT_EQ(m.bodies[static_cast<std::size_t>(core)].sphere_count, 0) << "the rigid core is hidden";
  EXPECT_EQ(m.initial_held_body, core);
  EXPECT_EQ(m.material_names[static_cast<std::size_t>(net.material)], "silicone");

  // Capsule r = 6 mm, h = 14 mm, 16 segments, 4 rings per hemisphere, and
  // the default cylinder rings round(2h / (π r / 2·4)) − 1 = 11:
  // V = 2 + 16·(2·4 + 11) = 306.
  const int cylinder_rings =
      static_cast<int>(std::lround(2.0 * 0.014 / (std::numbers::pi * 0.006 / 8.0))) - 1;
  EXPECT_EQ(cylinder_rings, 11);
  const auto mesh = numen::core::make_capsule(0.006, 0.014, 16, 4, cylinder_rings);
  expect_closed_net_counts(net, mesh, 2 + 16 * (2 * 4 + cylinder_rings));
  EXPECT_EQ(m.num_nodes(), 306);
  EXPECT_EQ(static_cast<int>(m.net_springs.size()), net.structural_count + net.bending_count);
  for (int i = 0; i < net.node_count; ++i) {
    const auto n = static_cast<std::size_t>(net.node_begin + i);
    ASSERT_TRUE(m.node_rest[n].isApprox(mesh.vertices[static_cast<std::size_t>(i)], 1e-12))
        << "node " << i;
  }
  double mass = 0.0;
  for (double x : m.node_mass) mass += x;
  EXPECT_NEAR(mass, 0.01, 1e-12);
  EXPECT_NEAR(net.mass, 0.01, 1e-12);
  EXPECT_DOUBLE_EQ(net.tie_stiffness, 400.0);
  EXPECT_DOUBLE_EQ(net.tie_damping, 0.2);
  EXPECT_DOUBLE_EQ(m.net_springs[0].stiffness, 200.0);
  EXPECT_DOUBLE_EQ(m.net_springs[static_cast<std::size_t>(net.structural_count)].stiffness, 50.0);
  // The implicit solve's settings of the scene.
  EXPECT_EQ(m.solver.max_iterations, 100);
  EXPECT_DOUBLE_EQ(m.solver.tolerance, 3e-4);
  EXPECT_EQ(m.solver.error_estimate_delay, 1);  // the energy-norm error estimate
}

TEST(DeformableShippedScene, EndobagIsAnIcosphereNetJointedToTheTube) {
  NUMEN_REQUIRE_ARTICULATION();
  const Scene& s = endobag_scene();
  const Model& m = s.model;
  ASSERT_EQ(m.num_nets(), 1);
  const NetModel& net = m.nets[0];
  EXPECT_EQ(net.name, "bag");
  const int core = body_index(m, "bag_core");
  const int tube = body_index(m, "tube");
  ASSERT_GE(core, 0);
  ASSERT_GE(tube, 0);
  EXPECT_EQ(net.body, core);
  EXPECT_EQ(m.bodies[static_cast<std::size_t>(core)].sphere_count, 0);
  // Fixed to the tube: one articulation, so the bag does not collide with
  // the tube and the jaws it encloses.
  EXPECT_EQ(m.num_joints(), 5);
  EXPECT_EQ(m.articulation.body_tree[static_cast<std::size_t>(core)],
            m.articulation.body_tree[static_cast<std::size_t>(tube)]);
  // Icosphere, 2 subdivisions: V = 10·4² + 2 = 162, E = 30·4² = 480.
  const auto mesh = numen::core::make_icosphere(0.012, 2);
  expect_closed_net_counts(net, mesh, 162);
  EXPECT_EQ(net.structural_count, 480);
  // The bag starts 5 mm ahead of the tip, on the tube's axis: 45 mm from the
  // tube's COM (40 mm behind the tip).
  const auto& tube0 = m.bodies[static_cast<std::size_t>(tube)].initial_pose;
  const auto& core0 = m.bodies[static_cast<std::size_t>(core)].initial_pose;
  EXPECT_LT((core0.position - (tube0.position + tube0.orientation * Vec3(0, 0, 0.045))).norm(),
            1e-9);
  // The jaws' spheres (2–11 mm ahead of the tip, radius 1.5 mm, for straight
  // jaws; opened by up to 0.6 rad they stay within 9 mm of the bag's centre)
  // are inside the bag (radius 12 mm, centred 5 mm ahead of the tip).
  for (const char* jaw : {"jaw_1", "jaw_2"}) {
    const int j = body_index(m, jaw);
    ASSERT_GE(j, 0);
    const auto& b = m.bodies[static_cast<std::size_t>(j)];
    for (int i = 0; i < b.sphere_count; ++i) {
      const auto& sp = m.body_spheres[static_cast<std::size_t>(b.sphere_begin + i)];
      // Jaw frame: hinge at the tip, COM 6 mm ahead; worst case the jaw straight ahead.
      const double ahead = 0.006 + sp.center.z();
      EXPECT_LT(std::abs(ahead - 0.005) + sp.radius, 0.012) << jaw << " sphere " << i;
    }
  }
}

/// Distance from p to the segment [a, b].
double segment_distance(const Vec3& p, const Vec3& a, const Vec3& b) {
  const Vec3 ab = b - a;
  const double t = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
  return (p - (a + t * ab)).norm();
}

TEST(DeformableShippedScene, RecordedTargetGoesThroughThePost) {
  // The probe placed where the hand puts it (the core at the device's target,
  // the net in its rest shape) over the recorded motion: its node spheres go
  // deep into the post, and its axis passes through the post itself.
  const Scene& s = deformable_scene();
  const Model& m = s.model;
  const numen::core::Obstacle* post = nullptr;
  for (const auto& o : m.obstacles)
    if (o.name == "post") post = &o;
  ASSERT_NE(post, nullptr);
  ASSERT_EQ(post->type, numen::core::ShapeType::kCapsule);
  const Vec3 axis = post->pose.orientation * Vec3::UnitZ();
  const Vec3 pa = post->pose.position - post->half_length * axis;
  const Vec3 pb = post->pose.position + post->half_length * axis;
  const auto kin = numen::hal::make_kinematics(s.device);
  const NetModel& net = m.nets[0];

  double deepest = 0.0, deepest_time = -1.0, axis_inside = 0.0;
  double first_contact = -1.0;
  for (std::size_t k = 0; k < s.trajectory.size(); k += 5) {
    const auto& sample = s.trajectory[k];
    const numen::core::Pose core =
        kin->forward(numen::sim::instrument_axes(s.device, *kin, sample));
    double depth = 0.0;
    for (int i = net.node_begin; i < net.node_begin + net.node_count; ++i) {
      const auto n = static_cast<std::size_t>(i);
      const Vec3 x = core.position + core.orientation * m.node_rest[n];
      depth = std::max(depth, post->radius + m.node_radius[n] - segment_distance(x, pa, pb));
    }
    // The probe's axis: the capsule's segment along the core's z.
    for (double z = -0.014; z <= 0.014 + 1e-12; z += 0.001) {
      const Vec3 x = core.position + core.orientation * Vec3(0.0, 0.0, z);
      axis_inside = std::max(axis_inside, post->radius - segment_distance(x, pa, pb));
    }
    if (depth > 0.0 && first_contact < 0.0) first_contact = sample.time;
    if (depth > deepest) {
      deepest = depth;
      deepest_time = sample.time;
    }
  }
  std::printf(
      "[   info   ] target probe vs post: first contact at %.2f s, deepest %.2f mm at %.2f s; "
      "probe axis %.2f mm inside the post\n",
      first_contact, deepest * 1e3, deepest_time, axis_inside * 1e3);
  // A hollow net's node spheres reach at most post radius + node radius
  // (~6.4 mm) into a 5 mm post: when a node sits on its axis.
  EXPECT_GE(deepest, 0.006) << "the hand's probe must go deep into the post";
  EXPECT_GT(axis_inside, 0.002) << "the probe's axis must pass through the post";
  // First met on the lateral sweep at 2.5–3.5 s (the run tests run 10 s).
  EXPECT_GT(first_contact, 2.5);
  EXPECT_LT(first_contact, 3.5);
  // The core starts where the device puts it.
  const numen::core::Pose start =
      kin->forward(numen::sim::instrument_axes(s.device, *kin, s.trajectory.at(0.0)));
  EXPECT_LT(
      (m.bodies[static_cast<std::size_t>(net.body)].initial_pose.position - start.position).norm(),
      1e-9);
}

// ---------------------------------------------------------------- loader

// A small valid scene: a held tool with a sphere, a hidden core body and one
// deformable on it. Every error test changes one thing.
const std::string kMiniNet = R"(name = "mini"
dt = 0.001
gravity = [0.0, 0.0, 0.0]

[[material]]
name = "steel"

[[material]]
name = "rubber"

[[body]]
name = "tool"
mass = 0.1
material = "steel"
spheres = [[0.0, 0.0, 0.0, 0.01]]
[body.coupling]
stiffness = 100.0
damping_ratio = 0.85

[[body]]
name = "core"
mass = 0.05
inertia = [1.0e-5, 1.0e-5, 1.0e-5]
material = "rubber"
position = [0.0, 0.1, 0.0]

[[deformable]]
name = "skin"
body = "core"
mesh = "icosphere"
radius = 0.01
subdivisions = 1
mass = 0.01
stiffness = 200.0
tie_stiffness = 500.0

[[obstacle]]
name = "floor"
type = "plane"
point = [0.0, 0.0, -0.1]
normal = [0.0, 0.0, 1.0]

[device]
kind = "pose-tracker"
attach = "tool"

[trajectory]
source = "scripted"
start = { position = [0.0, 0.0, 0.0] }

[[trajectory.segment]]
type = "hold"
duration = 0.25
)";

/// The [[deformable]] table of kMiniNet replaced by `table` (which starts with "[[deformable]]").
std::string with_deformable(const std::string& table) {
  const auto begin = kMiniNet.find("[[deformable]]");
  const auto end = kMiniNet.find("[[obstacle]]");
  return kMiniNet.substr(0, begin) + table + "\n" + kMiniNet.substr(end);
}

/// Expects the error of `text` at the value of the first line containing
/// `needle` (column of `value` there), with dotted key `key` and `phrase` in
/// the message; the formatted what() carries file:line:column: key. `fine_obj`, when not empty,
/// is written beside the scene as fine.obj.
void expect_error_at(const std::string& text, const std::string& needle, const std::string& value,
                     const std::string& key, const std::string& phrase,
                     const std::string& fine_obj = "") {
  TempDir dir;
  if (!fine_obj.empty()) dir.write("fine.obj", fine_obj);
  const InputError e = load_error(dir, text);
  EXPECT_EQ(e.file(), (dir / "bad.toml").string());
  EXPECT_EQ(e.line(), line_of(text, needle)) << e.what();
  EXPECT_EQ(e.column(), column_of(text, needle, value)) << e.what();
  EXPECT_EQ(e.key(), key) << e.what();
  EXPECT_NE(e.message().find(phrase), std::string::npos) << e.what();
  const std::string where = e.file() + ":" + std::to_string(e.line()) + ":" +
                            std::to_string(e.column()) + ": " + key + ": ";
  EXPECT_EQ(std::string(e.what()).rfind(where, 0), 0u) << e.what();
}

TEST(DeformableLoader, MiniSceneLoadsWithDefaults) {
  TempDir dir;
  const Scene s = load_scene(dir.write("mini.toml", kMiniNet));
  ASSERT_EQ(s.model.num_nets(), 1);
  const NetModel& net = s.model.nets[0];
  EXPECT_EQ(net.name, "skin");
  EXPECT_EQ(net.body, 1);
  EXPECT_EQ(net.node_count, 42);  // 10·4 + 2
  EXPECT_EQ(net.structural_count, 120);
  EXPECT_EQ(net.bending_count, 120);
  // Defaults: the core's material, no damping, no bending, node radius from the mesh.
  EXPECT_EQ(s.model.material_names[static_cast<std::size_t>(net.material)], "rubber");
  EXPECT_EQ(net.tie_damping, 0.0);
  for (int i = 0; i < net.structural_count; ++i)
    EXPECT_EQ(s.model.net_springs[static_cast<std::size_t>(net.spring_begin + i)].damping, 0.0);
  for (int i = 0; i < net.bending_count; ++i)
    EXPECT_EQ(
        s.model.net_springs[static_cast<std::size_t>(net.spring_begin + net.structural_count + i)]
            .stiffness,
        0.0);
  for (double r : s.model.node_radius) {
    EXPECT_GT(r, 0.002);
    EXPECT_LT(r, 0.006);
  }
  EXPECT_EQ(net.rest_speed, 3e-5);  // resting nodes (core::NetSettings' default)
}

TEST(DeformableLoader, RestSpeedSetsOrSwitchesOffTheNetsRestingNodes) {
  TempDir dir;
  const std::string off =
      replace(kMiniNet, "tie_stiffness = 500.0", "tie_stiffness = 500.0\nrest_speed = 0.0");
  EXPECT_EQ(load_scene(dir.write("off.toml", off)).model.nets[0].rest_speed, 0.0);
  const std::string set =
      replace(kMiniNet, "tie_stiffness = 500.0", "tie_stiffness = 500.0\nrest_speed = 1e-4");
  EXPECT_EQ(load_scene(dir.write("set.toml", set)).model.nets[0].rest_speed, 1e-4);
  expect_error_at(
      replace(kMiniNet, "tie_stiffness = 500.0", "tie_stiffness = 500.0\nrest_speed = -1e-6"),
      "rest_speed = ", "-1e-6", "deformable[0].rest_speed", "must be in");
}

TEST(DeformableLoader, MeshKindsScaleAndPlacement) {
  TempDir dir;
  // A unit tetrahedron (outward winding), 2 cm after scaling; its path is
  // relative to the scene file's folder.
  std::filesystem::create_directories(dir / "meshes");
  dir.write("meshes/tet.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n");
  const std::string text = with_deformable(R"([[deformable]]
name = "ball"
body = "core"
mesh = "icosphere"
radius = 0.01
subdivisions = 0
position = [0.0, 0.0, 0.05]
orientation = [0.7071067811865476, 0.7071067811865476, 0.0, 0.0]
scale = [1.0, 2.0, 1.0]
mass = 0.01
stiffness = 200.0
tie_stiffness = 500.0
node_radius = 0.003
material = "steel"

[[deformable]]
name = "pill"
body = "core"
mesh = "capsule"
radius = 0.005
half_length = 0.01
segments = 8
rings = 2
cylinder_rings = 3
mass = 0.01
stiffness = 200.0
damping = 0.1
bending_stiffness = 10.0
bending_damping = 0.01
tie_stiffness = 500.0
tie_damping = 0.2

[[deformable]]
name = "brick"
body = "core"
mesh = "box"
half_extents = [0.01, 0.02, 0.03]
subdivisions = 1
mass = 0.01
stiffness = 200.0
tie_stiffness = 500.0

[[deformable]]
name = "tet"
body = "core"
mesh = "obj"
file = "meshes/tet.obj"
scale = [0.02, 0.02, 0.02]
mass = 0.01
stiffness = 200.0
tie_stiffness = 500.0
)");
  const Scene s = load_scene(dir.write("kinds.toml", text));
  const Model& m = s.model;
  ASSERT_EQ(m.num_nets(), 4);
  // Icosphere s = 0: 12 vertices, scaled 2× along y, turned 90° about x
  // (y → z), centred 5 cm along the core's z.
  EXPECT_EQ(m.nets[0].node_count, 12);
  auto expected = numen::core::make_icosphere(0.01, 0);
  double ymax0 = 0.0;
  for (const Vec3& v : expected.vertices) ymax0 = std::max(ymax0, v.y());
  numen::core::transform_mesh(
      expected, Vec3(1.0, 2.0, 1.0),
      numen::core::Pose{Vec3(0.0, 0.0, 0.05), Quat(std::sqrt(0.5), std::sqrt(0.5), 0.0, 0.0)});
  double zmax = -1.0;
  for (int i = 0; i < 12; ++i) {
    const Vec3& r = m.node_rest[static_cast<std::size_t>(i)];
    EXPECT_TRUE(r.isApprox(expected.vertices[static_cast<std::size_t>(i)], 1e-12))
        << "vertex " << i;
    zmax = std::max(zmax, r.z() - 0.05);
    EXPECT_DOUBLE_EQ(m.node_radius[static_cast<std::size_t>(i)], 0.003);
  }
  EXPECT_NEAR(zmax, 2.0 * ymax0, 1e-12);  // the axis scaled 2×, turned from y onto z
  EXPECT_EQ(m.material_names[static_cast<std::size_t>(m.nets[0].material)], "steel");
  // Capsule: V = 2 + 8·(2·2 + 3) = 58.
  EXPECT_EQ(m.nets[1].node_count, 58);
  EXPECT_EQ(m.nets[1].structural_count, 3 * 58 - 6);
  EXPECT_DOUBLE_EQ(m.nets[1].tie_damping, 0.2);
  // Box n = 1: 6(n+2)² − 12(n+2) + 8 = 26 vertices.
  EXPECT_EQ(m.nets[2].node_count, 26);
  // OBJ tetrahedron: 4 nodes, 6 edges, no bending pair (each edge's two
  // opposite vertices form another edge: skipped, not doubled).
  EXPECT_EQ(m.nets[3].node_count, 4);
  EXPECT_EQ(m.nets[3].structural_count, 6);
  EXPECT_EQ(m.nets[3].bending_count, 0);
  const Vec3& tip = m.node_rest[static_cast<std::size_t>(m.nets[3].node_begin + 3)];
  EXPECT_TRUE(tip.isApprox(Vec3(0.0, 0.0, 0.02), 1e-12)) << tip.transpose();
  EXPECT_EQ(m.num_nodes(), 12 + 58 + 26 + 4);
}

TEST(DeformableLoader, ABoxTakesItsSubdivisionsPerAxis) {
  const std::string box =
      "mesh = \"box\"\nhalf_extents = [0.012, 0.010, 0.004]\nsubdivisions = [23, 23, 2]";
  TempDir dir;
  const Scene s = load_scene(
      dir.write("pad.toml", replace(kMiniNet, "mesh = \"icosphere\"\nradius = 0.01\nsubdivisions = 1", box)));
  // (23 + 2)(23 + 2)(2 + 2) − 23·23·2 nodes: the suturing scene's pad.
  EXPECT_EQ(s.model.nets[0].node_count, 25 * 25 * 4 - 23 * 23 * 2);
  const numen::core::TriangleMesh mesh =
      numen::core::make_box(Vec3(0.012, 0.010, 0.004), std::array<int, 3>{23, 23, 2});
  EXPECT_EQ(mesh.num_vertices(), s.model.nets[0].node_count);
  EXPECT_EQ(mesh.num_triangles(), 2 * mesh.num_vertices() - 4);  // closed, genus 0
  EXPECT_EQ(s.model.nets[0].structural_count, 3 * mesh.num_vertices() - 6);
}

// ---------------------------------------------------------------- errors

TEST(DeformableLoaderErrors, UnknownBody) {
  const std::string text = replace(kMiniNet, "body = \"core\"", "body = \"kore\"");
  expect_error_at(text, "body = \"kore\"", "\"kore\"", "deformable[0].body",
                  "no body named \"kore\"");
}

TEST(DeformableLoaderErrors, BodyWithSpheresIsRejected) {
  const std::string text = replace(kMiniNet, "body = \"core\"", "body = \"tool\"");
  expect_error_at(text, "body = \"tool\"", "\"tool\"", "deformable[0].body", "hidden");
  TempDir dir;
  const InputError e = load_error(dir, text);
  EXPECT_NE(e.message().find("does not collide"), std::string::npos) << e.what();
  EXPECT_NE(e.message().find("spheres"), std::string::npos) << e.what();
}

TEST(DeformableLoaderErrors, SolverErrorEstimateDelayOutOfRange) {
  const std::string solver = "[solver]\ntolerance = 1.0e-3\nerror_estimate_delay = ";
  const std::string text = replace(kMiniNet, "[[material]]", solver + "9\n\n[[material]]");
  expect_error_at(text, "error_estimate_delay = 9", "9", "solver.error_estimate_delay",
                  "must be in [0, 8]");
  TempDir dir;
  const Scene s = load_scene(
      dir.write("delay.toml", replace(kMiniNet, "[[material]]", solver + "0\n\n[[material]]")));
  EXPECT_EQ(s.model.solver.error_estimate_delay, 0);  // the residual rule
  EXPECT_EQ(load_scene(dir.write("mini.toml", kMiniNet)).model.solver.error_estimate_delay,
            numen::core::SolverSettings{}.error_estimate_delay);
}

TEST(DeformableLoaderErrors, SolverErrorToleranceOutOfRange) {
  const std::string solver = "[solver]\ntolerance = 1.0e-4\nerror_tolerance = ";
  expect_error_at(replace(kMiniNet, "[[material]]", solver + "0.0\n\n[[material]]"),
                  "error_tolerance = 0.0", "0.0", "solver.error_tolerance", "must be in");
  expect_error_at(replace(kMiniNet, "[[material]]", solver + "2.0\n\n[[material]]"),
                  "error_tolerance = 2.0", "2.0", "solver.error_tolerance", "must be in");
  TempDir dir;
  const Scene s = load_scene(
      dir.write("error.toml", replace(kMiniNet, "[[material]]", solver + "3.0e-4\n\n[[material]]")));
  EXPECT_EQ(s.model.solver.tolerance, 1e-4);
  EXPECT_EQ(s.model.solver.error_tolerance, 3e-4);
  // Unset: ≤ 0, the error rule takes `tolerance`.
  EXPECT_LE(load_scene(dir.write("mini.toml", kMiniNet)).model.solver.error_tolerance, 0.0);
}

TEST(DeformableLoaderErrors, UnknownMeshKind) {
  const std::string text = replace(kMiniNet, "mesh = \"icosphere\"", "mesh = \"torus\"");
  expect_error_at(text, "mesh = \"torus\"", "\"torus\"", "deformable[0].mesh",
                  "\"icosphere\", \"capsule\", \"box\", \"obj\"");
}

TEST(DeformableLoaderErrors, MeshTooLargeIsRefusedBeforeItIsBuilt) {
  const std::string text =
      replace(kMiniNet, "mesh = \"icosphere\"\nradius = 0.01\nsubdivisions = 1",
              "mesh = \"capsule\"\nradius = 0.01\nhalf_length = 0.02\nsegments = 1024\n"
              "rings = 256\ncylinder_rings = 100000");
  expect_error_at(text, "mesh = \"capsule\"", "\"capsule\"", "deformable[0].mesh",
                  "more than the 65536");
}

TEST(DeformableLoaderErrors, MissingObjFile) {
  const std::string text = replace(kMiniNet, "mesh = \"icosphere\"\nradius = 0.01\nsubdivisions = 1",
                                   "mesh = \"obj\"\nfile = \"nowhere/probe.obj\"");
  expect_error_at(text, "file = ", "\"nowhere", "deformable[0].file", "mesh file not found");
  TempDir dir;
  const InputError e = load_error(dir, text);
  // The path is resolved against the scene file's folder.
  EXPECT_NE(e.message().find((dir / "nowhere/probe.obj").string()), std::string::npos) << e.what();
}

// A directory given as the mesh file said "mesh file not found": it says it is a directory.
TEST(DeformableLoaderErrors, ObjFileThatIsADirectoryIsNamedAsSuch) {
  const std::string text = replace(kMiniNet, "mesh = \"icosphere\"\nradius = 0.01\nsubdivisions = 1",
                                   "mesh = \"obj\"\nfile = \"meshes\"");
  TempDir dir;
  std::filesystem::create_directories(dir / "meshes");
  const InputError e = load_error(dir, text);
  EXPECT_EQ(e.line(), line_of(text, "file = "));
  EXPECT_EQ(e.column(), column_of(text, "file = ", "\"meshes"));
  EXPECT_EQ(e.key(), "deformable[0].file");
  EXPECT_EQ(e.message(), (dir / "meshes").string() + " is a directory, not a mesh file");
}

TEST(DeformableLoaderErrors, BadObjFileNamesTheSceneKey) {
  TempDir dir;
  dir.write("empty.obj", "# no faces\nv 0 0 0\n");
  const std::string text = replace(kMiniNet, "mesh = \"icosphere\"\nradius = 0.01\nsubdivisions = 1",
                                   "mesh = \"obj\"\nfile = \"empty.obj\"");
  const InputError e = load_error(dir, text);
  EXPECT_EQ(e.line(), line_of(text, "file = "));
  EXPECT_EQ(e.key(), "deformable[0].file");
  EXPECT_NE(e.message().find("empty.obj"), std::string::npos) << e.what();
}

TEST(DeformableLoaderErrors, BadNumbers) {
  expect_error_at(replace(kMiniNet, "mass = 0.01", "mass = -0.01"), "mass = -0.01", "-0.01",
                  "deformable[0].mass", "must be in");
  expect_error_at(replace(kMiniNet, "stiffness = 200.0", "stiffness = \"stiff\""),
                  "stiffness = \"stiff\"", "\"stiff\"", "deformable[0].stiffness",
                  "expected a number");
  expect_error_at(replace(kMiniNet, "tie_stiffness = 500.0", "tie_stiffness = 0.0"),
                  "tie_stiffness = 0.0", "0.0", "deformable[0].tie_stiffness", "must be in");
  expect_error_at(replace(kMiniNet, "subdivisions = 1", "subdivisions = 7"), "subdivisions = 7", "7",
                  "deformable[0].subdivisions", "[0, 6]");
  expect_error_at(replace(kMiniNet, "subdivisions = 1", "subdivisions = 1.5"), "subdivisions = 1.5",
                  "1.5", "deformable[0].subdivisions", "expected an integer");
  expect_error_at(replace(kMiniNet, "radius = 0.01\nsubdivisions", "radius = 0.0\nsubdivisions"),
                  "radius = 0.0", "0.0", "deformable[0].radius", "must be in");
  expect_error_at(replace(kMiniNet, "tie_stiffness = 500.0", "tie_stiffness = 500.0\ndamping = -1.0"),
                  "damping = -1.0", "-1.0", "deformable[0].damping", "must be in");
  expect_error_at(
      replace(kMiniNet, "tie_stiffness = 500.0", "tie_stiffness = 500.0\nscale = [1.0, 0.0, 1.0]"),
      "scale = ", "[", "deformable[0].scale", "non-zero");
  expect_error_at(
      replace(kMiniNet, "tie_stiffness = 500.0", "tie_stiffness = 500.0\nposition = [1.0, 2.0]"),
      "position = [1.0, 2.0]", "[", "deformable[0].position", "expected 3 numbers");
  expect_error_at(
      replace(kMiniNet, "tie_stiffness = 500.0", "tie_stiffness = 500.0\nnode_radius = -0.001"),
      "node_radius = ", "-0.001", "deformable[0].node_radius", "must be in");
}

TEST(DeformableLoaderErrors, BadBoxSubdivisionsAreLocated) {
  const std::string box = "mesh = \"box\"\nhalf_extents = [0.012, 0.010, 0.004]\nsubdivisions = ";
  const std::string ico = "mesh = \"icosphere\"\nradius = 0.01\nsubdivisions = 1";
  expect_error_at(replace(kMiniNet, ico, box + "[23, 23]"), "subdivisions = [23, 23]", "[",
                  "deformable[0].subdivisions", "expected 3 numbers");
  expect_error_at(replace(kMiniNet, ico, box + "[23, -1, 2]"), "subdivisions = [23, -1, 2]", "[",
                  "deformable[0].subdivisions", "entry 1 is -1");
  expect_error_at(replace(kMiniNet, ico, box + "[23, 2.5, 2]"), "subdivisions = [23, 2.5, 2]", "[",
                  "deformable[0].subdivisions", "entry 1 is 2.5");
  expect_error_at(replace(kMiniNet, ico, box + "[256, 256, 256]"), "subdivisions = [256", "[",
                  "deformable[0].subdivisions", "more than the 65536");
  expect_error_at(replace(kMiniNet, ico, box + "257"), "subdivisions = 257", "257",
                  "deformable[0].subdivisions", "[0, 256]");
}

TEST(DeformableLoaderErrors, MissingRequiredKeys) {
  // A missing key points at the table ([[deformable]] header line).
  for (const char* key : {"mass = 0.01\n", "stiffness = 200.0\n", "tie_stiffness = 500.0\n",
                          "radius = 0.01\n", "body = \"core\"\n", "name = \"skin\"\n"}) {
    const std::string line(key);
    const std::string text = replace(kMiniNet, "\n" + line, "\n");
    TempDir dir;
    const InputError e = load_error(dir, text);
    EXPECT_EQ(e.line(), line_of(text, "[[deformable]]")) << e.what();
    EXPECT_EQ(e.key(), "deformable[0]." + line.substr(0, line.find(' '))) << e.what();
    EXPECT_NE(e.message().find("missing"), std::string::npos) << e.what();
  }
}

TEST(DeformableLoaderErrors, UnknownKey) {
  expect_error_at(replace(kMiniNet, "tie_stiffness = 500.0", "tie_stiffnes = 500.0"), "tie_stiffnes",
                  "500.0", "deformable[0].tie_stiffnes", "unknown key");
  // A key of another mesh kind is unknown here too.
  expect_error_at(replace(kMiniNet, "subdivisions = 1", "subdivisions = 1\nhalf_length = 0.01"),
                  "half_length", "0.01", "deformable[0].half_length", "unknown key");
  // And [[deformable]] itself is known at the top level.
  TempDir dir;
  EXPECT_NO_THROW((void)load_scene(dir.write("ok.toml", kMiniNet)));
}

TEST(DeformableLoaderErrors, DuplicateName) {
  const std::string text = with_deformable(R"([[deformable]]
name = "skin"
body = "core"
mesh = "icosphere"
radius = 0.01
mass = 0.01
stiffness = 200.0
tie_stiffness = 500.0

[[deformable]]
name = "skin"
body = "core"
mesh = "icosphere"
radius = 0.02
mass = 0.01
stiffness = 200.0
tie_stiffness = 500.0
)");
  TempDir dir;
  const InputError e = load_error(dir, text);
  EXPECT_EQ(e.key(), "deformable[1].name");
  EXPECT_NE(e.message().find("declared twice"), std::string::npos) << e.what();
}

TEST(DeformableLoaderErrors, CoreRejectionIsLocatedAtTheDeformablesTable) {
  // A scale that flattens the sphere to ~1e-300 m along x: every triangle is
  // degenerate; core::add_net's message lands on the [[deformable]] table.
  const std::string text = replace(kMiniNet, "tie_stiffness = 500.0",
                                   "tie_stiffness = 500.0\nscale = [1.0e-300, 1.0, 1.0]");
  TempDir dir;
  const InputError e = load_error(dir, text);
  EXPECT_EQ(e.line(), line_of(text, "[[deformable]]")) << e.what();
  EXPECT_EQ(e.key(), "deformable[0]") << e.what();
  EXPECT_NE(e.message().find("net 'skin'"), std::string::npos) << e.what();
  EXPECT_NE(e.message().find("mesh"), std::string::npos) << e.what();
}

TEST(DeformableLoaderErrors, UnknownMaterial) {
  const std::string text =
      replace(kMiniNet, "tie_stiffness = 500.0", "tie_stiffness = 500.0\nmaterial = \"gold\"");
  expect_error_at(text, "material = \"gold\"", "\"gold\"", "deformable[0].material",
                  "unknown material");
}

// ---------------------------------------------------------------- net size of a mesh file

// A fine organ surface from a mesh file, simplified into a coarser net at load (docs/fine-surface.md):
// kMiniNet's deformable made of fine.obj (the 35 × 25 × 20 mm
// ellipsoid, 2562 vertices, in mm), placed off the core's origin, with `keys` added.
std::string fine_organ_scene(const std::string& keys) {
  return replace(kMiniNet, "mesh = \"icosphere\"\nradius = 0.01\nsubdivisions = 1",
                 "mesh = \"file\"\nfile = \"fine.obj\"\nunits = \"mm\"\nposition = [0.005, 0.0, "
                 "0.0]\norientation = [0.9238795, 0.0, 0.3826834, 0.0]" +
                     (keys.empty() ? "" : "\n" + keys));
}

/// Loads fine_organ_scene(keys) with fine.obj (fine_ellipsoid_obj(4, holes, spike)) beside it.
Scene load_fine_organ(const std::string& keys, int holes = 0, double spike = 1.0) {
  TempDir dir;
  dir.write("fine.obj", numen::test::fine_ellipsoid_obj(4, holes, spike));
  return load_scene(dir.write("organ.toml", fine_organ_scene(keys)));
}

/// The net of `s` (its one net) is closed and manifold with `nodes` nodes, and the fine ellipsoid
/// (2562 vertices, 5120 triangles) rides on it, every fine vertex within `distance` m of it.
void expect_fine_ellipsoid_on_net(const Scene& s, int nodes, double distance) {
  ASSERT_EQ(s.model.num_nets(), 1);
  const NetModel& net = s.model.nets[0];
  ASSERT_EQ(s.net_triangles.size(), 1u);
  numen::core::TriangleMesh rest;
  rest.vertices.assign(s.model.node_rest.begin() + net.node_begin,
                       s.model.node_rest.begin() + net.node_begin + net.node_count);
  rest.triangles = s.net_triangles[0];
  EXPECT_EQ(numen::core::validate_mesh(rest), "");  // no edge in more than two triangles
  // Closed (no edge on one triangle), genus 0: F = 2V − 4, E = 3V − 6. (A coarse net has fewer
  // bending springs than edges: a pair that is also an edge is skipped, core::build_mesh_topology.)
  const numen::core::MeshTopology topo = numen::core::build_mesh_topology(rest);
  EXPECT_EQ(topo.boundary_edges, 0);
  EXPECT_EQ(net.node_count, nodes);
  EXPECT_EQ(rest.num_triangles(), 2 * nodes - 4);
  EXPECT_EQ(static_cast<int>(topo.edges.size()), 3 * nodes - 6);
  EXPECT_EQ(net.structural_count, 3 * nodes - 6);
  EXPECT_EQ(net.bending_count, static_cast<int>(topo.bending_pairs.size()));
  EXPECT_EQ(net.surface_point_count, 2562);
  EXPECT_EQ(net.surface_face_count, 5120);
  const double offset = numen::core::net_surface_max_offset(s.model, 0);
  EXPECT_GT(offset, 0.0);
  EXPECT_LT(offset, distance);
  ASSERT_EQ(s.net_loads.size(), 1u);
  EXPECT_TRUE(s.net_loads[0].simplified);
  EXPECT_EQ(s.net_loads[0].mesh_vertices, 2562);
  EXPECT_EQ(s.net_loads[0].mesh_triangles, 5120);
  EXPECT_EQ(s.net_loads[0].nodes_asked, nodes);
}

// A mesh file of more vertices than the default net size gets a net of that size; the fine
// surface is given in the net's frame (placed and turned like the net: a frame mismatch would put
// it millimetres off).
TEST(DeformableNetSize, FineMeshFileGetsTheDefaultNetSize) {
  const Scene s = load_fine_organ("");
  expect_fine_ellipsoid_on_net(s, numen::sim::kDefaultNetNodes, 0.5e-3);
  EXPECT_EQ(s.net_loads[0].nodes_from, "default");
}

TEST(DeformableNetSize, NodesSetsTheNetSize) {
  const Scene s = load_fine_organ("nodes = 300");
  expect_fine_ellipsoid_on_net(s, 300, 1.0e-3);
  EXPECT_EQ(s.net_loads[0].nodes_from, "nodes");
  // The mesh's own vertex count is the mesh itself: no fine surface.
  const Scene own = load_fine_organ("nodes = 2562");
  EXPECT_EQ(own.model.nets[0].node_count, 2562);
  EXPECT_EQ(own.model.nets[0].surface_point_count, 0);
  EXPECT_TRUE(own.model.net_surface_points.empty());
  EXPECT_FALSE(own.net_loads[0].simplified);
}

// edge_length L (m) asks for the node count of equilateral triangles of side L tiling the
// surface: 2 A / (√3 L²) + 2.
TEST(DeformableNetSize, EdgeLengthSetsTheNetSize) {
  const Scene s = load_fine_organ("edge_length = 0.004");
  const NetModel& net = s.model.nets[0];
  double area = 0.0;  // of the fine surface at rest: its triangles' areas
  numen::core::TriangleMesh fine = numen::core::make_icosphere(1.0, 4);
  for (Vec3& v : fine.vertices) v = Vec3(0.035 * v.x(), 0.025 * v.y(), 0.020 * v.z());
  for (double a : numen::core::vertex_areas(fine)) area += a;
  const int nodes = static_cast<int>(std::lround(2.0 * area / (std::sqrt(3.0) * 0.004 * 0.004))) + 2;
  expect_fine_ellipsoid_on_net(s, nodes, 1.0e-3);
  EXPECT_EQ(s.net_loads[0].nodes_from, "edge_length");
  double sum = 0.0;  // the structural springs' rest lengths are the net's edges
  for (int i = 0; i < net.structural_count; ++i)
    sum += s.model.net_springs[static_cast<std::size_t>(net.spring_begin + i)].rest_length;
  EXPECT_NEAR(sum / net.structural_count, 0.004, 0.001);
  // A length finer than the mesh's own edges is the mesh itself.
  const Scene own = load_fine_organ("edge_length = 0.0005");
  EXPECT_EQ(own.model.nets[0].node_count, 2562);
  EXPECT_EQ(own.model.nets[0].surface_point_count, 0);
}

// The shipped organ (1002 vertices) is simplified to the 500-node surface net its `nodes` asks for,
// the mesh its fine surface (every vertex mapped), and given its material: 80 nodes inside the
// surface (580 in all).
TEST(DeformableNetSize, ShippedOrganIsSimplifiedToItsNodesWithTheMeshAsItsFineSurface) {
  NUMEN_REQUIRE_ARTICULATION();  // the default scene's instrument has joints
  const Scene s = load_scene(scene_path("default"));
  ASSERT_EQ(s.model.num_nets(), 1);
  ASSERT_EQ(s.net_loads.size(), 1u);
  EXPECT_EQ(s.net_loads[0].mesh_vertices, 1002);
  EXPECT_TRUE(s.net_loads[0].simplified);
  EXPECT_EQ(s.net_loads[0].nodes_from, "nodes");
  EXPECT_EQ(s.net_loads[0].nodes_asked, 500);
  EXPECT_TRUE(s.net_loads[0].material);
  EXPECT_EQ(s.model.nets[0].node_count, 500 + s.net_loads[0].interior_nodes);
  EXPECT_EQ(s.net_loads[0].interior_nodes, 80);
  EXPECT_EQ(s.model.nets[0].surface_point_count, 1002);
  EXPECT_EQ(s.model.net_surface_points.size(), 1002u);
}

// A fine surface standing off its net by more than the smaller of half the net's mean edge
// length and 2 % of the organ's size is a load warning with the distance, and only then: the
// ellipsoid at a handful of nodes and at 300, and one with a thin spike (a vertex 3 times as far
// out) that a coarse net cuts off. The organ's share does not grow with a coarser net's edge: a
// net so coarse that its surface is millimetres off, within half its long edges, is warned too.
TEST(DeformableNetSize, FarFineSurfaceIsAWarningWithTheDistance) {
  int within_half_edge = 0;  // warned cases the half edge alone would have let through
  for (const int nodes : {4, 12, 40, 300, -12}) {
    const double spike = nodes < 0 ? 3.0 : 1.0;
    const Scene s = load_fine_organ("nodes = " + std::to_string(std::abs(nodes)), 0, spike);
    const NetModel& net = s.model.nets[0];
    double sum = 0.0;
    for (int i = 0; i < net.structural_count; ++i)
      sum += s.model.net_springs[static_cast<std::size_t>(net.spring_begin + i)].rest_length;
    const double half_edge = 0.5 * sum / net.structural_count;
    // The organ's size: the longest side of the placed fine surface's bounding box.
    numen::core::TriangleMesh fine = numen::core::make_icosphere(1.0, 4);
    fine.vertices.front() *= spike;
    const Quat q(0.9238795, 0.0, 0.3826834, 0.0);
    Vec3 lo = Vec3::Constant(1e9), hi = -lo;
    for (const Vec3& v : fine.vertices) {
      const Vec3 p = q.normalized() * Vec3(0.035 * v.x(), 0.025 * v.y(), 0.020 * v.z());
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
    const double bound = std::min(half_edge, 0.02 * (hi - lo).maxCoeff());  // kMaxFineOffsetShare
    const double offset = numen::core::net_surface_max_offset(s.model, 0);
    if (offset > bound && offset <= half_edge) ++within_half_edge;
    std::printf("[   info   ] %d nodes: offset %.3f mm, half edge %.3f mm, bound %.3f mm\n", nodes,
                offset * 1e3, half_edge * 1e3, bound * 1e3);
    const auto w = std::find_if(s.warnings.begin(), s.warnings.end(), [](const std::string& x) {
      return x.find("mm off the net simplified from it") != std::string::npos;
    });
    EXPECT_EQ(w != s.warnings.end(), offset > bound) << nodes << " nodes: offset " << offset
                                                     << " m, bound " << bound << " m";
    if (w != s.warnings.end()) {
      EXPECT_NE(w->find("fine.obj"), std::string::npos) << *w;
      EXPECT_NE(w->find("deformable[0].file"), std::string::npos) << *w;
    }
    if (spike > 1.0) {
      EXPECT_NE(w, s.warnings.end()) << "the spike is cut off the 12-node net";
    }
  }
  EXPECT_GT(within_half_edge, 0) << "no net coarse enough that only the organ's share warns";
}

/// The bytes of `path`.
std::string file_bytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// `cache` keeps the simplified net in a file (mesh_cache.hpp): the next load reads the same net;
// a damaged or stale file is a warning at `cache` and the net is simplified again (and the file
// rewritten); on a mesh that is its own net the key is a warning.
TEST(DeformableNetSize, CacheFileKeepsTheSimplifiedNet) {
  TempDir dir;
  dir.write("fine.obj", numen::test::fine_ellipsoid_obj(4));
  const std::string keys = "nodes = 300\ncache = \"organ.nmnet\"";
  const auto load = [&](const std::string& k) { return load_scene(dir.write("organ.toml", fine_organ_scene(k))); };
  const auto cache_warning = [](const Scene& s) {
    const auto w = std::find_if(s.warnings.begin(), s.warnings.end(), [](const std::string& x) {
      return x.find("deformable[0].cache") != std::string::npos;
    });
    return w == s.warnings.end() ? std::string() : *w;
  };
  const Scene made = load(keys);
  EXPECT_FALSE(made.net_loads[0].cache_loaded);
  EXPECT_EQ(cache_warning(made), "");
  ASSERT_TRUE(std::filesystem::exists(dir / "organ.nmnet"));
  const Scene read = load(keys);
  EXPECT_TRUE(read.net_loads[0].cache_loaded);
  EXPECT_EQ(cache_warning(read), "");
  expect_fine_ellipsoid_on_net(read, 300, 1.0e-3);
  EXPECT_EQ(read.model.node_rest, made.model.node_rest);
  EXPECT_EQ(read.net_triangles, made.net_triangles);
  // Damaged (a flipped byte): simplified again, a warning, the file rewritten.
  std::string bytes = file_bytes(dir / "organ.nmnet");
  bytes.back() = static_cast<char>(bytes.back() ^ 0x10);
  dir.write("organ.nmnet", bytes);
  const Scene damaged = load(keys);
  EXPECT_FALSE(damaged.net_loads[0].cache_loaded);
  EXPECT_NE(
      cache_warning(damaged).find("organ.nmnet: damaged (checksum mismatch): simplified again"),
      std::string::npos)
      << cache_warning(damaged);
  EXPECT_EQ(damaged.model.node_rest, made.model.node_rest);
  EXPECT_TRUE(load(keys).net_loads[0].cache_loaded);
  // Stale: another node count.
  const Scene stale = load("nodes = 301\ncache = \"organ.nmnet\"");
  EXPECT_FALSE(stale.net_loads[0].cache_loaded);
  EXPECT_EQ(stale.model.nets[0].node_count, 301);
  EXPECT_NE(cache_warning(stale).find("stale (simplified from another mesh, to another size"),
            std::string::npos)
      << cache_warning(stale);
  // Nothing to cache.
  EXPECT_NE(cache_warning(load("nodes = 2562\ncache = \"organ.nmnet\"")).find("nothing to cache"),
            std::string::npos);
}

/// Expects fine_organ_scene(`cache = "<cache>"`, with `keys`) in `dir` (fine.obj beside it) to fail
/// at `cache`, located, with `phrase`.
void expect_cache_refused(const TempDir& dir, const std::string& cache, const std::string& phrase,
                          const std::string& keys = "nodes = 300") {
  const std::string text = fine_organ_scene(keys + "\ncache = \"" + cache + "\"");
  const InputError e = load_error(dir, text);
  EXPECT_EQ(e.key(), "deformable[0].cache") << e.what();
  EXPECT_EQ(e.line(), line_of(text, "cache = ")) << e.what();
  EXPECT_EQ(e.column(), column_of(text, "cache = ", "\"" + cache + "\"")) << e.what();
  EXPECT_NE(e.message().find(phrase), std::string::npos) << e.what();
}

// A `cache` path never clobbers what is not numen's own net cache (issue 66): the organ's own
// mesh, a text file, the scene file, a symlink and a device node were replaced, a FIFO blocked
// the load, a directory was "out of memory", a missing folder was made. Each is an error at
// `cache`, before the simplification, and the thing is left as it was.
TEST(DeformableNetSizeErrors, ACachePathThatIsNotANetCacheIsRefusedAtCache) {
  TempDir dir;
  const std::string mesh = numen::test::fine_ellipsoid_obj(4);
  dir.write("fine.obj", mesh);
  expect_cache_refused(dir, "fine.obj",
                       "fine.obj: not a numen cache (it does not start with \"NUMENNET\"); "
                       "refusing to overwrite it");
  EXPECT_EQ(file_bytes(dir / "fine.obj"), mesh);
  expect_cache_refused(dir, "bad.toml", "not a numen cache");  // the scene file itself
  EXPECT_NE(file_bytes(dir / "bad.toml").find("[[deformable]]"), std::string::npos);
  dir.write("notes.txt", "notes\n");
  expect_cache_refused(dir, "notes.txt", "refusing to overwrite it");
  EXPECT_EQ(file_bytes(dir / "notes.txt"), "notes\n");
  std::filesystem::create_symlink(dir / "notes.txt", dir / "link.nmnet");
  expect_cache_refused(dir, "link.nmnet", "is a symbolic link, not a cache file");
  EXPECT_TRUE(std::filesystem::is_symlink(dir / "link.nmnet"));
  std::filesystem::create_directory(dir / "folder.nmnet");
  expect_cache_refused(dir, "folder.nmnet", "is a directory, not a cache file");
  ASSERT_EQ(::mkfifo((dir / "pipe.nmnet").c_str(), 0644), 0);
  expect_cache_refused(dir, "pipe.nmnet", "is a FIFO (named pipe), not a cache file");
  EXPECT_TRUE(std::filesystem::is_fifo(dir / "pipe.nmnet"));
  if (::mknod((dir / "null").c_str(), S_IFCHR | 0666, ::makedev(1, 3)) == 0) {  // needs root
    expect_cache_refused(dir, "null", "is a character device, not a cache file");
    EXPECT_TRUE(std::filesystem::is_character_file(dir / "null"));
  }
  expect_cache_refused(dir, "nonexistent/dir/x.nmnet", "does not exist");
  EXPECT_FALSE(std::filesystem::exists(dir / "nonexistent"));
  dir.write("tet.nmshape", std::string("NUMENMSH") + std::string(40, '\0'));
  expect_cache_refused(dir, "tet.nmshape", "a numen mesh-shape cache, not a net cache");
}

// A net cache whose header is this mesh's (key and all) but whose net, with a valid checksum, was
// simplified from another mesh (the organ 5 times as large) is not used: a warning at `cache`
// naming the file, the net simplified again.
TEST(DeformableNetSize, ANetCacheOfAnotherMeshIsNamedAndNotUsed) {
  TempDir dir;
  dir.write("fine.obj", numen::test::fine_ellipsoid_obj(4));
  const auto load = [&](const std::string& k) {
    return load_scene(dir.write("organ.toml", fine_organ_scene(k)));
  };
  const Scene made = load("nodes = 300\ncache = \"a.nmnet\"");
  (void)load("nodes = 300\nscale = 5.0\ncache = \"b.nmnet\"");
  const std::string a = file_bytes(dir / "a.nmnet"), b = file_bytes(dir / "b.nmnet");
  dir.write("a.nmnet", a.substr(0, 20) + b.substr(20));  // a's magic, version, key; b's net
  const Scene s = load("nodes = 300\ncache = \"a.nmnet\"");
  EXPECT_FALSE(s.net_loads[0].cache_loaded);
  EXPECT_EQ(s.model.node_rest, made.model.node_rest);
  std::string warning;
  for (const std::string& w : s.warnings)
    if (w.find("deformable[0].cache") != std::string::npos) warning = w;
  EXPECT_NE(warning.find((dir / "a.nmnet").string() + ": damaged (its net lies off this mesh"),
            std::string::npos)
      << warning;
  EXPECT_NE(warning.find("simplified again"), std::string::npos) << warning;
}

/// Expects loading fine_organ_scene(keys) with `obj` as fine.obj to fail at the value of the line
/// holding `needle` (column of `value`), key `key`, with `phrase`.
void expect_net_size_error_with(const std::string& keys, const std::string& needle,
                                const std::string& value, const std::string& key,
                                const std::string& phrase, const std::string& obj) {
  expect_error_at(fine_organ_scene(keys), needle, value, key, phrase, obj);
}

/// Expects loading fine_organ_scene(keys) (fine.obj with `holes` triangles removed) to fail at
/// the value of the line holding `needle` (column of `value`), key `key`, with `phrase`.
void expect_net_size_error(const std::string& keys, const std::string& needle,
                           const std::string& value, const std::string& key,
                           const std::string& phrase, int holes = 0) {
  expect_error_at(fine_organ_scene(keys), needle, value, key, phrase,
                  numen::test::fine_ellipsoid_obj(4, holes));
}

/// A closed latitude-longitude sphere of radius 20 mm in mm: two poles and `rings` − 1 rings of
/// `segments` vertices.
std::string uv_sphere_obj(int rings, int segments) {
  std::string out;
  char line[96];
  std::snprintf(line, sizeof line, "v 0 0 20\n");
  out += line;
  for (int i = 1; i < rings; ++i)
    for (int j = 0; j < segments; ++j) {
      const double th = std::numbers::pi * i / rings, ph = 2.0 * std::numbers::pi * j / segments;
      std::snprintf(line, sizeof line, "v %.9f %.9f %.9f\n", 20.0 * std::sin(th) * std::cos(ph),
                    20.0 * std::sin(th) * std::sin(ph), 20.0 * std::cos(th));
      out += line;
    }
  out += "v 0 0 -20\n";
  const int south = 2 + (rings - 1) * segments;  // OBJ indices from 1
  const auto at = [&](int ring, int j) { return 2 + (ring - 1) * segments + (j % segments); };
  for (int j = 0; j < segments; ++j) {
    std::snprintf(line, sizeof line, "f 1 %d %d\n", at(1, j), at(1, j + 1));
    out += line;
    std::snprintf(line, sizeof line, "f %d %d %d\n", south, at(rings - 1, j + 1), at(rings - 1, j));
    out += line;
    for (int i = 1; i + 1 < rings; ++i) {
      std::snprintf(line, sizeof line, "f %d %d %d\nf %d %d %d\n", at(i, j), at(i + 1, j),
                    at(i + 1, j + 1), at(i, j), at(i + 1, j + 1), at(i, j + 1));
      out += line;
    }
  }
  return out;
}

// `nodes` is capped by the net's largest size (65 536 nodes), not only by the mesh's vertices:
// 163 843 nodes on a 163 842-vertex mesh said "at most 163842", which was then refused at `file`.
// Here a 65 538-vertex sphere.
TEST(DeformableNetSizeErrors, NodesAboveTheNetCapAreRefusedAtNodesWithTheCap) {
  const std::string obj = uv_sphere_obj(257, 256);  // 2 + 256 · 256 = 65 538 vertices
  expect_net_size_error_with("nodes = 65539", "nodes = 65539", "65539", "deformable[0].nodes",
                             "65539 nodes is more than the 65538 vertices of fine.obj: the net is "
                             "made by simplifying the mesh, never by refining it (at most 65536, "
                             "the most a net may have)",
                             obj);
  expect_net_size_error_with("nodes = 65538", "nodes = 65538", "65538", "deformable[0].nodes",
                             "65538 nodes is more than the 65536 a net may have (at most 65536, "
                             "the most a net may have)",
                             obj);
}

// The hint to set `cache` after a slow simplification (kSlowNetSimplifySeconds of wall clock, a
// 327 680-triangle organ takes 6-7 s), and none with a cache or under the threshold.
TEST(DeformableNetSize, ASlowSimplificationWithoutACacheHintsAtCache) {
  using numen::sim::slow_net_simplification_hint;
  const auto hint = slow_net_simplification_hint(6.5, 1024, false);
  ASSERT_TRUE(hint.has_value());
  EXPECT_EQ(*hint,
            "simplified to 1024 nodes in 6.5 s (wall clock) at every load: `cache = true` "
            "(or a file path) keeps the net for the next load");
  EXPECT_TRUE(slow_net_simplification_hint(numen::sim::kSlowNetSimplifySeconds, 8, false));
  EXPECT_FALSE(slow_net_simplification_hint(6.5, 1024, true));
  EXPECT_FALSE(slow_net_simplification_hint(1.9, 1024, false));
  // A quick one in a scene: no hint.
  for (const std::string& w : load_fine_organ("nodes = 300").warnings)
    EXPECT_EQ(w.find("wall clock"), std::string::npos) << w;
}

TEST(DeformableNetSizeErrors, BadNodeCountsAreLocated) {
  expect_net_size_error("nodes = 3", "nodes = 3", "3", "deformable[0].nodes",
                        "at least 4 nodes (a tetrahedron), got 3");
  expect_net_size_error("nodes = -5", "nodes = -5", "-5", "deformable[0].nodes", "at least 4 nodes");
  expect_net_size_error("nodes = 2563", "nodes = 2563", "2563", "deformable[0].nodes",
                        "more than the 2562 vertices of fine.obj");
  expect_net_size_error("nodes = 500.5", "nodes = 500.5", "500.5", "deformable[0].nodes",
                        "expected an integer");
  expect_net_size_error("nodes = 500\nedge_length = 0.004", "edge_length = ", "0.004",
                        "deformable[0].edge_length", "give nodes or edge_length, not both");
  expect_net_size_error("edge_length = 0.0", "edge_length = ", "0.0", "deformable[0].edge_length",
                        "must be a length > 0");
  expect_net_size_error("edge_length = 1.0", "edge_length = ", "1.0", "deformable[0].edge_length",
                        "fewer than the 4 of a closed net");
}

// A mesh with holes is refused before it is simplified, at the key that asked for the net's size
// (the file for the default size), naming the file.
TEST(DeformableNetSizeErrors, MeshWithHolesIsNotSimplified) {
  expect_net_size_error("", "file = ", "\"fine.obj\"", "deformable[0].file",
                        "fine.obj: the mesh has 3 edges on one triangle only (holes)", 1);
  expect_net_size_error("nodes = 300", "nodes = 300", "300", "deformable[0].nodes",
                        "a net is simplified from a closed surface only", 1);
  // Used as it is, the open mesh is a net as before.
  const Scene s = load_fine_organ("nodes = 2562", 1);
  EXPECT_EQ(s.model.nets[0].node_count, 2562);
}

TEST(DeformableNetSizeErrors, BuiltInMeshesRefuseTheNetSizeKeys) {
  expect_error_at(replace(kMiniNet, "subdivisions = 1", "subdivisions = 1\nnodes = 20"),
                  "nodes = 20", "20", "deformable[0].nodes",
                  "the built-in icosphere is its own net, sized by radius and subdivisions");
  expect_error_at(replace(kMiniNet, "subdivisions = 1", "subdivisions = 1\nedge_length = 0.002"),
                  "edge_length = ", "0.002", "deformable[0].edge_length",
                  "sets the size of a net simplified from a mesh file");
}

}  // namespace
