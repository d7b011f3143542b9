#pragma once
/// @file mesh_shape.hpp
/// Closed triangle meshes as rigid collision shapes (docs/meshes.md): the exact signed distance
/// from a point to the surface, for the spheres of the bodies and the nodes of the nets against a
/// mesh obstacle. The closest point on each candidate triangle is Ericson's (Real-Time Collision
/// Detection, 2005, §5.1.5); inside/outside is the sign of (p − q)·n̂ with n̂ the angle-weighted
/// pseudo-normal of the closest feature (face, edge or vertex; Bærentzen & Aanæs, IEEE TVCG 11(3),
/// 2005), exact for a closed, consistently wound, manifold mesh. Candidates come from a bounding
/// volume hierarchy (an AABB tree, median split, ≤ kMeshLeafSize triangles a leaf) searched
/// nearest child first, its search radius capped by a coarse grid of signed distances at cell
/// centres (the signed distance is 1-Lipschitz: |sd(p) − sd(c)| ≤ |p − c|), which also rejects a
/// point that cannot be within reach without entering the tree.
///
/// Build (build_mesh_shape()) at load time allocates; the queries never allocate nor throw.

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "numen/core/mesh.hpp"
#include "numen/core/types.hpp"

namespace numen::core {

/// Most triangles in one leaf of a MeshShape's tree.
inline constexpr int kMeshLeafSize = 4;

/// Most cells along the longest side of a MeshShape's signed-distance grid.
inline constexpr int kMeshGridCells = 32;

/// A node of a MeshShape's AABB tree (mesh frame, m). An inner node (count == 0) has its first
/// child at index + 1 and its second at `index`; a leaf holds triangles [index, index + count).
struct MeshBvhNode {
  Vec3 lo = Vec3::Zero();
  Vec3 hi = Vec3::Zero();
  std::int32_t index = 0;
  std::int32_t count = 0;
};

/// A closed mesh prepared for signed-distance queries. Everything in the mesh's own frame (m);
/// an obstacle places it with its pose. Triangles are in the tree's leaf order (not the input's).
struct MeshShape {
  std::vector<Vec3> vertices;                  ///< m.
  std::vector<std::array<int, 3>> triangles;   ///< Outward winding, leaf order.
  std::vector<Vec3> face_normals;              ///< Unit outward normal per triangle.
  std::vector<std::array<int, 3>> triangle_edges;  ///< Edges (v0v1, v1v2, v2v0) per triangle.
  std::vector<Vec3> edge_normals;              ///< n_a + n_b of an edge's two faces (unnormalised).
  std::vector<Vec3> vertex_normals;            ///< Σ angle·n of the incident faces (unnormalised).
  std::vector<MeshBvhNode> nodes;              ///< Tree, root at 0.
  /// Signed distance at the grid's cell centres (m, > 0 outside), x fastest.
  std::vector<float> grid_distance;
  std::array<int, 3> grid_cells = {0, 0, 0};   ///< Cells per axis.
  Vec3 grid_origin = Vec3::Zero();             ///< Corner of cell (0, 0, 0) (m).
  double grid_cell = 0.0;                      ///< Cell side (m).
  Vec3 aabb_min = Vec3::Zero();                ///< Bounds of the vertices (m).
  Vec3 aabb_max = Vec3::Zero();
  int tree_depth = 0;                          ///< Levels of the tree (root = 1).

  int num_triangles() const noexcept { return static_cast<int>(triangles.size()); }
  /// Heap bytes of the arrays above (capacity × element size).
  std::size_t memory_bytes() const noexcept;
};

/// Builds `out` from `mesh`, which must pass validate_mesh() and be closed (every edge shared by
/// exactly two triangles), consistently wound (each edge traversed once each way) and wound
/// outward (positive signed volume). Returns "" on success, else a message naming the first
/// offence (boundary edges counted, the edge of an inconsistent winding by its vertex indices,
/// the volume); `out` is then unspecified. Allocates: load time only.
std::string build_mesh_shape(const TriangleMesh& mesh, MeshShape& out);

/// The closest surface point of a MeshShape to a query point.
struct MeshDistance {
  double distance = 0.0;         ///< Signed distance (m): > 0 outside, < 0 inside.
  Vec3 point = Vec3::Zero();     ///< Closest point on the surface (mesh frame, m).
  Vec3 normal = Vec3::UnitZ();   ///< Unit outward direction at `point` for the query point:
                                 ///< (p − q)/|p − q| · sign, or the feature's pseudo-normal when
                                 ///< p lies on the surface.
  int triangle = -1;             ///< Triangle holding `point` (leaf order).
};

/// Signed distance from `p` (mesh frame) to the surface when it is below `reach` (m, ≥ 0; every
/// point inside the mesh counts, however deep): fills `out` and returns true; returns false when
/// sd(p) ≥ reach (also for a non-finite p). No allocation, no exception.
bool mesh_signed_distance(const MeshShape& shape, const Vec3& p, double reach,
                          MeshDistance& out) noexcept;

/// The exact signed distance by brute force over every triangle, with the same closest point and
/// pseudo-normal rules (a reference for tests and for the grid at build). No allocation.
MeshDistance mesh_signed_distance_brute(const MeshShape& shape, const Vec3& p) noexcept;

}  // namespace numen::core
