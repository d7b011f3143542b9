// Tests of sim/scene's mesh keys (scene_mesh.cpp, the mesh obstacles of scene_model.cpp, the
// nets' mesh files of scene_deformable.cpp): the shipped mesh scene loads and runs with its probe
// on the surface, units/scale/placement reach the model, and each bad mesh is an InputError at
// the scene's line and key that names the mesh file.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "numen/core/mesh_shape.hpp"
#include "numen/sim/input/input_error.hpp"
#include "numen/sim/run/run.hpp"
#include "numen/sim/run/run_summary.hpp"
#include "numen/sim/scene/scene.hpp"
#include "build_features.hpp"
#include "mesh_text.hpp"
#include "scene_text.hpp"
#include "temp_dir.hpp"

namespace {

using numen::core::MeshDistance;
using numen::core::ShapeType;
using numen::core::Vec3;
using numen::sim::InputError;
using numen::sim::load_scene;
using numen::sim::Scene;
using numen::test::kMiniScene;
using numen::test::line_of;
using numen::test::replace;
using numen::test::TempDir;
using numen::test::with_mesh_obstacle;

using numen::test::kTetObj;

/// kTetObj and a second tetrahedron whose apex pokes through its face z = 0 from below: its three
/// side faces (file triangles 5, 6, 7) cross the first's base (triangle 0).
const std::string kPokeObj = std::string(kTetObj) +
                             "v 0.1 0.1 -1\nv 0.35 0.1 -1\nv 0.1 0.35 -1\nv 0.2 0.2 0.1\n"
                             "f 5 7 6\nf 5 6 8\nf 5 8 7\nf 6 7 8\n";

/// The mini scene with an anchored body "core" (at z = 0.2 m) whose net "organ" has the mesh keys
/// `mesh_keys` (`mesh`, `file`, `scale`, ...).
std::string with_organ_net(const std::string& mesh_keys) {
  return replace(kMiniScene, "[[obstacle]]",
                 "[[body]]\nname = \"core\"\nmass = 0.05\ninertia = [1e-5, 1e-5, 1e-5]\n"
                 "position = [0.0, 0.0, 0.2]\nanchored = true\n\n"
                 "[[deformable]]\nname = \"organ\"\nbody = \"core\"\n" +
                     mesh_keys +
                     "mass = 0.01\nstiffness = 200.0\ntie_stiffness = 500.0\n\n[[obstacle]]");
}

TEST(SceneMesh, ShippedMeshSceneLoadsAndItsProbeStaysOnTheSurface) {
  const Scene s = load_scene(std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/mesh.toml");
  ASSERT_EQ(s.model.obstacles.size(), 1u);
  EXPECT_EQ(s.model.obstacles[0].type, ShapeType::kMesh);
  ASSERT_EQ(s.model.meshes.size(), 1u);
  EXPECT_EQ(s.model.meshes[0].num_triangles(), 1280);
  // Millimetres to metres: the lobe's semi-axes are 60 × 40 × 25 mm.
  EXPECT_NEAR(s.model.meshes[0].aabb_min.x(), -0.060, 1e-6);
  EXPECT_NEAR(s.model.meshes[0].aabb_max.y(), 0.040, 1e-6);
  const numen::sim::RunSummary r = numen::sim::run_scene(s, numen::sim::RunOptions{});
  EXPECT_EQ(r.exit_status, 0);
  EXPECT_GE(r.contacts_max, 1);
  EXPECT_EQ(r.contact_overflow, 0);
  EXPECT_GT(r.target_penetration_max_mm, 7.0);  // the hand goes 8 mm in
  EXPECT_LT(r.tool_penetration_max_mm, 2.0);    // the probe stays on the surface
}

TEST(SceneMesh, UnitsScaleAndPlacementReachTheModel) {
  TempDir dir;
  dir.write("tet.obj", kTetObj);
  const Scene s = load_scene(dir.write(
      "s.toml", with_mesh_obstacle("file = \"tet.obj\"\nunits = \"cm\"\nscale = 2.0\n"
                                   "position = [0.0, 0.0, -0.1]\n"
                                   "orientation = [0.0, 0.0, 0.0, 1.0]\n")));
  const auto& ob = s.model.obstacles[0];
  const auto& shape = s.model.meshes[static_cast<std::size_t>(ob.mesh)];
  EXPECT_NEAR(shape.aabb_max.x(), 0.02, 1e-9);  // 1 × cm × 2, in the mesh frame
  EXPECT_NEAR(ob.pose.position.z(), -0.1, 1e-15);
  // Turned half a turn about z: the world box spans x in [−0.02, 0].
  EXPECT_NEAR(ob.aabb_min.x(), -0.02, 1e-9);
  EXPECT_NEAR(ob.aabb_max.x(), 0.0, 1e-9);
  // Per-axis scale, and the default (metres) for a mesh in metres.
  const Scene t = load_scene(
      dir.write("t.toml", with_mesh_obstacle("file = \"tet.obj\"\nscale = [0.01, 0.02, 0.03]\n")));
  EXPECT_NEAR(t.model.meshes[0].aabb_max.z(), 0.03, 1e-9);
}

TEST(SceneMesh, InwardWindingIsTurnedWithAWarning) {
  TempDir dir;
  dir.write("inward.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 4 2\nf 1 3 4\nf 2 4 3\n");
  const Scene s = load_scene(dir.write("s.toml", with_mesh_obstacle("file = \"inward.obj\"\n")));
  ASSERT_EQ(s.model.meshes.size(), 1u);
  bool warned = false;
  for (const std::string& w : s.warnings) warned |= w.find("wind inward") != std::string::npos;
  EXPECT_TRUE(warned);
  MeshDistance d;
  ASSERT_TRUE(numen::core::mesh_signed_distance(s.model.meshes[0], Vec3(0.1, 0.1, 0.1), 1.0, d));
  EXPECT_LT(d.distance, 0.0);  // inside is inside
}

TEST(SceneMesh, SelfIntersectingMeshIsWarnedWithAPairAndTheCount) {
  TempDir dir;
  dir.write("poke.obj", kPokeObj);
  const std::string text = with_mesh_obstacle("file = \"poke.obj\"\n");
  const Scene s = load_scene(dir.write("s.toml", text));
  std::string warning;
  for (const std::string& w : s.warnings)
    if (w.find("intersects itself") != std::string::npos) warning = w;
  ASSERT_NE(warning, "");
  EXPECT_NE(warning.find("s.toml:" + std::to_string(line_of(text, "poke.obj")) + ": obstacle[0].file: "),
            std::string::npos) << warning;
  EXPECT_NE(warning.find("poke.obj: the surface intersects itself: 3 pairs of triangles meet (first: triangles "),
            std::string::npos) << warning;
  EXPECT_TRUE(warning.find("triangles 0 and ") != std::string::npos ||
              warning.find(" and 0 of the file") != std::string::npos) << warning;
  // The shipped lobe: no such warning, and its band is built (no note).
  const Scene lobe = load_scene(std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/mesh.toml");
  for (const std::string& w : lobe.warnings) EXPECT_EQ(w.find("intersects itself"), std::string::npos) << w;
  EXPECT_GT(lobe.model.meshes[0].band.width, 0.0);
  EXPECT_EQ(lobe.model.meshes[0].band.note, "");
}

TEST(SceneMesh, NetMeshThatIntersectsItselfIsWarnedAtItsFile) {
  NUMEN_REQUIRE_DEFORMABLE();
  // The poking pair of tetrahedra as the surface of an organ's net.
  TempDir dir;
  dir.write("poke.obj", kPokeObj);
  const auto organ = [](const std::string& mesh_keys) {
    return with_organ_net(mesh_keys + "scale = 0.02\n");
  };
  const std::string text = organ("mesh = \"file\"\nfile = \"poke.obj\"\n");
  const Scene s = load_scene(dir.write("s.toml", text));
  std::string warning;
  for (const std::string& w : s.warnings)
    if (w.find("intersects itself") != std::string::npos) warning = w;
  ASSERT_NE(warning, "");
  EXPECT_NE(warning.find("s.toml:" + std::to_string(line_of(text, "poke.obj")) + ": deformable[0].file: poke.obj: "),
            std::string::npos) << warning;
  EXPECT_NE(warning.find("the surface intersects itself: 3 pairs of triangles meet (first: triangles "),
            std::string::npos) << warning;
  EXPECT_NE(warning.find("the net's rest surface passes through itself"), std::string::npos) << warning;
  // The clean tetrahedron and a built-in icosphere: no such warning.
  dir.write("tet.obj", kTetObj);
  for (const std::string& keys : {std::string("mesh = \"file\"\nfile = \"tet.obj\"\n"),
                                  std::string("mesh = \"icosphere\"\nradius = 1.0\n")}) {
    const Scene clean = load_scene(dir.write("c.toml", organ(keys)));
    for (const std::string& w : clean.warnings)
      EXPECT_EQ(w.find("intersects itself"), std::string::npos) << w;
  }
}

/// The InputError of `text` (scene in `dir`) at the line holding `needle` and `key`, naming
/// `mesh_file` and containing `message`.
void expect_mesh_error(const TempDir& dir, const std::string& text, const std::string& needle,
                       const std::string& key, const std::string& mesh_file,
                       const std::string& message) {
  const InputError e = numen::test::load_error(dir, text);
  const std::string what = e.what();
  EXPECT_EQ(e.line(), line_of(text, needle)) << what;
  EXPECT_EQ(e.key(), key) << what;
  EXPECT_NE(what.find("bad.toml"), std::string::npos) << what;
  EXPECT_NE(what.find(mesh_file), std::string::npos) << what;
  EXPECT_NE(what.find(message), std::string::npos) << what;
}

TEST(SceneMesh, BadMeshesAreLocatedAtTheSceneKeyAndNameTheMeshFile) {
  TempDir dir;
  // Missing.
  expect_mesh_error(dir, with_mesh_obstacle("file = \"nowhere.stl\"\n"), "file = ",
                    "obstacle[0].file", "nowhere.stl", "mesh file not found");
  // Empty.
  dir.write("empty.obj", "");
  expect_mesh_error(dir, with_mesh_obstacle("file = \"empty.obj\"\n"), "file = ",
                    "obstacle[0].file", "empty.obj", "no face");
  // A non-finite vertex: the mesh file's line too.
  dir.write("nan.obj", "v 0 0 0\nv 1 0 0\nv 0 nan 0\nf 1 2 3\n");
  expect_mesh_error(dir, with_mesh_obstacle("file = \"nan.obj\"\n"), "file = ",
                    "obstacle[0].file", "nan.obj:3:", "not a finite number");
  // Open where a closed surface is needed: the boundary edges counted.
  dir.write("open.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\n");
  expect_mesh_error(dir, with_mesh_obstacle("file = \"open.obj\"\n"), "file = ",
                    "obstacle[0].file", "open.obj", "open: 3 boundary edges");
  // Degenerate after scaling: flattened to 1e-13 of its height.
  dir.write("tet.obj", kTetObj);
  expect_mesh_error(dir, with_mesh_obstacle("file = \"tet.obj\"\nscale = [1.0, 1.0, 1e-13]\n"),
                    "scale = ", "obstacle[0].scale", "tet.obj", "degenerate");
  // Units outside the list.
  const InputError u = numen::test::load_error(
      dir, with_mesh_obstacle("file = \"tet.obj\"\nunits = \"inch\"\n"));
  EXPECT_EQ(u.key(), "obstacle[0].units") << u.what();
}

/// The exact what() of an error at `key` of the first line of `text` holding `needle`, at its
/// value (`needle` ends where the value starts): "<dir>/bad.toml:L:C: <key>: <message>".
std::string located(const TempDir& dir, const std::string& text, const std::string& needle,
                    const std::string& key, const std::string& message) {
  return (dir / "bad.toml").string() + ":" + std::to_string(line_of(text, needle)) + ":" +
         std::to_string(static_cast<int>(needle.size()) + 1) + ": " + key + ": " + message;
}

// Defects 1 and 2: a PLY whose header disagrees with its body (Assimp aborted the process on
// it) or promises more elements than the file holds (a minute and 1.2 GB, or std::bad_alloc) is
// refused at the scene's `file` key with both numbers (the checks: mesh_counts_test.cpp).
TEST(SceneMesh, PlyCountsThatDisagreeWithItsBodyAreRefusedAtTheFileKey) {
  TempDir dir;
  const auto ply = [&](const std::string& name, const std::string& vertices) {
    return dir.write(name, numen::test::ascii_ply(vertices, "4"));
  };
  const std::string two = ply("two.ply", "2");
  std::string text = with_mesh_obstacle("file = \"two.ply\"\n");
  EXPECT_EQ(std::string(numen::test::load_error(dir, text).what()),
            located(dir, text, "file = ", "obstacle[0].file",
                    two + ": the PLY header's elements take 6 lines (vertex 2, face 4), the body "
                          "after end_header has 8"));
  const std::string many = ply("many.ply", "100000000");
  text = with_mesh_obstacle("file = \"many.ply\"\n");
  EXPECT_EQ(std::string(numen::test::load_error(dir, text).what()),
            located(dir, text, "file = ", "obstacle[0].file",
                    many + ": the PLY header's elements take 100000004 lines (vertex 100000000, "
                           "face 4), the body after end_header has 8"));
  // The same file with its true count loads.
  ply("tet.ply", "4");
  EXPECT_EQ(load_scene(dir.write("s.toml", with_mesh_obstacle("file = \"tet.ply\"\n")))
                .model.meshes.size(),
            1u);
}

// Defect 3: a glTF buffer's URI led out of the mesh's folder; its bytes became the obstacle's
// vertices and the run exited 0. Refused at `file`, naming the glTF's key and the URI.
TEST(SceneMesh, GltfBufferOutsideTheMeshFolderIsRefusedAtTheFileKey) {
  TempDir dir;
  const std::string gltf =
      dir.write("leak.gltf", numen::test::tet_gltf("../../../../../../etc/passwd"));
  const std::string text = with_mesh_obstacle("file = \"leak.gltf\"\n");
  EXPECT_EQ(
      std::string(numen::test::load_error(dir, text).what()),
      located(dir, text, "file = ", "obstacle[0].file",
              gltf + ": buffers[0].uri \"../../../../../../etc/passwd\" has a \"..\" segment: "
                     "a glTF's buffers and images are read only from data: URIs and relative "
                     "paths inside the mesh file's folder"));
}

// Defect 4: `scale = 1e30` loaded and every step was non-finite (exit 4, penetrations of
// 2.5·10^31 mm); a mesh must span [kMinMeshSize, kMaxMeshSize] once scaled, refused at `scale`
// (else `units`, else `file`).
TEST(SceneMesh, MeshFarOutsideTheSceneScaleIsRefusedAtScale) {
  TempDir dir;
  const std::string tet = dir.write("tet.obj", kTetObj);  // 1 m a side
  const auto message = [&](const std::string& size) {
    return tet + ": the mesh, scaled, spans " + size +
           " m (its bounding box's longest side), outside [1e-06, 1000] m: a wrong unit or scale?";
  };
  std::string text = with_mesh_obstacle("file = \"tet.obj\"\nscale = 1e30\n");
  EXPECT_EQ(std::string(numen::test::load_error(dir, text).what()),
            located(dir, text, "scale = ", "obstacle[0].scale", message("1e+30")));
  text = with_mesh_obstacle("file = \"tet.obj\"\nscale = [1.0, 1e-30, 1.0]\n");
  EXPECT_EQ(std::string(numen::test::load_error(dir, text).what()),  // the longest side counts:
            located(dir, text, "scale = ", "obstacle[0].scale",      // flattened, not small
                    tet + ": invalid mesh after scaling and placement (vertices counted from 0 in "
                          "the order the triangles first use them): triangle 0 is degenerate "
                          "(area 5e-31 m^2, at most 2e-12)"));
  text = with_mesh_obstacle("file = \"tet.obj\"\nunits = \"mm\"\nscale = 1e-30\n");
  EXPECT_EQ(std::string(numen::test::load_error(dir, text).what()),
            located(dir, text, "scale = ", "obstacle[0].scale", message("1e-33")));
  // A body's mesh; without `scale`, at `units`.
  text = replace(kMiniScene, "spheres = [[0.0, 0.0, 0.0, 0.01]]",
                 "spheres = [[0.0, 0.0, 0.0, 0.01]]\n[body.mesh]\nfile = \"tet.obj\"\n"
                 "scale = [2e3, 1.0, 1.0]");
  EXPECT_EQ(std::string(numen::test::load_error(dir, text).what()),
            located(dir, text, "scale = ", "body[0].mesh.scale", message("2000")));
  dir.write("km.obj",
            "v 0 0 0\nv 2e6 0 0\nv 0 2e6 0\nv 0 0 2e6\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n");
  text = with_mesh_obstacle("file = \"km.obj\"\nunits = \"mm\"\n");
  EXPECT_EQ(std::string(numen::test::load_error(dir, text).what()),
            located(dir, text, "units = ", "obstacle[0].units",
                    (dir / "km.obj").string() +
                        ": the mesh, scaled, spans 2000 m (its bounding "
                        "box's longest side), outside [1e-06, 1000] m: a wrong unit or scale?"));
  // The bounds themselves load.
  for (const char* scale : {"1e3", "1e-6"})
    EXPECT_EQ(load_scene(dir.write("s.toml", with_mesh_obstacle("file = \"tet.obj\"\nscale = " +
                                                                std::string(scale) + "\n")))
                  .model.meshes.size(),
              1u)
        << scale;
}

// The same bound on a net's mesh, a file's or a built-in one's, at its `scale`.
TEST(SceneMesh, NetFarOutsideTheSceneScaleIsRefusedAtScale) {
  NUMEN_REQUIRE_DEFORMABLE();
  TempDir dir;
  dir.write("tet.obj", kTetObj);
  std::string text = with_organ_net("mesh = \"file\"\nfile = \"tet.obj\"\nscale = 1e30\n");
  EXPECT_EQ(std::string(numen::test::load_error(dir, text).what()),
            located(dir, text, "scale = ", "deformable[0].scale",
                    "tet.obj: the mesh, scaled, spans 1e+30 m (its bounding box's longest side), "
                    "outside [1e-06, 1000] m: a wrong unit or scale?"));
  text = with_organ_net("mesh = \"icosphere\"\nradius = 1.0\nscale = 1e-9\n");
  EXPECT_EQ(std::string(numen::test::load_error(dir, text).what()),
            located(dir, text, "scale = ", "deformable[0].scale",
                    "icosphere: the mesh, scaled, spans 2e-09 m (its bounding box's longest side), "
                    "outside [1e-06, 1000] m: a wrong unit or scale?"));
}

TEST(SceneMesh, DeformableNetFromAnStlFile) {
  NUMEN_REQUIRE_DEFORMABLE();
  TempDir dir;
  dir.write("tet.stl",
            "solid t\nfacet normal 0 0 0\nouter loop\nvertex 0 0 0\nvertex 0 1 0\nvertex 1 0 0\n"
            "endloop\nendfacet\nfacet normal 0 0 0\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n"
            "vertex 0 0 1\nendloop\nendfacet\nfacet normal 0 0 0\nouter loop\nvertex 0 0 0\n"
            "vertex 0 0 1\nvertex 0 1 0\nendloop\nendfacet\nfacet normal 0 0 0\nouter loop\n"
            "vertex 1 0 0\nvertex 0 1 0\nvertex 0 0 1\nendloop\nendfacet\nendsolid t\n");
  const std::string text = replace(kMiniScene, "[[obstacle]]",
                                   "[[body]]\nname = \"core\"\nmass = 0.05\n"
                                   "inertia = [1e-5, 1e-5, 1e-5]\n\n"
                                   "[[deformable]]\nname = \"tet\"\nbody = \"core\"\n"
                                   "mesh = \"file\"\nfile = \"tet.stl\"\nunits = \"mm\"\n"
                                   "scale = 20.0\nmass = 0.01\nstiffness = 200.0\n"
                                   "tie_stiffness = 500.0\n\n[[obstacle]]");
  const Scene s = load_scene(dir.write("net.toml", text));
  ASSERT_EQ(s.model.num_nets(), 1);
  EXPECT_EQ(s.model.nets[0].node_count, 4);
}

}  // namespace
