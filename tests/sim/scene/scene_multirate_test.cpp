// Tests of sim/scene_multirate: the [multirate] table of a scene file — the scene loop's period
// and the proximity margin, and the scenes a multirate god-object refuses, each with a located
// error (file, line, column, key).
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "build_features.hpp"
#include "scene_text.hpp"
#include "temp_dir.hpp"
#include "numen/core/features.hpp"
#include "numen/core/multirate.hpp"
#include "numen/sim/input/input_error.hpp"
#include "numen/sim/scene/scene.hpp"

namespace {

using numen::sim::InputError;
using numen::sim::Scene;
using numen::test::replace;
using numen::test::TempDir;

/// The shipped construction scene with `table` after its coupling line, loadable from `dir`.
std::string construction_with(const std::string& table) {
  return replace(numen::test::shipped_scene_text("construction.toml"), "coupling = \"god-object\"\n",
                 "coupling = \"god-object\"\n\n" + table + "\n");
}

InputError multirate_load_error(TempDir& dir, const std::string& text,
                                const char* file = "mr.toml") {
  try {
    numen::sim::load_scene(dir.write(file, text));
  } catch (const InputError& e) {
    return e;
  }
  ADD_FAILURE() << "loaded without an error";
  return InputError("", 0, 0, "", "");
}

}  // namespace

TEST(SceneMultirate, SceneDtAndMarginGiveTheRatioAndEveryHeldBodyIsATool) {
  TempDir dir;
  const Scene s = numen::sim::load_scene(
      dir.write("mr.toml", construction_with("[multirate]\nscene_dt = 0.01\nmargin = 0.008")));
  ASSERT_TRUE(s.multirate.has_value());
  EXPECT_EQ(s.multirate->ratio, 10);
  EXPECT_DOUBLE_EQ(s.multirate->scene_dt_s, 0.01);
  EXPECT_DOUBLE_EQ(s.multirate->margin_m, 0.008);
  // "held" at the start, "loose_1" after the release (tool switching).
  ASSERT_EQ(s.multirate->tools.size(), 2u);
  EXPECT_EQ(s.model.bodies[static_cast<std::size_t>(s.multirate->tools[0])].name, "held");
  EXPECT_EQ(s.model.bodies[static_cast<std::size_t>(s.multirate->tools[1])].name, "loose_1");
  // Without the table nothing changes; at scene_dt = dt the margin may be left out.
  EXPECT_FALSE(numen::sim::load_scene(std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/construction.toml")
                   .multirate.has_value());
  const Scene one = numen::sim::load_scene(
      dir.write("one.toml", construction_with("[multirate]\nscene_dt = 0.001")));
  EXPECT_EQ(one.multirate->ratio, 1);
  EXPECT_EQ(one.multirate->margin_m, 0.0);
  // The longest step where an organ's surface has folded: 0.5 ms unless set.
  EXPECT_DOUBLE_EQ(s.multirate->fold_step_s, 5e-4);
  const Scene fold = numen::sim::load_scene(dir.write(
      "fold.toml",
      construction_with("[multirate]\nscene_dt = 0.01\nmargin = 0.008\nfold_step = 0.002")));
  EXPECT_DOUBLE_EQ(fold.multirate->fold_step_s, 0.002);
}

TEST(SceneMultirate, BadValuesAreLocatedErrors) {
  TempDir dir;
  const std::string not_multiple = construction_with("[multirate]\nscene_dt = 0.0025\nmargin = 0.01");
  const InputError e1 = multirate_load_error(dir, not_multiple);
  EXPECT_EQ(e1.key(), "multirate.scene_dt");
  EXPECT_EQ(e1.line(), numen::test::line_of(not_multiple, "scene_dt = 0.0025"));
  EXPECT_NE(std::string(e1.what()).find("whole multiple of dt"), std::string::npos) << e1.what();
  // 1e-10 s off a multiple: the message quotes every digit (it read "got 0.001 s, 1 dt").
  const std::string near = construction_with("[multirate]\nscene_dt = 0.0010000001\nmargin = 0.01");
  const InputError e_near = multirate_load_error(dir, near);
  EXPECT_EQ(e_near.key(), "multirate.scene_dt");
  EXPECT_EQ(e_near.line(), numen::test::line_of(near, "scene_dt = 0.0010000001"));
  EXPECT_EQ(e_near.message(),
            "must be a whole multiple of dt = 0.001 s (got 0.0010000001 s, 1.0000001 dt)");
  const InputError e2 =
      multirate_load_error(dir, construction_with("[multirate]\nscene_dt = 0.0005\nmargin = 0.01"));
  EXPECT_EQ(e2.key(), "multirate.scene_dt") << "shorter than dt";
  const InputError e3 =
      multirate_load_error(dir, construction_with("[multirate]\nscene_dt = 0.01"));
  EXPECT_EQ(e3.key(), "multirate.margin");
  EXPECT_NE(std::string(e3.what()).find("missing"), std::string::npos) << e3.what();
  const InputError e4 =
      multirate_load_error(dir, construction_with("[multirate]\nscene_dt = 0.01\nmargin = -0.001"));
  EXPECT_EQ(e4.key(), "multirate.margin");
  const std::string no_fold =
      construction_with("[multirate]\nscene_dt = 0.01\nmargin = 0.01\nfold_step = 0");
  const InputError e6 = multirate_load_error(dir, no_fold);
  EXPECT_EQ(e6.key(), "multirate.fold_step");
  EXPECT_EQ(e6.line(), numen::test::line_of(no_fold, "fold_step = 0"));
  EXPECT_EQ(e6.message(), "must be in [1e-06, 10], got 0");
  const InputError e5 =
      multirate_load_error(dir, construction_with("[multirate]\nscene_dt = 0.01\nmargn = 0.01"));
  EXPECT_NE(std::string(e5.what()).find("margn"), std::string::npos) << "a typo is refused: " << e5.what();
}

TEST(SceneMultirate, WhatTheMultirateGodObjectCannotRunIsRefusedAtTheTable) {
  TempDir dir;
  // An integrator without an effective contact force (the impulse hand-back needs it).
  const std::string trbdf2 = replace(construction_with("[multirate]\nscene_dt = 0.01\nmargin = 0.01"),
                                     "integrator = \"implicit-euler\"", "integrator = \"tr-bdf2\"");
  const InputError e1 = multirate_load_error(dir, trbdf2);
  EXPECT_EQ(e1.key(), "multirate.scene_dt");
  EXPECT_NE(std::string(e1.what()).find("integrator"), std::string::npos) << e1.what();
  // A net off its rigid component's centre of mass (the device loop lumps the net onto the
  // component, which keeps its own centre of mass).
  if (numen::core::kWithDeformable) {
    const std::string text = numen::test::shipped_scene_text("deformable.toml") +
                             "\n[multirate]\nscene_dt = 0.01\nmargin = 0.01\n";
    const std::string data = std::string("\"") + NUMEN_SOURCE_DIR + "/sim/data/";
    const std::string off = replace(replace(text, "\"../data/", data), "position = [0.0, 0.0, 0.0]     # mesh centre",
                                    "position = [0.0, 0.0, 0.005]   # mesh centre");
    const InputError e2 = multirate_load_error(dir, off, "deformable_mr.toml");
    EXPECT_EQ(e2.key(), "multirate.scene_dt");
    EXPECT_NE(std::string(e2.what()).find("net 'probe' has its centre of mass"), std::string::npos) << e2.what();
  }
}

// The lattice scene's god-object is the held tube's articulation: the trocar sleeve, the tube
// and both jaws, with the pivot, insertion and jaw joints (two prescribed by the jaw axis).
TEST(SceneMultirate, AnArticulatedToolIsOneGodObject) {
  NUMEN_REQUIRE_ARTICULATION();
  TempDir dir;
  const std::string text = numen::test::shipped_scene_text("lattice.toml") +
                           "\n[multirate]\nscene_dt = 0.005\nmargin = 0.005\n";
  const std::string data = std::string("\"") + NUMEN_SOURCE_DIR + "/sim/data/";
  const Scene s = numen::sim::load_scene(dir.write("default_mr.toml", replace(text, "\"../data/", data)));
  ASSERT_TRUE(s.multirate.has_value());
  EXPECT_EQ(s.multirate->ratio, 5);
  ASSERT_EQ(s.multirate->tools.size(), 1u);
  const std::vector<int> god = numen::core::god_object_bodies(s.model, s.multirate->tools[0]);
  EXPECT_EQ(god.size(), 4u) << "sleeve, tube, jaw_1, jaw_2";
  numen::core::Model device;
  ASSERT_EQ(numen::core::make_god_object_model(s.model, s.multirate->tools[0], s.model.dt, device), "");
  EXPECT_EQ(device.num_bodies(), 4);
  EXPECT_EQ(device.num_joints(), 4);
  EXPECT_TRUE(device.obstacles.empty());
  EXPECT_EQ(device.bodies[static_cast<std::size_t>(device.initial_held_body)].name,
            s.model.bodies[static_cast<std::size_t>(s.multirate->tools[0])].name);
}

// The margin must cover the hand's travel in one scene period: at 100 ms the construction
// scene's hand moves up to 52 mm, five times a 10 mm margin — a warning with the numbers; at
// 10 ms (5 mm) none.
TEST(SceneMultirate, AMarginShorterThanTheHandsTravelIsWarnedAbout) {
  TempDir dir;
  const auto warned = [](const Scene& s) {
    for (const std::string& w : s.warnings)
      if (w.find("the hand travels up to") != std::string::npos) return true;
    return false;
  };
  const Scene slow = numen::sim::load_scene(
      dir.write("slow.toml", construction_with("[multirate]\nscene_dt = 0.1\nmargin = 0.01")));
  EXPECT_TRUE(warned(slow));
  const Scene fine = numen::sim::load_scene(
      dir.write("fine.toml", construction_with("[multirate]\nscene_dt = 0.01\nmargin = 0.01")));
  EXPECT_FALSE(warned(fine));
}

// A net on a body the device never holds would be the scene loop's alone: the device loop would
// not feel it. Refused at the table, naming the net and the body.
TEST(SceneMultirate, ANetOnABodyNoGodObjectHoldsIsRefused) {
  if (!numen::core::kWithDeformable) GTEST_SKIP() << "a build without nets";
  TempDir dir;
  std::string text = numen::test::shipped_scene_text("deformable.toml") +
                     "\n[multirate]\nscene_dt = 0.01\nmargin = 0.002\n";
  text = replace(text, "\"../data/", std::string("\"") + NUMEN_SOURCE_DIR + "/sim/data/");
  text = replace(text, "[[deformable]]\nname = \"probe\"\nbody = \"core\"",
                 "[[body]]\nname = \"spare\"\nmass = 0.05\ninertia = [1.0e-5, 1.0e-5, 1.0e-5]\n"
                 "material = \"steel\"\n\n[[deformable]]\nname = \"probe\"\nbody = \"spare\"");
  const InputError e = multirate_load_error(dir, text, "spare_net_mr.toml");
  EXPECT_EQ(e.key(), "multirate.scene_dt");
  EXPECT_NE(std::string(e.what()).find("net 'probe' is on body 'spare', which is in no body's god-object"),
            std::string::npos) << e.what();
}

namespace {

/// The shipped bimanual scene (two devices) with [multirate] at 5 ms, its graspers left out
/// (grasping runs in the single-rate step), its files where the shipped scene is, `edit` (from,
/// to) made when given.
std::string bimanual_multirate_text(const std::string& from = "", const std::string& to = "") {
  std::string text = numen::test::shipped_scene_text("bimanual.toml") +
                     "\n[multirate]\nscene_dt = 0.005\nmargin = 0.005\n";
  for (const char* grasp : {"[[grasp]]\nname = \"left_grasper\"\njaws = [\"jaw_1_l\", \"jaw_2_l\"]\n",
                            "[[grasp]]\nname = \"right_grasper\"\njaws = [\"jaw_1_r\", \"jaw_2_r\"]\n"})
    text = replace(text, grasp, "");
  const std::string data = std::string("\"") + NUMEN_SOURCE_DIR + "/sim/data/";
  for (int i = 0; i < 4; ++i) text = replace(text, "\"../data/", data);
  const std::string dcf = std::string("dcf = \"") + NUMEN_SOURCE_DIR + "/sim/scenes/devices/";
  while (text.find("dcf = \"devices/") != std::string::npos) text = replace(text, "dcf = \"devices/", dcf);
  if (!from.empty()) text = replace(text, from, to);
  return text;
}

}  // namespace

// Several devices (issue 54): the bimanual scene with [multirate] loads; the second device's
// first body is in MultirateScene::other_devices, and the god-object holds both instruments
// (eight bodies, eight joints), the held one by the target.
TEST(SceneMultirate, SeveralDevicesMakeOneCompositeGodObject) {
  NUMEN_REQUIRE_DEFORMABLE();
  NUMEN_REQUIRE_ARTICULATION();
  TempDir dir;
  const Scene s = numen::sim::load_scene(dir.write("bimanual_mr.toml", bimanual_multirate_text()));
  ASSERT_TRUE(s.multirate.has_value());
  ASSERT_EQ(s.multirate->other_devices.size(), 1u);
  const numen::core::Model& m = s.model;
  EXPECT_EQ(m.bodies[static_cast<std::size_t>(s.multirate->other_devices[0])].name.back(), 'r')
      << "a body of device \"right\"";
  const std::vector<int> god =
      numen::core::god_object_bodies(m, s.multirate->tools[0], s.multirate->other_devices);
  EXPECT_EQ(god.size(), 8u) << "both instruments' sleeve, tube and jaws";
  numen::core::Model device;
  ASSERT_EQ(numen::core::make_god_object_model(m, s.multirate->tools[0], m.dt, device, s.multirate->other_devices), "");
  EXPECT_EQ(device.num_bodies(), 8);
  EXPECT_EQ(device.num_joints(), 8);
  EXPECT_EQ(device.bodies[static_cast<std::size_t>(device.initial_held_body)].name, "tube_l");
}

// With several devices the first holds a body throughout: a release (`attach = "none"`) is
// refused at the event's key, and so is a first device without `attach`.
TEST(SceneMultirate, SeveralDevicesRefuseAReleaseOfTheHeldBody) {
  NUMEN_REQUIRE_DEFORMABLE();
  NUMEN_REQUIRE_ARTICULATION();
  TempDir dir;
  const InputError release = multirate_load_error(
      dir,
      bimanual_multirate_text("\n[multirate]",
                              "\n[[event]]\ntime = 1.0\nattach = \"none\"\n\n[multirate]"),
      "release.toml");
  EXPECT_EQ(release.key(), "event[0].attach") << release.what();
  EXPECT_NE(std::string(release.what()).find("holds a body throughout"), std::string::npos) << release.what();
  const InputError unheld = multirate_load_error(
      dir, bimanual_multirate_text("attach = \"tube_l\"\n", ""), "unheld.toml");
  EXPECT_EQ(unheld.key(), "multirate.scene_dt") << unheld.what();
  EXPECT_NE(std::string(unheld.what()).find("holding a body from the start"), std::string::npos) << unheld.what();
}
