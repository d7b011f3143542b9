// Tests of sim/scene_pointer: `[trajectory] source = "pointer"` — an evemu recording of a
// mouse replayed through the relative-pose integrator becomes the scene's trajectory; every
// bad key of [trajectory.pointer] and every bad recording is a located error; memory does not
// depend on dt; a recording that never moves the target is a warning.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "numen/hal/features.hpp"
#include "numen/hal/input/evemu_log.hpp"
#include "numen/sim/input/input_error.hpp"
#include "numen/sim/input/pointer_path.hpp"
#include "numen/sim/scene/scene.hpp"
#include "scene_text.hpp"
#include "temp_dir.hpp"

namespace {

using numen::core::Vec3;
using numen::sim::InputError;
using numen::sim::Scene;
using numen::test::line_of;
using numen::test::load_error;
using numen::test::replace;
using numen::test::TempDir;

const std::string kRecording = std::string(NUMEN_TEST_DATA_DIR) + "/mouse_clutch.evemu";

/// The mini scene driven by `recording` with the keys of the shipped mouse scene.
std::string pointer_scene(const std::string& recording = kRecording) {
  const std::string& mini = numen::test::kMiniScene;
  return mini.substr(0, mini.find("[trajectory]")) + R"([trajectory]
source = "pointer"
file = ")" + recording + R"("
start = { position = [0.0, 0.0, 0.02] }

[trajectory.pointer]
clutch_key = "BTN_LEFT"
clutch_mode = "hold"
frame = "world"
workspace_min = [-0.2, -0.2, 0.0]
workspace_max = [0.2, 0.2, 0.1]

[[trajectory.pointer.axis]]
code = "REL_X"
dof = "x"
scale = 1.0e-4
[[trajectory.pointer.axis]]
code = "REL_Y"
dof = "y"
scale = -1.0e-4
[[trajectory.pointer.axis]]
code = "REL_WHEEL"
dof = "z"
scale = 2.0e-3
)";
}

/// The same settings as pointer_scene(), for the expected targets.
numen::hal::RelativePoseIntegratorSettings expected_settings() {
  numen::hal::RelativePoseIntegratorSettings s;
  s.axes = {{REL_X, numen::hal::PoseDof::kX, 1e-4},
            {REL_Y, numen::hal::PoseDof::kY, -1e-4},
            {REL_WHEEL, numen::hal::PoseDof::kZ, 2e-3}};
  s.initial_pose.position = Vec3(0.0, 0.0, 0.02);
  s.workspace_min = Vec3(-0.2, -0.2, 0.0);
  s.workspace_max = Vec3(0.2, 0.2, 0.1);
  return s;
}

/// Numbers instead of the names of pointer_scene() where this build cannot resolve names
/// (NUMEN_WITH_EVDEV=OFF); the text unchanged otherwise.
std::string portable(std::string text) {
  if (numen::hal::kWithEvdev) return text;
  for (const auto& [name, number] : {std::pair{"\"REL_X\"", "0"}, {"\"REL_Y\"", "1"},
                                      {"\"REL_WHEEL\"", "8"}, {"\"BTN_LEFT\"", "272"}}) {
    for (auto at = text.find(name); at != std::string::npos; at = text.find(name))
      text.replace(at, std::string(name).size(), number);
  }
  return text;
}

TEST(ScenePointer, TheRecordingReplayedIsTheTrajectory) {
  TempDir dir;
  const Scene s = numen::sim::load_scene(dir.write("pointer.toml", portable(pointer_scene())));
  const numen::sim::PointerPath path(numen::hal::load_evemu_recording(kRecording), expected_settings());
  EXPECT_TRUE(numen::test::warnings_besides_no_feedback(s).empty());  // the mouse: no feedback
  EXPECT_GT(path.counters().moving_reports, 0u);
  EXPECT_GT(path.counters().ignored_reports, 0u);  // the recording has motion with the button up
  EXPECT_NEAR(s.trajectory.duration(), path.duration(), s.model.dt);
  for (double t = 0.0; t <= s.trajectory.duration(); t += s.model.dt) {
    ASSERT_EQ(s.trajectory.at(t).pose.position, path.evaluate(t).pose.position) << t;
  }
  EXPECT_NE(s.trajectory.at(s.trajectory.duration()).pose.position, Vec3(0.0, 0.0, 0.02));
}

TEST(ScenePointer, NumbersAreAcceptedForCodes) {
  TempDir dir;
  std::string text = replace(pointer_scene(), "code = \"REL_X\"", "code = 0");
  text = replace(text, "clutch_key = \"BTN_LEFT\"", "clutch_key = 272");
  text = portable(text);
  const Scene s = numen::sim::load_scene(dir.write("numbers.toml", text));
  const Scene named = numen::sim::load_scene(dir.write("names.toml", portable(pointer_scene())));
  EXPECT_EQ(s.trajectory.at(1.0).pose.position, named.trajectory.at(1.0).pose.position);
}

// Issue 17 made memory independent of dt: the pointer trajectory keeps the report poses.
TEST(ScenePointer, MemoryDoesNotDependOnTheControlPeriod) {
  TempDir dir;
  const std::string text = portable(pointer_scene());
  const Scene coarse = numen::sim::load_scene(dir.write("coarse.toml", text));
  const Scene fine = numen::sim::load_scene(dir.write("fine.toml", replace(text, "dt = 0.001", "dt = 0.0005")));
  EXPECT_EQ(fine.trajectory.size(), 2 * coarse.trajectory.size() - 1);
  EXPECT_EQ(coarse.trajectory.memory_bytes(), fine.trajectory.memory_bytes());
}

TEST(ScenePointer, ARecordingThatNeverMovesTheTargetIsAWarning) {
  TempDir dir;
  // The recording clutches with the left button; a right-button clutch never engages.
  const std::string text = portable(replace(pointer_scene(), "clutch_key = \"BTN_LEFT\"",
                                            numen::hal::kWithEvdev ? "clutch_key = \"BTN_RIGHT\""
                                                                   : "clutch_key = 0x111"));
  const Scene s = numen::sim::load_scene(dir.write("right.toml", text));
  const std::vector<std::string> warnings = numen::test::warnings_besides_no_feedback(s);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("never moves the target"), std::string::npos) << warnings[0];
}

/// One bad edit of the pointer scene and where its error must point.
struct BadKey {
  const char* what;     // the case
  const char* from;     // text replaced in pointer_scene() ...
  const char* to;       // ... by this
  const char* key;      // the error's dotted key
  const char* needle;   // the error's line holds this ("" : the [trajectory] line)
  const char* message;  // part of the message
};

TEST(ScenePointer, EveryBadKeyIsALocatedError) {
  const std::vector<BadKey> cases = {
      {"unknown key", "frame = \"world\"", "frame = \"world\"\nclutch = 1", "trajectory.pointer.clutch",
       "clutch = 1", "unknown key"},
      {"unknown axis key", "dof = \"x\"", "dof = \"x\"\ncounts = 2", "trajectory.pointer.axis[0].counts",
       "counts = 2", "unknown key"},
      {"axis code missing", "code = \"REL_X\"\n", "", "trajectory.pointer.axis[0].code",
       "[[trajectory.pointer.axis]]", "missing: an EV_REL code"},
      {"axis code out of range", "code = \"REL_X\"", "code = 16", "trajectory.pointer.axis[0].code",
       "code = 16", "must be an EV_REL code in [0, 15], got 16"},
      {"axis code negative", "code = \"REL_X\"", "code = -1", "trajectory.pointer.axis[0].code",
       "code = -1", "got -1"},
      {"axis code not a name or integer", "code = \"REL_X\"", "code = 1.5",
       "trajectory.pointer.axis[0].code", "code = 1.5", "expected an EV_REL code"},
      {"dof", "dof = \"y\"", "dof = \"w\"", "trajectory.pointer.axis[1].dof", "dof = \"w\"",
       "unknown value \"w\""},
      {"scale zero", "scale = 2.0e-3", "scale = 0.0", "trajectory.pointer.axis[2].scale",
       "scale = 0.0", "must not be 0"},
      {"scale not finite", "scale = 2.0e-3", "scale = nan", "trajectory.pointer.axis[2].scale",
       "scale = nan", "must be finite"},
      {"clutch_key out of range", "clutch_key = \"BTN_LEFT\"", "clutch_key = 768",
       "trajectory.pointer.clutch_key", "clutch_key = 768", "must be an EV_KEY code in [0, 767]"},
      {"clutch_mode", "clutch_mode = \"hold\"", "clutch_mode = \"press\"",
       "trajectory.pointer.clutch_mode", "clutch_mode", "unknown value \"press\""},
      {"frame", "frame = \"world\"", "frame = \"body\"", "trajectory.pointer.frame", "frame =",
       "unknown value \"body\""},
      {"inverted workspace", "workspace_min = [-0.2, -0.2, 0.0]", "workspace_min = [-0.2, 0.3, 0.0]",
       "trajectory.pointer.workspace_min", "workspace_min", "the y bound 0.3 m of workspace_min is above"},
      {"workspace not finite", "workspace_max = [0.2, 0.2, 0.1]", "workspace_max = [0.2, inf, 0.1]",
       "trajectory.pointer.workspace_max[1]", "workspace_max", "must be finite"},
      {"start outside the workspace", "start = { position = [0.0, 0.0, 0.02] }",
       "start = { position = [0.0, 0.0, 0.5] }", "trajectory.start.position", "start =",
       "the start position's z = 0.5 m is outside the pointer workspace [0, 0.1] m"},
      {"placement", "source = \"pointer\"", "source = \"pointer\"\nplacement = { scale = 2.0 }",
       "trajectory.placement", "placement =", "unknown key"},
      {"file missing", "mouse_clutch.evemu", "no_such.evemu", "trajectory.file", "file =",
       "pointer recording not found"},
      {"file a directory", "/mouse_clutch.evemu", "", "trajectory.file", "file =",
       "is a directory, not an evemu recording"},
  };
  TempDir dir;
  for (const BadKey& c : cases) {
    SCOPED_TRACE(c.what);
    const std::string text = portable(replace(pointer_scene(), c.from, c.to));
    const InputError e = load_error(dir, text);
    EXPECT_EQ(e.key(), c.key);
    EXPECT_EQ(e.line(), line_of(text, c.needle)) << e.what();
    EXPECT_GT(e.column(), 0);
    EXPECT_NE(e.message().find(c.message), std::string::npos) << e.what();
  }
}

TEST(ScenePointer, AnEmptyAxisListIsALocatedError) {
  TempDir dir;
  std::string text = pointer_scene();
  text = replace(text.substr(0, text.find("[[trajectory.pointer.axis]]")), "frame = \"world\"",
                 "frame = \"world\"\naxis = []");
  const InputError e = load_error(dir, portable(text));
  EXPECT_EQ(e.key(), "trajectory.pointer.axis");
  EXPECT_EQ(e.line(), line_of(text, "axis = []"));
  EXPECT_NE(e.message().find("at least one"), std::string::npos) << e.what();
}

TEST(ScenePointer, EveryBadNameIsALocatedError) {
  TempDir dir;
  const std::vector<BadKey> cases = {
      {"unknown name", "code = \"REL_X\"", "code = \"REL_Q\"", "trajectory.pointer.axis[0].code",
       "REL_Q", "\"REL_Q\" is not the name of an EV_REL code"},
      {"a key's name for an axis", "code = \"REL_X\"", "code = \"BTN_LEFT\"",
       "trajectory.pointer.axis[0].code", "code = \"BTN_LEFT\"", "is not the name of an EV_REL code"},
      {"an axis's name for the clutch", "clutch_key = \"BTN_LEFT\"", "clutch_key = \"REL_X\"",
       "trajectory.pointer.clutch_key", "clutch_key", "\"REL_X\" is not the name of an EV_KEY code"},
      {"lower case", "clutch_key = \"BTN_LEFT\"", "clutch_key = \"btn_left\"",
       "trajectory.pointer.clutch_key", "clutch_key", "is not the name of an EV_KEY code"},
  };
  for (const BadKey& c : cases) {
    SCOPED_TRACE(c.what);
    const std::string text = replace(pointer_scene(), c.from, c.to);
    const InputError e = load_error(dir, text);
    if (numen::hal::kWithEvdev) {
      EXPECT_EQ(e.key(), c.key);
      EXPECT_EQ(e.line(), line_of(text, c.needle)) << e.what();
      EXPECT_NE(e.message().find(c.message), std::string::npos) << e.what();
    } else {  // without libevdev the first name the loader meets is refused, whatever it is
      EXPECT_EQ(e.key(), "trajectory.pointer.axis[0].code") << e.what();
      EXPECT_NE(e.message().find("NUMEN_WITH_EVDEV=OFF"), std::string::npos) << e.what();
    }
  }
}

TEST(ScenePointer, EveryBadRecordingIsALocatedError) {
  TempDir dir;
  const std::string header = "# EVEMU 1.3\nN: m\nI: 0003 1d6b 0104 0001\n";
  const struct {
    const char* what;
    std::string recording;
    const char* message;
  } cases[] = {
      {"malformed line", header + "E: 0.000001 0002 0000 0005\nE: 0.000001 0002 zz 0005\n",
       "bad.evemu:5:18: bad event code"},
      {"garbage line", header + "hello\n", "bad.evemu:4:1: unknown line"},
      {"trailing text", header + "E: 0.000001 0002 0000 5junk\n", "bad.evemu:4:24: bad value"},
      {"no event", header, "no event line (E:)"},
      {"no report", header + "E: 0.000001 0002 0000 0005\n", "1 events and no SYN_REPORT"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.what);
    const std::string rec = dir.write("bad.evemu", c.recording);
    const std::string text = portable(pointer_scene(rec));
    const InputError e = load_error(dir, text);
    EXPECT_EQ(e.key(), "trajectory.file");
    EXPECT_EQ(e.line(), line_of(text, "file ="));
    EXPECT_NE(e.message().find(c.message), std::string::npos) << e.what();
  }
}

TEST(ScenePointer, ATargetDrivenBeyondTenMetresIsRefused) {
  TempDir dir;
  std::string text = replace(pointer_scene(), "scale = 1.0e-4", "scale = 1.0");  // 1 m per count
  text = replace(text, "workspace_min = [-0.2, -0.2, 0.0]", "workspace_min = [-100.0, -100.0, 0.0]");
  text = portable(replace(text, "workspace_max = [0.2, 0.2, 0.1]", "workspace_max = [100.0, 100.0, 0.1]"));
  const InputError e = load_error(dir, text);
  EXPECT_EQ(e.key(), "trajectory.file");
  EXPECT_NE(e.message().find("m from the world origin"), std::string::npos) << e.what();
  EXPECT_NE(e.message().find("beyond 10 m"), std::string::npos) << e.what();
}

}  // namespace
