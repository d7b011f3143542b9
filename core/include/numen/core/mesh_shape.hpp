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
/// point that cannot be within reach without entering the tree. Near the surface (|sd| ≤ the
/// band's width) a narrow-band grid answers instead, at a cost that does not grow with the
/// triangle count: each cell lists the triangles whose closest-feature region (face prism, edge
/// wedge, vertex cone) meets it within the band (MeshBand, mesh_shape_band.cpp).
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

/// Cells along each side of a narrow band's brick (the band stores only the bricks it meets).
inline constexpr int kMeshBrickCells = 8;

/// Default width of the narrow band (m): the largest sphere radius that gets the flat query when
/// the caller does not say (the scene passes its largest sphere radius plus a margin).
inline constexpr double kMeshDefaultBand = 0.005;

/// Most bytes a narrow band may take, while built (12 per (cell, triangle) pair, 4 per grid cell)
/// and kept; a mesh whose band would need more keeps the tree alone (MeshBand::note says so).
inline constexpr std::size_t kMeshBandMaxBytes = std::size_t{256} << 20;

/// How build_mesh_shape() builds the narrow band.
struct MeshShapeOptions {
  /// Band width B (m, ≥ 0): points with |sd| ≤ B are answered from the band; 0 builds none.
  double band = kMeshDefaultBand;
  /// Cell side as a multiple of the mean edge length (> 0).
  double cell_factor = 1.0;
  /// Memory cap of the band (bytes), kMeshBandMaxBytes by default.
  std::size_t max_band_bytes = kMeshBandMaxBytes;
};

/// A MeshShape's narrow band (mesh frame, m): a uniform grid of cells of side `cell` around the
/// surface, stored in bricks of kMeshBrickCells³ cells, only the bricks that hold a listed cell.
/// A cell lists every triangle that can hold the closest surface point of a point x of the cell
/// with |sd(x)| ≤ `width`: the closest point q of x on a closed surface is the closest point on
/// every triangle holding q, so x lies in the face prism, the edge wedge (the edge regions of both
/// triangles) or the vertex cone ((x − v)·(u − v) ≤ 0 for every neighbour u) of q's feature; a
/// feature is listed in the cells that meet its region within distance `width`, then a cell keeps
/// the triangles within min(width, d_c + ρ) + ρ of its centre (d_c the nearest listed, ρ the
/// half-diagonal). An empty cell or one outside the bricks has no point with |sd| ≤ width.
struct MeshBand {
  double width = 0.0;                       ///< B (m); 0: no band.
  double cell = 0.0;                        ///< Cell side (m).
  Vec3 origin = Vec3::Zero();               ///< Corner of cell (0, 0, 0) (m).
  std::array<int, 3> cells = {0, 0, 0};     ///< Cells per axis (multiples of kMeshBrickCells).
  /// Per brick (x fastest): its slot, or −1 when none of its cells is listed.
  std::vector<std::int32_t> brick_slot;
  /// Per slot, kMeshBrickCells³ + 1 offsets into `triangles`: local cell i (x fastest) lists
  /// triangles[begin[i], begin[i + 1]).
  std::vector<std::uint32_t> cell_begin;
  /// Per listed triangle (t, leaf order) of a cell, `(t << 7) | q` with q = ⌊127 d / D⌋, d the
  /// distance from the cell's centre to t and D = width + 2ρ (≥ d): a cell's list is in
  /// increasing d, and d(x, t) ≥ q·D/127 − |x − centre| lets a query stop early.
  std::vector<std::int32_t> triangles;
  std::string note;                         ///< "" or why there is no band (the memory cap).
};

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
  MeshBand band;                               ///< Narrow band (empty: the tree answers all).

  int num_triangles() const noexcept { return static_cast<int>(triangles.size()); }
  /// Heap bytes of the arrays above (capacity × element size).
  std::size_t memory_bytes() const noexcept;
};

/// Builds `out` from `mesh`, which must pass validate_mesh() and be closed (every edge shared by
/// exactly two triangles), consistently wound (each edge traversed once each way) and wound
/// outward (positive signed volume). Returns "" on success, else a message naming the first
/// offence (boundary edges counted, the edge of an inconsistent winding by its vertex indices,
/// the volume); `out` is then unspecified. Allocates: load time only. The narrow band follows
/// `options`; a band over the memory cap is not built (out.band.note says so), which is not an
/// error: the tree answers every query.
std::string build_mesh_shape(const TriangleMesh& mesh, MeshShape& out,
                             const MeshShapeOptions& options = {});

/// The first part of build_mesh_shape(): `out` gets the vertices of `mesh`, its AABB tree, its
/// triangles in the tree's leaf order and their bounds (aabb_min, aabb_max, tree_depth), the rest
/// empty. `mesh` must pass validate_mesh() and have a triangle; it need not be closed (enough for
/// find_self_intersections()). Allocates: load time only.
void build_mesh_tree(const TriangleMesh& mesh, MeshShape& out);

/// Builds `s.band` for a MeshShape whose tree, normals and edges are built (build_mesh_shape()
/// calls it). Allocates: load time only.
void build_mesh_band(MeshShape& s, const MeshShapeOptions& options);

/// Bytes of the narrow band's arrays (capacity × element size).
std::size_t mesh_band_bytes(const MeshBand& band) noexcept;

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
