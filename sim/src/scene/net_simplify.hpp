#pragma once
/// @file net_simplify.hpp
/// An organ's coarse simulation net made from its fine surface, and the nearest net triangle of
/// each fine vertex (docs/fine-surface.md): CGAL 5.5's
/// Surface_mesh_simplification (edge collapse, Lindstrom & Turk's cost and placement, the link
/// condition keeping the surface manifold) and its AABB tree. CGAL's headers are included by
/// net_simplify.cpp only (a heavy compile). Private to numen::sim; load time only (allocates).

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "numen/core/mesh.hpp"

namespace numen::sim {

/// Simplifies the closed, manifold surface `fine` (every edge in exactly two triangles,
/// consistently wound; metres, any frame) by edge collapses until it has `nodes` vertices
/// (4 ≤ nodes < fine's vertex count), into `net`: new vertex positions by Lindstrom & Turk's
/// volume- and boundary-preserving placement (Lindstrom & Turk 1998; CGAL's
/// LindstromTurk_placement), triangles wound like `fine`'s. Collapses that would make the surface
/// non-manifold are refused (Dey et al.'s link condition), so the net can keep a few more
/// vertices than asked on a surface that cannot lose them: the caller compares
/// net.num_vertices() with `nodes`. Returns "" on success, else what failed (a triangle of `fine`
/// that does not make a manifold, consistently wound surface with the ones before it, by index);
/// `net` is then empty.
std::string simplify_to_net(const core::TriangleMesh& fine, int nodes, core::TriangleMesh& net);

/// The simplifier's identity for a cache of its nets (mesh_cache.hpp, net_cache_key()): CGAL's
/// CGAL_VERSION_NR, so that another CGAL's nets are made again.
std::uint64_t net_simplifier_version();

/// For each point of `points` (the frame of `net`'s vertices, m), the index of `net`'s triangle
/// nearest to it (CGAL's AABB tree, exact closest-point distances; ties to the first found).
/// `net` must hold at least one non-degenerate triangle.
std::vector<int> nearest_net_triangles(const core::TriangleMesh& net,
                                       std::span<const core::Vec3> points);

}  // namespace numen::sim
