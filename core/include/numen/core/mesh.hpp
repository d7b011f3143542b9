#pragma once
/// @file mesh.hpp
/// Triangle surface meshes for deformable god-objects (paper §4.2; Meseure &
/// Chaillou, JVCA 2000): built-in shapes (icosphere, capsule, box, torus), the
/// topology a mass-spring net needs (edges, bending pairs across adjacent
/// triangles) and lumped per-vertex areas. Load time only: every function
/// here allocates; nothing is called from step().

#include <array>
#include <string>
#include <utility>
#include <vector>

#include "numen/core/types.hpp"

namespace numen::core {

/// An indexed triangle mesh. Vertices in metres in the mesh's own frame;
/// triangles wind counter-clockwise seen from outside (outward normal
/// (v1 − v0) × (v2 − v0)).
struct TriangleMesh {
  std::vector<Vec3> vertices;                 ///< m.
  std::vector<std::array<int, 3>> triangles;  ///< Vertex indices.
  int num_vertices() const noexcept { return static_cast<int>(vertices.size()); }
  int num_triangles() const noexcept { return static_cast<int>(triangles.size()); }
};

/// Geodesic sphere of `radius` (m, > 0) centred at the origin: the regular
/// icosahedron (12 vertices) with each triangle split in four `subdivisions`
/// times (0..6), new vertices projected on the sphere. Vertex count
/// 10·4^s + 2: 12, 42, 162, 642, 2562, ... Closed, manifold, outward winding.
/// Arguments out of range give an empty mesh (which validate_mesh() rejects).
TriangleMesh make_icosphere(double radius, int subdivisions);

/// Capsule along z centred at the origin: a cylinder of `radius` (m, > 0) and
/// half length `half_length` (m, ≥ 0; 0 gives a sphere) capped by two
/// hemispheres. `segments` vertices per ring around z (≥ 3), `rings` rings
/// per hemisphere from the equator to (excluding) the pole (≥ 1), and
/// `cylinder_rings` intermediate rings along the cylinder (≥ 0). One vertex per
/// pole. With half_length 0 the two equator rings are one and cylinder_rings is
/// ignored. Vertex count 2 + segments·(2·rings + cylinder_rings), or
/// 2 + segments·(2·rings − 1) for half_length 0. Closed, manifold, outward
/// winding. Arguments out of range give an empty mesh.
TriangleMesh make_capsule(double radius, double half_length, int segments, int rings,
                          int cylinder_rings);

/// Box of `half_extents` (m, each > 0) centred at the origin, each face a grid
/// of (subdivisions + 1)² quads split into two triangles (subdivisions ≥ 0),
/// vertices shared along the box's edges (no duplicates): 6(n+2)² − 12(n+2) + 8
/// vertices for n = subdivisions. Closed, manifold, outward winding. Arguments
/// out of range give an empty mesh.
TriangleMesh make_box(const Vec3& half_extents, int subdivisions);

/// Box of `half_extents` (m, each > 0) centred at the origin with subdivisions per axis
/// (x, y, z; each ≥ 0): the faces normal to axis a are grids of (n_u + 1) × (n_v + 1) quads
/// over the two other axes, each split into two triangles, vertices shared along the box's
/// edges: (n_x + 2)(n_y + 2)(n_z + 2) − n_x n_y n_z vertices. A thin pad whose top face alone
/// is touched carries a fine top and bottom on a few rows of side (the suturing scene's pad,
/// docs/suturing.md). Closed, manifold, outward winding. Arguments out of range give an empty
/// mesh. make_box(h, n) is make_box(h, {n, n, n}), vertex for vertex.
TriangleMesh make_box(const Vec3& half_extents, const std::array<int, 3>& subdivisions);

/// Torus around z centred at the origin: tube of `minor_radius` (m, > 0) around the circle of
/// `major_radius` (m, > minor_radius) in the xy plane; `segments` (≥ 3) vertices along that
/// circle times `sides` (≥ 3) around the tube, 2·segments·sides triangles. Closed, manifold,
/// outward winding. Arguments out of range give an empty mesh.
TriangleMesh make_torus(double major_radius, double minor_radius, int segments, int sides);

/// Checks a mesh for use as a net: at least one triangle, indices in range,
/// finite vertices, no degenerate triangle (area ≤ 1e-12 × the squared
/// bounding-box diagonal, or a repeated index), no edge shared by more than two
/// triangles, no unused vertex. Returns "" when valid, else a message naming
/// the first offending triangle/vertex/edge by index. Checked in this order:
/// no triangle, non-finite vertex, index out of range or repeated, degenerate
/// area, edge shared by more than two triangles, unused vertex. Winding
/// consistency is not checked.
std::string validate_mesh(const TriangleMesh& mesh);

/// Edges and bending pairs of a valid mesh.
struct MeshTopology {
  /// Unique undirected edges (i < j), sorted lexicographically.
  std::vector<std::pair<int, int>> edges;
  /// For each edge shared by exactly two triangles, the two vertices opposite
  /// to it (one in each triangle), as (min, max), in the order of `edges`;
  /// pairs that coincide with an edge or repeat an earlier pair are skipped
  /// (they would double a spring). The classic mass-spring bending spring
  /// (Provot 1995; Meseure & Chaillou 2000).
  std::vector<std::pair<int, int>> bending_pairs;
  /// Number of edges shared by one triangle only (0 for a closed mesh).
  int boundary_edges = 0;
};

/// Builds the topology of a mesh that passed validate_mesh(). Deterministic.
/// Edges of a non-manifold mesh (more than two triangles) get no bending pair.
MeshTopology build_mesh_topology(const TriangleMesh& mesh);

/// Lumped (barycentric) area of each vertex: one third of the area of every
/// triangle it belongs to (m²), indexed like mesh.vertices. Their sum is the
/// mesh's area. Triangles with an index out of range are skipped.
std::vector<double> vertex_areas(const TriangleMesh& mesh);

/// Mean length of the edges incident to each vertex (m), from `topology`
/// (built from the same mesh), indexed like mesh.vertices; 0 for a vertex on no
/// edge.
std::vector<double> mean_incident_edge_length(const TriangleMesh& mesh,
                                              const MeshTopology& topology);

/// Applies x ↦ scale ⊙ x then the rigid transform `pose` to every vertex
/// (load-time placement of a mesh in a body frame): x ↦ R (scale ⊙ x) + p with
/// R the rotation of the (normalised) pose.orientation and p pose.position (m).
/// A scale with a negative product flips the winding; the triangles are
/// reordered (second and third index swapped) to stay outward.
void transform_mesh(TriangleMesh& mesh, const Vec3& scale, const Pose& pose);

}  // namespace numen::core
