// Organs at the user's scale (docs/fine-surface.md): figure
// reproductions, label figures (tests/CMakeLists.txt: OrganScale.*), left out of the README's
// test command. A user's fine organ mesh — a closed 35 × 25 × 20 mm ellipsoid of 20 480 or
// 200 000 triangles from sim/data/make_fine_ellipsoid.py — in place of the shipped organ runs the
// shipped excerpt on a net of the default size with its own surface mapped on it; and the force a
// sphere meets pressed into that ellipsoid, on a 1 000-node net carrying the 10 242-vertex
// surface, against the 10 242-node net of the mesh itself at dt and at dt/10. They report; the
// only speed figures are printed, not checked (the machines are shared).
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include "build_features.hpp"
#include "child_process.hpp"
#include "numen/core/data.hpp"
#include "numen/core/step.hpp"
#include "numen/sim/scene/scene.hpp"
#include "organ_indentation.hpp"
#include "scene_text.hpp"
#include "temp_dir.hpp"

namespace core = numen::core;
using core::Vec3;
using numen::test::ChildResult;
using numen::test::TempDir;
using numen::test::run_child;

namespace {

/// Writes the closed ellipsoid of geodesic frequency `f` (20 f² triangles) to `path` with the
/// shipped generator (sim/data/make_fine_ellipsoid.py; python3's standard library only).
void organ_scale_write_ellipsoid(int f, const std::string& path) {
  const std::string cmd = "python3 " + std::string(NUMEN_SOURCE_DIR) +
                          "/sim/data/make_fine_ellipsoid.py " + std::to_string(f) + " > '" + path + "'";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
}

/// `text` with every occurrence of `from` replaced by `to`.
std::string organ_scale_replace_all(std::string text, const std::string& from, const std::string& to) {
  for (std::size_t at = text.find(from); at != std::string::npos; at = text.find(from, at + to.size()))
    text.replace(at, from.size(), to);
  return text;
}

/// A scene of one anchored organ (`organ_keys`: its [[deformable]]'s mesh and size keys) and a
/// 2.5 mm probe imposed on the device's pose (direct coupling): the indentation scene.
std::string organ_scale_probe_scene(const std::string& organ_keys, double tie_stiffness,
                                    double tie_damping, double spring_scale = 1.0) {
  return numen::test::indentation_bench_scene(
      "mass = 0.07\nstiffness = " + std::to_string(200.0 * spring_scale) +
      "\ndamping = " + std::to_string(0.1 * spring_scale) +
      "\nbending_stiffness = " + std::to_string(50.0 * spring_scale) +
      "\nbending_damping = " + std::to_string(0.03 * spring_scale) +
      "\ntie_stiffness = " + std::to_string(tie_stiffness) +
      "\ntie_damping = " + std::to_string(tie_damping) + "\n" + organ_keys);
}

/// The scene `text` written to `dir`/`name` and loaded.
numen::sim::Scene organ_scale_load(const TempDir& dir, const std::string& name, const std::string& text) {
  const std::string path = (dir.path() / name).string();
  std::ofstream(path) << text;
  return numen::sim::load_scene(path);
}

}  // namespace

TEST(OrganScale, FineEllipsoidOrgansRunTheShippedExcerptOnTheScenesNet) {
  // The default scene with the organ (and its rigid core, the same mesh scaled 3 mm in) read
  // from the fine ellipsoid: loaded on the scene's 500-node net (given its material) carrying the
  // file's surface, run offline over the shipped excerpt, clean. Printed: the net, the load, the step times and the
  // real-time factor (docs/fine-surface.md).
  NUMEN_REQUIRE_ARTICULATION();  // the default scene's instrument
  NUMEN_REQUIRE_DEFORMABLE();
  TempDir dir;
  for (const int f : {32, 100}) {
    const std::string obj = (dir.path() / ("ellipsoid_" + std::to_string(f) + ".obj")).string();
    organ_scale_write_ellipsoid(f, obj);
    std::string text = numen::test::shipped_scene_text("default.toml");
    text = organ_scale_replace_all(text, "../data/organ_lobe.obj", obj);
    text = organ_scale_replace_all(text, "\"../data/", "\"" + std::string(NUMEN_SOURCE_DIR) + "/sim/data/");
    const std::string scene = (dir.path() / ("organ_" + std::to_string(f) + ".toml")).string();
    std::ofstream(scene) << text;

    const ChildResult info = run_child({NUMEN_CLI, "info", scene, "--json"}, dir.path().string(), 600);
    ASSERT_EQ(info.status, 0) << info.err;
    const nlohmann::json inf = nlohmann::json::parse(info.out);
    const ChildResult run = run_child({NUMEN_CLI, "run", scene, "--json"}, dir.path().string(), 900);
    ASSERT_EQ(run.status, 0) << run.err.substr(0, 2000);
    const nlohmann::json sum = nlohmann::json::parse(run.out);
    const numen::sim::Scene s = numen::sim::load_scene(scene);
    ASSERT_EQ(s.model.num_nets(), 1);
    const core::NetModel& net = s.model.nets[0];
    ASSERT_EQ(s.net_loads.size(), 1u);
    EXPECT_EQ(net.node_count - s.net_loads[0].interior_nodes, 500);
    EXPECT_EQ(net.surface_point_count, 10 * f * f + 2);
    EXPECT_EQ(net.surface_face_count, 20 * f * f);
    std::printf("[organ scale] %d-triangle ellipsoid: net %d nodes, %d triangles; fine surface %d "
                "vertices; load %.2f s wall (numen info); run: step median %.1f us, p99 %.1f us, "
                "real-time factor %.2f, exit %d\n",
                20 * f * f, net.node_count, net.face_count, net.surface_point_count, info.wall_s,
                sum["step_time_us"]["median"].get<double>(), sum["step_time_us"]["p99"].get<double>(),
                sum["real_time_factor"].get<double>(), run.status);
    double simplify_s = -1.0;
    for (const auto& mesh : inf["meshes"])
      if (mesh.contains("net_load")) simplify_s = mesh["net_load"]["simplify_cpu_s"].get<double>();
    std::printf("[organ scale] %d-triangle ellipsoid: simplification and map %.2f s of CPU\n", 20 * f * f,
                simplify_s);
    EXPECT_GT(simplify_s, 0.0);
  }
}

TEST(OrganScale, ForceAgainstIndentationOnNetsOf1000To10242NodesOfTheSameMesh) {
  // The 20 480-triangle ellipsoid (10 242 vertices) as its own 10 242-node net and as nets of
  // 1 000, 2 500 and 5 000 nodes carrying its surface; a 2.5 mm sphere imposed along +z into its
  // lower pole at 20 mm/s, 6 mm past its first touch. Per-node constants scale with the node's
  // share of the surface (a net ten times finer has ten times as many ties under the sphere):
  // tie_stiffness and tie_damping ∝ 1 / nodes, 100 N/m and 0.17 N·s/m at 1 000; the springs'
  // constants are per spring (the shipped organ's). Compared over 5 ms means against the
  // 10 242-node net at 0.1 ms (the reference): every net at 1 ms.
  NUMEN_REQUIRE_DEFORMABLE();
  TempDir dir;
  const std::string obj = (dir.path() / "ellipsoid_32.obj").string();
  organ_scale_write_ellipsoid(32, obj);
  const double k_tie = 100.0, c_tie = 0.17, ratio = 1000.0 / 10242.0;
  const std::string file = "mesh = \"file\"\nfile = \"" + obj + "\"\n";
  numen::sim::Scene fine = organ_scale_load(
      dir, "fine.toml", organ_scale_probe_scene(file + "nodes = 10242\n", k_tie * ratio, c_tie * ratio));
  ASSERT_EQ(fine.model.nets[0].node_count, 10242);
  ASSERT_EQ(fine.model.nets[0].surface_point_count, 0);
  ASSERT_EQ(fine.model.bodies[1].name, "probe");

  // The first touch of the ellipsoid's surface, the same for both (the fine net's triangles are
  // the coarse one's fine surface).
  const Vec3 from(0.0, 0.0, -0.03), dir_z = Vec3::UnitZ();
  const double touch = numen::test::organ::first_touch(fine.model, from, dir_z, 0.0025);
  ASSERT_TRUE(std::isfinite(touch));
  const double speed = 0.02, depth = 0.006;
  const auto curve = [&](core::Model m, double dt, int every) {
    m.dt = dt;
    return numen::test::organ::indentation_curve(m, from, dir_z, speed, depth, every, touch);
  };
  const auto ref = curve(fine.model, 1e-4, 10);
  double peak = 0.0;
  const double fine_error =
      numen::test::organ::compare_curves("10242-node net at 1 ms", curve(fine.model, 1e-3, 1), ref, peak);
  // Nets of 1 000, 2 500 and 5 000 nodes simplified from the same mesh, carrying it, their ties
  // scaled by their node's share of the surface (tie_stiffness ∝ 1 / nodes).
  std::vector<double> errors;
  for (const int nodes : {1000, 2500, 5000}) {
    const double share = 1000.0 / nodes;
    const numen::sim::Scene s = organ_scale_load(
        dir, "net.toml",
        organ_scale_probe_scene(file + "nodes = " + std::to_string(nodes) + "\n", k_tie * share, c_tie * share));
    ASSERT_EQ(s.model.nets[0].node_count, nodes);
    ASSERT_EQ(s.model.nets[0].surface_point_count, 10242);
    const std::string label = std::to_string(nodes) + "-node net at 1 ms";
    double p = 0.0;
    errors.push_back(numen::test::organ::compare_curves(label.c_str(), curve(s.model, 1e-3, 1), ref, p));
  }
  std::printf("[organ scale] force against indentation of a 2.5 mm sphere 6 mm into the 20 480-triangle "
              "ellipsoid: reference (10 242 nodes, 0.1 ms) peak %.3f N; largest difference of the 5 ms "
              "means: 1 000 nodes %.3f N (%.0f %%), 2 500 nodes %.3f N (%.0f %%), 5 000 nodes %.3f N "
              "(%.0f %%), 10 242 nodes at 1 ms %.3f N (%.0f %%)\n",
              peak, errors[0], 100.0 * errors[0] / peak, errors[1], 100.0 * errors[1] / peak, errors[2],
              100.0 * errors[2] / peak, fine_error, 100.0 * fine_error / peak);
  EXPECT_GT(peak, 1.0);
  // The coarser the net under the sphere, the stiffer: the error shrinks as the net refines.
  EXPECT_GT(errors[0], errors[1]);
  EXPECT_GT(errors[1], errors[2]);
  EXPECT_GT(errors[2], 0.0);
}
