// Tests of sim/scene/scene_needle: the [[needle]] keys of a scene file, their defaults, and the
// located errors — a value out of range, a needle larger than the jaws can hold, a needle placed
// inside tissue, a puncture threshold ≤ 0 (docs/suturing.md "Scene keys") — and the warnings.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "build_features.hpp"
#include "numen/core/needle.hpp"
#include "numen/sim/scene/scene.hpp"
#include "scene/scene_needle.hpp"
#include "scene_text.hpp"
#include "temp_dir.hpp"

namespace {

/// The shipped default scene (its instrument's jaws jaw_1, jaw_2; its organ; its data files made
/// absolute) with a grasper closing at 30° (its jaws' tips 2.69 mm apart there) and `tail`.
std::string default_with(const std::string& tail) {
  std::string text = numen::test::shipped_scene_text("default.toml");
  const std::string from = "\"../data/", to = "\"" + std::string(NUMEN_SOURCE_DIR) + "/sim/data/";
  for (std::size_t at = text.find(from); at != std::string::npos; at = text.find(from, at + to.size()))
    text.replace(at, from.size(), to);
  return text + R"(
[[grasp]]
name = "driver"
jaws = ["jaw_1", "jaw_2"]
close_angle_deg = 30.0
open_angle_deg = 40.0
)" + tail;
}

/// The 1-based line of the last occurrence of `needle` in `text`, and its value's column.
std::pair<int, int> where(const std::string& text, const std::string& key, const std::string& value) {
  const std::size_t at = text.rfind(key);
  const int line = 1 + static_cast<int>(std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(at), '\n'));
  return {line, static_cast<int>(text.find(value, at) - text.rfind('\n', at))};
}

/// Nine marks "[0.0, 0.0, 0.0], ..." (one more than kMaxNeedlePasses).
std::string nine_points() {
  std::string out;
  for (int i = 0; i < 9; ++i) out += (i ? ", " : "") + std::string("[0.0, 0.0, 0.0]");
  return out;
}

}  // namespace

TEST(SceneNeedle, KeysAreReadWithTheirDefaults) {
  NUMEN_REQUIRE_DEFORMABLE();  // the default scene has an organ
  numen::test::TempDir dir;
  const std::string text = default_with(R"(
[[needle]]
name = "sh"
position = [0.0, 0.1, 0.1]

[[needle]]
name = "small"
radius = 0.006
arc = 0.375
wire_radius = 0.0002
mass = 5.0e-5
material = "steel"
position = [0.0, 0.15, 0.1]
orientation = [0.0, 1.0, 0.0, 0.0]
puncture_force = 1.5
entry_mark = [[0.0, 0.15, 0.05], [0.01, 0.15, 0.05]]
exit_mark = [0.0, 0.16, 0.05]
)");
  const numen::sim::Scene s = numen::sim::load_scene(dir.write("needle.toml", text));
  ASSERT_EQ(s.model.needles.size(), 2u);
  const numen::core::NeedleModel& sh = s.model.needles[0];
  EXPECT_EQ(sh.name, "sh");
  EXPECT_NEAR(sh.length(), 0.026, 1e-12) << "the 26 mm half circle by default";
  EXPECT_NEAR(sh.arc_angle, M_PI, 1e-12);
  EXPECT_EQ(sh.wire_radius, 0.35e-3);
  EXPECT_TRUE(std::isnan(sh.puncture_force));
  const numen::core::BodyModel& b = s.model.bodies[static_cast<std::size_t>(sh.body)];
  EXPECT_EQ(b.name, "sh");
  EXPECT_NEAR(b.mass, numen::core::needle_steel_mass(0.026 / M_PI, 0.5, 0.35e-3), 1e-15);
  EXPECT_EQ(b.initial_pose.position, numen::core::Vec3(0.0, 0.1, 0.1));
  const numen::core::NeedleModel& small = s.model.needles[1];
  EXPECT_EQ(small.radius, 0.006);
  EXPECT_NEAR(small.arc_angle, 0.75 * M_PI, 1e-12);
  EXPECT_EQ(small.wire_radius, 0.0002);
  EXPECT_EQ(small.puncture_force, 1.5);
  const numen::core::BodyModel& sb = s.model.bodies[static_cast<std::size_t>(small.body)];
  EXPECT_EQ(sb.mass, 5.0e-5);
  EXPECT_NEAR(std::abs(sb.initial_pose.orientation.x()), 1.0, 1e-12);
  ASSERT_EQ(s.needle_marks.size(), 2u);
  EXPECT_TRUE(s.needle_marks[0].entry.empty() && s.needle_marks[0].exit.empty());
  ASSERT_EQ(s.needle_marks[1].entry.size(), 2u) << "a list of marks: one per pass";
  EXPECT_EQ(s.needle_marks[1].entry[1], numen::core::Vec3(0.01, 0.15, 0.05));
  ASSERT_EQ(s.needle_marks[1].exit.size(), 1u) << "one point: one pass";
  EXPECT_EQ(s.needle_marks[1].exit[0], numen::core::Vec3(0.0, 0.16, 0.05));
}

// A scene with [multirate] and a [[needle]] loads: with the grasper of default_with(), the device
// loop carries the needle (docs/multirate-suturing.md, "A needle in the device loop").
TEST(SceneNeedle, AMultirateSceneCarriesTheNeedleInTheDeviceLoop) {
  NUMEN_REQUIRE_DEFORMABLE();  // the default scene has an organ
  numen::test::TempDir dir;
  const std::string text = default_with("\n[multirate]\nscene_dt = 0.002\nmargin = 0.002\n\n[[needle]]\n"
                                        "name = \"sh\"\nposition = [0.0, 0.1, 0.1]\npuncture_force = 1.5\n");
  const numen::sim::Scene s = numen::sim::load_scene(dir.write("mr.toml", text));
  ASSERT_TRUE(s.multirate.has_value());
  ASSERT_EQ(s.model.needles.size(), 1u);
  EXPECT_NE(std::find(s.multirate->carried.begin(), s.multirate->carried.end(), s.model.needles[0].body),
            s.multirate->carried.end());
}

TEST(SceneNeedle, BadNeedlesAreLocatedErrorsNamingTheirKeys) {
  NUMEN_REQUIRE_DEFORMABLE();
  numen::test::TempDir dir;
  using numen::test::expect_located;
  using numen::test::load_error;
  struct Case {
    std::string keys, key_text, value, key, message;
  };
  const std::string head = "\n[[needle]]\nname = \"sh\"\n";
  const std::vector<Case> cases = {
      {"radius = 0.0\nposition = [0.0, 0.1, 0.1]\n", "radius = ", "0.0", "needle[0].radius", "must be > 0"},
      {"arc = 1.0\nposition = [0.0, 0.1, 0.1]\n", "arc = ", "1.0", "needle[0].arc", "fraction of a circle"},
      {"arc = 0.0\nposition = [0.0, 0.1, 0.1]\n", "arc = ", "0.0", "needle[0].arc", "fraction of a circle"},
      {"wire_radius = 0.0\nposition = [0.0, 0.1, 0.1]\n", "wire_radius = ", "0.0", "needle[0].wire_radius", "must be > 0"},
      {"radius = 0.001\nwire_radius = 0.001\nposition = [0.0, 0.1, 0.1]\n", "wire_radius = ", "0.001",
       "needle[0].wire_radius", "must be below radius"},
      {"mass = 0.0\nposition = [0.0, 0.1, 0.1]\n", "mass = ", "0.0", "needle[0].mass", "must be > 0"},
      {"puncture_force = 0.0\nposition = [0.0, 0.1, 0.1]\n", "puncture_force = ", "0.0", "needle[0].puncture_force",
       "must be > 0"},
      {"puncture_force = -1.0\nposition = [0.0, 0.1, 0.1]\n", "puncture_force = ", "-1.0", "needle[0].puncture_force",
       "must be in [0, inf]"},
      {"wire_radius = 0.0015\nposition = [0.0, 0.1, 0.1]\n", "wire_radius = ", "0.0015", "needle[0].wire_radius",
       "larger than the jaws can hold"},
      {"position = [0.07072, 0.02836, -0.04475]\n", "position = ", "[0.07072", "needle[0].position",
       "starts inside the tissue of deformable \"organ\""},
      {"radius_mm = 8.0\nposition = [0.0, 0.1, 0.1]\n", "radius_mm = ", "8.0", "needle[0].radius_mm", "unknown key"},
      {"puncture_force = 1.0\nentry_mark = [[0.0, 0.0, 0.0], [0.0, 0.0]]\nposition = [0.0, 0.1, 0.1]\n",
       "entry_mark = ", "[0.0, 0.0]]", "needle[0].entry_mark[1]", "expected 3 numbers, found 2"},
      {"puncture_force = 1.0\nexit_mark = [[0.0, 0.0, 0.0], [0.0, \"y\", 0.0]]\nposition = [0.0, 0.1, 0.1]\n",
       "exit_mark = ", "\"y\"", "needle[0].exit_mark[1][1]", "expected a number"},
      {"puncture_force = 1.0\nexit_mark = [[0.0, 0.0, 0.0], 1.0]\nposition = [0.0, 0.1, 0.1]\n", "exit_mark = ",
       "1.0]", "needle[0].exit_mark[1]", "expected a point [x, y, z]"},
      {"puncture_force = 1.0\nentry_mark = [" + nine_points() + "]\nposition = [0.0, 0.1, 0.1]\n", "entry_mark = ",
       "[[0.0", "needle[0].entry_mark", "at most 8 marks (one per pass)"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.keys);
    const std::string text = default_with(head + c.keys);
    const auto [line, column] = where(text, c.key_text, c.value);
    expect_located(load_error(dir, text), (dir / "bad.toml").string(), line,
                   c.key == "needle[0].radius_mm" ? 0 : column, c.key, c.message);
  }
}

TEST(SceneNeedle, JawsThatDipDeeperThanTheWireBetweenTheirSpheresAreWarned) {
  NUMEN_REQUIRE_DEFORMABLE();
  // The default scene's jaws: four 1.5 mm spheres 3 mm apart (touching): their surface dips 1.5 mm
  // between two, more than the 0.35 mm wire's radius: warned. The same jaws of ten spheres (1 mm
  // apart, a dip of 0.09 mm): not.
  numen::test::TempDir dir;
  const std::string needle = "\n[[needle]]\nname = \"sh\"\nposition = [0.0, 0.1, 0.1]\n";
  const numen::sim::Scene sparse = numen::sim::load_scene(dir.write("sparse.toml", default_with(needle)));
  int warned = 0;
  for (const std::string& w : sparse.warnings)
    warned += w.find("needle \"sh\": grasper \"driver\"'s jaws dip 1.5") != std::string::npos &&
              w.find("more than the wire's radius (0.35 mm)") != std::string::npos;
  EXPECT_EQ(warned, 1);
  using numen::test::replace;  // both jaws' sphere lines
  const std::string dense_text = replace(replace(default_with(needle), "count = 4", "count = 10"), "count = 4", "count = 10");
  const numen::sim::Scene dense = numen::sim::load_scene(dir.write("dense.toml", dense_text));
  for (const std::string& w : dense.warnings) EXPECT_EQ(w.find("jaws dip"), std::string::npos) << w;
}

TEST(SceneNeedle, APunctureIntoAnOrganGivenByItsMaterialOnACoarseNetIsWarned) {
  NUMEN_REQUIRE_DEFORMABLE();
  // The shipped organ given by its material on a 500-node net (its mean edge above 1.5 mm): a
  // needle that punctures is warned that its puncture can overshoot there; one that never
  // punctures (no puncture_force) is not.
  numen::test::TempDir dir;
  const std::string organ = "mesh = \"file\"\nfile = \"" + std::string(NUMEN_SOURCE_DIR) +
                            "/sim/data/organ_lobe.obj\"\nyoungs_modulus_kpa = 120.0\npoisson_ratio = 0.45\n"
                            "support_length = 0.02\nnodes = 500\n";
  const std::string bench = numen::test::indentation_bench_scene(organ, 0.0025, 1e-3);
  const std::string needle = "\n[[needle]]\nname = \"n\"\nposition = [0.0, 0.1, 0.1]\n";
  const auto warnings = [](const numen::sim::Scene& s) {
    int n = 0;
    for (const std::string& w : s.warnings)
      n += w.find("needle \"n\": deformable \"organ\" is given by its material on a net of ") != std::string::npos &&
           w.find("mm mean edge: the needle's puncture there can overshoot its puncture_force") != std::string::npos;
    return n;
  };
  const numen::sim::Scene punctures =
      numen::sim::load_scene(dir.write("a.toml", bench + needle + "puncture_force = 1.0\n"));
  ASSERT_TRUE(punctures.net_loads[0].material);
  EXPECT_GT(punctures.net_loads[0].material_constants.surface_mean_edge, numen::sim::kNeedleMaterialNetEdge);
  EXPECT_EQ(warnings(punctures), 1);
  EXPECT_EQ(warnings(numen::sim::load_scene(dir.write("b.toml", bench + needle))), 0);
}
