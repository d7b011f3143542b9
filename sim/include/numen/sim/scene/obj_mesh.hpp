#pragma once
/// @file obj_mesh.hpp
/// Wavefront OBJ surface meshes for deformable tools, read with Debian's
/// tinyobjloader (libtinyobjloader-dev), not a hand-written parser.

#include <string>

#include "numen/core/mesh.hpp"

namespace numen::sim {

/// Reads the triangle mesh of a Wavefront OBJ file: every shape's faces
/// (polygons are triangulated by the loader; a face's winding is kept), vertex
/// positions only (normals, texture coordinates and materials are ignored;
/// `mtllib` is skipped, an .mtl file is not needed), with vertices that no face
/// uses removed and the others kept in file order, indices compacted. Positions
/// are read in double precision (tinyobjloader_double). The result passes core::validate_mesh(); metres are assumed (scale in the scene).
/// Throws InputError naming `path` (and the line, when the loader gives it)
/// when the file cannot be read or parsed, a face points past the vertex list
/// or has fewer than 3 vertices, the file has no face, or the mesh is invalid
/// (validate_mesh's message, whose indices count from 0 over the kept vertices
/// and the triangles after triangulation). The loader's warnings are appended
/// to the message. Load time only.
core::TriangleMesh load_obj_mesh(const std::string& path);

}  // namespace numen::sim
