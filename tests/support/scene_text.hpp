#pragma once
/// @file scene_text.hpp
/// Helpers of the scene-file tests (tests/sim/scene/scene*_test.cpp): locate a
/// needle in a scene text (1-based line and column, as InputError reports
/// them), edit a template scene, load a text expecting an InputError, and check where
/// the error is located.
/// Header-only; include from numen::sim test files only.

#include <gtest/gtest.h>

#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "numen/sim/input/input_error.hpp"
#include "numen/sim/scene/scene.hpp"
#include "temp_dir.hpp"

namespace numen::test {

/// A tetrahedron of side 1 as an OBJ file (file units), wound outward: the mesh tests' smallest
/// closed mesh.
inline constexpr const char* kTetObj =
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";

/// A small valid scene: a 0.1 kg ball (one 10 mm sphere, coupling 100 N/m, damping ratio 0.85)
/// held by a pose tracker over a floor plane at z = -0.1 m, on a scripted path (10 mm line in
/// 0.5 s, hold 0.25 s). The scene-file tests change one thing in it; the run tests replace its
/// [trajectory] (everything from "[trajectory]" on).
inline const std::string kMiniScene = R"(name = "mini"
dt = 0.001
gravity = [0.0, 0.0, 0.0]

[[material]]
name = "steel"

[[body]]
name = "tool"
mass = 0.1
material = "steel"
spheres = [[0.0, 0.0, 0.0, 0.01]]
[body.coupling]
stiffness = 100.0
damping_ratio = 0.85

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
type = "line"
to = [0.01, 0.0, 0.0]
duration = 0.5

[[trajectory.segment]]
type = "hold"
duration = 0.25
)";


/// An indentation bench as a scene (docs/organs.md, "Force against indentation"; docs/tissue.md):
/// body 0 "organ_core" anchored at the origin carrying [[deformable]] "organ" (material
/// "tissue", its other keys `deformable`), body 1 "probe" (one sphere of `probe_radius` m,
/// imposed on the device's pose: coupling "direct") 30 mm below the origin; contacts 2e4 N/m and
/// 10 N·s/m, implicit Euler at `dt`, the nets' solve to 3e-4 in at most 200 iterations. The
/// harness of organ_indentation.hpp drives the probe (body 1).
inline std::string indentation_bench_scene(const std::string& deformable, double probe_radius = 0.0025,
                                           double dt = 0.001) {
  return "name = \"indentation-bench\"\ndt = " + std::to_string(dt) + R"(
gravity = [0.0, 0.0, 0.0]
integrator = "implicit-euler"
coupling = "direct"

[solver]
tolerance = 3.0e-4
max_iterations = 200

[[material]]
name = "steel"

[[material]]
name = "tissue"

[contact_default]
stiffness = 2.0e4
damping = 10.0

[[body]]
name = "organ_core"
mass = 0.1
inertia = [1.0e-4, 1.0e-4, 1.0e-4]
anchored = true
material = "tissue"

[[body]]
name = "probe"
mass = 0.05
inertia = [1.0e-5, 1.0e-5, 1.0e-5]
material = "steel"
spheres = [[0.0, 0.0, 0.0, )" + std::to_string(probe_radius) + R"(]]
position = [0.0, 0.0, -0.03]

[[deformable]]
name = "organ"
body = "organ_core"
material = "tissue"
)" + deformable + R"(

[device]
kind = "pose-tracker"
attach = "probe"

[trajectory]
source = "scripted"
start = { position = [0.0, 0.0, -0.03] }

[[trajectory.segment]]
type = "hold"
duration = 0.1
)";
}

/// A small valid scene of two devices (`[[device]]`, docs/scenes.md "Several devices"): pose
/// trackers "left" (nodes 1–6, holds "left_tool") and "right" (nodes 7–12, drives "right_tool"
/// through its link), each on its own scripted path ([device.trajectory]). The tests of several
/// devices change one thing in it.
inline const std::string kTwoDeviceScene = R"(name = "two"
dt = 0.001
gravity = [0.0, 0.0, 0.0]

[[material]]
name = "steel"

[[body]]
name = "left_tool"
mass = 0.1
material = "steel"
spheres = [[0.0, 0.0, 0.0, 0.01]]
[body.coupling]
stiffness = 100.0
damping_ratio = 0.85

[[body]]
name = "right_tool"
mass = 0.1
material = "steel"
spheres = [[0.0, 0.0, 0.0, 0.01]]
link = "tool"
device = "right"
[body.coupling]
stiffness = 100.0
damping_ratio = 0.85

[[device]]
kind = "pose-tracker"
name = "left"
attach = "left_tool"
[device.feedback]
stiffness = 50.0
damping = 0.5
[device.trajectory]
source = "scripted"
start = { position = [0.0, 0.0, 0.0] }
[[device.trajectory.segment]]
type = "line"
to = [0.01, 0.0, 0.0]
duration = 0.5

[[device]]
kind = "pose-tracker"
name = "right"
first_node_id = 7
[device.feedback]
stiffness = 80.0
damping = 0.8
[device.trajectory]
source = "scripted"
start = { position = [0.0, 0.05, 0.0] }
[[device.trajectory.segment]]
type = "line"
to = [0.0, 0.06, 0.0]
duration = 0.75
)";

/// `s`'s warnings but the load note of a device without feedback ("no feedback: ...",
/// docs/scenes.md "Device"), which a pose tracker without [device.feedback] (the mini scene's)
/// always carries: for the tests of the other warnings.
inline std::vector<std::string> warnings_besides_no_feedback(const sim::Scene& s) {
  std::vector<std::string> rest;
  for (const std::string& w : s.warnings)
    if (w.rfind("no feedback: ", 0) != 0) rest.push_back(w);
  return rest;
}

/// The shipped JIGSAWS excerpt (sim/data) the scene tests load.
inline std::string jigsaws_excerpt_path() {
  return std::string(NUMEN_SOURCE_DIR) + "/sim/data/jigsaws_suturing_b002_excerpt.txt";
}

/// 1-based line of the `nth` (1-based) line of `text` containing `needle` (0: none).
inline int line_of(const std::string& text, const std::string& needle, int nth = 1) {
  std::istringstream in(text);
  std::string line;
  for (int n = 1; std::getline(in, line); ++n)
    if (line.find(needle) != std::string::npos && --nth == 0) return n;
  return 0;
}

/// 1-based column of `value` at or after `needle` in the first line
/// containing `needle` (0: none).
inline int column_of(const std::string& text, const std::string& needle, const std::string& value) {
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    const auto at = line.find(needle);
    if (at == std::string::npos) continue;
    const auto c = line.find(value, at);
    return c == std::string::npos ? 0 : static_cast<int>(c) + 1;
  }
  return 0;
}

/// `text` (a shipped scene's) with every `dcf = "devices/…"` made absolute under `scene_dir`
/// (the shipped scene's directory, with or without a trailing slash), so that a copy of the
/// scene loads from another directory with the node DCFs beside the shipped scene.
inline std::string with_absolute_dcf_paths(std::string text, std::string scene_dir) {
  if (!scene_dir.empty() && scene_dir.back() != '/') scene_dir += '/';
  const std::string from = "dcf = \"devices/";
  const std::string to = "dcf = \"" + scene_dir + "devices/";
  for (std::size_t at = text.find(from); at != std::string::npos; at = text.find(from, at + to.size()))
    text.replace(at, from.size(), to);
  return text;
}

/// The text of the shipped scene sim/scenes/`name`, its DCF paths made absolute
/// (with_absolute_dcf_paths()) so that an edited copy loads from another directory.
inline std::string shipped_scene_text(const std::string& name) {
  const std::string dir = std::string(NUMEN_SOURCE_DIR) + "/sim/scenes";
  std::ifstream in(dir + "/" + name);
  std::ostringstream text;
  text << in.rdbuf();
  return with_absolute_dcf_paths(text.str(), dir);
}

/// A shipped scene's text (shipped_scene_text()) with its "../data/" paths made absolute, so that
/// it loads from a temporary directory.
inline std::string shipped_scene_text_anywhere(const std::string& name) {
  std::string text = shipped_scene_text(name);
  const std::string from = "\"../data/", to = "\"" + std::string(NUMEN_SOURCE_DIR) + "/sim/data/";
  for (std::size_t at = text.find(from); at != std::string::npos; at = text.find(from, at + to.size()))
    text.replace(at, from.size(), to);
  return text;
}

/// Replaces the `nth` occurrence of `from` in `text` (which must exist: a
/// missing one fails the test as a bug of the test's template).
inline std::string replace(std::string text, const std::string& from, const std::string& to,
                           int nth = 1) {
  std::size_t at = text.find(from);
  while (at != std::string::npos && --nth > 0) at = text.find(from, at + 1);
  EXPECT_NE(at, std::string::npos) << "test bug: '" << from << "' not in the template";
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

/// kMiniScene with a deformable organ "organ" made of mesh file `file` (beside the scene, in
/// millimetres) on a hidden core body 0.1 m along y from the tool, `keys` (e.g. "nodes = 300")
/// added to its [[deformable]] table. Needs a build with deformable nets.
inline std::string with_organ_mesh_file(const std::string& file, const std::string& keys = "") {
  return kMiniScene + R"(
[[body]]
name = "core"
mass = 0.05
inertia = [1.0e-5, 1.0e-5, 1.0e-5]
material = "steel"
position = [0.0, 0.1, 0.0]

[[deformable]]
name = "organ"
body = "core"
mesh = "file"
file = ")" + file + R"("
units = "mm"
mass = 0.01
stiffness = 200.0
tie_stiffness = 500.0
)" + keys + "\n";
}

/// kMiniScene with a mesh obstacle named "organ" of `keys` (after name and type: `file`, `units`,
/// `scale`, ...) in place of its floor.
inline std::string with_mesh_obstacle(const std::string& keys) {
  return replace(kMiniScene,
                 "name = \"floor\"\ntype = \"plane\"\npoint = [0.0, 0.0, -0.1]\n"
                 "normal = [0.0, 0.0, 1.0]",
                 "name = \"organ\"\ntype = \"mesh\"\n" + keys);
}

/// Writes `text` as `name` in `dir`, loads it and returns the InputError
/// thrown (printed as info); fails the test if the scene loads or another
/// exception is thrown.
inline sim::InputError load_error(const TempDir& dir, const std::string& text,
                                  const std::string& name = "bad.toml") {
  const std::string path = dir.write(name, text);
  try {
    (void)sim::load_scene(path);
  } catch (const sim::InputError& e) {
    std::printf("[   info   ] %s\n", e.what());
    return e;
  } catch (const std::exception& e) {
    ADD_FAILURE() << "expected InputError, got another exception: " << e.what();
    return sim::InputError(path, 0, 0, "", "wrong exception type");
  }
  ADD_FAILURE() << "expected InputError, the scene loaded:\n" << text;
  return sim::InputError(path, 0, 0, "", "no error");
}

/// what() must contain the scene file's name, the line (and column), the key and `message`.
inline void expect_located(const sim::InputError& e, const std::string& file, int line, int column,
                           const std::string& key, const std::string& message) {
  const std::string what = e.what();
  SCOPED_TRACE(what);
  EXPECT_EQ(e.file(), file);
  EXPECT_NE(what.find(std::filesystem::path(file).filename().string()), std::string::npos)
      << "file name";
  EXPECT_GT(line, 0) << "test bug: the line was not found in the template";
  EXPECT_EQ(e.line(), line);
  std::ostringstream place;
  place << ':' << line << ':';
  if (column > 0) {
    EXPECT_EQ(e.column(), column);
    place << column << ':';
  }
  EXPECT_NE(what.find(place.str()), std::string::npos) << place.str();
  if (!key.empty()) {
    EXPECT_EQ(e.key(), key);
    EXPECT_NE(what.find(key), std::string::npos) << "dotted key";
  }
  EXPECT_NE(e.message().find(message), std::string::npos) << "message: " << e.message();
}

}  // namespace numen::test
