// Tests of sim/mesh_file: mesh files through Assimp — OBJ (quads triangulated, normals/texture
// coordinates ignored, unused vertices removed), STL (ASCII, binary), PLY, glTF (its node
// transform applied) — and the InputError for each failure, naming the file.
#include "numen/sim/scene/mesh_file.hpp"

#include <gtest/gtest.h>

#include <algorithm>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include "numen/sim/input/input_error.hpp"
#include "temp_dir.hpp"

namespace {

using numen::core::build_mesh_topology;
using numen::core::TriangleMesh;
using numen::core::validate_mesh;
using numen::core::Vec3;
using numen::sim::InputError;
using numen::sim::load_mesh_file;
using numen::sim::signed_volume;
using numen::test::TempDir;

/// Loads `path` expecting an InputError; returns it.
InputError mesh_load_error(const std::string& path) {
  try {
    load_mesh_file(path);
  } catch (const InputError& e) {
    return e;
  }
  ADD_FAILURE() << "no InputError for " << path;
  return InputError(path, 0, 0, "", "");
}

/// A cube of side 2 centred at the origin, six quads wound outward.
constexpr const char* kCube = R"(# cube
o cube
v -1 -1 -1
v  1 -1 -1
v  1  1 -1
v -1  1 -1
v -1 -1  1
v  1 -1  1
v  1  1  1
v -1  1  1
f 1 4 3 2
f 5 6 7 8
f 1 2 6 5
f 2 3 7 6
f 3 4 8 7
f 4 1 5 8
)";

TEST(ObjMesh, CubeQuadsAreTriangulated) {
  TempDir dir;
  const TriangleMesh m = load_mesh_file(dir.write("cube.obj", kCube));
  EXPECT_EQ(m.num_vertices(), 8);
  EXPECT_EQ(m.num_triangles(), 12);
  EXPECT_EQ(validate_mesh(m), "");
  EXPECT_EQ(build_mesh_topology(m).boundary_edges, 0);
  EXPECT_NEAR(signed_volume(m), 8.0, 1e-12);  // winding kept: outward
  // Numbered in the order the triangles first use them.
  EXPECT_EQ(std::count(m.vertices.begin(), m.vertices.end(), Vec3(1, 1, 1)), 1);
}

// A directory given as the mesh says it is a directory (not "cannot open").
TEST(ObjMesh, ADirectoryIsNamedAsSuch) {
  TempDir dir;
  const std::string folder = (dir / "meshes.obj").string();
  std::filesystem::create_directories(folder);
  const InputError e = mesh_load_error(folder);
  EXPECT_EQ(std::string(e.what()), folder + ": is a directory, not a mesh file");
}

TEST(ObjMesh, NormalsAndTexcoordsIgnored) {
  TempDir dir;
  const std::string path = dir.write("tri.obj",
                                     "mtllib missing.mtl\n"
                                     "v 0 0 0\nv 0.5 0 0\nv 0 0.25 0.1\n"
                                     "vt 0 0\nvt 1 0\nvt 0 1\n"
                                     "vn 0 0 1\nvn 0 0 1\nvn 0 0 1\n"
                                     "usemtl red\n"
                                     "f 1/1/1 2/2/2 3/3/3\n");
  const TriangleMesh m = load_mesh_file(path);
  ASSERT_EQ(m.num_vertices(), 3);
  ASSERT_EQ(m.num_triangles(), 1);
  EXPECT_EQ(m.triangles[0], (std::array<int, 3>{0, 1, 2}));
  EXPECT_EQ(m.vertices[1], Vec3(0.5, 0, 0));
  EXPECT_NEAR(m.vertices[2].y(), 0.25, 1e-7);
  EXPECT_NEAR(m.vertices[2].z(), 0.1, 1e-7);  // read as float by Assimp
  // Normal-only and negative (relative) indices too.
  const TriangleMesh n = load_mesh_file(dir.write("rel.obj",
                                                 "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\n"
                                                 "f -3//1 -2//1 -1//1\n"));
  EXPECT_EQ(n.triangles[0], (std::array<int, 3>{0, 1, 2}));
}

TEST(ObjMesh, UnusedVerticesRemovedAndIndicesCompacted) {
  TempDir dir;
  const std::string path = dir.write("unused.obj",
                                     "v 9 9 9\n"  // unused
                                     "v 0 0 0\nv 1 0 0\n"
                                     "v 7 7 7\n"  // unused
                                     "v 0 1 0\nv 1 1 0\n"
                                     "f 2 3 5\nf 3 6 5\n");
  const TriangleMesh m = load_mesh_file(path);
  ASSERT_EQ(m.num_vertices(), 4);
  EXPECT_EQ(m.vertices[0], Vec3(0, 0, 0));
  EXPECT_EQ(m.vertices[1], Vec3(1, 0, 0));
  EXPECT_EQ(m.vertices[2], Vec3(0, 1, 0));
  EXPECT_EQ(m.vertices[3], Vec3(1, 1, 0));
  ASSERT_EQ(m.num_triangles(), 2);
  EXPECT_EQ(m.triangles[0], (std::array<int, 3>{0, 1, 2}));
  EXPECT_EQ(m.triangles[1], (std::array<int, 3>{1, 3, 2}));
  EXPECT_EQ(validate_mesh(m), "");
}

TEST(ObjMesh, SeveralShapesShareTheVertexList) {
  TempDir dir;
  const std::string path = dir.write("groups.obj",
                                     "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\n"
                                     "o a\nf 1 2 3\n"
                                     "o b\nf 2 4 3\n");
  const TriangleMesh m = load_mesh_file(path);
  EXPECT_EQ(m.num_vertices(), 4);
  EXPECT_EQ(m.num_triangles(), 2);
}

TEST(ObjMesh, MissingFile) {
  TempDir dir;
  const std::string path = (dir / "nope.obj").string();
  const InputError e = mesh_load_error(path);
  EXPECT_EQ(e.file(), path);
  EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
}

TEST(ObjMesh, NoFace) {
  TempDir dir;
  const std::string path = dir.write("points.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2\n");
  const InputError e = mesh_load_error(path);
  const std::string what = e.what();
  EXPECT_NE(what.find(path), std::string::npos) << what;
  EXPECT_NE(what.find("no face"), std::string::npos) << what;
  EXPECT_NE(std::string(mesh_load_error(dir.write("empty.obj", "")).what()).find("no face"),
            std::string::npos);
}

TEST(ObjMesh, NonManifoldEdge) {
  TempDir dir;
  const std::string path = dir.write("fin.obj",
                                     "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\n"
                                     "f 1 2 3\nf 2 1 4\nf 1 2 5\n");
  const InputError e = mesh_load_error(path);
  const std::string what = e.what();
  EXPECT_EQ(e.file(), path);
  EXPECT_NE(what.find(path), std::string::npos) << what;
  EXPECT_NE(what.find("edge (0, 1)"), std::string::npos) << what;
  EXPECT_NE(what.find("3 triangles"), std::string::npos) << what;
}

TEST(ObjMesh, DegenerateFace) {
  TempDir dir;
  const std::string path = dir.write("flat.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n");
  const std::string what = mesh_load_error(path).what();
  EXPECT_NE(what.find(path), std::string::npos) << what;
  EXPECT_NE(what.find("degenerate"), std::string::npos) << what;
}

TEST(ObjMesh, BadFaces) {
  TempDir dir;
  // A triangle and a quad pointing past the vertex list, a face of two vertices
  // (the loader only warns about these and drops or keeps them).
  for (const char* face : {"f 1 2 5\n", "f 1 2 3 7\n", "f 1 2 3\nf 2 4\n"}) {
    const std::string path =
        dir.write("range.obj", std::string("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\n") + face);
    const std::string what = mesh_load_error(path).what();
    EXPECT_NE(what.find(path), std::string::npos) << what;
  }
}

TEST(ObjMesh, ParseErrorCarriesTheLine) {
  TempDir dir;
  // Index 0 does not exist in OBJ (1-based): the loader stops at line 4.
  const std::string path = dir.write("zero.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n");
  const InputError e = mesh_load_error(path);
  const std::string what = e.what();
  EXPECT_NE(what.find(path), std::string::npos) << what;
  EXPECT_EQ(e.line(), 4) << what;
  EXPECT_NE(what.find(path + ":4:"), std::string::npos) << what;
}

}  // namespace

namespace {

TEST(ObjMesh, MalformedVertexCoordinatesAreRefusedAtTheirLine) {
  // Assimp reads a bad or missing coordinate as 0: checked before it.
  numen::test::TempDir dir;
  const std::string faces = "f 1 2 3\n";
  const std::string bad = dir.write("bad_v.obj", "v 0 0 0\nv 1 0 0\nv 0 1 abc\n" + faces);
  const InputError e1 = mesh_load_error(bad);
  EXPECT_EQ(e1.line(), 3) << e1.what();
  EXPECT_NE(std::string(e1.what()).find("abc"), std::string::npos) << e1.what();
  const std::string short_v = dir.write("short_v.obj", "v 0 0 0\nv 1 0\nv 0 1 0\n" + faces);
  const InputError e2 = mesh_load_error(short_v);
  EXPECT_EQ(e2.line(), 2) << e2.what();
  const std::string inf_v = dir.write("inf_v.obj", "v 0 0 0\nv inf 0 0\nv 0 1 0\n" + faces);
  EXPECT_EQ(mesh_load_error(inf_v).line(), 2);
  // Colours after the coordinates and comments are fine.
  EXPECT_EQ(numen::sim::load_mesh_file(dir.write(
                "ok.obj", "v 0 0 0 1 0 0\nv 1 0 0 # corner\nv 0 1 0\n" + faces))
                .num_vertices(),
            3);
}

}  // namespace

namespace {

using numen::test::TempDir;

/// The unit tetrahedron (outward winding) the format tests read.
void expect_tetrahedron(const TriangleMesh& m, const Vec3& offset) {
  ASSERT_EQ(m.num_vertices(), 4);
  ASSERT_EQ(m.num_triangles(), 4);
  EXPECT_EQ(validate_mesh(m), "");
  EXPECT_EQ(build_mesh_topology(m).boundary_edges, 0);
  EXPECT_NEAR(signed_volume(m), 1.0 / 6.0, 1e-7);
  for (const Vec3& v : {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)})
    EXPECT_EQ(std::count(m.vertices.begin(), m.vertices.end(), v + offset), 1) << v.transpose();
}

constexpr const char* kTetStl = R"(solid tet
facet normal 0 0 -1
 outer loop
  vertex 0 0 0
  vertex 0 1 0
  vertex 1 0 0
 endloop
endfacet
facet normal 0 -1 0
 outer loop
  vertex 0 0 0
  vertex 1 0 0
  vertex 0 0 1
 endloop
endfacet
facet normal -1 0 0
 outer loop
  vertex 0 0 0
  vertex 0 0 1
  vertex 0 1 0
 endloop
endfacet
facet normal 1 1 1
 outer loop
  vertex 1 0 0
  vertex 0 1 0
  vertex 0 0 1
 endloop
endfacet
endsolid tet
)";

/// A binary STL of `tris` (each three vertices), normals zero.
std::string binary_stl(const std::vector<std::array<Vec3, 3>>& tris) {
  std::string out(80, ' ');
  const auto n = static_cast<std::uint32_t>(tris.size());
  out.append(reinterpret_cast<const char*>(&n), 4);
  for (const auto& t : tris) {
    float f[12] = {0, 0, 0};
    for (int k = 0; k < 3; ++k)
      for (int c = 0; c < 3; ++c) f[3 + 3 * k + c] = static_cast<float>(t[static_cast<std::size_t>(k)][c]);
    out.append(reinterpret_cast<const char*>(f), sizeof f);
    out.append(2, '\0');
  }
  return out;
}

std::vector<std::array<Vec3, 3>> tet_triangles() {
  const Vec3 o(0, 0, 0), x(1, 0, 0), y(0, 1, 0), z(0, 0, 1);
  return {{o, y, x}, {o, x, z}, {o, z, y}, {x, y, z}};
}

TEST(MeshFile, StlAsciiAndBinary) {
  TempDir dir;
  expect_tetrahedron(load_mesh_file(dir.write("tet.stl", kTetStl)), Vec3::Zero());
  expect_tetrahedron(load_mesh_file(dir.write("tet_bin.stl", binary_stl(tet_triangles()))),
                     Vec3::Zero());
}

TEST(MeshFile, Ply) {
  TempDir dir;
  const std::string ply =
      "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
      "property float z\nelement face 4\nproperty list uchar int vertex_indices\nend_header\n"
      "0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";
  expect_tetrahedron(load_mesh_file(dir.write("tet.ply", ply)), Vec3::Zero());
}

TEST(MeshFile, GltfWithItsNodeTransform) {
  TempDir dir;
  // The tetrahedron in an embedded buffer, its node translated by (0, 0, 2).
  const std::string gltf =
      R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0,"translation":[0,0,2]}],"meshes":[{"primitives":[{"attributes":{"POSITION":0},"indices":1}]}],"buffers":[{"byteLength":72,"uri":"data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAAAAAAAAAAAAAAAIA/AAACAAEAAAABAAMAAAADAAIAAQACAAMA"}],"bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":48},{"buffer":0,"byteOffset":48,"byteLength":24}],"accessors":[{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","max":[1,1,1],"min":[0,0,0]},{"bufferView":1,"componentType":5123,"count":12,"type":"SCALAR"}]})";
  expect_tetrahedron(load_mesh_file(dir.write("tet.gltf", gltf)), Vec3(0, 0, 2));
}

TEST(MeshFile, NonFiniteBinaryStlVertexIsRefused) {
  TempDir dir;
  auto tris = tet_triangles();
  tris[3][2] = Vec3(0, 0, std::numeric_limits<double>::quiet_NaN());
  const std::string path = dir.write("nan.stl", binary_stl(tris));
  const std::string what = mesh_load_error(path).what();
  EXPECT_NE(what.find(path), std::string::npos) << what;
  EXPECT_NE(what.find("not finite"), std::string::npos) << what;
}

TEST(MeshFile, TriangleBoundIsNamed) {
  TempDir dir;
  const std::string path = dir.write("tet.stl", kTetStl);
  try {
    load_mesh_file(path, 3);
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(path), std::string::npos) << what;
    EXPECT_NE(what.find("4 triangles, more than the 3"), std::string::npos) << what;
    EXPECT_NE(what.find("kMaxMeshTriangles"), std::string::npos) << what;
  }
  EXPECT_EQ(load_mesh_file(path, 4).num_triangles(), 4);
}

TEST(MeshFile, UnparsableFileNamesAssimp) {
  TempDir dir;
  const std::string path = dir.write("junk.stl", "solid x\nfacet normal 0 0 1\n outer loop\n");
  const std::string what = mesh_load_error(path).what();
  EXPECT_NE(what.find(path), std::string::npos) << what;
}

// Only the formats whose headers and references are checked reach Assimp: an OFF whose header
// promised 4·10^8 vertices parsed for half a minute at 4.7 GB.
TEST(MeshFile, FormatsOtherThanTheCheckedOnesAreRefusedByName) {
  TempDir dir;
  const std::string off = dir.write("bomb.off", "OFF\n400000000 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n");
  EXPECT_EQ(
      std::string(mesh_load_error(off).what()),
      off + ": a mesh file is .stl, .obj, .ply, .gltf or .glb: not \".off\" (docs/meshes.md)");
  const std::string bare = dir.write("mesh", kCube);
  EXPECT_EQ(std::string(mesh_load_error(bare).what()),
            bare +
                ": a mesh file is .stl, .obj, .ply, .gltf or .glb: this one has no extension "
                "(docs/meshes.md)");
  // The case of the extension does not matter.
  EXPECT_EQ(load_mesh_file(dir.write("CUBE.OBJ", kCube)).num_triangles(), 12);
}

}  // namespace
