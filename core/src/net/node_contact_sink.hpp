#pragma once
/// @file node_contact_sink.hpp
/// Private to numen::core (core/src/net): the writer of the node contacts of the collision
/// stage of the nets (net_collision.cpp: node spheres; net_surface.cpp: an organ's surface
/// triangles), bounded by the capacity, counting what it cannot keep. No allocation.

#include <algorithm>
#include <array>

#include "contact/narrowphase.hpp"
#include "numen/core/net_state.hpp"
#include "numen/core/net_surface_map.hpp"
#include "numen/core/types.hpp"

namespace numen::core::detail {

/// Writes node contacts up to the capacity, counts the rest; tracks the
/// deepest contact (dropped ones included) of the current net and of the call.
struct NodeContactSink {
  NodeContact* out;
  int capacity;
  int count = 0;
  int dropped = 0;              ///< Contacts not written: a node sphere's, or a whole triangle contact.
  double net_max_depth = 0.0;  ///< Reset per net.
  double max_depth = 0.0;

  /// A node sphere's contact. `com_b`: centre of mass of body_b (ignored for a static obstacle).
  void add(int node, int body_b, int obstacle, int sphere_b, int material_pair,
           const ContactGeometry& g, const Vec3& com_b) noexcept {
    net_max_depth = std::max(net_max_depth, g.depth);
    if (count >= capacity) {
      ++dropped;
      return;
    }
    write(node, body_b, obstacle, sphere_b, material_pair, g, com_b);
  }

  /// A contact of the surface triangle `face` (global node indices `nodes`, barycentric
  /// weights `w` of the closest point) with the sphere `sphere_b` of the dynamic body `body_b`
  /// (centre of mass `com_b`): one entry per node of weight > 0 (NodeContact::face), all or
  /// none — a triangle contact that does not fit whole is dropped and counted once.
  void add_face(int face, const std::array<int, 3>& nodes, const Vec3& w, int body_b,
                int sphere_b, int material_pair, const ContactGeometry& g,
                const Vec3& com_b) noexcept {
    net_max_depth = std::max(net_max_depth, g.depth);
    if (count + entries_of(w) > capacity) {
      ++dropped;
      return;
    }
    write_triangle(face, nodes, w, w, body_b, sphere_b, material_pair, g, com_b);
  }

  /// A contact of a fine surface's triangle (net_surface_map.hpp) at the point of barycentric
  /// weights `w` over its vertices, embedded `e[i]` on the net triangles e[i]->face (node
  /// indices `faces[e[i]->face]`, Model::net_faces): the point Σ_i w_i p_i moves with the nodes
  /// as Σ_i w_i Σ_m b_i,m x_m (the offsets' turn frozen over the step, as the contact's normal
  /// is). Written per distinct net triangle T as that triangle's contact: face_weights the
  /// normalised Σ_{i on T} w_i b_i, each node's share its weight before normalising (the shares
  /// of the whole contact sum to 1; a point within one net triangle is exactly one triangle
  /// contact). All or none; a contact that does not fit whole is dropped and counted once.
  void add_surface_face(const std::array<const NetSurfacePoint*, 3>& e,
                        const std::array<int, 3>* faces, const Vec3& w, int body_b, int sphere_b,
                        int material_pair, const ContactGeometry& g, const Vec3& com_b) noexcept {
    net_max_depth = std::max(net_max_depth, g.depth);
    std::array<int, 3> face{-1, -1, -1};
    std::array<Vec3, 3> weight{Vec3::Zero(), Vec3::Zero(), Vec3::Zero()};
    int groups = 0;
    for (int i = 0; i < 3; ++i) {
      if (!(w[i] > 0.0)) continue;
      const int f = e[static_cast<std::size_t>(i)]->face;
      int k = 0;
      while (k < groups && face[static_cast<std::size_t>(k)] != f) ++k;
      if (k == groups) face[static_cast<std::size_t>(groups++)] = f;
      weight[static_cast<std::size_t>(k)] += w[i] * e[static_cast<std::size_t>(i)]->weights;
    }
    int entries = 0;
    for (int k = 0; k < groups; ++k) entries += entries_of(weight[static_cast<std::size_t>(k)]);
    if (count + entries > capacity) {
      ++dropped;
      return;
    }
    for (int k = 0; k < groups; ++k) {
      const Vec3& b = weight[static_cast<std::size_t>(k)];
      const double sum = b.sum();
      if (!(sum > 0.0)) continue;
      const int f = face[static_cast<std::size_t>(k)];
      write_triangle(f, faces[f], b / sum, b, body_b, sphere_b, material_pair, g, com_b);
    }
  }

 private:
  /// Entries a triangle contact of node weights `b` takes: one per weight > 0.
  static int entries_of(const Vec3& b) noexcept {
    return (b.x() > 0.0 ? 1 : 0) + (b.y() > 0.0 ? 1 : 0) + (b.z() > 0.0 ? 1 : 0);
  }

  /// The entries of a contact of the net triangle `face` (global node indices `nodes`): one per
  /// node of share > 0, NodeContact::face_weights `weights`, share `shares[m]`. The caller checked
  /// the room (entries_of(shares)).
  void write_triangle(int face, const std::array<int, 3>& nodes, const Vec3& weights,
                      const Vec3& shares, int body_b, int sphere_b, int material_pair,
                      const ContactGeometry& g, const Vec3& com_b) noexcept {
    for (int m = 0; m < 3; ++m) {
      if (!(shares[m] > 0.0)) continue;
      NodeContact& c = write(nodes[static_cast<std::size_t>(m)], body_b, -1, sphere_b,
                             material_pair, g, com_b);
      c.face = face;
      c.face_weights = weights;
      c.share = shares[m];
    }
  }

  NodeContact& write(int node, int body_b, int obstacle, int sphere_b, int material_pair,
                     const ContactGeometry& g, const Vec3& com_b) noexcept {
    NodeContact& c = out[count++];
    c = NodeContact{};  // the slot may hold a held spring or a law's coefficients of an earlier step
    c.node = node;
    c.body_b = body_b;
    c.obstacle = obstacle;
    c.sphere_b = sphere_b;
    c.material_pair = material_pair;
    c.position = g.position;
    c.normal = g.normal;
    c.depth = g.depth;
    if (body_b >= 0) c.r_b = g.position - com_b;
    return c;
  }
};

}  // namespace numen::core::detail
