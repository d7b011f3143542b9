#pragma once
/// @file net_tetrahedralize.hpp
/// The volume of an organ given by its material (core/net_material.hpp, docs/tissue.md): a
/// tetrahedral mesh of its closed surface net, made with CGAL 5.5 (Delaunay_triangulation_3, the
/// AABB tree, Side_of_triangle_mesh and Polygon_mesh_processing's self-intersection test, on the
/// Exact_predicates_inexact_constructions_kernel). CGAL's headers are included by
/// net_tetrahedralize.cpp only (a heavy compile). Private to numen::sim; load time only
/// (allocates).

#include <string>

#include "numen/core/mesh.hpp"
#include "numen/core/net_material.hpp"

namespace numen::sim {

/// Most lattice points tetrahedralize_net() lays over a surface's bounding box (both sub-lattices
/// of the body-centred cubic lattice together): about half of them inside a rounded organ, 1 M
/// nodes make some 6 M tetrahedra and take several seconds.
inline constexpr long kMaxTetrahedralizeLatticePoints = 2'000'000;

/// Interior lattice spacing of an organ given by its material, in mean edges of its surface net
/// (the spacing the scene loader and the stability study's organ give tetrahedralize_net()): at
/// 2 the shipped organ has 1 338 nodes (336 inside) and steps at 459 µs median, at 1 it has 4 293
/// (3 291 inside) and steps at 1 769 µs, for the same feedback force within 1 % on the default
/// scene's recording (docs/tissue.md, "Measured").
inline constexpr double kInteriorSpacingEdges = 2.0;

/// Fills `out` with a tetrahedral mesh of the closed surface `surface` (metres, any frame; the
/// frame of `out`): the surface's vertices are the first nodes, in their order (out.surface is
/// `surface`, vertices and triangles unchanged), the interior nodes on (a jitter off) a
/// body-centred cubic lattice of spacing `spacing` (m, finite, > 0; the surface net's mean edge
/// length, mean_edge_length(), gives interior edges like the surface's).
///
/// Method. The lattice is the points (i, j, k)·s and (i + ½, j + ½, k + ½)·s (integers i, j, k;
/// anchored at the frame's origin) over the surface's bounding box; a point is kept when it is at
/// least 0.5·s from the surface (exact point-triangle distances), so that no interior node crowds
/// a surface vertex, and inside it (CGAL::Side_of_triangle_mesh, exact predicates). Each kept point
/// is then moved by a deterministic jitter of at most 1e-4·s per axis (no four points exactly
/// coplanar, no five cospherical: the Delaunay's predicates stay in floating point). The surface's
/// vertices and the kept points are tetrahedralised together (Delaunay, exact predicates), and
/// the finite cells whose centroid is inside the surface are kept but for those of volume
/// ≤ 1e-9·s³ (slivers of coplanar surface vertices). The Delaunay mesh is not constrained to the
/// surface: a surface triangle need not be a tetrahedron's face. On a curved surface of irregular
/// triangles all are (the shipped organ, an icosphere); a planar quad of four cocircular corners
/// (a box's faces, a torus's rings) may be split along its other diagonal (none of a box's
/// triangles, half of a torus's are faces), the volume the same; where the surface is not convex
/// and such a quad not planar, the cells would cross the surface slightly.
/// Node count ≈ surface vertices + 2 V / s³ for enclosed volume V, less the lattice points within
/// 0.5·s of the surface. Cost: each triangle scans the lattice points within s of its bounding
/// box (a surface of triangles much larger than s costs more), and the Delaunay about 4 µs a
/// point: 22 ms for the shipped organ at its mean edge (4 300 nodes), 0.85 s for a 10 242-vertex
/// icosphere (157 000 nodes, 913 000 tetrahedra).
///
/// Which lattice points and cells are inside is decided with one exact query per connected set of
/// points far from the surface and per cell near it (net_tetrahedralize.cpp says why that holds).
///
/// out.interior holds the kept points (jittered) that are a corner of some kept cell (the others
/// are dropped): those of the corner points (i, j, k)·s first, then those of the centre points,
/// each in order of k, then j, then i; out.tetrahedra the kept cells, positively oriented (node
/// indices as in core::TetrahedralMesh: surface vertex i is node i, interior point j node
/// surface.num_vertices() + j), each rotated to start at its smallest index (orientation kept)
/// and sorted: the output depends on the input only (two calls give the same mesh).
///
/// Returns "" on success, else a message (`out` is then empty) on the first of: `spacing` not
/// finite and > 0; a surface core::validate_mesh() refuses (its message); an edge in one triangle
/// only (the surface is not closed; the edge's vertices and its triangle named); triangles not
/// consistently wound (the triangle named); two triangles that intersect other than along a
/// shared edge or vertex (both named); a lattice of more than kMaxTetrahedralizeLatticePoints
/// points (the spacing that fits named); no cell inside the surface; a surface vertex in no kept
/// cell (the vertex named: one at the position of another, or on a flat stretch of surface).
std::string tetrahedralize_net(const core::TriangleMesh& surface, double spacing,
                               core::TetrahedralMesh& out);

/// Mean length of the edges of `mesh` (m), each edge once (core::build_mesh_topology()); 0 for a
/// mesh without edges. `mesh` must pass core::validate_mesh().
double mean_edge_length(const core::TriangleMesh& mesh);

}  // namespace numen::sim
