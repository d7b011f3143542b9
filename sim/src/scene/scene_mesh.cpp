/// @file scene_mesh.cpp
/// Mesh-file keys of a scene table (see scene_mesh.hpp).

#include "scene_mesh.hpp"

#include <system_error>

#include "numen/sim/scene/mesh_file.hpp"

namespace numen::sim {

SceneMeshFile read_scene_mesh_file(const TomlTable& t, const std::filesystem::path& scene_dir) {
  std::filesystem::path file = t.string("file");
  if (file.is_relative()) file = scene_dir / file;
  SceneMeshFile out;
  out.path = file.string();
  std::error_code ec;
  if (std::filesystem::is_directory(file, ec))
    t.fail("file", out.path + " is a directory, not a mesh file");
  if (!std::filesystem::is_regular_file(file, ec))
    t.fail("file", "mesh file not found: " + out.path + (ec ? " (" + ec.message() + ")" : ""));
  try {
    out.mesh = load_mesh_file(out.path);
  } catch (const InputError& e) {
    t.fail("file", e.what());  // "<mesh file>[:<line>]: <message>"
  }
  return out;
}

core::Vec3 read_mesh_scale(const TomlTable& t) {
  const std::string units = t.choice("units", {"m", "cm", "mm"}, "m");
  const double unit = units == "mm" ? 1e-3 : units == "cm" ? 1e-2 : 1.0;
  core::Vec3 scale = core::Vec3::Ones();
  if (const toml::node* n = t.node("scale"); n != nullptr && n->is_number()) {
    scale = core::Vec3::Constant(t.number("scale"));
  } else if (n != nullptr) {
    scale = t.vec3("scale");
  }
  if (!scale.allFinite() || !(scale.cwiseAbs().minCoeff() > 0.0))
    t.fail("scale", "every factor must be finite and non-zero");
  return unit * scale;
}

void check_scaled_mesh(const TomlTable& t, const core::TriangleMesh& mesh, const std::string& path) {
  const std::string invalid = core::validate_mesh(mesh);
  if (invalid.empty()) return;
  t.fail(t.has("scale") ? "scale" : "file",
         path + ": invalid mesh after scaling and placement (vertices counted from 0 in the order "
                "the triangles first use them): " + invalid);
}

}  // namespace numen::sim
