// Tests of sim/scene/mesh_cache (the cache file of a built mesh shape) and of the mesh tables'
// `cache` key: a loaded shape is the built one, a stale or damaged file is rebuilt with a note (a
// located warning in a scene), a file that cannot be written leaves the shape built, and a path
// that names anything but nothing or a numen cache is refused and left as it was.
#include "numen/sim/scene/mesh_cache.hpp"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <unistd.h>

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
  const std::filesystem::path path = dir / "torus.nmshape";
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
  damaged(good.substr(0, 12), "damaged (12 bytes, shorter than its header)");
  std::string version = good;
  version[8] = static_cast<char>(version[8] + 1);
  damaged(version, "stale (format version ");
}

TEST(MeshCache, AFileThatCannotBeWrittenLeavesTheShapeBuilt) {
  TempDir dir;
  core::MeshShape s;
  MeshCacheOutcome o;
  // A name of 250 bytes: absent, in a folder that exists, but its temporary file's name (7 bytes
  // more) is over the 255 a name may have (a write that fails even as root).
  ASSERT_EQ(build_mesh_shape_cached(cache_torus(), {}, dir / std::string(250, 'c'), s, o), "");
  EXPECT_FALSE(o.written);
  EXPECT_FALSE(o.cache_refused);
  EXPECT_NE(o.note.find("cannot write"), std::string::npos) << o.note;
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir.path()),
                          std::filesystem::directory_iterator()),
            0)
      << "no temporary file left behind";
  EXPECT_EQ(s.num_triangles(), cache_torus().num_triangles());
  // A mesh the build refuses: its error, nothing written.
  core::TriangleMesh open = cache_torus();
  open.triangles.pop_back();
  EXPECT_NE(build_mesh_shape_cached(open, {}, dir / "open.nmshape", s, o), "");
  EXPECT_FALSE(std::filesystem::exists(dir / "open.nmshape"));
}

/// Expects build_mesh_shape_cached() with cache path `path` to refuse it with `phrase` (naming
/// the path), nothing built.
void expect_refused(const std::filesystem::path& path, const std::string& phrase) {
  core::MeshShape s;
  MeshCacheOutcome o;
  const std::string err = build_mesh_shape_cached(cache_torus(), {}, path, s, o);
  EXPECT_TRUE(o.cache_refused) << path;
  EXPECT_FALSE(o.written) << path;
  EXPECT_NE(err.find(path.string()), std::string::npos) << err;
  EXPECT_NE(err.find(phrase), std::string::npos) << err;
  EXPECT_EQ(s.num_triangles(), 0) << "nothing built for a refused path";
}

// A cache path never clobbers what is not numen's own cache of that kind (issue 66: the organ's
// mesh, a text file, the scene file, a symlink and a device node were replaced; a FIFO blocked
// the load; a directory read as 2^63 - 1 bytes; a missing folder was made).
TEST(MeshCache, APathThatIsNotThisCacheIsRefusedAndLeftAsItWas) {
  TempDir dir;
  const std::string text = "a text file, not a cache\n";
  expect_refused(
      dir.write("notes.txt", text),
      "not a numen cache (it does not start with \"NUMENMSH\"); refusing to overwrite it");
  EXPECT_EQ(cache_file_bytes(dir / "notes.txt"), text);
  expect_refused(dir.write("empty", ""), "not a numen cache");
  EXPECT_TRUE(std::filesystem::is_regular_file(dir / "empty"));
  // Another kind's cache: a net cache named as a mesh shape's.
  expect_refused(dir.write("organ.nmnet", std::string("NUMENNET") + std::string(40, '\0')),
                 "a numen net cache, not a mesh-shape cache; refusing to overwrite it");
  // A symbolic link, even to a good cache: neither followed nor replaced.
  core::MeshShape s;
  MeshCacheOutcome o;
  ASSERT_EQ(build_mesh_shape_cached(cache_torus(), {}, dir / "good.nmshape", s, o), "");
  const std::string good = cache_file_bytes(dir / "good.nmshape");
  std::filesystem::create_symlink(dir / "good.nmshape", dir / "link.nmshape");
  expect_refused(dir / "link.nmshape", "is a symbolic link, not a cache file");
  EXPECT_TRUE(std::filesystem::is_symlink(dir / "link.nmshape"));
  EXPECT_EQ(cache_file_bytes(dir / "good.nmshape"), good);
  // A directory (was "out of memory"), a FIFO (was a load blocked for ever), a device node.
  std::filesystem::create_directory(dir / "folder.nmshape");
  expect_refused(dir / "folder.nmshape", "is a directory, not a cache file");
  EXPECT_TRUE(std::filesystem::is_directory(dir / "folder.nmshape"));
  ASSERT_EQ(::mkfifo((dir / "pipe.nmshape").c_str(), 0644), 0);
  expect_refused(dir / "pipe.nmshape", "is a FIFO (named pipe), not a cache file");
  EXPECT_TRUE(std::filesystem::is_fifo(dir / "pipe.nmshape"));
  if (::mknod((dir / "null").c_str(), S_IFCHR | 0666, ::makedev(1, 3)) == 0) {  // needs root
    expect_refused(dir / "null", "is a character device, not a cache file");
    EXPECT_TRUE(std::filesystem::is_character_file(dir / "null"));
  }
  // A folder that does not exist is not made.
  expect_refused(dir / "nonexistent" / "dir" / "x.nmshape", "does not exist");
  EXPECT_FALSE(std::filesystem::exists(dir / "nonexistent"));
  expect_refused(dir / "notes.txt" / "x.nmshape", "cannot look at it");
}

// A cache whose header is this mesh's but whose payload (checksum and all) is another mesh's:
// not used, named, rebuilt.
TEST(MeshCache, AnotherMeshsShapeUnderThisMeshsKeyIsNotUsed) {
  TempDir dir;
  core::TriangleMesh moved = cache_torus();
  moved.vertices[5].x() += 1e-6;
  core::MeshShape s;
  MeshCacheOutcome o;
  ASSERT_EQ(build_mesh_shape_cached(cache_torus(), {}, dir / "a.nmshape", s, o), "");
  ASSERT_EQ(build_mesh_shape_cached(moved, {}, dir / "b.nmshape", s, o), "");
  const std::string a = cache_file_bytes(dir / "a.nmshape");
  const std::string b = cache_file_bytes(dir / "b.nmshape");
  // Magic, version and key of a (20 bytes); size, checksum and payload of b.
  dir.write("a.nmshape", a.substr(0, 20) + b.substr(20));
  core::MeshShape r;
  ASSERT_EQ(build_mesh_shape_cached(cache_torus(), {}, dir / "a.nmshape", r, o), "");
  EXPECT_FALSE(o.loaded);
  EXPECT_NE(o.note.find((dir / "a.nmshape").string() +
                        ": damaged (its key is this mesh's, its vertices another mesh's): rebuilt"),
            std::string::npos)
      << o.note;
  EXPECT_EQ(r.vertices, cache_torus().vertices);
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
  std::string flipped = cache_file_bytes(dir / "tet.nmshape");
  flipped.back() = static_cast<char>(flipped.back() ^ 0x10);
  dir.write("tet.nmshape", flipped);
  const numen::sim::Scene third = numen::sim::load_scene(scene);
  std::string warning;
  for (const std::string& w : third.warnings)
    if (w.find("damaged") != std::string::npos) warning = w;
  EXPECT_NE(warning.find("s.toml:" + std::to_string(numen::test::line_of(text, "cache = ")) +
                         ": obstacle[0].cache: "),
            std::string::npos) << warning;
  EXPECT_NE(warning.find("tet.nmshape: damaged (checksum mismatch): rebuilt"), std::string::npos)
      << warning;
  // The mesh file itself as the cache: an error at `cache`, the mesh untouched.
  const std::string own = cached_tet_scene("cache = \"tet.obj\"\n");
  const numen::sim::InputError refused = numen::test::load_error(dir, own);
  EXPECT_EQ(refused.key(), "obstacle[0].cache") << refused.what();
  EXPECT_EQ(refused.line(), numen::test::line_of(own, "cache = ")) << refused.what();
  EXPECT_NE(refused.message().find("tet.obj: not a numen cache"), std::string::npos)
      << refused.what();
  EXPECT_NE(refused.message().find("refusing to overwrite it"), std::string::npos)
      << refused.what();
  EXPECT_EQ(cache_file_bytes(dir / "tet.obj"), numen::test::kTetObj);
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
