// Tests of the bodies' meshes in a scene ([body.mesh], scene_model.cpp's parse_body_meshes and
// scene_mesh.cpp's add_mesh_shape): the example scene tests/data/mesh_body.toml loads and runs
// with the lobe pushed away by the probe, the keys reach core::BodyModel::mesh and mesh_pose,
// and every bad key is an InputError at the scene's line and key.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "numen/core/mesh_shape.hpp"
#include "numen/sim/input/input_error.hpp"
#include "numen/sim/run/run.hpp"
#include "numen/sim/run/run_summary.hpp"
#include "numen/sim/scene/scene.hpp"
#include "scene_text.hpp"
#include "temp_dir.hpp"

namespace {

using numen::core::Vec3;
using numen::sim::InputError;
using numen::sim::load_scene;
using numen::sim::Scene;
using numen::test::kMiniScene;
using numen::test::kTetObj;
using numen::test::line_of;
using numen::test::replace;
using numen::test::TempDir;

/// The mini scene with a second body "block" (no spheres) whose [body.mesh] table holds `keys`.
std::string with_mesh_body(const std::string& keys) {
  return replace(kMiniScene, "[[obstacle]]",
                 "[[body]]\nname = \"block\"\nmass = 0.05\ninertia = [1e-5, 1e-5, 1e-5]\n"
                 "position = [0.0, 0.0, 0.05]\n[body.mesh]\n" + keys + "\n[[obstacle]]");
}

TEST(SceneMeshBody, ExampleSceneLoadsAndItsProbePushesTheLobeAway) {
  const Scene s = load_scene(std::string(NUMEN_TEST_DATA_DIR) + "/mesh_body.toml");
  ASSERT_EQ(s.model.num_bodies(), 2);
  const numen::core::BodyModel& lobe = s.model.bodies[0];
  ASSERT_EQ(lobe.mesh, 0);
  ASSERT_EQ(s.model.meshes.size(), 1u);
  EXPECT_EQ(s.model.meshes[0].num_triangles(), 1280);
  EXPECT_GT(s.model.meshes[0].band.width, 0.0);  // the probe's 4 mm spheres + 1 mm
  EXPECT_EQ(s.model.bodies[1].mesh, -1);
  for (const std::string& w : s.warnings) EXPECT_EQ(w.find("mesh"), std::string::npos) << w;
  const numen::sim::RunSummary r = numen::sim::run_scene(s, numen::sim::RunOptions{});
  EXPECT_EQ(r.exit_status, 0);
  EXPECT_GE(r.contacts_max, 5);  // four feet on the floor and the probe on the lobe
  EXPECT_EQ(r.contact_overflow, 0);
  // The hand goes 24 mm past where it meets the lobe: the lobe gives way (0.07 m/s) instead of
  // letting the probe or the hand in.
  EXPECT_GT(r.free_body_speed_max_mps, 0.03);
  EXPECT_LT(r.target_penetration_max_mm, 2.0);
  EXPECT_LT(r.tool_penetration_max_mm, 1.0);
}

TEST(SceneMeshBody, KeysReachTheModel) {
  TempDir dir;
  dir.write("tet.obj", kTetObj);
  const Scene s = load_scene(dir.write(
      "s.toml", with_mesh_body("file = \"tet.obj\"\nunits = \"cm\"\nscale = 2.0\n"
                               "position = [0.0, 0.01, 0.0]\n"
                               "orientation = [0.0, 0.0, 0.0, 1.0]\n")));
  ASSERT_EQ(s.model.num_bodies(), 2);
  const numen::core::BodyModel& b = s.model.bodies[1];
  ASSERT_EQ(b.mesh, 0);
  EXPECT_NEAR(s.model.meshes[0].aabb_max.x(), 0.02, 1e-9);  // 1 × cm × 2, in the mesh frame
  EXPECT_NEAR(b.mesh_pose.position.y(), 0.01, 1e-15);
  EXPECT_NEAR(std::abs(b.mesh_pose.orientation.z()), 1.0, 1e-15);
  EXPECT_EQ(s.model.bodies[0].mesh, -1);
}

TEST(SceneMeshBody, BadKeysAreLocated) {
  TempDir dir;
  dir.write("tet.obj", kTetObj);
  // Not a table.
  {
    const std::string text = replace(kMiniScene, "material = \"steel\"\n",
                                     "material = \"steel\"\nmesh = \"tet.obj\"\n");
    const InputError e = numen::test::load_error(dir, text);
    EXPECT_EQ(e.key(), "body[0].mesh") << e.what();
    EXPECT_EQ(e.line(), line_of(text, "mesh = ")) << e.what();
    EXPECT_NE(std::string(e.what()).find("expected a table"), std::string::npos) << e.what();
  }
  // A key the table does not take.
  {
    const std::string text = with_mesh_body("file = \"tet.obj\"\nmaterial = \"steel\"\n");
    const InputError e = numen::test::load_error(dir, text);
    EXPECT_EQ(e.key(), "body[1].mesh.material") << e.what();
  }
  // No file.
  {
    const InputError e = numen::test::load_error(dir, with_mesh_body("units = \"mm\"\n"));
    EXPECT_EQ(e.key(), "body[1].mesh.file") << e.what();
  }
  // Missing, open: at `file`, naming the mesh file.
  {
    const std::string text = with_mesh_body("file = \"nowhere.obj\"\n");
    const InputError e = numen::test::load_error(dir, text);
    EXPECT_EQ(e.key(), "body[1].mesh.file") << e.what();
    EXPECT_EQ(e.line(), line_of(text, "nowhere.obj")) << e.what();
    EXPECT_NE(std::string(e.what()).find("mesh file not found"), std::string::npos) << e.what();
  }
  {
    dir.write("open.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\n");
    const InputError e = numen::test::load_error(dir, with_mesh_body("file = \"open.obj\"\n"));
    EXPECT_EQ(e.key(), "body[1].mesh.file") << e.what();
    EXPECT_NE(std::string(e.what()).find("open.obj"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("open: 3 boundary edges"), std::string::npos) << e.what();
  }
  // A zero quaternion.
  {
    const InputError e = numen::test::load_error(
        dir, with_mesh_body("file = \"tet.obj\"\norientation = [0.0, 0.0, 0.0, 0.0]\n"));
    EXPECT_EQ(e.key(), "body[1].mesh.orientation") << e.what();
  }
}

}  // namespace
