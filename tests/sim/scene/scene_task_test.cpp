// Tests of sim/scene/scene_task: the [task] table of a scene file — the objects a bimanual task
// moves and the pegs they go to (docs/scenes.md "Grasping", docs/grasping.md "Peg transfer").

#include <gtest/gtest.h>

#include <string>

#include "numen/sim/scene/scene.hpp"
#include "scene_text.hpp"
#include "temp_dir.hpp"

namespace {

/// kMiniScene with two loose rings, an anchored base, two capsule pegs and a box, then `task`.
std::string mini_with_task(const std::string& task) {
  return numen::test::kMiniScene + R"(
[[body]]
name = "ring_a"
mass = 0.004
material = "steel"
position = [0.1, 0.0, 0.0]
spheres = [[0.0, 0.0, 0.0, 0.002]]

[[body]]
name = "ring_b"
mass = 0.004
material = "steel"
position = [0.2, 0.0, 0.0]
spheres = [[0.0, 0.0, 0.0, 0.002]]

[[body]]
name = "base"
mass = 0.1
material = "steel"
anchored = true
inertia = [1.0e-4, 1.0e-4, 1.0e-4]
position = [0.3, 0.0, 0.0]

[[obstacle]]
name = "peg_1"
type = "capsule"
from = [0.0, 0.1, -0.1]
to = [0.0, 0.1, -0.08]
radius = 0.002

[[obstacle]]
name = "peg_2"
type = "capsule"
from = [0.0, 0.2, -0.1]
to = [0.0, 0.2, -0.08]
radius = 0.002

[[obstacle]]
name = "block"
type = "box"
position = [0.0, 0.3, -0.1]
half_extents = [0.01, 0.01, 0.01]
)" + task;
}

}  // namespace

TEST(SceneTask, ObjectsPegsAndReachAreRead) {
  numen::test::TempDir dir;
  const numen::sim::Scene plain = numen::sim::load_scene(dir.write("plain.toml", mini_with_task("")));
  EXPECT_FALSE(plain.task.has_value());
  const numen::sim::Scene s = numen::sim::load_scene(dir.write(
      "task.toml", mini_with_task("\n[task]\nobjects = [\"ring_b\", \"ring_a\"]\npegs = [\"peg_2\", \"peg_1\"]\n")));
  ASSERT_TRUE(s.task.has_value());
  ASSERT_EQ(s.task->objects.size(), 2u);
  EXPECT_EQ(s.model.bodies[static_cast<std::size_t>(s.task->objects[0])].name, "ring_b");
  EXPECT_EQ(s.model.bodies[static_cast<std::size_t>(s.task->objects[1])].name, "ring_a");
  ASSERT_EQ(s.task->pegs.size(), 2u);
  EXPECT_EQ(s.model.obstacles[static_cast<std::size_t>(s.task->pegs[0])].name, "peg_2");
  EXPECT_EQ(s.task->reach, 0.005);  // the default
  const numen::sim::Scene r = numen::sim::load_scene(dir.write(
      "reach.toml", mini_with_task("\n[task]\nobjects = [\"ring_a\"]\npegs = [\"peg_1\"]\nreach = 0.007\n")));
  EXPECT_EQ(r.task->reach, 0.007);
}

TEST(SceneTask, ErrorsAreLocatedAtTheirKeys) {
  numen::test::TempDir dir;
  struct Case {
    std::string body, needle, key, message;
  };
  const Case cases[] = {
      {"objects = [\"ring_a\", \"ring_c\"]\npegs = [\"peg_1\"]\n", "objects = ", "task.objects", "no body named \"ring_c\""},
      {"objects = [\"base\"]\npegs = [\"peg_1\"]\n", "objects = ", "task.objects", "is anchored"},
      {"objects = [\"ring_a\", \"ring_a\"]\npegs = [\"peg_1\"]\n", "objects = ", "task.objects", "named twice"},
      {"objects = []\npegs = [\"peg_1\"]\n", "objects = ", "task.objects", "expected a list of names"},
      {"pegs = [\"peg_1\"]\n", "[task]", "task.objects", "missing"},
      {"objects = [\"ring_a\"]\npegs = [\"block\"]\n", "pegs = ", "task.pegs", "is not a capsule"},
      {"objects = [\"ring_a\"]\npegs = [\"peg_9\"]\n", "pegs = ", "task.pegs", "no obstacle named \"peg_9\""},
      {"objects = [\"ring_a\"]\npegs = [\"peg_1\"]\nreach = 0.0\n", "reach = ", "task.reach", "must be > 0"},
      {"objects = [\"ring_a\"]\npegs = [\"peg_1\"]\ntarget = 1\n", "target = ", "task.target", "unknown key"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.body);
    const std::string text = mini_with_task("\n[task]\n" + c.body);
    const numen::sim::InputError e = numen::test::load_error(dir, text);
    EXPECT_EQ(e.key(), c.key) << e.what();
    EXPECT_EQ(e.line(), numen::test::line_of(text, c.needle)) << e.what();
    EXPECT_NE(e.message().find(c.message), std::string::npos) << e.what();
  }
}
