#pragma once
/// @file net_surface.hpp
/// Private to numen::core (core/src/net): an organ's surface contacts (docs/organs.md,
/// "Surface contacts"). An organ (a net on an anchored body, BodyModel::anchored) whose net has
/// surface triangles (Model::net_faces) meets the dynamic bodies' spheres with its triangles
/// through the node centres instead of its node spheres: a contact per triangle whose closest
/// point to a sphere's centre lies inside it within the sphere's radius, and one at the nearest
/// edge or vertex point when that is nearer, each written as one NodeContact per triangle node of
/// barycentric weight > 0 (NodeContact::face). No allocation, no exception.

#include <array>

#include "net/node_contact_sink.hpp"
#include "numen/core/model.hpp"
#include "numen/core/net_state.hpp"

namespace numen::core {

struct Data;
struct NetScratch;

namespace detail {

/// The spheres of the `num_near` near bodies of NetScratch (near_bodies, near_sphere_end,
/// near_spheres: gather_bodies() of net_collision.cpp) against the triangles of `net`, at the
/// nodes' current positions. Broad phase: the triangles whose bounds meet the near spheres'
/// bounds (NetScratch::face_candidates, one pass over the net's triangles), then per sphere
/// those whose bounds are within its radius. Narrow phase: the closest point q on each
/// candidate (Ericson 2005, §5.1.5; mesh_shape_query.hpp), at d = |c − q| < r (sphere centre c,
/// radius r). A triangle whose q lies inside it: a contact along its outward unit normal o,
/// depth r − o · (c − q) (up to 2r for a centre r inside). The nearest q on an edge or a vertex,
/// when nearer than every such triangle: one more, o = ±(c − q)/d, outside or inside from the
/// angle-weighted pseudo-normal at q of the triangles that share it (Bærentzen & Aanæs 2005),
/// depth r ∓ d. Normal −o (from the tool's sphere into the organ), position the middle of the
/// overlap ½ (q + c − r o). A net triangle turned over (its normal more than 90° from its rest
/// normal, carried by the net's body) counts with its rest normal instead, here and in the
/// pseudo-normal (docs/organs.md, "Surface contacts"). `mat_net`: the net's row of
/// Model::material_pairs.
///
/// A net with a fine surface (NetModel::surface_face_count > 0, net_surface_map.hpp) meets the
/// spheres with the fine triangles instead, by the same tests: the candidates are the fine
/// triangles riding on the net triangles within NetModel::surface_reach of the near spheres'
/// bounds (Model::net_face_surface_faces), each gathered once, its vertices placed once per call
/// (NetScratch::surface_*), those on a torn net triangle left out; a contact at a fine point is
/// written on the net triangles its vertices ride on (NodeContactSink::add_surface_face()).
void collide_net_faces(const Model& model, const Data& data, NetScratch& ns, const NetModel& net,
                       int num_near, int mat_net, NodeContactSink& sink) noexcept;

/// Σ_m w_m value(node_m) over the triangle of a triangle contact's share (NodeContact::face ≥
/// 0: the triangle's point), else value(node): the node side of a contact's relative velocity
/// or displacement. `value(int node)` returns a Vec3.
template <typename Value>
inline Vec3 contact_node_value(const Model& model, const NodeContact& c, Value value) noexcept {
  if (c.face < 0) return value(c.node);
  const std::array<int, 3>& t = model.net_faces[static_cast<std::size_t>(c.face)];
  return c.face_weights.x() * value(t[0]) + c.face_weights.y() * value(t[1]) +
         c.face_weights.z() * value(t[2]);
}

/// 1 / m of the node side of a contact along a direction: 1 / m_node, or Σ_m w_m² / m_m over
/// a triangle contact's nodes (the triangle's point moved by a force f split as w_m f).
inline double contact_node_inverse_mass(const Model& model, const NodeContact& c) noexcept {
  if (c.face < 0) return 1.0 / model.node_mass[static_cast<std::size_t>(c.node)];
  const std::array<int, 3>& t = model.net_faces[static_cast<std::size_t>(c.face)];
  double inv = 0.0;
  for (int m = 0; m < 3; ++m)
    inv += c.face_weights[m] * c.face_weights[m] / model.node_mass[static_cast<std::size_t>(t[static_cast<std::size_t>(m)])];
  return inv;
}

}  // namespace detail
}  // namespace numen::core
