#pragma once
/// @file scene_mesh.hpp
/// The keys of a mesh file in a scene table — `file`, `units`, `scale` — shared by the
/// [[deformable]] nets and the mesh obstacles (docs/meshes.md). Private to numen::sim.
/// Load time only (allocates, throws InputError located at the key, naming the mesh file).

#include <filesystem>
#include <string>

#include "numen/core/mesh.hpp"
#include "toml_reader.hpp"

namespace numen::sim {

/// A mesh read from a scene table's `file` key, with the path it was read from.
struct SceneMeshFile {
  core::TriangleMesh mesh;  ///< In the file's frame and units.
  std::string path;         ///< `file` resolved against the scene's folder.
};

/// Reads `file` (a path relative to `scene_dir`, or absolute) with load_mesh_file(). Any
/// InputError of the mesh file is raised again at the table's `file` key, its message naming the
/// mesh file (and the mesh file's line, for an OBJ line).
SceneMeshFile read_scene_mesh_file(const TomlTable& t, const std::filesystem::path& scene_dir);

/// The factor of `units` ("m" 1, "cm" 0.01, "mm" 0.001; "m" when absent) times `scale` (one
/// number or [x, y, z], each finite and non-zero; a negative product mirrors the mesh; 1 when
/// absent), per axis.
core::Vec3 read_mesh_scale(const TomlTable& t);

/// Fails at `scale` (or `file` when absent) when the mesh, scaled and placed, no longer passes
/// core::validate_mesh() (a triangle degenerate after scaling), naming `path`.
void check_scaled_mesh(const TomlTable& t, const core::TriangleMesh& mesh, const std::string& path);

}  // namespace numen::sim
