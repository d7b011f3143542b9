#pragma once
/// @file mesh_shape_intersect.hpp
/// Self-intersections of a closed mesh (docs/meshes.md, "Self-intersections"): the pairs of
/// triangles that share no vertex and meet, found through the MeshShape's AABB tree (the tree
/// against itself, pairs of overlapping boxes) and a triangle–triangle test on orientation signs:
/// two triangles that are not coplanar meet exactly when an edge of one crosses the other (the
/// segment where they meet ends on an edge of one of them), each crossing decided by the signs of
/// 3×3 orientation determinants (double precision, not adaptive: a pair within rounding of
/// touching may go either way); coplanar triangles meet when an edge of one crosses an edge of
/// the other or a vertex of one lies in the other, in the plane. Load time only (allocates).

#include <array>
#include <cstdint>

#include "numen/core/mesh_shape.hpp"

namespace numen::core {

/// What find_self_intersections() found.
struct MeshSelfIntersections {
  std::int64_t count = 0;  ///< Pairs of triangles that share no vertex and meet.
  /// The first pair found (deterministic), as vertex-index triples of MeshShape::triangles
  /// (the mesh's vertex indices, its triangles' winding); unset when count is 0.
  std::array<int, 3> first_a = {-1, -1, -1};
  std::array<int, 3> first_b = {-1, -1, -1};
};

/// Every pair of triangles of `shape` that share no vertex and meet (touching counts).
/// Pairs that share a vertex or an edge are skipped (they meet there by construction).
MeshSelfIntersections find_self_intersections(const MeshShape& shape);

/// The same for any mesh that passes validate_mesh(), open ones included (a net's surface):
/// builds the tree (build_mesh_tree()) and searches it. Empty result for a mesh without triangles.
MeshSelfIntersections find_self_intersections(const TriangleMesh& mesh);

/// True when the triangles (a0, a1, a2) and (b0, b1, b2) meet (a point in common, the boundary
/// included). The signs come from double-precision orientation determinants.
bool triangles_intersect(const Vec3& a0, const Vec3& a1, const Vec3& a2, const Vec3& b0,
                         const Vec3& b1, const Vec3& b2) noexcept;

}  // namespace numen::core
