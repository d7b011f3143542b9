// Tests of sim/scene/scene_thread: the [[thread]] keys of a scene file and their located errors —
// a thread of zero or negative length or segments, a bad material value, an unknown body or key,
// a thread that starts inside tissue (docs/thread.md "Scene keys (`[[thread]]`)"). On the shipped probe scene,
// which has no joints, so these run in every build (the one with tissue where there are nets).

#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

#include "build_features.hpp"
#include "numen/sim/scene/scene.hpp"
#include "scene_text.hpp"
#include "temp_dir.hpp"

namespace {

/// The shipped probe scene (one body, "probe"; no joints, no nets) with a scripted hold as its
/// [trajectory], so that `numen run` would take it.
std::string probe_scene() {
  return numen::test::shipped_scene_text_anywhere("probe.toml") +
         "\n[trajectory]\nsource = \"scripted\"\nstart = { position = [0.0, 0.0, 0.01] }\n"
         "[[trajectory.segment]]\ntype = \"hold\"\nduration = 0.1\n";
}

}  // namespace

TEST(SceneThread, KeysAreReadIntoTheModel) {
  numen::test::TempDir dir;
  const std::string text = probe_scene() +
                           "\n[[thread]]\nname = \"suture\"\nlength = 0.05\nsegments = 50\n"
                           "attach_body = \"probe\"\ndirection = [1.0, 0.0, 0.0]\n"
                           "self_friction = 0.3\n";
  const numen::sim::Scene s = numen::sim::load_scene(dir.write("thread.toml", text));
  ASSERT_EQ(s.model.threads.size(), 1u);
  EXPECT_EQ(s.model.threads[0].name, "suture");
  EXPECT_EQ(s.model.threads[0].length, 0.05);
  EXPECT_EQ(s.model.threads[0].segments, 50);
  EXPECT_GE(s.model.threads[0].tie_start.body, 0);
  EXPECT_EQ(s.model.threads[0].self_friction, 0.3);
}

TEST(SceneThread, BadThreadsAreLocatedErrorsNamingTheirKeys) {
  numen::test::TempDir dir;
  using numen::test::expect_located;
  using numen::test::load_error;
  struct Case {
    std::string keys, key, message;
  };
  const std::vector<Case> cases = {
      {"length = 0.0\n", "thread[0].length", "must be > 0"},
      {"length = -0.1\n", "thread[0].length", "must be > 0"},
      {"segments = 0\n", "thread[0].segments", "must be 1"},
      {"radius = 0.0\n", "thread[0].radius", "must be > 0"},
      {"youngs_modulus_kpa = 0.0\n", "thread[0].youngs_modulus_kpa", "must be > 0"},
      {"density = -1.0\n", "thread[0].density", "must be > 0"},
      {"damping = -1.0\n", "thread[0].damping", "must be >= 0"},
      {"tissue_friction = -0.1\n", "thread[0].tissue_friction", "must be >= 0"},
      {"self_friction = -0.1\n", "thread[0].self_friction", "must be >= 0"},
      {"attach_body = \"nowhere\"\n", "thread[0].attach_body", "no body named \"nowhere\""},
      {"length_mm = 50.0\n", "thread[0].length_mm", "unknown key"},
  };
  const std::string base = probe_scene();
  for (const Case& c : cases) {
    SCOPED_TRACE(c.keys);
    const std::string text = base + "\n[[thread]]\nname = \"suture\"\n" + c.keys;
    const int line = 1 + static_cast<int>(std::count(text.begin(), text.end(), '\n')) - 1;
    // The value's column ("length = 0.0": 10); an unknown key is located at its line only.
    const int column = c.key == "thread[0].length_mm" ? 0 : static_cast<int>(c.keys.find('=') + 3);
    expect_located(load_error(dir, text), (dir / "bad.toml").string(), line, column, c.key, c.message);
  }
}

// A thread lives in the scene loop of a multirate run (docs/multirate-suturing.md, "A thread in
// the scene loop"): a scene with [multirate] and a [[thread]] loads, without a warning where it
// has no grasper (with one: SceneGrasp.AMultirateGrasperSceneWithAThreadIsWarnedAtTheThread).
TEST(SceneThread, AMultirateSceneLoadsItsThread) {
  numen::test::TempDir dir;
  const std::string text = probe_scene() + "\n[multirate]\nscene_dt = 0.002\nmargin = 0.002\n" +
                           "\n[[thread]]\nname = \"suture\"\nlength = 0.05\nattach_body = \"probe\"\n";
  const numen::sim::Scene s = numen::sim::load_scene(dir.write("mr.toml", text));
  ASSERT_TRUE(s.multirate.has_value());
  ASSERT_EQ(s.model.threads.size(), 1u);
  for (const std::string& w : s.warnings) EXPECT_EQ(w.find("thread"), std::string::npos) << w;
}

// A thread touches tissue from outside and goes into it only behind a needle: one whose initial
// straight shape runs through a deformable's closed rest surface is refused at its direction,
// naming the thread, the deformable and the node; pointed away from it, it loads.
TEST(SceneThread, AThreadStartingInsideTissueIsALocatedError) {
  NUMEN_REQUIRE_DEFORMABLE();
  numen::test::TempDir dir;
  const std::string block =
      numen::test::indentation_bench_scene("mesh = \"box\"\nhalf_extents = [0.01, 0.01, 0.005]\nsubdivisions = 4\n"
                                           "mass = 0.01\nstiffness = 200.0\ndamping = 0.1\n"
                                           "tie_stiffness = 100.0\ntie_damping = 0.17\n");
  const auto with_thread = [&](const std::string& direction) {
    return block + "\n[[thread]]\nname = \"suture\"\nlength = 0.04\nsegments = 20\nstart = [0.0, 0.0, 0.02]\n"
                   "direction = " + direction + "\n";
  };
  const std::string text = with_thread("[0.0, 0.0, -1.0]");
  const int line = static_cast<int>(std::count(text.begin(), text.end(), '\n'));
  numen::test::expect_located(numen::test::load_error(dir, text), (dir / "bad.toml").string(), line, 13,
                              "thread[0].direction",
                              "thread \"suture\" starts inside the tissue of deformable \"organ\" (its node 8 of 21");
  EXPECT_EQ(numen::sim::load_scene(dir.write("ok.toml", with_thread("[0.0, 0.0, 1.0]"))).model.threads.size(), 1u);
}
