// Tests of sim/scene: [device.canopen] (sim/src/scene/scene_device.cpp): the managed stack's
// defaults, the PDO mappings, the DCFs read per node, their errors located in the scene or in
// the DCF, and the shipped scenes configuring every node from its DCF; [device.passivity]
// (the axes it controls, its errors located).
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

using numen::sim::InputError;
using numen::sim::load_scene;
using numen::sim::Scene;
using numen::test::expect_located;
using numen::test::TempDir;

// A small valid scene (pose tracker, scripted path; tests/support/scene_text.hpp). Every error
// test below changes one thing in it, so that the error can only come from that change.
using numen::test::kMiniScene;

}  // namespace

// ---------------------------------------------------------------- [device.canopen]

TEST(SceneCanopen, DefaultsAreTheManagedStackAndKeysAreRead) {
  TempDir dir;
  const Scene d = load_scene(dir.write("mini.toml", kMiniScene));
  EXPECT_TRUE(d.device.canopen.managed);
  ASSERT_EQ(d.device.canopen.axes.size(), 6u);
  EXPECT_EQ(d.device.canopen.axes[0].node_id, 1);
  EXPECT_EQ(d.device.canopen.axes[5].node_id, 6);
  EXPECT_EQ(d.device.canopen.axes[0].effective_heartbeat_timeout_ms(), 30u);
  EXPECT_EQ(d.device.canopen.axes[0].drive_tpdo_cob_id, 0u);  // a pose tracker has no drives

  const std::string text = replace(kMiniScene, "attach = \"tool\"\n", R"(attach = "tool"

[device.canopen]
controller_node_id = 100
node_heartbeat_period = 20
heartbeat_timeout = 50
startup_timeout = 500
)");
  const Scene s = load_scene(dir.write("canopen.toml", text));
  EXPECT_EQ(s.device.canopen.controller_node_id, 100);
  EXPECT_EQ(s.device.canopen.startup_timeout_ms, 500u);
  EXPECT_EQ(s.device.canopen.axes[3].heartbeat_period_ms, 20);
  EXPECT_EQ(s.device.canopen.axes[3].effective_heartbeat_timeout_ms(), 50u);

  const Scene m = load_scene(dir.write(
      "minimal.toml", replace(kMiniScene, "attach = \"tool\"\n", "attach = \"tool\"\ncanopen = { managed = false }\n")));
  EXPECT_FALSE(m.device.canopen.managed);
}

TEST(SceneCanopen, MappingsAreListedAndErrorsAreLocated) {
  TempDir dir;
  const std::string axis = R"(
[[device.canopen.axis]]
encoder_tpdo = [0x60040020, 0x60410010]
[[device.canopen.axis]]
[[device.canopen.axis]]
[[device.canopen.axis]]
[[device.canopen.axis]]
[[device.canopen.axis]]
node_id = 9
)";
  const std::string text = replace(kMiniScene, "attach = \"tool\"\n", "attach = \"tool\"\n" + axis);
  const Scene s = load_scene(dir.write("map.toml", text));
  ASSERT_EQ(s.device.canopen.axes[0].encoder_tpdo.size(), 2u);
  EXPECT_EQ(s.device.canopen.axes[0].encoder_tpdo[1].index, 0x6041);
  EXPECT_EQ(s.device.canopen.axes[5].node_id, 9);

  // An object numen does not map: located at the list element.
  const std::string bad = replace(text, "[0x60040020, 0x60410010]", "[0x60040020, 0x60720010]");
  const InputError e = load_error(dir, bad, "badmap.toml");
  expect_located(e, (dir.path() / "badmap.toml").string(), line_of(bad, "0x60720010"),
                 column_of(bad, "encoder_tpdo", "0x60720010"),
                 "device.canopen.axis[0].encoder_tpdo[1]", "is not an object numen maps");
  // No position object: the whole mapping is refused, at its key.
  const std::string nopos = replace(text, "[0x60040020, 0x60410010]", "[0x60410010]");
  const InputError e2 = load_error(dir, nopos, "nopos.toml");
  EXPECT_EQ(e2.line(), line_of(nopos, "[0x60410010]"));
  EXPECT_NE(std::string(e2.what()).find("must map the position value 0x6004:00"), std::string::npos);
  // A node id used by the controller.
  const std::string clash = replace(text, "node_id = 9", "node_id = 127");
  const InputError e3 = load_error(dir, clash, "clash.toml");
  EXPECT_EQ(e3.line(), line_of(clash, "node_id = 127"));
  EXPECT_NE(std::string(e3.what()).find("controller's node id"), std::string::npos);
  // An unknown key.
  const InputError e4 = load_error(dir, replace(kMiniScene, "attach = \"tool\"\n", "attach = \"tool\"\ncanopen = { manged = true }\n"), "typo.toml");
  EXPECT_NE(std::string(e4.what()).find("manged"), std::string::npos);
}

std::string shipped_dcf_text(const char* name) {
  std::ifstream in(std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/devices/" + name);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

TEST(SceneCanopen, DcfsAreReadPerNodeRelativeToTheScene) {
  TempDir dir;
  const std::string dcf = shipped_dcf_text("encoder.dcf");
  dir.write("enc.dcf", dcf);
  const std::string text = replace(kMiniScene, "attach = \"tool\"\n", R"(attach = "tool"

[device.canopen]
dcf = "enc.dcf"
sdo_timeout = 50
sdo_poll_period = 100
)");
  const Scene s = load_scene(dir.write("dcf.toml", text));
  EXPECT_EQ(s.device.canopen.sdo_timeout_ms, 50u);
  EXPECT_EQ(s.device.canopen.sdo_poll_period_ms, 100u);
  for (std::size_t i = 0; i < 6; ++i) {
    const numen::hal::CanopenAxisConfig& x = s.device.canopen.axes[i];
    ASSERT_NE(x.dcf, nullptr);
    EXPECT_EQ(x.dcf->resolved_node_id, x.node_id);
    EXPECT_EQ(x.dcf->find({0x1800, 1})->value, 0x180u + x.node_id);  // $NODEID resolved per node
    EXPECT_EQ(x.dcf->path, (dir.path() / "enc.dcf").string());
  }
  // One axis's own DCF wins over the device's.
  dir.write("own.dcf", dcf);
  const std::string own = replace(text, "sdo_poll_period = 100\n", "sdo_poll_period = 100\n" R"(
[[device.canopen.axis]]
[[device.canopen.axis]]
[[device.canopen.axis]]
[[device.canopen.axis]]
[[device.canopen.axis]]
[[device.canopen.axis]]
dcf = "own.dcf"
)");
  const Scene o = load_scene(dir.write("own.toml", own));
  EXPECT_EQ(o.device.canopen.axes[5].dcf->path, (dir.path() / "own.dcf").string());
  EXPECT_EQ(o.device.canopen.axes[4].dcf->path, (dir.path() / "enc.dcf").string());
}

TEST(SceneCanopen, DcfErrorsAreLocatedInTheSceneOrInTheDcf) {
  TempDir dir;
  const std::string dcf = shipped_dcf_text("encoder.dcf");
  const std::string scene = replace(kMiniScene, "attach = \"tool\"\n", "attach = \"tool\"\n\n[device.canopen]\ndcf = \"enc.dcf\"\n");
  // No such file: at the scene's key.
  const InputError missing = load_error(dir, scene, "missing.toml");
  expect_located(missing, (dir.path() / "missing.toml").string(), line_of(scene, "dcf = "),
                 column_of(scene, "dcf = ", "\"enc.dcf\""), "device.canopen.dcf", "DCF file not found");
  // A malformed DCF: at its line, section and key, naming the scene key.
  const std::string bad = replace(dcf, "AccessType=rw\nDefaultValue=10", "AccessType=rx\nDefaultValue=10");
  dir.write("enc.dcf", bad);
  const InputError e = load_error(dir, scene, "bad.toml");
  EXPECT_EQ(e.file(), (dir.path() / "enc.dcf").string());
  EXPECT_EQ(e.line(), line_of(bad, "AccessType=rx"));
  EXPECT_EQ(e.key(), "[1017] AccessType");
  EXPECT_NE(std::string(e.what()).find("is not ro, wo, rw, rwr, rww or const (the DCF of device.canopen.dcf)"),
            std::string::npos);
  // A DCF that disagrees with the scene: the heartbeat, at the DCF's value.
  dir.write("enc.dcf", dcf);
  const std::string hb = replace(scene, "dcf = \"enc.dcf\"\n", "dcf = \"enc.dcf\"\nnode_heartbeat_period = 20\n");
  const InputError e2 = load_error(dir, hb, "hb.toml");
  EXPECT_EQ(e2.line(), line_of(dcf, "ParameterValue=10"));
  EXPECT_EQ(e2.key(), "[1017] ParameterValue");
  EXPECT_NE(std::string(e2.what()).find("producer heartbeat time 10 ms, the axis 'x' node's heartbeat_period is 20 ms"),
            std::string::npos) << e2.what();
  // A COB-ID the DCF does not configure: at the file.
  const std::string cob = replace(dcf, "ParameterValue=$NODEID+0x180", "ParameterValue=$NODEID+0x190");
  dir.write("enc.dcf", cob);
  const InputError e3 = load_error(dir, scene, "cob.toml");
  EXPECT_EQ(e3.line(), 0);
  EXPECT_NE(std::string(e3.what()).find("no enabled TPDO with COB-ID 0x181 (the encoder TPDO of axis 'x')"),
            std::string::npos) << e3.what();
  // Only the managed stack is configured.
  dir.write("enc.dcf", dcf);
  const InputError e4 = load_error(dir, replace(scene, "[device.canopen]\n", "[device.canopen]\nmanaged = false\n"), "minimal.toml");
  EXPECT_NE(std::string(e4.what()).find("set managed = true"), std::string::npos);
}

TEST(SceneCanopen, ShippedScenesConfigureEveryNodeFromItsDcf) {
  const std::string dir = std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/";
  for (const char* name : {"construction.toml"}) {  // mouse.toml: needs libevdev for its codes
    SCOPED_TRACE(name);
    const Scene s = load_scene(dir + name);
    for (const numen::hal::CanopenAxisConfig& x : s.device.canopen.axes) {
      ASSERT_NE(x.dcf, nullptr);
      EXPECT_NE(x.dcf->path.find("devices/encoder.dcf"), std::string::npos);
    }
  }
  if (!numen::core::kWithArticulation) GTEST_SKIP() << "the trocar and arm scenes have joints: NUMEN_WITH_ARTICULATION=OFF";
  for (const char* name : {"lattice.toml", "phantom.toml"}) {
    SCOPED_TRACE(name);
    const Scene s = load_scene(dir + name);
    for (std::size_t i = 0; i < s.device.axes.size(); ++i) {
      const numen::hal::CanopenAxisConfig& x = s.device.canopen.axes[i];
      ASSERT_NE(x.dcf, nullptr);
      EXPECT_EQ(x.dcf->find({0x1400, 1}) != nullptr, s.device.axes[i].has_drive());
    }
  }
}

// ---------------------------------------------------------------- [device.passivity]

namespace {

/// The mini scene on a phantom (drives on turret, shoulder, elbow) with `section` appended.
std::string phantom_scene(const std::string& section) {
  return replace(kMiniScene, "kind = \"pose-tracker\"", "kind = \"phantom\"") + section;
}

}  // namespace

TEST(ScenePassivity, OffWithoutTheSectionEveryDrivenAxisByDefaultOrTheNamedOnes) {
  TempDir dir;
  const Scene off = load_scene(dir.write("off.toml", phantom_scene("")));
  EXPECT_FALSE(off.device.passivity.enabled);
  const Scene all = load_scene(dir.write("all.toml", phantom_scene("\n[device.passivity]\n")));
  EXPECT_TRUE(all.device.passivity.enabled);
  EXPECT_EQ(all.device.passivity.axis_mask, 0b111u);  // turret, shoulder, elbow
  EXPECT_EQ(all.device.passivity.velocity_threshold, numen::hal::kDefaultPassivityVelocityThreshold);
  const Scene some = load_scene(dir.write(
      "some.toml", phantom_scene("\n[device.passivity]\nenabled = true\naxes = [\"elbow\", "
                                 "\"turret\"]\nvelocity_threshold = 0.002\nenergy_limit = 1e-4\n")));
  EXPECT_TRUE(some.device.passivity.enabled);
  EXPECT_EQ(some.device.passivity.axis_mask, 0b101u);
  EXPECT_EQ(some.device.passivity.velocity_threshold, 0.002);
  EXPECT_EQ(some.device.passivity.energy_limit, 1e-4);
  EXPECT_TRUE(std::isinf(all.device.passivity.energy_limit));
  const Scene disabled =
      load_scene(dir.write("disabled.toml", phantom_scene("\n[device.passivity]\nenabled = false\n")));
  EXPECT_FALSE(disabled.device.passivity.enabled);
}

TEST(ScenePassivity, ErrorsAreLocated) {
  TempDir dir;
  const std::string file = (dir.path() / "bad.toml").string();
  struct Case {
    std::string line, value, key, message;
  };
  for (const Case& c : std::vector<Case>{
           {"axes = [\"elbo\"]", "\"elbo\"", "device.passivity.axes[0]", "no axis named \"elbo\""},
           {"axes = [\"turret\", \"gimbal_yaw\"]", "\"gimbal_yaw\"", "device.passivity.axes[1]",
            "axis without a drive \"gimbal_yaw\" (driven axes: \"turret\", \"shoulder\", \"elbow\")"},
           {"axes = [3]", "3", "device.passivity.axes[0]", "expected an axis name"},
           {"axes = \"elbow\"", "\"elbow\"", "device.passivity.axes", "expected a list"},
           {"axes = []", "[]", "device.passivity.axes", "expected a list"},
           {"enabled = 1", "1", "device.passivity.enabled", "expected true or false"},
           {"velocity_threshold = -1.0", "-1.0", "device.passivity.velocity_threshold", "must be in"},
           {"energy_limit = 0.0", "0.0", "device.passivity.energy_limit", "must be in"},
           {"stiffness = 3.0", "3.0", "device.passivity.stiffness", "unknown key"},
       }) {
    const std::string text = phantom_scene("\n[device.passivity]\n" + c.line + "\n");
    const InputError e = load_error(dir, text);
    expect_located(e, file, line_of(text, c.line), column_of(text, c.line, c.value), c.key,
                   c.message);
  }
}

// ---------------------------------------------------------------- [device.igtl]

namespace {
// The mini scene with a [device.igtl] of these keys (lines ending in \n).
std::string scene_igtl_text(const std::string& keys) {
  return replace(kMiniScene, "attach = \"tool\"\n", "attach = \"tool\"\n\n[device.igtl]\n" + keys + "\n");
}
}  // namespace

TEST(SceneIgtl, KeysAreReadWithPlusDefaults) {
  const TempDir dir;
  const std::string text = scene_igtl_text(
      "device_name = \"StylusToTracker\"\nport = 18945\n"
      "calibration = { position = [0.0, 0.0, 0.15] }\n"
      "registration = { position = [0.1, 0.0, 1.0], orientation = [0.0, 0.0, 0.0, 1.0] }\n");
  const Scene s = load_scene(dir.write("igtl.toml", text));
  ASSERT_TRUE(s.igtl.has_value());
  EXPECT_EQ(s.igtl->host, "127.0.0.1");
  EXPECT_EQ(s.igtl->port, 18945);
  EXPECT_EQ(s.igtl->device_name, "StylusToTracker");
  EXPECT_EQ(s.igtl->units, "mm");
  EXPECT_DOUBLE_EQ(s.igtl->metres_per_unit, 1e-3);
  EXPECT_DOUBLE_EQ(s.igtl->calibration.position.z(), 0.15);
  EXPECT_DOUBLE_EQ(s.igtl->registration.orientation.z(), 1.0);
  // Without the table: no tracker.
  EXPECT_FALSE(load_scene(dir.write("plain.toml", kMiniScene)).igtl.has_value());
}

TEST(SceneIgtl, ErrorsAreLocatedAtTheirKeys) {
  const TempDir dir;
  const std::string base = replace(kMiniScene, "attach = \"tool\"\n",
                                   "attach = \"tool\"\n\n[device.igtl]\ndevice_name = \"Stylus\"\n"
                                   "port = 18944\nunits = \"mm\"\n\n");
  const std::string port = replace(base, "port = 18944", "port = 70000");
  const InputError e = load_error(dir, port, "port.toml");
  expect_located(e, (dir.path() / "port.toml").string(), line_of(port, "port = 70000"),
                 column_of(port, "port = 70000", "70000"), "device.igtl.port",
                 "must be a TCP port in [1, 65535]");
  const std::string units = replace(base, "units = \"mm\"", "units = \"inch\"");
  const InputError e2 = load_error(dir, units, "units.toml");
  EXPECT_EQ(e2.line(), line_of(units, "units = \"inch\""));
  EXPECT_EQ(e2.key(), "device.igtl.units");
  const std::string name = replace(base, "device_name = \"Stylus\"", "device_name = \"ABCDEFGHIJKLMNOPQRSTUVWXYZ\"");
  EXPECT_EQ(load_error(dir, name, "name.toml").key(), "device.igtl.device_name");
  const std::string typo = replace(base, "units = \"mm\"", "unit = \"mm\"");
  EXPECT_NE(std::string(load_error(dir, typo, "typo.toml").what()).find("unit"), std::string::npos);
  const std::string phantom = replace(base, "kind = \"pose-tracker\"", "kind = \"phantom\"");
  const InputError e3 = load_error(dir, phantom, "phantom.toml");
  EXPECT_EQ(e3.key(), "device.igtl");
  EXPECT_NE(std::string(e3.what()).find("pose-tracker"), std::string::npos);
}

// registration = "NAME": read from that TRANSFORM at start, with a bounded wait; errors located.
TEST(SceneIgtl, ARegistrationNamedIsReadFromItsTransformAndErrorsAreLocated) {
  const TempDir dir;
  const std::string text = scene_igtl_text(
      "device_name = \"StylusToTracker\"\nregistration = \"TrackerToScene\"\nregistration_wait = 2.5\n");
  const Scene s = load_scene(dir.write("named.toml", text));
  ASSERT_TRUE(s.igtl.has_value());
  EXPECT_EQ(s.igtl->registration_name, "TrackerToScene");
  EXPECT_DOUBLE_EQ(s.igtl->registration_wait_s, 2.5);
  EXPECT_EQ(s.igtl->registration_line, line_of(text, "registration = \"TrackerToScene\""));
  const std::string fixed_wait = replace(text, "registration = \"TrackerToScene\"",
                                         "registration = { position = [0.0, 0.0, 1.0] }");
  EXPECT_EQ(load_error(dir, fixed_wait, "fixed.toml").key(), "device.igtl.registration_wait");
  const std::string tool = replace(text, "\"TrackerToScene\"", "\"StylusToTracker\"");
  EXPECT_EQ(load_error(dir, tool, "tool.toml").key(), "device.igtl.registration");
  const std::string wait = replace(text, "registration_wait = 2.5", "registration_wait = 0.0");
  EXPECT_EQ(load_error(dir, wait, "wait.toml").key(), "device.igtl.registration_wait");
}

// ---------------------------------------------------------------- no [device.feedback]

TEST(SceneDevice, AHapticDeviceWithoutFeedbackWarnsAtLoad) {
  NUMEN_REQUIRE_ARTICULATION();  // the lattice scene has joints
  // The lattice scene without its [device.feedback]: a trainer with drives on its pivots and
  // insertion whose feedback would stay exactly 0 (issue 56: coupling −12.2 N, feedback 0).
  std::string text = numen::test::shipped_scene_text("lattice.toml");
  const auto from = text.find("[device.feedback]");
  const auto to = text.find("max_torque = 0.3", from);
  ASSERT_NE(from, std::string::npos);
  ASSERT_NE(to, std::string::npos);
  text.erase(from, text.find('\n', to) + 1 - from);
  const std::string data = "\"" + std::string(NUMEN_SOURCE_DIR) + "/sim/data/";
  for (auto at = text.find("\"../data/"); at != std::string::npos; at = text.find("\"../data/", at))
    text.replace(at, 9, data);
  TempDir dir;
  const Scene s = load_scene(dir.write("lattice.toml", text));
  EXPECT_EQ(s.model.feedback.k_t, 0.0);
  const std::string expected =
      "no feedback: device \"laparoscopic_trainer\" has motors (drives on pivot_x, pivot_y, "
      "depth) but no [device.feedback]: feedback_wrench stays 0 and the drives are sent no "
      "torque; give [device.feedback] stiffness and damping (docs/scenes.md)";
  EXPECT_EQ(std::count(s.warnings.begin(), s.warnings.end(), expected), 1)
      << (s.warnings.empty() ? std::string("no warning") : s.warnings.front());
  // The shipped scene, with its table: no such warning.
  const Scene shipped = load_scene(std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/lattice.toml");
  for (const std::string& w : shipped.warnings) EXPECT_EQ(w.rfind("no feedback", 0), std::string::npos) << w;
}

TEST(SceneDevice, ADeviceWithoutMotorsSaysItHasNoFeedback) {
  // The mini scene's pose tracker: no drives, no [device.feedback].
  TempDir dir;
  const Scene s = load_scene(dir.write("mini.toml", numen::test::kMiniScene));
  ASSERT_EQ(s.warnings.size(), 1u);
  EXPECT_EQ(s.warnings[0], "no feedback: non-haptic device (device \"pose_tracker\" has no drives and "
                           "no [device.feedback]): feedback_wrench stays 0");
  // With the table: no warning; the gains are read.
  const Scene fed = load_scene(dir.write(
      "fed.toml", replace(numen::test::kMiniScene, "attach = \"tool\"\n",
                          "attach = \"tool\"\n[device.feedback]\nstiffness = 50.0\n")));
  EXPECT_TRUE(fed.warnings.empty()) << fed.warnings.front();
  EXPECT_EQ(fed.model.feedback.k_t, 50.0);
}

// ---------------------------------------------------------------- several devices ([[device]])

TEST(SceneDevices, EachDeviceHasItsNodesFeedbackAndTrajectory) {
  TempDir dir;
  const Scene s = load_scene(dir.write("two.toml", numen::test::kTwoDeviceScene));
  ASSERT_EQ(numen::sim::num_devices(s), 2u);
  EXPECT_EQ(s.device.name, "left");
  EXPECT_EQ(s.device.canopen.axes.front().node_id, 1);
  EXPECT_DOUBLE_EQ(s.model.feedback.k_t, 50.0);
  const numen::sim::SceneDevice& right = s.extra_devices.front();
  EXPECT_EQ(right.device.name, "right");
  EXPECT_EQ(right.device.canopen.axes.front().node_id, 7);
  EXPECT_EQ(right.device.canopen.axes.back().node_id, 12);
  ASSERT_EQ(s.model.extra_feedback.size(), 1u);
  EXPECT_DOUBLE_EQ(s.model.extra_feedback[0].k_t, 80.0);
  EXPECT_DOUBLE_EQ(s.model.extra_feedback[0].gamma_t, 0.8);
  EXPECT_DOUBLE_EQ(numen::core::feedback_gains(s.model, 1).k_t, 80.0);
  EXPECT_DOUBLE_EQ(numen::core::feedback_gains(s.model, 0).k_t, 50.0);
  // Each its own path: the left one starts at the origin, the right one 5 cm along y; the scene
  // lasts as long as the longer (0.75 s).
  EXPECT_NEAR(s.trajectory.at(0.0).pose.position.y(), 0.0, 1e-12);
  EXPECT_NEAR(right.trajectory.at(0.0).pose.position.y(), 0.05, 1e-12);
  EXPECT_NEAR(s.duration_s, 0.75, 1e-9);
  EXPECT_EQ(s.model.initial_held_body, 0);
}

TEST(SceneDevices, ASingleDeviceArrayIsTheSingleDevice) {
  TempDir dir;
  const Scene one = load_scene(dir.write("one.toml", kMiniScene));
  const Scene arr = load_scene(dir.write("arr.toml", replace(kMiniScene, "[device]", "[[device]]")));
  EXPECT_TRUE(arr.extra_devices.empty());
  EXPECT_EQ(arr.device.name, one.device.name);
  EXPECT_EQ(arr.binding.links.size(), one.binding.links.size());
  EXPECT_DOUBLE_EQ(arr.duration_s, one.duration_s);
}

TEST(SceneDevices, ClashesOnTheSharedBusAreLocated) {
  TempDir dir;
  const std::string& two = numen::test::kTwoDeviceScene;
  // One node id for two devices: at the second's first_node_id, naming both.
  const std::string node = replace(two, "first_node_id = 7", "first_node_id = 6");
  const InputError e1 = load_error(dir, node, "node.toml");
  expect_located(e1, (dir.path() / "node.toml").string(), line_of(node, "first_node_id = 6"),
                 column_of(node, "first_node_id", "6"), "device[1].first_node_id",
                 "CANopen node id 6 of axis \"x\" of device \"right\" is device \"left\"'s too");
  // One name for two devices: at the second's name.
  const std::string name = replace(two, "name = \"right\"", "name = \"left\"");
  const std::string named = replace(name, "device = \"right\"", "device = \"left\"");
  const InputError e2 = load_error(dir, named, "name.toml");
  expect_located(e2, (dir.path() / "name.toml").string(), line_of(named, "name = \"left\"", 2),
                 0, "device[1].name",
                 "device name \"left\" is used twice");
  // One COB-ID for two devices (an axis's encoder COB-ID given by hand): at that key.
  const std::string cob = replace(two, "first_node_id = 7\n", R"(first_node_id = 7
[[device.axis]]
encoder_cob_id = 0x181
[[device.axis]]
[[device.axis]]
[[device.axis]]
[[device.axis]]
[[device.axis]]
)");
  const InputError e3 = load_error(dir, cob, "cob.toml");
  expect_located(e3, (dir.path() / "cob.toml").string(), line_of(cob, "encoder_cob_id = 0x181"),
                 column_of(cob, "encoder_cob_id", "0x181"), "device[1].axis[0].encoder_cob_id",
                 "COB-ID 0x181 of axis \"x\" of device \"right\" is device \"left\"'s too");
}

TEST(SceneDevices, ACobIdOfTwoDevicesWithDcfsIsLocatedAtTheSceneKey) {
  NUMEN_REQUIRE_ARTICULATION();  // tube_clash.toml's instruments are on joints
  // Issue 70: the two instruments of tests/data/tube_clash.toml, each node configured by its DCF;
  // the right one's pivot_x encoder given the left one's COB-ID (0x181). Its DCF (node 6) has
  // no TPDO 0x181: that mismatch, at the DCF's line, was the error, with no scene line.
  TempDir dir;
  std::ifstream in(std::string(NUMEN_SOURCE_DIR) + "/tests/data/tube_clash.toml");
  std::ostringstream os;
  os << in.rdbuf();
  const std::string text = numen::test::with_absolute_dcf_paths(
      replace(os.str(), "encoder_cob_id = 0x186", "encoder_cob_id = 0x181"),
      std::string(NUMEN_SOURCE_DIR) + "/sim/scenes");
  const InputError e = load_error(dir, text, "cob.toml");
  expect_located(e, (dir.path() / "cob.toml").string(), line_of(text, "encoder_cob_id = 0x181", 2),
                 column_of(text, "encoder_cob_id = 0x181", "0x181"), "device[1].axis[0].encoder_cob_id",
                 "COB-ID 0x181 of axis \"pivot_x\" of device \"right\" is device \"left\"'s too");
}

TEST(SceneDevices, OnlyTheFirstDeviceHoldsAndEachNeedsATrajectory) {
  TempDir dir;
  const std::string& two = numen::test::kTwoDeviceScene;
  const std::string attach = replace(two, "first_node_id = 7\n", "first_node_id = 7\nattach = \"right_tool\"\n");
  const InputError e1 = load_error(dir, attach, "attach.toml");
  expect_located(e1, (dir.path() / "attach.toml").string(), line_of(attach, "attach = \"right_tool\""),
                 column_of(attach, "attach = ", "\"right_tool\""), "device[1].attach",
                 "the held body is the first device's");
  // The second device's path removed, and no scene [trajectory] to fall back on.
  std::string bare = two.substr(0, two.rfind("[device.trajectory]"));
  const InputError e2 = load_error(dir, bare, "bare.toml");
  EXPECT_EQ(e2.line(), line_of(bare, "[[device]]", 2)) << e2.what();
  EXPECT_NE(e2.message().find("device \"right\" has no trajectory"), std::string::npos) << e2.what();
  // With the scene's [trajectory], the second device runs it.
  const std::string shared = bare + R"(
[trajectory]
source = "scripted"
start = { position = [0.0, 0.02, 0.0] }
[[trajectory.segment]]
type = "hold"
duration = 0.25
)";
  const Scene s = load_scene(dir.write("shared.toml", shared));
  ASSERT_EQ(s.extra_devices.size(), 1u);
  EXPECT_NEAR(s.extra_devices[0].trajectory.at(0.0).pose.position.y(), 0.02, 1e-12);
  EXPECT_NEAR(s.trajectory.at(0.0).pose.position.y(), 0.0, 1e-12);  // the left one's own
}

TEST(SceneDevices, AnAdmittanceSceneOfTwoDevicesIsRefusedAtTheSecond) {
  // One admittance device per loop (docs/safety.md "Admittance devices": core::Data has one
  // measured wrench, on the held body): a second device of an admittance scene is refused at
  // its table, naming it.
  TempDir dir;
  const std::string two = replace(
      replace(numen::test::kTwoDeviceScene, "dt = 0.001\n", "dt = 0.001\ncoupling = \"admittance\"\n"),
      "attach = \"left_tool\"\n", "attach = \"left_tool\"\n[device.admittance]\n");
  const InputError e = load_error(dir, two, "admittance.toml");
  EXPECT_EQ(e.key(), "device[1]") << e.what();
  EXPECT_EQ(e.line(), line_of(two, "[[device]]", 2)) << e.what();
  EXPECT_NE(e.message().find("an admittance scene (coupling = \"admittance\") has one device"),
            std::string::npos)
      << e.what();
}

TEST(SceneDevices, AManipulatorTheRecordingDoesNotHaveIsLocated) {
  TempDir dir;
  const std::string jig = replace(numen::test::kTwoDeviceScene, R"(source = "scripted"
start = { position = [0.0, 0.05, 0.0] }
[[device.trajectory.segment]]
type = "line"
to = [0.0, 0.06, 0.0]
duration = 0.75
)", "source = \"jigsaws\"\nfile = \"" + numen::test::jigsaws_excerpt_path() +
                                           "\"\nmanipulator = \"slave_centre\"\n");
  const InputError e = load_error(dir, jig, "jig.toml");
  expect_located(e, (dir.path() / "jig.toml").string(), line_of(jig, "slave_centre"),
                 column_of(jig, "manipulator", "\"slave_centre\""), "device[1].trajectory.manipulator",
                 "slave_left");
}

// Issue 66: a device after the first that drives nothing (no body's link, no prescribed joint)
// loaded, and the run exited 1 with "control loop: devices 0 and 1 both drive the held body
// (link binding body -1)", unlocated and untrue. It is refused at its [[device]] table.
TEST(SceneDevices, ADeviceThatDrivesNothingIsRefusedAtItsTable) {
  TempDir dir;
  const std::string idle =
      replace(numen::test::kTwoDeviceScene, "link = \"tool\"\ndevice = \"right\"\n", "");
  const InputError e = load_error(dir, idle, "idle.toml");
  EXPECT_EQ(e.key(), "device[1]") << e.what();
  EXPECT_EQ(e.line(), line_of(idle, "[[device]]", 2)) << e.what();
  EXPECT_NE(e.message().find("device \"right\" drives nothing: no [[body]] has link = \"...\" "
                             "with device = \"right\""),
            std::string::npos)
      << e.what();
}
