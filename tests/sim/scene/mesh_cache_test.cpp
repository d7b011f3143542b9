// Tests of sim/scene/mesh_cache (the cache file of a built mesh shape) and of the mesh tables'
// `cache` key: a loaded shape is the built one, a stale or damaged file is rebuilt with a note (a
// located warning in a scene), a file that cannot be written leaves the shape built.
#include "numen/sim/scene/mesh_cache.hpp"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>

#include "numen/sim/input/input_error.hpp"
#include "numen/sim/scene/scene.hpp"
#include "scene_text.hpp"
#include "temp_dir.hpp"

namespace {

namespace core = numen::core;
using core::Vec3;
using numen::sim::build_mesh_shape_cached;
using numen::sim::MeshCacheOutcome;
using numen::test::TempDir;

/// A torus of 1024 triangles and its shape's options (a 5 mm band).
const core::TriangleMesh& cache_torus() {
  static const core::TriangleMesh mesh = core::make_torus(0.04, 0.015, 32, 16);
  return mesh;
}

/// Same arrays, and the same answers at 2000 random points near the torus.
void expect_same_cached_shape(const core::MeshShape& a, const core::MeshShape& b) {
  EXPECT_EQ(a.vertices, b.vertices);
  EXPECT_EQ(a.triangles, b.triangles);
  EXPECT_EQ(a.triangle_edges, b.triangle_edges);
  EXPECT_EQ(a.grid_distance, b.grid_distance);
  ASSERT_EQ(a.nodes.size(), b.nodes.size());
  for (std::size_t i = 0; i < a.nodes.size(); ++i) {
    EXPECT_EQ(a.nodes[i].lo, b.nodes[i].lo);
    EXPECT_EQ(a.nodes[i].index, b.nodes[i].index);
    EXPECT_EQ(a.nodes[i].count, b.nodes[i].count);
  }
  EXPECT_EQ(a.band.width, b.band.width);
  EXPECT_EQ(a.band.brick_slot, b.band.brick_slot);
  EXPECT_EQ(a.band.cell_begin, b.band.cell_begin);
  EXPECT_EQ(a.band.triangles, b.band.triangles);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-0.06, 0.06);
  for (int i = 0; i < 2000; ++i) {
    const Vec3 p(u(rng), u(rng), u(rng) / 3.0);
    core::MeshDistance da, db;
    const bool ha = core::mesh_signed_distance(a, p, 0.01, da);
    ASSERT_EQ(ha, core::mesh_signed_distance(b, p, 0.01, db));
    if (ha) {
      EXPECT_EQ(da.distance, db.distance);
    }
  }
}

TEST(MeshCache, TheLoadedShapeIsTheBuiltOne) {
  TempDir dir;
  const std::filesystem::path path = dir / "sub" / "torus.nmshape";  // its folder is made
  core::MeshShape built, loaded;
  MeshCacheOutcome o;
  ASSERT_EQ(build_mesh_shape_cached(cache_torus(), {}, path, built, o), "");
  EXPECT_FALSE(o.loaded);
  EXPECT_TRUE(o.written);
  EXPECT_EQ(o.note, "");  // a missing file is no warning
  ASSERT_TRUE(std::filesystem::exists(path));
  ASSERT_EQ(build_mesh_shape_cached(cache_torus(), {}, path, loaded, o), "");
  EXPECT_TRUE(o.loaded);
  EXPECT_FALSE(o.written);
  EXPECT_EQ(o.note, "");
  expect_same_cached_shape(built, loaded);
  core::MeshShape direct;
  ASSERT_EQ(core::build_mesh_shape(cache_torus(), direct), "");
  expect_same_cached_shape(direct, loaded);
}

TEST(MeshCache, AStaleFileIsRebuiltWithANote) {
  TempDir dir;
  const std::filesystem::path path = dir / "torus.nmshape";
  core::MeshShape s;
  MeshCacheOutcome o;
  ASSERT_EQ(build_mesh_shape_cached(cache_torus(), {}, path, s, o), "");
  // Other band settings.
  core::MeshShapeOptions wider;
  wider.band = 0.006;
  ASSERT_EQ(build_mesh_shape_cached(cache_torus(), wider, path, s, o), "");
  EXPECT_FALSE(o.loaded);
  EXPECT_TRUE(o.written);
  EXPECT_NE(o.note.find("torus.nmshape: stale (built from other triangles or band settings): rebuilt"),
            std::string::npos) << o.note;
  EXPECT_EQ(s.band.width, 0.006);
  // Other triangles (one vertex moved by 1 µm).
  core::TriangleMesh moved = cache_torus();
  moved.vertices[5].x() += 1e-6;
  ASSERT_EQ(build_mesh_shape_cached(moved, wider, path, s, o), "");
  EXPECT_NE(o.note.find("stale"), std::string::npos) << o.note;
  EXPECT_EQ(s.vertices[5].x(), moved.vertices[5].x());
  ASSERT_EQ(build_mesh_shape_cached(moved, wider, path, s, o), "");
  EXPECT_TRUE(o.loaded);
  EXPECT_NE(numen::sim::mesh_cache_key(moved, wider), numen::sim::mesh_cache_key(cache_torus(), wider));
}

/// The bytes of `path`.
std::string cache_file_bytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

TEST(MeshCache, ADamagedFileIsRebuiltWithANote) {
  TempDir dir;
  const std::filesystem::path path = dir / "torus.nmshape";
  core::MeshShape s;
  MeshCacheOutcome o;
  ASSERT_EQ(build_mesh_shape_cached(cache_torus(), {}, path, s, o), "");
  const std::string good = cache_file_bytes(path);
  const auto damaged = [&](std::string bytes, const std::string& why) {
    dir.write("torus.nmshape", bytes);
    core::MeshShape r;
    ASSERT_EQ(build_mesh_shape_cached(cache_torus(), {}, path, r, o), "");
    EXPECT_FALSE(o.loaded) << why;
    EXPECT_NE(o.note.find(why), std::string::npos) << o.note;
    expect_same_cached_shape(s, r);
    EXPECT_EQ(cache_file_bytes(path), good) << why;  // written again
  };
  std::string flipped = good;
  flipped[good.size() / 2] = static_cast<char>(flipped[good.size() / 2] ^ 0x10);
  damaged(flipped, "damaged (checksum mismatch)");
  damaged(good.substr(0, good.size() - 100), "damaged (");
  damaged("not a cache at all, but long enough to hold a header", "damaged (not a numen mesh cache)");
  damaged("", "damaged (not a numen mesh cache)");
  std::string version = good;
  version[8] = static_cast<char>(version[8] + 1);
  damaged(version, "stale (format version ");
}

TEST(MeshCache, AFileThatCannotBeWrittenLeavesTheShapeBuilt) {
  TempDir dir;
  dir.write("plain", "a file where a folder should be");
  core::MeshShape s;
  MeshCacheOutcome o;
  ASSERT_EQ(build_mesh_shape_cached(cache_torus(), {}, dir / "plain" / "torus.nmshape", s, o), "");
  EXPECT_FALSE(o.written);
  EXPECT_NE(o.note.find("cannot write"), std::string::npos) << o.note;
  EXPECT_EQ(s.num_triangles(), cache_torus().num_triangles());
  // A mesh the build refuses: its error, nothing written.
  core::TriangleMesh open = cache_torus();
  open.triangles.pop_back();
  EXPECT_NE(build_mesh_shape_cached(open, {}, dir / "open.nmshape", s, o), "");
  EXPECT_FALSE(std::filesystem::exists(dir / "open.nmshape"));
}

/// The mini scene with a mesh obstacle of the tetrahedron tet.obj and `cache_line`.
std::string cached_tet_scene(const std::string& cache_line) {
  return numen::test::replace(numen::test::kMiniScene,
                              "name = \"floor\"\ntype = \"plane\"\npoint = [0.0, 0.0, -0.1]\n"
                              "normal = [0.0, 0.0, 1.0]",
                              "name = \"organ\"\ntype = \"mesh\"\nfile = \"tet.obj\"\n"
                              "position = [0.0, 0.0, -0.5]\n" + cache_line);
}

TEST(MeshCache, TheSceneKeyReadsAndWritesTheFileAndLocatesItsWarnings) {
  TempDir dir;
  dir.write("tet.obj", numen::test::kTetObj);
  const std::string text = cached_tet_scene("cache = \"tet.nmshape\"\n");
  const std::string scene = dir.write("s.toml", text);
  const numen::sim::Scene first = numen::sim::load_scene(scene);
  ASSERT_TRUE(std::filesystem::exists(dir / "tet.nmshape"));  // relative to the scene's folder
  for (const std::string& w : first.warnings) EXPECT_EQ(w.find("cache"), std::string::npos) << w;
  const numen::sim::Scene second = numen::sim::load_scene(scene);
  for (const std::string& w : second.warnings) EXPECT_EQ(w.find("cache"), std::string::npos) << w;
  EXPECT_EQ(second.model.meshes[0].triangles, first.model.meshes[0].triangles);
  // Damaged: a warning at the `cache` key, naming the cache file.
  dir.write("tet.nmshape", "garbage");
  const numen::sim::Scene third = numen::sim::load_scene(scene);
  std::string warning;
  for (const std::string& w : third.warnings)
    if (w.find("damaged") != std::string::npos) warning = w;
  EXPECT_NE(warning.find("s.toml:" + std::to_string(numen::test::line_of(text, "cache = ")) +
                         ": obstacle[0].cache: "),
            std::string::npos) << warning;
  EXPECT_NE(warning.find("tet.nmshape: damaged (not a numen mesh cache): rebuilt"), std::string::npos)
      << warning;
  // true: the default folder, under $XDG_CACHE_HOME.
  const char* old = std::getenv("XDG_CACHE_HOME");
  const std::string saved = old != nullptr ? old : "";
  ::setenv("XDG_CACHE_HOME", (dir.path() / "xdg").c_str(), 1);
  (void)numen::sim::load_scene(dir.write("t.toml", cached_tet_scene("cache = true\n")));
  if (old != nullptr) ::setenv("XDG_CACHE_HOME", saved.c_str(), 1);
  else ::unsetenv("XDG_CACHE_HOME");
  int files = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir.path() / "xdg" / "numen" / "meshes")) {
    EXPECT_EQ(e.path().filename().string().rfind("tet-", 0), 0u) << e.path();
    ++files;
  }
  EXPECT_EQ(files, 1);
  // Neither a boolean nor a string.
  const std::string bad = cached_tet_scene("cache = 3\n");
  const numen::sim::InputError e = numen::test::load_error(dir, bad);
  EXPECT_EQ(e.key(), "obstacle[0].cache") << e.what();
  EXPECT_EQ(e.line(), numen::test::line_of(bad, "cache = ")) << e.what();
}

}  // namespace
