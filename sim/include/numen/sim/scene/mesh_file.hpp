#pragma once
/// @file mesh_file.hpp
/// Triangle meshes from files, read with Debian's Assimp (libassimp-dev), the one reader of every
/// mesh a scene uses: the deformable nets' and the mesh obstacles' (docs/meshes.md).

#include <string>

#include "numen/core/mesh.hpp"

namespace numen::sim {

/// Most triangles a mesh file may have. The bound is memory: loading a mesh obstacle peaks at
/// about 0.56 GB per million triangles (Assimp's copy, numen's vertex map and mesh, the built
/// core::MeshShape), the kept shape 0.145 GB, a narrow band at most core::kMeshBandMaxBytes more;
/// 2 million keeps one mesh near 1.1 GB: a 1-million-triangle mesh loads (docs/meshes.md, "Limits").
inline constexpr int kMaxMeshTriangles = 2'000'000;

/// Reads the triangle surface of a mesh file (`.stl` ASCII or binary, Wavefront `.obj`, `.ply`
/// ASCII or binary, glTF 2.0 `.gltf`/`.glb`; the extension in any case) in the file's own frame
/// and units: every mesh of the file, each node's transform applied (glTF), polygons triangulated
/// (a face's winding kept), points and lines dropped, positions only (normals, texture
/// coordinates, colours and materials are ignored; an OBJ's .mtl is not needed). Vertices at the
/// same position are one vertex (across the file's meshes too), numbered in the order the
/// triangles first use them. The result passes core::validate_mesh().
/// Checked before Assimp reads the file: an OBJ file's `v` and `f` lines, at their line (a
/// coordinate that is not a finite number, a vertex without three coordinates, a face of fewer
/// than three vertices or one naming a vertex that does not exist: OBJ counts from 1, negative is
/// relative); a PLY's header against its body and its faces' vertex indices, a binary STL's count
/// against its size (mesh_counts.hpp); a glTF's buffer and image URIs (a `data:` URI or a relative
/// path inside the file's folder). Assimp then opens only the file and files in its folder,
/// resolved canonically (MeshFolderIOSystem, mesh_side_files.hpp).
/// Throws InputError naming `path` (and the line, for an OBJ line or a PLY header or ASCII line)
/// when the file is missing, a directory, unreadable, empty, of another extension, fails a check
/// above, refers to a file outside its folder, is not parsed by Assimp (its message appended), has
/// no triangle, more than `max_triangles` triangles (the bound named), a non-finite vertex, or is
/// an invalid mesh (validate_mesh's message: degenerate triangle, edge shared by more than two
/// triangles). Throws std::bad_alloc when memory runs out, Assimp's included (Assimp keeps an
/// importer's exception as its error: it is thrown again). Load time only.
core::TriangleMesh load_mesh_file(const std::string& path, int max_triangles = kMaxMeshTriangles);

/// Signed volume of a triangle mesh (m³; divergence theorem): > 0 for a closed mesh wound
/// outward, < 0 wound inward.
double signed_volume(const core::TriangleMesh& mesh);

}  // namespace numen::sim
