#pragma once
/// @file mesh_text.hpp
/// Mesh files of the mesh-reader tests (tests/sim/scene/mesh_*_test.cpp, scene_mesh_test.cpp,
/// the `numen` command's): the unit tetrahedron as an ASCII PLY with the counts a test puts in its
/// header and as a glTF with the buffer URI it names, the message of loading a file, and a fine
/// closed ellipsoid as a Wavefront OBJ (the organ tests' user mesh from CT, made coarse at load).
/// Header-only; include from numen::sim test files only.

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>

#include "numen/core/mesh.hpp"

#include "numen/sim/input/input_error.hpp"
#include "numen/sim/scene/mesh_file.hpp"

namespace numen::test {

/// The unit tetrahedron as a PLY body, wound outward: 4 vertices, then 4 faces (the body's lines
/// 10 to 17 of ascii_ply()).
inline constexpr const char* kTetPlyBody =
    "0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";

/// An ASCII PLY whose header declares `vertices` vertices (float x y z) and `faces` faces (uchar
/// counted int lists), 9 lines, followed by `body`.
inline std::string ascii_ply(const std::string& vertices, const std::string& faces,
                             const std::string& body = kTetPlyBody) {
  return "ply\nformat ascii 1.0\nelement vertex " + vertices +
         "\nproperty float x\nproperty float y\nproperty float z\nelement face " + faces +
         "\nproperty list uchar int vertex_indices\nend_header\n" + body;
}

/// The unit tetrahedron's glTF buffer: 4 float vertices (48 bytes), 12 uint16 indices (24 bytes).
inline std::string tet_gltf_buffer() {
  const float v[12] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
  const std::uint16_t i[12] = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
  std::string out(72, '\0');
  std::memcpy(out.data(), v, 48);
  std::memcpy(out.data() + 48, i, 24);
  return out;
}

/// A glTF 2.0 of the tetrahedron whose one buffer (tet_gltf_buffer()'s layout) is `uri`, plus
/// `extra` top-level members (",\"images\":[…]").
inline std::string tet_gltf(const std::string& uri, const std::string& extra = "") {
  return R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],)"
         R"("meshes":[{"primitives":[{"attributes":{"POSITION":0},"indices":1}]}],)"
         R"("buffers":[{"byteLength":72,"uri":")" +
         uri +
         R"("}],)"
         R"("bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":48},)"
         R"({"buffer":0,"byteOffset":48,"byteLength":24}],)"
         R"("accessors":[{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3",)"
         R"("max":[1,1,1],"min":[0,0,0]},{"bufferView":1,"componentType":5123,"count":12,)"
         R"("type":"SCALAR"}])" +
         extra + "}";
}

/// The what() of loading `path` with sim::load_mesh_file(), "" when it loads.
inline std::string mesh_load_message(const std::string& path) {
  try {
    (void)sim::load_mesh_file(path);
  } catch (const sim::InputError& e) {
    return e.what();
  }
  return "";
}

/// A closed ellipsoid of semi-axes 35 × 25 × 20 (the shipped organ's, in millimetres: give the
/// scene `units = "mm"`) as a Wavefront OBJ: core::make_icosphere(1, subdivisions) scaled,
/// 10·4^s + 2 vertices and 20·4^s triangles (s = 4: 2562 and 5120), outward. Optionally without
/// its last `holes` triangles (an open surface), and with its first vertex `spike` times as far
/// from the centre (a thin spike). The fine organ surface of the net-size tests (docs/fine-surface.md).
inline std::string fine_ellipsoid_obj(int subdivisions, int holes = 0, double spike = 1.0) {
  core::TriangleMesh m = core::make_icosphere(1.0, subdivisions);
  m.vertices.front() *= spike;
  std::string out = "# fine ellipsoid 35 x 25 x 20 mm\n";
  char line[96];
  for (const core::Vec3& v : m.vertices) {
    std::snprintf(line, sizeof line, "v %.9f %.9f %.9f\n", 35.0 * v.x(), 25.0 * v.y(), 20.0 * v.z());
    out += line;
  }
  for (int i = 0; i + holes < m.num_triangles(); ++i) {
    const auto& t = m.triangles[static_cast<std::size_t>(i)];
    std::snprintf(line, sizeof line, "f %d %d %d\n", t[0] + 1, t[1] + 1, t[2] + 1);
    out += line;
  }
  return out;
}

}  // namespace numen::test
