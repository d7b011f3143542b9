#pragma once
/// @file net_surface_map.hpp
/// An organ's fine surface mapped onto its coarser simulation net (docs/organs.md, "A fine
/// surface on a coarser net"). The net's nodes are what the solver moves; the user's own
/// full-resolution surface rides on the net's triangles, one embedding per fine vertex — the
/// net triangle it lies over, the barycentric weights of its foot point on that triangle and its
/// offset from the foot in the triangle's frame — as SOFA's BarycentricMapping and iMSTK's
/// PointwiseMap carry a visual or collision model on a mechanical one. The fine surface is then
/// what the tool's spheres touch (net_surface.hpp): a contact at a fine point goes back to the
/// net's nodes through the same weights (the map's transpose). Load time builds the map
/// (allocates); the step reads it without allocating.

#include <array>
#include <span>
#include <string>
#include <vector>

#include "numen/core/net_state.hpp"
#include "numen/core/types.hpp"

namespace numen::core {

struct Model;
struct Data;

/// One fine-surface vertex embedded on a net triangle.
///
/// Position at the nodes' current positions x_0, x_1, x_2 of Model::net_faces[face]:
///     p = Σ_m weights_m x_m + F (x_0, x_1, x_2) · offset,
/// F = [e_1, e_2, n] the triangle's orthonormal frame: e_1 = (x_1 − x_0)/|x_1 − x_0|,
/// n = (x_1 − x_0) × (x_2 − x_0) normalised (outward), e_2 = n × e_1. At the rest shape p is
/// the vertex's rest position exactly; under a rigid motion of the triangle p moves with it.
struct NetSurfacePoint {
  int face = -1;                  ///< Net triangle: global index into Model::net_faces.
  Vec3 weights = Vec3::Zero();    ///< Barycentric weights of the foot point (each ≥ 0, sum 1).
  Vec3 offset = Vec3::Zero();     ///< Foot point to vertex in the triangle's frame F (m).
};

/// One record of a patch of the fine triangles riding on a net triangle, for the contact search
/// to skip as a whole (net_surface.cpp, gather_surface_candidates()). A patch has one record per
/// net triangle its vertices ride on (1 to 3: Model::net_surface_clusters[c .. c + parts) for the
/// patch c): the patch's vertices on `face` have their first two barycentric weights in
/// [weights_lo, weights_hi], so their feet lie in the parallelogram of those four corners (the
/// third weight 1 − w_0 − w_1) at any shape of the net triangle (a foot is affine in its
/// corners), and each vertex is within `offset_max` of its foot (F is orthonormal); the patch's
/// triangles lie in the convex hull of its vertices. Built by add_net_surface().
struct NetSurfaceCluster {
  int face = -1;                        ///< Net triangle: global index into Model::net_faces.
  int parts = 0;                        ///< On a patch's first record its records' count, else 0.
  /// The least w_0, w_1 of the patch's vertices on `face` (rounded down to a float).
  std::array<float, 2> weights_lo{0.0F, 0.0F};
  /// The largest w_0, w_1 of the patch's vertices on `face` (rounded up to a float).
  std::array<float, 2> weights_hi{0.0F, 0.0F};
  /// On a patch's first record: its vertices' largest |offset| (m, rounded up to a float).
  float offset_max = 0.0F;
  /// On a patch's first record: how many fine triangles it holds, consecutive in
  /// Model::net_face_surface_faces from the first whose Model::net_face_surface_cluster names it.
  int riders = 0;
};

/// Maps a fine surface onto net `net` of `model`: after add_net(), before or after
/// finalize_model() (which reads nothing of it), before make_data() (which sizes the contacts'
/// scratch by it).
///
/// `vertices`: the fine surface's vertices in the net's rigid component's body frame (the frame
/// of Model::node_rest; m), size V ≥ 3. `triangles`: the fine surface's triangles as indices into
/// `vertices` (closed or not; a fine surface that encloses a negative volume is turned outward,
/// as add_net() turns the net). `nearest_face`: for each fine vertex, the net's own triangle
/// (0 ≤ f < NetModel::face_count, net-local) nearest to it at the rest shape — found by the
/// caller's spatial search (sim uses CGAL's AABB tree) — on which add_net_surface() computes the
/// foot point (Ericson 2005, §5.1.5) and the offset.
///
/// Fills Model::net_surface_points, net_surface_faces, net_face_surface_begin /
/// net_face_surface_faces (which fine triangles ride on each net triangle),
/// net_face_surface_cluster / net_surface_clusters (their patches) and the net's
/// NetModel::surface_* ranges. Returns "" on success, else a message naming the net and the first
/// offending fine vertex or triangle (index out of range, repeated index, a non-finite vertex, a
/// degenerate net triangle under it); the model is then unchanged. A net takes one fine surface.
/// Allocates: load time only.
std::string add_net_surface(Model& model, int net, std::span<const Vec3> vertices,
                            std::span<const std::array<int, 3>> triangles,
                            std::span<const int> nearest_face);

/// Position of fine vertex `point` (global index into Model::net_surface_points) at the nodes'
/// states `nodes` (Data::nodes: world positions, m; indexed by global node). See
/// NetSurfacePoint. No allocation.
Vec3 net_surface_position(const Model& model, std::span<const NodeState> nodes, int point) noexcept;

/// The fine surface of net `net` at the nodes' positions in `data` (world, m): `out` takes its
/// NetModel::surface_point_count positions in order (size ≥ that; the view and the recordings
/// draw it). Returns the number written; 0 for a net without a fine surface. No allocation.
int net_surface_positions(const Model& model, const Data& data, int net, std::span<Vec3> out) noexcept;

/// Largest distance (m) from a fine vertex to its foot point on the net at the rest shape
/// (|offset|): how far the fine surface stands off the net it rides on. 0 without a fine
/// surface.
double net_surface_max_offset(const Model& model, int net) noexcept;

}  // namespace numen::core
