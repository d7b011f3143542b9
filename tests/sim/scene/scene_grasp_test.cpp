// Tests of sim/scene/scene_grasp: the [[grasp]] keys of a scene file, their defaults, the
// located errors and the load warning of a body the grip cannot hold (docs/scenes.md,
// "Grasping"; docs/grasping.md); with [multirate], the bodies the device loop carries, the
// tissue warning and the grasper refused outside the instruments (docs/multirate.md).

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "build_features.hpp"
#include "numen/core/grasp.hpp"
#include "numen/core/step_stages.hpp"
#include "numen/sim/scene/scene.hpp"
#include "scene_text.hpp"
#include "temp_dir.hpp"

namespace {

/// The shipped default scene (its instrument's jaws jaw_1, jaw_2; its data files made absolute)
/// with a 20 g block and `grasp` appended.
std::string default_with_grasp(const std::string& grasp, double block_mass = 0.02) {
  std::string text = numen::test::shipped_scene_text("default.toml");
  const std::string from = "\"../data/", to = "\"" + std::string(NUMEN_SOURCE_DIR) + "/sim/data/";
  for (std::size_t at = text.find(from); at != std::string::npos; at = text.find(from, at + to.size()))
    text.replace(at, from.size(), to);
  return text + R"(
[[body]]
name = "block"
mass = )" + std::to_string(block_mass) + R"(
material = "steel"
position = [0.2, 0.2, 0.2]
spheres = [[0.0, 0.0, 0.0, 0.004]]
)" + grasp;
}

/// default_with_grasp() as a multirate scene (scene loop at 2 ms) with one grasper on the jaws,
/// and `extra` appended.
std::string multirate_with_grasper(const std::string& extra) {
  return default_with_grasp("\n[multirate]\nscene_dt = 0.002\nmargin = 0.002\n\n[[grasp]]\nname = \"grasper\"\n"
                            "jaws = [\"jaw_1\", \"jaw_2\"]\n" + extra);
}

}  // namespace

TEST(SceneGrasp, KeysAreReadWithTheirDefaults) {
  NUMEN_REQUIRE_DEFORMABLE();  // the default scene has an organ
  numen::test::TempDir dir;
  const std::string text = default_with_grasp(R"(
[[grasp]]
name = "grasper"
jaws = ["jaw_1", "jaw_2"]

[[grasp]]
name = "tight"
jaws = ["jaw_2", "jaw_1"]
close_angle_deg = 5.0
open_angle_deg = 8.0
stiffness = 5000.0
damping = 3.0
grip_radius = 0.002
max_force = 12.0
tissue = false
thread = false
)");
  const numen::sim::Scene s = numen::sim::load_scene(dir.write("grasp.toml", text));
  ASSERT_EQ(s.model.grasps.size(), 2u);
  const numen::core::GraspModel& g = s.model.grasps[0];
  EXPECT_EQ(g.name, "grasper");
  int jaw_1 = -1, jaw_2 = -1;
  for (int i = 0; i < s.model.num_bodies(); ++i) {
    if (s.model.bodies[static_cast<std::size_t>(i)].name == "jaw_1") jaw_1 = i;
    if (s.model.bodies[static_cast<std::size_t>(i)].name == "jaw_2") jaw_2 = i;
  }
  EXPECT_EQ(g.jaws[0], jaw_1);
  EXPECT_EQ(g.jaws[1], jaw_2);
  EXPECT_GE(g.jaw_joints[0], 0) << "the jaw's hinge is found";
  EXPECT_GE(g.jaw_joints[1], 0);
  EXPECT_NEAR(g.close_angle, 10.0 * M_PI / 180, 1e-12);
  EXPECT_NEAR(g.open_angle, 15.0 * M_PI / 180, 1e-12);
  EXPECT_EQ(g.stiffness, 2000.0);
  EXPECT_EQ(g.damping, 2.0);
  EXPECT_EQ(g.grip_radius, 0.0015);
  EXPECT_EQ(g.max_force, 5.0);
  const numen::core::GraspModel& t = s.model.grasps[1];
  EXPECT_NEAR(t.close_angle, 5.0 * M_PI / 180, 1e-12);
  EXPECT_NEAR(t.open_angle, 8.0 * M_PI / 180, 1e-12);
  EXPECT_EQ(t.stiffness, 5000.0);
  EXPECT_EQ(t.damping, 3.0);
  EXPECT_EQ(t.grip_radius, 0.002);
  EXPECT_EQ(t.max_force, 12.0);
  EXPECT_TRUE(g.tissue);
  EXPECT_FALSE(t.tissue);
  EXPECT_TRUE(g.thread);
  EXPECT_FALSE(t.thread);
  EXPECT_NE(s.model.stage_plan & numen::core::kStageGrasp, 0u);
}

TEST(SceneGrasp, ErrorsAreLocatedAtTheirKeys) {
  NUMEN_REQUIRE_DEFORMABLE();  // the default scene has an organ
  numen::test::TempDir dir;
  using numen::test::expect_located;
  using numen::test::load_error;
  const std::string head = "\n[[grasp]]\nname = \"grasper\"\n";
  struct Case {
    std::string keys, needle, value, key, message;
  };
  const Case cases[] = {
      {"jaws = [\"jaw_1\", \"jaw_3\"]\n", "jaws = ", "[\"jaw_1\", \"jaw_3\"]", "grasp[0].jaws", "no body named \"jaw_3\""},
      {"jaws = [\"jaw_1\"]\n", "jaws = ", "[\"jaw_1\"]", "grasp[0].jaws", "expected two body names"},
      {"jaws = [\"jaw_1\", \"jaw_1\"]\n", "jaws = ", "[\"jaw_1\", \"jaw_1\"]", "grasp[0].jaws", "both jaws are one body"},
      {"jaws = [\"jaw_1\", \"organ_core\"]\n", "jaws = ", "[\"jaw_1\", \"organ_core\"]", "grasp[0].jaws", "is anchored"},
      {"jaws = [\"jaw_1\", \"sleeve\"]\n", "jaws = ", "[\"jaw_1\", \"sleeve\"]", "grasp[0].jaws", "has no spheres"},
      {"jaws = [\"jaw_1\", \"jaw_2\"]\nclose_angle_deg = 20.0\nopen_angle_deg = 15.0\n", "open_angle_deg = ",
       "15.0", "grasp[0].open_angle_deg", "must exceed close_angle_deg"},
      {"jaws = [\"jaw_1\", \"jaw_2\"]\nstiffness = 0.0\n", "stiffness = 0.0", "0.0", "grasp[0].stiffness", "must be > 0"},
      {"jaws = [\"jaw_1\", \"jaw_2\"]\ngrip = 0.002\n", "grip = ", "0.002", "grasp[0].grip", "grip"},
      {"jaws = [\"jaw_1\", \"jaw_2\"]\ntissue = 1\n", "tissue = ", "1", "grasp[0].tissue", "expected true or false"},
      {"jaws = [\"jaw_1\", \"jaw_2\"]\nthread = \"no\"\n", "thread = ", "\"no\"", "grasp[0].thread", "expected true or false"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.keys);
    const std::string text = default_with_grasp(head + c.keys);
    // The appended [[grasp]] is the text's last table: its needle's last occurrence.
    const std::size_t at = text.rfind(c.needle);
    const int line = 1 + static_cast<int>(std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(at), '\n'));
    expect_located(load_error(dir, text), (dir / "bad.toml").string(), line,
                   c.key == "grasp[0].grip" ? 0 : static_cast<int>(text.find(c.value, at) - text.rfind('\n', at)), c.key,
                   c.message);
  }
}

TEST(SceneGrasp, ABodyHeavierThanTheGripHoldsIsWarnedWithTheNumbers) {
  NUMEN_REQUIRE_DEFORMABLE();  // the default scene has an organ
  numen::test::TempDir dir;
  std::string text = default_with_grasp("\n[[grasp]]\nname = \"grasper\"\njaws = [\"jaw_1\", \"jaw_2\"]\n", 1.0);
  text = numen::test::replace(text, "gravity = [0.0, 0.0, 0.0]", "gravity = [0.0, 0.0, -9.81]");
  const numen::sim::Scene s = numen::sim::load_scene(dir.write("heavy.toml", text));
  bool warned = false;
  for (const std::string& w : s.warnings)
    warned = warned || (w.find("grasp \"grasper\": body \"block\" weighs 9.81 N (1 kg), more than the grip's "
                               "max_force 5 N") != std::string::npos);
  EXPECT_TRUE(warned);
}

TEST(SceneGrasp, TheHeavyBodyWarningLeavesOutTheGraspersOwnInstrument) {
  NUMEN_REQUIRE_DEFORMABLE();  // the default scene has an organ
  // Issue 70: a grip of 0.1 N and gravity on: the 20 g block (0.196 N) is warned; the grasper's
  // own tube (50 g, 0.49 N; joined to its jaws) is not something it grasps, and was warned too.
  numen::test::TempDir dir;
  std::string text = default_with_grasp(
      "\n[[grasp]]\nname = \"grasper\"\njaws = [\"jaw_1\", \"jaw_2\"]\nmax_force = 0.1\n");
  text = numen::test::replace(text, "gravity = [0.0, 0.0, 0.0]", "gravity = [0.0, 0.0, -9.81]");
  const numen::sim::Scene s = numen::sim::load_scene(dir.write("heavy.toml", text));
  int block = 0, own = 0;
  for (const std::string& w : s.warnings) {
    block += w.find("grasp \"grasper\": body \"block\" weighs") != std::string::npos ? 1 : 0;
    own += w.find("grasp \"grasper\": body \"tube\"") != std::string::npos ? 1 : 0;
  }
  EXPECT_EQ(block, 1);
  EXPECT_EQ(own, 0) << "the grasper's own tube is listed as a heavy body";
}

TEST(SceneGrasp, AMultirateSceneCarriesTheFreeBodiesAndWarnsThatItHoldsNoTissue) {
  NUMEN_REQUIRE_DEFORMABLE();  // the default scene has an organ
  numen::test::TempDir dir;
  const std::string multirate = "\n[multirate]\nscene_dt = 0.002\nmargin = 0.002\n";
  const std::string grasp = "\n[[grasp]]\nname = \"grasper\"\njaws = [\"jaw_1\", \"jaw_2\"]\n";
  const numen::sim::Scene s =
      numen::sim::load_scene(dir.write("mr.toml", default_with_grasp(multirate + grasp)));
  ASSERT_TRUE(s.multirate.has_value());
  const auto named = std::find_if(s.model.bodies.begin(), s.model.bodies.end(),
                                  [](const numen::core::BodyModel& b) { return b.name == "block"; });
  ASSERT_NE(named, s.model.bodies.end());
  const int block = static_cast<int>(named - s.model.bodies.begin());
  // The block is the one free body: the device loop carries it (what the jaws may hold).
  EXPECT_EQ(s.multirate->carried, std::vector<int>{block});
  const auto tissue_warning = [](const numen::sim::Scene& scene) {
    return std::count_if(scene.warnings.begin(), scene.warnings.end(), [](const std::string& w) {
      return w.find("grasp[0].tissue") != std::string::npos &&
             w.find("holds bodies only") != std::string::npos;
    });
  };
  EXPECT_EQ(tissue_warning(s), 1);  // the default scene has an organ
  const numen::sim::Scene off = numen::sim::load_scene(
      dir.write("off.toml", default_with_grasp(multirate + grasp + "tissue = false\n")));
  EXPECT_EQ(tissue_warning(off), 0);
}

TEST(SceneGrasp, AMultirateGrasperOutsideTheInstrumentsIsRefusedAtItsJaws) {
  NUMEN_REQUIRE_DEFORMABLE();  // the default scene has an organ
  numen::test::TempDir dir;
  const std::string text = default_with_grasp(
      "\n[multirate]\nscene_dt = 0.002\nmargin = 0.002\n\n[[body]]\nname = \"loose\"\nmass = 0.01\n"
      "material = \"steel\"\nposition = [0.3, 0.2, 0.2]\nspheres = [[0.0, 0.0, 0.0, 0.004]]\n\n"
      "[[grasp]]\nname = \"odd\"\njaws = [\"block\", \"loose\"]\n");
  const std::size_t at = text.rfind("jaws = [\"block\"");
  const int line = 1 + static_cast<int>(std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(at), '\n'));
  numen::test::expect_located(numen::test::load_error(dir, text), (dir / "bad.toml").string(), line, 0,
                              "grasp[0].jaws", "is in no device's instrument");
}

// Graspers hold in the device step: a multirate scene whose device switches to another body (an
// attach event) would drop what they hold, and is refused at the table.
TEST(SceneGrasp, AMultirateGrasperSceneWithAToolSwitchIsRefused) {
  NUMEN_REQUIRE_DEFORMABLE();  // the default scene has an organ
  numen::test::TempDir dir;
  const std::string text = multirate_with_grasper("\n[[event]]\ntime = 1.0\nattach = \"block\"\n");
  const numen::sim::InputError e = numen::test::load_error(dir, text);
  EXPECT_EQ(e.key(), "multirate.scene_dt");
  EXPECT_NE(e.message().find("one held body"), std::string::npos) << e.what();
}

// A thread lives in the scene loop of a multirate run, the graspers in its device loop: a scene
// with both is warned at the thread's name that the jaws do not grasp it there
// (docs/multirate-suturing.md, "A thread in the scene loop").
TEST(SceneGrasp, AMultirateGrasperSceneWithAThreadIsWarnedAtTheThread) {
  NUMEN_REQUIRE_DEFORMABLE();  // the default scene has an organ
  numen::test::TempDir dir;
  const std::string text =
      multirate_with_grasper("\n[[thread]]\nname = \"suture\"\nlength = 0.05\nattach_body = \"block\"\n");
  const numen::sim::Scene s = numen::sim::load_scene(dir.write("mr.toml", text));
  ASSERT_EQ(s.model.threads.size(), 1u);
  const auto warned = std::find_if(s.warnings.begin(), s.warnings.end(), [](const std::string& w) {
    return w.find("thread[0].name") != std::string::npos &&
           w.find("thread 'suture' is not grasped by the jaws") != std::string::npos;
  });
  EXPECT_NE(warned, s.warnings.end()) << "warned at the thread's name";
}
