/// @file scene_plant_test.cpp
/// The closed loop's scene keys (sim/src/scene/scene_device.cpp): `[device.plant]` per axis or
/// for every axis, `[device.hand]` for both kinds of device, their located refusals, the
/// passivity lint (passivity_lint.hpp) with its warning and --strict error, and --replay.

#include <gtest/gtest.h>

#include <string>
#include <utility>

#include "build_features.hpp"
#include "numen/sim/input/input_error.hpp"
#include "numen/sim/scene/scene.hpp"
#include "scene_text.hpp"
#include "temp_dir.hpp"

namespace scene_plant_test {

using numen::sim::InputError;
using numen::sim::load_scene;
using numen::sim::Scene;
using numen::sim::SceneOverrides;
using numen::test::column_of;
using numen::test::expect_located;
using numen::test::kMiniScene;
using numen::test::line_of;
using numen::test::load_error;
using numen::test::replace;
using numen::test::TempDir;

/// kMiniScene (a pose tracker: 6 axes) with `plant` and `hand` tables after [device].
std::string with_tables(const std::string& tables) {
  return replace(kMiniScene, "[trajectory]\n", tables + "\n[trajectory]\n");
}

const std::string kPlant = R"([device.plant]
inertia = [0.2, 0.2, 0.2, 1e-4, 1e-4, 0.0]
damping = 1.5
coulomb = [0.1, 0.1, 0.1, 1e-3, 1e-3, 0.0]
current_lag = 2e-4
delay_periods = 1
substeps = 20
)";

TEST(ScenePlant, KeysAreReadPerAxisOrForEveryAxis) {
  TempDir dir;
  const Scene s = load_scene(dir.write("plant.toml", with_tables(kPlant)));
  ASSERT_TRUE(s.plant.has_value());
  ASSERT_EQ(s.plant->axes.size(), 6u);
  EXPECT_EQ(s.plant->axes[0].inertia, 0.2);
  EXPECT_EQ(s.plant->axes[5].inertia, 0.0);
  EXPECT_EQ(s.plant->axes[4].damping, 1.5) << "one number: every axis";
  EXPECT_EQ(s.plant->axes[3].coulomb, 1e-3);
  EXPECT_EQ(s.plant->axes[2].current_lag_s, 2e-4);
  EXPECT_EQ(s.plant->axes[1].delay_periods, 1);
  EXPECT_EQ(s.plant->substeps, 20);
  EXPECT_EQ(s.plant->torque_phase_s, s.compute_phase_s);
  // Without the table: replay; --replay drops a declared plant.
  EXPECT_FALSE(load_scene(dir.write("mini.toml", kMiniScene)).plant.has_value());
  SceneOverrides replay;
  replay.replay = true;
  EXPECT_FALSE(load_scene(dir.path() / "plant.toml", replay).plant.has_value());
}

TEST(ScenePlant, BadValuesAreLocatedAtTheirKey) {
  TempDir dir;
  const std::string file = (dir.path() / "bad.toml").string();
  struct Case {
    std::string from, to, key, message;
  };
  const Case cases[] = {
      {"inertia = [0.2, 0.2, 0.2, 1e-4, 1e-4, 0.0]", "inertia = [0.2, -0.2, 0.2, 1e-4, 1e-4, 0.0]",
       "device.plant.inertia", "entries must be finite and >= 0"},
      {"inertia = [0.2, 0.2, 0.2, 1e-4, 1e-4, 0.0]", "inertia = [0.2, 0.2, 0.2]",
       "device.plant.inertia", "6"},
      {"inertia = [0.2, 0.2, 0.2, 1e-4, 1e-4, 0.0]", "inertia = [0.2, nan, 0.2, 1e-4, 1e-4, 0.0]",
       "device.plant.inertia[1]", "finite"},
      {"damping = 1.5", "damping = -1.5", "device.plant.damping", "must be in [0, inf]"},
      {"damping = 1.5", "damping = nan", "device.plant.damping", ""},
      {"coulomb = [0.1, 0.1, 0.1, 1e-3, 1e-3, 0.0]", "coulomb = [0.1, 0.1, -0.1, 1e-3, 1e-3, 0.0]",
       "device.plant.coulomb", "entries must be in [0, inf]"},
      {"delay_periods = 1", "delay_periods = 65", "device.plant.delay_periods", "[0, 64]"},
      {"substeps = 20", "substeps = 0", "device.plant.substeps", "[1, 1000]"},
      {"substeps = 20", "substep = 20", "device.plant.substep", ""},
  };
  for (const Case& c : cases) {
    const std::string text = with_tables(replace(kPlant, c.from, c.to));
    const InputError e = load_error(dir, text, "bad.toml");
    expect_located(e, file, line_of(text, c.to), 0, c.key, c.message);
  }
  // The table is an impedance device's: an admittance scene refuses it.
  const std::string admittance = numen::test::shipped_scene_text("admittance.toml");
  const std::string text = replace(admittance, "[device.admittance]", kPlant + "\n[device.admittance]");
  const InputError e = load_error(dir, text, "adm.toml");
  EXPECT_NE(e.message().find("an impedance device's mechanics"), std::string::npos) << e.what();
}

// `inertia` takes one number for every axis, as damping and coulomb do (it was refused as
// "expected an array of numbers, found a number"), with the list's range.
TEST(ScenePlant, InertiaIsOneNumberForEveryAxisOrAListOfOnePerAxis) {
  TempDir dir;
  const std::string list = "inertia = [0.2, 0.2, 0.2, 1e-4, 1e-4, 0.0]";
  const std::pair<std::string, double> ones[] = {{"0.0", 0.0}, {"2e-3", 2e-3}, {"1", 1.0}};
  for (const auto& [value, m] : ones) {
    const std::string one = "inertia = " + value;
    const Scene s = load_scene(dir.write("one.toml", with_tables(replace(kPlant, list, one))));
    ASSERT_TRUE(s.plant.has_value()) << one;
    ASSERT_EQ(s.plant->axes.size(), 6u);
    for (const auto& axis : s.plant->axes) EXPECT_EQ(axis.inertia, m) << one;
  }
  const std::string file = (dir.path() / "bad.toml").string();
  struct Case {
    std::string to, message;
  };
  const Case cases[] = {
      {"inertia = -1.0",
       "must be finite and >= 0 (kg or kg·m²; 0: the axis follows the hand), got -1"},
      {"inertia = nan", "must be finite"},
      {"inertia = inf", "must be finite"},
      {"inertia = \"heavy\"", "expected a number, found a string"},
  };
  for (const Case& c : cases) {
    const std::string text = with_tables(replace(kPlant, list, c.to));
    const InputError e = load_error(dir, text, "bad.toml");
    expect_located(e, file, line_of(text, c.to), column_of(text, c.to, c.to.substr(10)),
                   "device.plant.inertia", c.message);
    EXPECT_EQ(e.message(), c.message);
  }
  // Without it the table is refused, saying both forms.
  const std::string text = with_tables(replace(kPlant, list + "\n", ""));
  const InputError e = load_error(dir, text, "bad.toml");
  EXPECT_EQ(e.key(), "device.plant.inertia");
  EXPECT_EQ(e.message(),
            "missing (one number for every axis, or a list of 6, one per axis, is required)");
}

TEST(ScenePlant, TheHandIsOneTableForBothKindsOfDevice) {
  TempDir dir;
  const std::string hand = "[device.hand]\nmass = 0.4\nstiffness = 250.0\nrotational_damping = 0.02\n";
  const Scene s = load_scene(dir.write("hand.toml", with_tables(hand)));
  EXPECT_EQ(s.hand.mass, 0.4);
  EXPECT_EQ(s.hand.stiffness, 250.0);
  EXPECT_EQ(s.hand.rotational_damping, 0.02);
  EXPECT_EQ(s.hand.damping, numen::sim::HandSettings{}.damping);
  const std::string bad = with_tables(replace(hand, "mass = 0.4", "mass = -0.4"));
  expect_located(load_error(dir, bad, "badhand.toml"), (dir.path() / "badhand.toml").string(),
                 line_of(bad, "mass = -0.4"), column_of(bad, "mass", "-0.4"), "device.hand.mass",
                 "must be");
  // An admittance scene's hand in its former place ([device.admittance.hand]) is still read;
  // given in both places it is refused.
  const std::string admittance = replace(numen::test::shipped_scene_text("admittance.toml"),
                                         "[device.hand]", "[device.admittance.hand]");
  const Scene a = load_scene(dir.write("adm.toml", admittance));
  EXPECT_EQ(a.hand.stiffness, 200.0);
  EXPECT_EQ(a.hand.damping, 6.0);
  const std::string twice =
      replace(admittance, "[device.admittance.hand]", hand + "\n[device.admittance.hand]");
  const InputError e = load_error(dir, twice, "twice.toml");
  EXPECT_NE(e.message().find("give the hand once, in [device.hand]"), std::string::npos) << e.what();
}

// The shipped closed-loop scenes pass the lint; the lattice scene's plant without damping or
// friction under a 3000 N/m coupling fails it on its driven axes: a warning naming the keys and
// both bounds, or with --strict an error at [device.plant] damping.
TEST(ScenePlant, ThePassivityLintWarnsOrRefusesWithStrict) {
  NUMEN_REQUIRE_ARTICULATION();  // the shipped trocar and PHANToM scenes are articulated
  for (const char* name : {"lattice.toml", "phantom.toml"}) {
    const Scene s = load_scene(std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/" + name);
    ASSERT_FALSE(s.passivity_lint.empty()) << name;
    for (const numen::sim::PassivityLintRow& r : s.passivity_lint)
      EXPECT_TRUE(r.passes) << name << " " << r.axis_name;
  }
  TempDir dir;
  std::string text = numen::test::shipped_scene_text("lattice.toml");
  text = replace(text, "damping = [0.02, 0.02, 1.5, 0.0, 0.0]", "damping = [0.0, 0.0, 0.0, 0.0, 0.0]");
  text = replace(text, "coulomb = [0.01, 0.01, 0.1, 0.0, 0.0]", "coulomb = [0.0, 0.0, 0.0, 0.0, 0.0]");
  text = replace(text, "stiffness = 300.0            # N/m", "stiffness = 3000.0");
  text = replace(text, "\"../data/", "\"" + std::string(NUMEN_SOURCE_DIR) + "/sim/data/");
  const std::string path = dir.write("active.toml", text);
  const Scene s = load_scene(path);
  int failing = 0;
  for (const numen::sim::PassivityLintRow& r : s.passivity_lint) failing += r.passes ? 0 : 1;
  EXPECT_EQ(failing, 3) << "pivot_x, pivot_y, depth";
  bool warned = false;
  for (const std::string& w : s.warnings)
    warned = warned || (w.find("device axis \"depth\"") != std::string::npos &&
                        w.find("Colgate & Schenkel") != std::string::npos &&
                        w.find("Abbott & Okamura") != std::string::npos &&
                        w.find("[device.plant] damping[2]") != std::string::npos);
  EXPECT_TRUE(warned);
  SceneOverrides strict;
  strict.strict = true;
  try {
    (void)load_scene(path, strict);
    ADD_FAILURE() << "--strict loaded a scene the lint fails";
  } catch (const InputError& e) {
    EXPECT_EQ(e.key(), "device.plant.damping");
    EXPECT_EQ(e.line(), line_of(text, "damping = [0.0, 0.0, 0.0, 0.0, 0.0]"));
    EXPECT_NE(e.message().find("(--strict)"), std::string::npos);
  }
}

}  // namespace scene_plant_test
