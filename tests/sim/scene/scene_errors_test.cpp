// Tests of sim/scene: scene-file errors name the file, line, column and dotted key with a
// message a user can act on; what is only doubtful is a warning; implausible inputs (issue 17)
// are refused where they are written.
#include "numen/sim/scene/scene.hpp"

#include <gtest/gtest.h>

#include "sanitizer.hpp"
#include "scene_text.hpp"
#include "temp_dir.hpp"

#include "numen/core/data.hpp"
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <numbers>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "numen/hal/device/device_config.hpp"
#include "numen/sim/device/simulated_instrument.hpp"
#include "numen/sim/input/input_error.hpp"

#include "articulation/joint_system.hpp"
#include "build_features.hpp"

namespace {

using numen::test::column_of;
using numen::test::line_of;
using numen::test::load_error;
using numen::test::replace;

namespace fs = std::filesystem;
using numen::sim::InputError;
using numen::sim::load_scene;
using numen::sim::Scene;
using numen::test::expect_located;
using numen::test::TempDir;

// A small valid scene (pose tracker, scripted path; tests/support/scene_text.hpp). Every error
// test below changes one thing in it, so that the error can only come from that change.
using numen::test::kMiniScene;

}  // namespace

// ---------------------------------------------------------------- scene-file errors

TEST(SceneErrors, TheTemplateIsValid) {
  TempDir dir;
  const Scene s = load_scene(dir.write("mini.toml", kMiniScene));
  EXPECT_EQ(s.name, "mini");
  EXPECT_EQ(s.model.num_bodies(), 1);
  EXPECT_NEAR(s.trajectory.duration(), 0.75, 1e-9);
  EXPECT_TRUE(numen::test::warnings_besides_no_feedback(s).empty());  // a pose tracker: no feedback
}

TEST(SceneErrors, NegativeContactOnsetDepthNamesTheKey) {
  TempDir dir;
  const std::string text = kMiniScene + "\n[contact_default]\nonset_depth = -1e-4\n";
  const InputError e = load_error(dir, text);
  expect_located(e, (dir.path() / "bad.toml").string(), line_of(text, "onset_depth = "),
                 column_of(text, "onset_depth = ", "-1e-4"), "contact_default.onset_depth", "");
}

TEST(SceneErrors, TrapezoidalWithFirstOrderCouplingNamesTheIntegratorKey) {
  TempDir dir;
  const std::string text = replace(
      kMiniScene, "dt = 0.001", "dt = 0.001\nintegrator = \"trapezoidal\"\ncoupling = \"first-order\"");
  const InputError e = load_error(dir, text);
  expect_located(e, (dir.path() / "bad.toml").string(), line_of(text, "integrator = "),
                 column_of(text, "integrator = ", "\"trapezoidal\""), "integrator", "first-order");
  EXPECT_NE(e.message().find("L-stable"), std::string::npos) << e.what();
}

TEST(SceneErrors, MissingSceneFile) {
  const std::string path = (fs::temp_directory_path() / "numen_no_such_scene_file.toml").string();
  try {
    (void)load_scene(path);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), path);
    EXPECT_NE(std::string(e.what()).find("numen_no_such_scene_file.toml"), std::string::npos);
    EXPECT_NE(e.message().find("cannot open"), std::string::npos) << e.what();
  }
}

TEST(SceneErrors, TomlSyntaxError) {
  TempDir dir;
  const std::string text = replace(kMiniScene, "mass = 0.1", "mass = = 0.1");
  const InputError e = load_error(dir, text, "syntax.toml");
  const std::string what = e.what();
  EXPECT_EQ(e.file(), (dir.path() / "syntax.toml").string());
  EXPECT_NE(what.find("syntax.toml"), std::string::npos) << what;
  EXPECT_EQ(e.line(), line_of(text, "mass = = 0.1")) << what;
  EXPECT_GT(e.column(), 0) << what;
  EXPECT_NE(e.message().find("TOML syntax"), std::string::npos) << what;
}

// toml++ 3.3.0 (upstream marzer/tomlplusplus#295, fixed by PR #305) reaches TOML_UNREACHABLE,
// undefined behaviour, on a non-ASCII character in U+00A1..U+0499 where the parser skips
// whitespace; sim/CMakeLists.txt compiles the parser with that fix. The 2-byte file is the
// fuzz corpus's regression input (tests/fuzz/corpus/scene); under UBSan the unfixed parser aborts.
TEST(SceneErrors, NonAsciiCharacterInABarePositionIsALocatedSyntaxError) {
  const std::string path =
      std::string(NUMEN_SOURCE_DIR) + "/tests/fuzz/corpus/scene/toml-issue-295-middle-dot";
  try {
    (void)load_scene(path);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), path);
    EXPECT_EQ(e.line(), 1) << e.what();
    EXPECT_EQ(e.column(), 1) << e.what();
    EXPECT_NE(e.message().find("TOML syntax"), std::string::npos) << e.what();
  }
  // The same character class after a value and as a key on a later line (U+00E9, U+0416).
  TempDir dir;
  for (const std::string bad : {"\xC3\xA9", "\xD0\x96"}) {
    const std::string text = replace(kMiniScene, "mass = 0.1", "mass = 0.1 " + bad + "\n" + bad + " = 1");
    const InputError e = load_error(dir, text, "non_ascii.toml");
    EXPECT_EQ(e.line(), line_of(text, "mass = 0.1")) << e.what();
    EXPECT_GT(e.column(), 0) << e.what();
    EXPECT_NE(e.message().find("TOML syntax"), std::string::npos) << e.what();
  }
}

TEST(SceneErrors, UnknownTopLevelKeyIsATypo) {
  TempDir dir;
  const std::string text = replace(kMiniScene, "gravity = [", "gravitty = [");
  const InputError e = load_error(dir, text);
  expect_located(e, (dir.path() / "bad.toml").string(), line_of(text, "gravitty"),
                 column_of(text, "gravitty", "["), "gravitty", "unknown key");
  EXPECT_NE(e.message().find("gravity"), std::string::npos) << "lists the allowed keys: " << e.what();
}

TEST(SceneErrors, UnknownKeyInsideSecondBody) {
  TempDir dir;
  const std::string text = replace(kMiniScene, "[[obstacle]]", R"([[body]]
name = "second"
mass = 0.2
radiuss = 0.01
position = [0.0, 0.3, 0.0]

[[obstacle]])");
  const InputError e = load_error(dir, text);
  expect_located(e, (dir.path() / "bad.toml").string(), line_of(text, "radiuss"),
                 column_of(text, "radiuss", "0.01"), "body[1].radiuss", "unknown key");
}

TEST(SceneErrors, NumberWhereAStringIsExpected) {
  TempDir dir;
  const std::string text = replace(kMiniScene, "name = \"tool\"", "name = 42");
  const InputError e = load_error(dir, text);
  expect_located(e, (dir.path() / "bad.toml").string(), line_of(text, "name = 42"),
                 column_of(text, "name = 42", "42"), "body[0].name", "expected a string");
  EXPECT_NE(e.message().find("integer"), std::string::npos) << e.what();
}

TEST(SceneErrors, NegativeMass) {
  TempDir dir;
  const std::string text = replace(kMiniScene, "mass = 0.1", "mass = -0.1");
  const InputError e = load_error(dir, text);
  expect_located(e, (dir.path() / "bad.toml").string(), line_of(text, "mass = -0.1"),
                 column_of(text, "mass = -0.1", "-0.1"), "body[0].mass", "must be in");
  EXPECT_NE(e.message().find("-0.1"), std::string::npos) << "quotes the value: " << e.what();
}

TEST(SceneErrors, UnknownMaterial) {
  TempDir dir;
  const std::string text = replace(kMiniScene, "material = \"steel\"", "material = \"wood\"");
  const InputError e = load_error(dir, text);
  expect_located(e, (dir.path() / "bad.toml").string(), line_of(text, "material = \"wood\""),
                 column_of(text, "material = \"wood\"", "\"wood\""), "body[0].material",
                 "unknown material \"wood\"");
  EXPECT_NE(e.message().find("steel"), std::string::npos) << "lists the declared ones: " << e.what();
}

TEST(SceneErrors, UnknownBodyInDeviceAttach) {
  TempDir dir;
  const std::string text = replace(kMiniScene, "attach = \"tool\"", "attach = \"tol\"");
  const InputError e = load_error(dir, text);
  expect_located(e, (dir.path() / "bad.toml").string(), line_of(text, "attach = \"tol\""),
                 column_of(text, "attach = \"tol\"", "\"tol\""), "device.attach", "no body named \"tol\"");
}

TEST(SceneErrors, ANonPositiveVelocityCutoffIsLocated) {
  TempDir dir;
  for (const std::string bad : {"0.0", "-50.0", "nan", "inf"}) {
    const std::string line = "velocity_cutoff = " + bad;
    const std::string text = replace(kMiniScene, "attach = \"tool\"", "attach = \"tool\"\n" + line);
    const InputError e = load_error(dir, text);
    expect_located(e, (dir.path() / "bad.toml").string(), line_of(text, line),
                   column_of(text, line, bad), "device.velocity_cutoff",
                   bad == "nan" || bad == "inf" ? "must be finite" : "must be in");
  }
}

TEST(SceneErrors, AnUnknownVelocityEstimatorOrFoawSettingIsLocated) {
  TempDir dir;
  struct Bad {
    std::string line, value, key, what;
  };
  for (const Bad& b : {Bad{"velocity_estimator = \"kalman\"", "\"kalman\"",
                           "device.velocity_estimator", "\"difference\", \"filter\", \"foaw\""},
                       Bad{"foaw_max_window = 0", "0", "device.foaw_max_window", "must be in [1, 32]"},
                       Bad{"foaw_max_window = 33", "33", "device.foaw_max_window", "must be in [1, 32]"},
                       Bad{"foaw_noise_counts = -1.0", "-1.0", "device.foaw_noise_counts", "must be in"}}) {
    const std::string text = replace(kMiniScene, "attach = \"tool\"", "attach = \"tool\"\n" + b.line);
    const InputError e = load_error(dir, text);
    expect_located(e, (dir.path() / "bad.toml").string(), line_of(text, b.line),
                   column_of(text, b.line, b.value), b.key, b.what);
  }
}

TEST(SceneErrors, ASoftStartOutsideZeroToTenSecondsIsLocated) {
  TempDir dir;
  for (const std::string bad : {"-0.1", "10.5", "nan", "inf", "\"fast\""}) {
    const std::string line = "soft_start = " + bad;
    const std::string text = replace(kMiniScene, "attach = \"tool\"", "attach = \"tool\"\n" + line);
    const InputError e = load_error(dir, text);
    expect_located(e, (dir.path() / "bad.toml").string(), line_of(text, line),
                   column_of(text, line, bad), "device.soft_start",
                   bad == "nan" || bad == "inf" ? "must be finite"
                   : bad[0] == '"'              ? "expected a number"
                                                : "must be in [0, 10]");
  }
}

TEST(SceneErrors, MissingTrajectoryFile) {
  TempDir dir;
  const std::string text = replace(kMiniScene, R"(source = "scripted"
start = { position = [0.0, 0.0, 0.0] })",
                                   R"(source = "jigsaws"
file = "no_such_recording.txt")");
  // Drop the segments that a jigsaws trajectory does not take.
  const std::string trimmed = text.substr(0, text.find("[[trajectory.segment]]"));
  const InputError e = load_error(dir, trimmed);
  expect_located(e, (dir.path() / "bad.toml").string(), line_of(trimmed, "no_such_recording"),
                 column_of(trimmed, "file = ", "\""), "trajectory.file", "not found");
  EXPECT_NE(e.message().find("no_such_recording.txt"), std::string::npos) << e.what();
}

namespace {

/// A trocar-instrument scene reading the JIGSAWS file `data` (absolute path), with `extra`
/// lines in its [trajectory].
std::string jigsaws_scene(const std::string& data, const std::string& extra = "") {
  std::string text = R"(name = "jig"
[[body]]
name = "tool"
mass = 0.05
spheres = [[0.0, 0.0, 0.0, 0.0025]]
[device]
kind = "trocar-instrument"
attach = "tool"
[device.trocar]
placement = "approach"
[trajectory]
source = "jigsaws"
file = ")";
  text += data;
  text += "\"\nmanipulator = \"slave_right\"\n";
  text += extra;
  return text;
}

}  // namespace

TEST(SceneErrors, JigsawsTrajectoryWithAMalformedLineNamesTheDataFile) {
  TempDir dir;
  // A copy of the shipped excerpt with one token of line 7 replaced.
  std::ifstream in(numen::test::jigsaws_excerpt_path());
  ASSERT_TRUE(in) << numen::test::jigsaws_excerpt_path();
  std::ostringstream data;
  std::string line;
  int bad_column = 0;
  for (int n = 1; std::getline(in, line); ++n) {
    if (n == 7) {
      // Replace the 5th token.
      std::size_t c = 0;
      for (int tok = 0; tok < 5; ++tok) {
        c = line.find_first_not_of(" \t", c);
        if (tok < 4) c = line.find_first_of(" \t", c);
      }
      const std::size_t end = line.find_first_of(" \t", c);
      line.replace(c, end - c, "1.2.3");
      bad_column = static_cast<int>(c) + 1;
    }
    data << line << '\n';
  }
  const std::string data_path = dir.write("recording.txt", data.str());
  const std::string text = jigsaws_scene(data_path);
  const std::string scene_path = dir.write("jig.toml", text);
  try {
    (void)load_scene(scene_path);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    const std::string what = e.what();
    std::printf("[   info   ] %s\n", what.c_str());
    SCOPED_TRACE(what);
    EXPECT_EQ(e.file(), data_path);
    EXPECT_NE(what.find("recording.txt"), std::string::npos);
    EXPECT_EQ(e.line(), 7);
    EXPECT_EQ(e.column(), bad_column);
    std::ostringstream place;
    place << ":7:" << bad_column << ':';
    EXPECT_NE(what.find(place.str()), std::string::npos);
    EXPECT_EQ(e.key(), "master_left.R12");  // 5th column: tip_x tip_y tip_z R11 R12
    EXPECT_NE(e.message().find("'1.2.3'"), std::string::npos);
    EXPECT_NE(e.message().find("not a number"), std::string::npos);
  }
  // The same scene with the shipped excerpt loads.
  const std::string good = replace(text, data_path, numen::test::jigsaws_excerpt_path());
  const Scene s = load_scene(dir.write("jig_ok.toml", good));
  EXPECT_NEAR(s.trajectory.duration(), 899.0 / 30.0, 1.5e-3);
}

TEST(SceneErrors, ScriptedSegmentWithNegativeDurationIsLocatedAtThatSegment) {
  TempDir dir;
  const std::string text = replace(kMiniScene, "duration = 0.25", "duration = -0.25");
  const InputError e = load_error(dir, text);
  expect_located(e, (dir.path() / "bad.toml").string(), line_of(text, "duration = -0.25"),
                 column_of(text, "duration = -0.25", "-0.25"), "trajectory.segment[1].duration", "> 0");
}

TEST(SceneErrors, WrongNumberOfDeviceAxes) {
  TempDir dir;
  const std::string text = kMiniScene + R"(
[[device.axis]]
name = "x"

[[device.axis]]
name = "y"
)";
  const InputError e = load_error(dir, text);
  const std::string what = e.what();
  SCOPED_TRACE(what);
  EXPECT_EQ(e.file(), (dir.path() / "bad.toml").string());
  EXPECT_NE(what.find("bad.toml"), std::string::npos);
  EXPECT_EQ(e.key(), "device.axis");
  EXPECT_NE(e.message().find("6 axes, 2 given"), std::string::npos);
  // Located at the axis list: its first [[device.axis]] header.
  EXPECT_EQ(e.line(), line_of(text, "[[device.axis]]"));
}

TEST(SceneErrors, AContactStiffnessTheStepCannotResolveIsAWarningNamingTheBody) {
  // The mini scene's tool: 0.1 kg, its sphere at the COM (effective mass 0.1 kg); at dt = 1 ms the
  // time-constant floor ω h ≤ 5 lets a contact act with at most 0.1 · (5 / 1 ms)² = 2.5e6 N/m.
  TempDir dir;
  const std::string stiff = kMiniScene + "\n[contact_default]\nstiffness = 1e9\n";
  const Scene s = load_scene(dir.write("stiff.toml", stiff));
  const std::vector<std::string> warnings = numen::test::warnings_besides_no_feedback(s);
  ASSERT_EQ(warnings.size(), 1u);
  const std::string& w = warnings[0];
  EXPECT_NE(w.find("body \"tool\""), std::string::npos) << w;
  EXPECT_NE(w.find("1e+09 N/m"), std::string::npos) << w;
  EXPECT_NE(w.find("2.5e+06 N/m"), std::string::npos) << w;
  EXPECT_NE(w.find("contact_max_omega_dt"), std::string::npos) << w;
  // Below the floor, or with the floor raised in [solver]: no warning.
  const Scene soft = load_scene(dir.write("soft.toml", kMiniScene + "\n[contact_default]\nstiffness = 2e6\n"));
  EXPECT_TRUE(numen::test::warnings_besides_no_feedback(soft).empty());
  const Scene raised = load_scene(
      dir.write("raised.toml", kMiniScene + "\n[contact_default]\nstiffness = 1e9\n[solver]\ncontact_max_omega_dt = 100.0\n"));
  EXPECT_TRUE(numen::test::warnings_besides_no_feedback(raised).empty());
  EXPECT_DOUBLE_EQ(raised.model.solver.contact_max_omega_dt, 100.0);
  // Out of range: an error naming the key.
  const InputError e = load_error(dir, kMiniScene + "\n[solver]\ncontact_max_omega_dt = 0.0\n");
  EXPECT_EQ(e.key(), "solver.contact_max_omega_dt");
}

TEST(SceneErrors, DampingOutsideThePapersRuleIsAWarningNotAnError) {
  TempDir dir;
  // ζ = 0.5 → γ/√(mk) = 1.0 < 1.4.
  const std::string low = replace(kMiniScene, "damping_ratio = 0.85", "damping_ratio = 0.5");
  const Scene s = load_scene(dir.write("low.toml", low));
  const std::vector<std::string> warnings = numen::test::warnings_besides_no_feedback(s);
  ASSERT_EQ(warnings.size(), 1u);
  const std::string& w = warnings[0];
  EXPECT_NE(w.find("low.toml"), std::string::npos) << w;
  EXPECT_NE(w.find("body[0].coupling"), std::string::npos) << w;
  EXPECT_NE(w.find("1.4"), std::string::npos) << w;
  // Explicit damping: γ = 2.5 √(m k) → above 2.
  const double gamma = 2.5 * std::sqrt(0.1 * 100.0);
  const std::string high = replace(kMiniScene, "damping_ratio = 0.85", "damping = " + std::to_string(gamma));
  const Scene h = load_scene(dir.write("high.toml", high));
  const std::vector<std::string> high_warnings = numen::test::warnings_besides_no_feedback(h);
  ASSERT_EQ(high_warnings.size(), 1u);
  EXPECT_NE(high_warnings[0].find("body[0].coupling.damping"), std::string::npos) << high_warnings[0];
  EXPECT_NEAR(h.model.bodies[0].coupling.gamma_t, gamma, 1e-6);
  // Inside the rule (γ/√(mk) = 1.6): no warning.
  const std::string ok = replace(kMiniScene, "damping_ratio = 0.85", "damping_ratio = 0.8");
  EXPECT_TRUE(numen::test::warnings_besides_no_feedback(load_scene(dir.write("ok.toml", ok))).empty());
}

TEST(SceneErrors, MissingDevice) {
  TempDir dir;
  const std::string text = replace(kMiniScene, "[device]\nkind = \"pose-tracker\"\nattach = \"tool\"\n", "");
  const InputError e = load_error(dir, text);
  const std::string what = e.what();
  SCOPED_TRACE(what);
  EXPECT_EQ(e.file(), (dir.path() / "bad.toml").string());
  EXPECT_NE(what.find("bad.toml"), std::string::npos);
  EXPECT_EQ(e.key(), "device");
  EXPECT_NE(what.find("device: missing"), std::string::npos);
  EXPECT_NE(e.message().find("`numen run` needs a [device]"), std::string::npos);
  EXPECT_NE(e.message().find("stepped by your own program"), std::string::npos);
  // Loaded to be stepped by the caller: no error; the same located error waits for a run.
  numen::sim::SceneOverrides caller;
  caller.caller_steps = true;
  const Scene s = load_scene((dir.path() / "bad.toml").string(), caller);
  EXPECT_FALSE(s.has_device);
  EXPECT_TRUE(s.has_trajectory);
  EXPECT_EQ(s.model.initial_held_body, 0);  // the first body that is not anchored
  EXPECT_EQ(s.model.feedback.k_t, 0.0);
  ASSERT_EQ(s.run_missing.size(), 1u);
  EXPECT_STREQ(s.run_missing[0].what(), e.what());
  try {
    numen::sim::require_runnable(s);
    ADD_FAILURE() << "require_runnable() accepted a scene without [device]";
  } catch (const InputError& r) {
    EXPECT_STREQ(r.what(), e.what());
  }
  ASSERT_EQ(s.warnings.size(), 1u);
  EXPECT_EQ(s.warnings[0], "no feedback: non-haptic device (the scene has no [device]): "
                           "feedback_wrench stays 0; a [device] table with kind = \"pose-tracker\" "
                           "and attach = \"tool\", and under it a [device.feedback] table with "
                           "stiffness (N/m) and damping (N·s/m), give it (as sim/scenes/probe.toml)");
  // The advice loads and gives feedback ([device.feedback] alone is refused: device.kind missing).
  const Scene fed = load_scene(
      dir.write("fed.toml", text + "\n[device]\nkind = \"pose-tracker\"\nattach = \"tool\"\n"
                                   "[device.feedback]\nstiffness = 100.0\ndamping = 1.0\n"),
      caller);
  EXPECT_TRUE(fed.warnings.empty()) << fed.warnings.front();
  EXPECT_EQ(fed.model.feedback.k_t, 100.0);
}

TEST(SceneErrors, MissingTrajectory) {
  TempDir dir;
  const std::string text = kMiniScene.substr(0, kMiniScene.find("[trajectory]"));
  const InputError e = load_error(dir, text);
  const std::string what = e.what();
  SCOPED_TRACE(what);
  EXPECT_EQ(e.file(), (dir.path() / "bad.toml").string());
  EXPECT_NE(what.find("bad.toml"), std::string::npos);
  EXPECT_EQ(e.key(), "trajectory");
  EXPECT_NE(what.find("trajectory: missing"), std::string::npos);
  EXPECT_NE(e.message().find("`numen run` needs a [trajectory]"), std::string::npos);
  // Loaded to be stepped by the caller: no error, no trajectory, no duration; a run refuses it
  // with the same located error.
  numen::sim::SceneOverrides caller;
  caller.caller_steps = true;
  const Scene s = load_scene((dir.path() / "bad.toml").string(), caller);
  EXPECT_FALSE(s.has_trajectory);
  EXPECT_TRUE(s.has_device);
  EXPECT_TRUE(s.trajectory.empty());
  EXPECT_EQ(s.duration_s, 0.0);
  EXPECT_EQ(s.model.initial_held_body, 0);
  ASSERT_EQ(s.run_missing.size(), 1u);
  EXPECT_STREQ(s.run_missing[0].what(), e.what());
  EXPECT_THROW(numen::sim::require_runnable(s), InputError);
}

// ---------------------------------------------------------------- input plausibility (issue 17)

namespace {

/// The first `rows` lines of the shipped excerpt, with `edit` applied to line `line` (1-based).
std::string excerpt_lines(int rows, int line = 0,
                          const std::function<void(std::string&)>& edit = nullptr) {
  std::ifstream in(numen::test::jigsaws_excerpt_path());
  std::string out, l;
  for (int n = 1; n <= rows && std::getline(in, l); ++n) {
    if (n == line && edit) edit(l);
    out += l + "\n";
  }
  return out;
}

}  // namespace

TEST(SceneErrors, ObstacleNameDeclaredTwice) {
  TempDir dir;
  const std::string text = replace(kMiniScene, "[device]", R"([[obstacle]]
name = "floor"
type = "sphere"
radius = 0.01
position = [0.0, 0.5, 0.0]

[device])");
  const InputError e = load_error(dir, text);
  expect_located(e, (dir.path() / "bad.toml").string(), line_of(text, "name = \"floor\"", 2),
                 8 /* the value of name = "floor" */, "obstacle[1].name",
                 "obstacle \"floor\" declared twice");
}

TEST(SceneErrors, ScriptedTargetsFartherThan10mAreLocated) {
  TempDir dir;
  {  // The start of the path.
    const std::string text = replace(kMiniScene, "start = { position = [0.0, 0.0, 0.0] }",
                                     "start = { position = [1000.0, 0.0, 0.0] }");
    const InputError e = load_error(dir, text);
    expect_located(e, (dir.path() / "bad.toml").string(), line_of(text, "start = {"),
                   column_of(text, "start = {", "[1000"), "trajectory.start.position", "1000 m");
    EXPECT_NE(e.message().find("beyond 10 m"), std::string::npos) << e.what();
  }
  {  // A segment's end point.
    const std::string text = replace(kMiniScene, "to = [0.01, 0.0, 0.0]", "to = [0.01, 1e100, 0.0]");
    const InputError e = load_error(dir, text);
    expect_located(e, (dir.path() / "bad.toml").string(), line_of(text, "to = [0.01, 1e100"),
                   column_of(text, "to = [0.01, 1e100", "["), "trajectory.segment[0].to", "1e+100 m");
  }
  {  // A placement that scales the path out of the room.
    const std::string text = replace(kMiniScene, "start = { position = [0.0, 0.0, 0.0] }",
                                     "start = { position = [0.5, 0.0, 0.0] }\nplacement = { scale = 100.0 }");
    const InputError e = load_error(dir, text);
    EXPECT_EQ(e.key(), "trajectory.placement") << e.what();
    EXPECT_EQ(e.line(), line_of(text, "placement = {")) << e.what();
    EXPECT_NE(e.message().find("50 m from the origin"), std::string::npos) << e.what();
  }
}

TEST(SceneErrors, AJigsawsTipAt1e308IsBlamedOnTheDataFileNotOnTheDevice) {
  TempDir dir;
  int column = 0;
  const std::string data = dir.write("tip.txt", excerpt_lines(40, 12, [&](std::string& l) {
    // Data column 58 (slave right tip x) is the 58th token.
    std::size_t c = 0;
    for (int tok = 0; tok < 58; ++tok) {
      c = l.find_first_not_of(" \t", c);
      if (tok < 57) c = l.find_first_of(" \t", c);
    }
    l.replace(c, l.find_first_of(" \t", c) - c, "1e308");
    column = static_cast<int>(c) + 1;
  }));
  const InputError e = load_error(dir, jigsaws_scene(data));
  EXPECT_EQ(e.file(), data);
  EXPECT_EQ(e.line(), 12);
  EXPECT_EQ(e.column(), column);
  EXPECT_EQ(e.key(), "slave_right.tip_x");
  EXPECT_NE(e.message().find("beyond 10 m"), std::string::npos) << e.what();
}

TEST(SceneErrors, AJigsawsTrajectoryOfOneRowIsRefused) {
  TempDir dir;
  {  // start_time == end_time: one row.
    const std::string text =
        jigsaws_scene(numen::test::jigsaws_excerpt_path(), "start_time = 2.0\nend_time = 2.0\n");
    const InputError e = load_error(dir, text);
    expect_located(e, (dir.path() / "bad.toml").string(), line_of(text, "end_time"),
                   column_of(text, "end_time", "2.0"), "trajectory.end_time", "holds one row");
    EXPECT_NE(e.message().find("at least two"), std::string::npos) << e.what();
  }
  {  // A file of one row.
    const std::string data = dir.write("one.txt", excerpt_lines(1));
    const std::string text = jigsaws_scene(data);
    const InputError e = load_error(dir, text);
    expect_located(e, (dir.path() / "bad.toml").string(), line_of(text, "file = "),
                   column_of(text, "file = ", "\""), "trajectory.file", "holds one row of one.txt");
  }
  {  // Two rows (1/30 s) are enough.
    const std::string data = dir.write("two.txt", excerpt_lines(2));
    const Scene s = load_scene(dir.write("two.toml", jigsaws_scene(data)));
    EXPECT_NEAR(s.duration_s, 1.0 / 30.0, 1e-3);
  }
}

TEST(SceneErrors, ATrajectoryFileThatIsADirectoryIsLocated) {
  TempDir dir;
  fs::create_directories(dir.path() / "recording");
  const std::string text = jigsaws_scene((dir.path() / "recording").string());
  const InputError e = load_error(dir, text);
  expect_located(e, (dir.path() / "bad.toml").string(), line_of(text, "file = "),
                 column_of(text, "file = ", "\""), "trajectory.file", "is a directory");
  EXPECT_EQ(std::string(e.what()).find("basic_filebuf"), std::string::npos) << e.what();
}

// dt = 1e-7 with a [bus] table that sets no compute_phase was blamed on bus.compute_phase at
// the [bus] header, quoting nothing: dt is blamed at its value, with the values that clash.
TEST(SceneErrors, APeriodShorterThanTheBusRoundTripBlamesDtWithTheValues) {
  TempDir dir;
  const std::string text =
      replace(kMiniScene, "dt = 0.001", "dt = 1e-7") + "\n[bus]\nlatency = 0.0001\n";
  const InputError e = load_error(dir, text);
  expect_located(e, (dir.path() / "bad.toml").string(), line_of(text, "dt = 1e-7"),
                 column_of(text, "dt = 1e-7", "1e-7"), "dt",
                 "the period 1e-07 s is not longer than the compute phase 0.00025 s (one SYNC "
                 "round trip, 2·[bus] latency = 0.0002 s, plus 50 µs unless [bus] compute_phase "
                 "is set)");
  // A compute_phase the file sets is blamed at its own value, with the interval it misses.
  const std::string set = replace(kMiniScene, "dt = 0.001", "dt = 0.0005") +
                          "\n[bus]\nlatency = 0.0001\ncompute_phase = 0.0006\n";
  const InputError p = load_error(dir, set);
  expect_located(p, (dir.path() / "bad.toml").string(), line_of(set, "compute_phase = 0.0006"),
                 column_of(set, "compute_phase = 0.0006", "0.0006"), "bus.compute_phase",
                 "must be in [2·latency, dt) = [0.0002, 0.0005) s: one SYNC round trip must fit "
                 "in the period (got 0.0006 s)");
}

TEST(SceneErrors, ADurationShorterThanOnePeriodIsRefused) {
  TempDir dir;
  const std::string text = replace(kMiniScene, "dt = 0.001", "dt = 0.001\nduration = 0.0001");
  const InputError e = load_error(dir, text);
  expect_located(e, (dir.path() / "bad.toml").string(), line_of(text, "duration = 0.0001"),
                 column_of(text, "duration = 0.0001", "0.0001"), "duration", "no step");
  const std::string huge = replace(kMiniScene, "dt = 0.001", "dt = 0.001\nduration = 1e300");
  const InputError h = load_error(dir, huge);
  EXPECT_EQ(h.key(), "duration");
  EXPECT_LT(std::string(h.what()).size(), 300u) << h.what();
}

TEST(SceneErrors, ANulByteInAMessageDoesNotCutIt) {
  const InputError e("scene.toml", 3, 7, "body[0].name", std::string("bad \0byte here", 14));
  const std::string what(e.what());  // up to the first NUL, as a terminal prints it
  EXPECT_EQ(what, "scene.toml:3:7: body[0].name: bad \\x00byte here");
}

TEST(SceneErrors, ASceneFileThatIsADirectoryIsNamedAsSuch) {
  TempDir dir;
  try {
    (void)load_scene(dir.path().string());
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), dir.path().string());
    EXPECT_NE(e.message().find("is a directory"), std::string::npos) << e.what();
  }
}

TEST(SceneErrors, AByteOrderMarkStartsASceneButIsNamedElsewhere) {
  TempDir dir;
  EXPECT_EQ(load_scene(dir.write("bom.toml", "\xEF\xBB\xBF" + kMiniScene)).name, "mini");
  const std::string text = replace(kMiniScene, "dt = 0.001", "\xEF\xBB\xBF" "dt = 0.001");
  const InputError e = load_error(dir, text);
  EXPECT_EQ(e.line(), line_of(text, "dt = 0.001")) << e.what();
  EXPECT_NE(e.message().find("byte order mark"), std::string::npos) << e.what();
}
