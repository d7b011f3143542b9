// Tests of sim/scene/mesh_side_files: a mesh file reads its side files (a glTF's buffers and
// images, an OBJ's .mtl) only from its own folder. A glTF buffer `uri` of
// "../../../../../../etc/passwd" used to be followed: another file's bytes became vertices.
// Through load_mesh_file() (mesh_side_files.hpp is private to numen::sim).
#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <string>

#include "mesh_text.hpp"
#include "numen/sim/scene/mesh_file.hpp"
#include "temp_dir.hpp"

namespace {

using numen::sim::load_mesh_file;
using numen::test::mesh_load_message;
using numen::test::TempDir;
using numen::test::tet_gltf;
using numen::test::tet_gltf_buffer;
namespace fs = std::filesystem;

constexpr const char* kOutside =
    ": a glTF's buffers and images are read only from data: URIs and relative paths inside the "
    "mesh "
    "file's folder";

TEST(MeshSideFiles, GltfBufferInTheFolderLoads) {
  TempDir dir;
  dir.write("tet.bin", tet_gltf_buffer());
  EXPECT_EQ(mesh_load_message(dir.write("tet.gltf", tet_gltf("tet.bin"))), "");
  fs::create_directories(dir / "buffers");
  dir.write("buffers/tet.bin", tet_gltf_buffer());
  const std::string below = dir.write("below.gltf", tet_gltf("buffers/tet.bin"));
  EXPECT_EQ(load_mesh_file(below).num_triangles(), 4);
}

// The defect: the buffer's URI climbs out of the folder (or is absolute, or a file: URI) and is
// refused by its key before Assimp reads anything.
TEST(MeshSideFiles, GltfUriOutsideTheFolderIsRefusedByItsKey) {
  TempDir dir;
  const std::string up = dir.write("up.gltf", tet_gltf("../../../../../../etc/passwd"));
  EXPECT_EQ(
      mesh_load_message(up),
      up + ": buffers[0].uri \"../../../../../../etc/passwd\" has a \"..\" segment" + kOutside);
  const std::string absolute = dir.write("absolute.gltf", tet_gltf("/etc/passwd"));
  EXPECT_EQ(mesh_load_message(absolute),
            absolute + ": buffers[0].uri \"/etc/passwd\" has an absolute path" + kOutside);
  const std::string scheme = dir.write("scheme.gltf", tet_gltf("file:///etc/passwd"));
  EXPECT_EQ(
      mesh_load_message(scheme),
      scheme + ": buffers[0].uri \"file:///etc/passwd\" has a URI scheme (\"file:\")" + kOutside);
  const std::string image = dir.write(
      "image.gltf", tet_gltf("tet.bin", R"(,"images":[{"uri":"a.png"},{"uri":"..\\secret.png"}])"));
  EXPECT_EQ(mesh_load_message(image),
            image + ": images[1].uri \"..\\secret.png\" has a \"..\" segment" + kOutside);
  // The same JSON in a .glb container (header, then the JSON chunk).
  const std::string json = tet_gltf("../../etc/passwd");
  std::string glb = "glTF";
  const std::uint32_t words[4] = {2, static_cast<std::uint32_t>(20 + json.size()),
                                  static_cast<std::uint32_t>(json.size()), 0x4E4F534Au};
  glb.append(reinterpret_cast<const char*>(words), sizeof words);
  glb += json;
  const std::string binary = dir.write("up.glb", glb);
  EXPECT_EQ(mesh_load_message(binary),
            binary + ": buffers[0].uri \"../../etc/passwd\" has a \"..\" segment" + kOutside);
}

// Whatever the URI says, Assimp opens nothing outside the folder: a symbolic link in it that
// points out is refused where it resolves, as is an OBJ's .mtl above the folder.
TEST(MeshSideFiles, FilesResolvedOutsideTheFolderAreNotOpened) {
  TempDir dir;
  fs::create_directories(dir / "mesh");
  fs::create_directories(dir / "elsewhere");
  dir.write("elsewhere/tet.bin", tet_gltf_buffer());
  fs::create_symlink(dir / "elsewhere/tet.bin", dir / "mesh/tet.bin");
  const std::string linked = dir.write("mesh/tet.gltf", tet_gltf("tet.bin"));
  const std::string folder = fs::canonical(dir / "mesh").string();
  const std::string target = fs::canonical(dir / "elsewhere/tet.bin").string();
  const std::string side_files =
      ", outside the mesh file's folder " + folder +
      ": a mesh file's side files (buffers, images, materials) are read only from its own folder";
  EXPECT_EQ(mesh_load_message(linked), linked + ": refers to " + target + side_files);
  dir.write("secret.mtl", "newmtl m\nKd 1 1 1\n");
  const std::string obj = dir.write("mesh/tet.obj",
                                    "mtllib ../secret.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\n"
                                    "v 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n");
  EXPECT_EQ(mesh_load_message(obj),
            obj + ": refers to " + fs::canonical(dir / "secret.mtl").string() + side_files);
  // The mesh file itself may be a link to another folder: its side files are still looked up in
  // (and confined to) the folder of the path as given.
  dir.write("mesh/real.bin", tet_gltf_buffer());
  dir.write("elsewhere/real.gltf", tet_gltf("real.bin"));
  fs::create_symlink(dir / "elsewhere/real.gltf", dir / "mesh/real.gltf");
  EXPECT_EQ(mesh_load_message((dir / "mesh/real.gltf").string()), "");
}

}  // namespace
