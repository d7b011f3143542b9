/// @file net_planes.cpp
/// The node planes of a multirate god-object's nets and of the organs it touches, and the
/// tissue planes (detail::build_node_planes(), multirate/net.hpp, docs/multirate.md
/// "Deformable god-objects", docs/organs.md "Organs in multirate"), in their phases.

#include "multirate/net.hpp"
#include "net/net_tissue.hpp"
#include "net/net_surface.hpp"
#include "numen/core/features.hpp"

#include <algorithm>
#include <cmath>

namespace numen::core::detail {
namespace {

/// The tissue planes of build_node_planes() (multirate/net.hpp): one per sphere's primary contact
/// on an organ given by its material, the contact's entries consecutive (the sink writes them so).
void build_tissue_planes(const Model& scene, Data& data, std::span<const int> device_body,
                         double margin, ContactPlaneSet& out) noexcept {
  if constexpr (!kWithDeformable) return;  // no nets: tissue_plane() is not built
  const int n = std::clamp(data.num_node_contacts, 0, static_cast<int>(data.node_contacts.size()));
  const int np = static_cast<int>(scene.material_pairs.size());
  const int num_spheres = static_cast<int>(scene.body_spheres.size());
  for (int i = 0; i < n;) {
    const NodeContact& c = data.node_contacts[static_cast<std::size_t>(i)];
    int last = i + 1;  // the contact's entries
    while (last < n && same_contact(data.node_contacts[static_cast<std::size_t>(last)], c)) ++last;
    const int first = i;
    i = last;
    if (!c.primary || c.face < 0 || c.node < 0 || c.node >= scene.num_nodes() || c.material_pair < 0 ||
        c.material_pair >= np || c.sphere_b < 0 || c.sphere_b >= num_spheres ||
        !in_god_object(device_body, c.body_b))
      continue;
    const NetModel& nm = scene.nets[static_cast<std::size_t>(scene.node_net[static_cast<std::size_t>(c.node)])];
    if (!(nm.contact_modulus > 0.0) || !scene.bodies[static_cast<std::size_t>(nm.body)].anchored) continue;
    if (out.count >= kMaxContactPlanes) {
      ++out.dropped;
      continue;
    }
    const Sphere& sp = scene.body_spheres[static_cast<std::size_t>(c.sphere_b)];
    TissuePlane t;
    if constexpr (kWithDeformable) t = tissue_plane(scene, data, nm, first, last, sp.radius);
    if (!t.valid) continue;
    const double k = scene.material_pairs[static_cast<std::size_t>(c.material_pair)].stiffness;
    const bool loaded = t.force > 0.0 && t.stiffness > 0.0;
    const double slope = loaded ? t.stiffness : t.secant_stiffness;
    if (!(k > 0.0) || !(slope > 0.0)) continue;
    const double rendered = 1.0 / (1.0 / slope + t.patch_compliance);  // k s
    ContactPlane& p = out.planes[static_cast<std::size_t>(out.count++)];
    p = ContactPlane{};  // the set is reused
    p.body = device_body[static_cast<std::size_t>(c.body_b)];
    p.sphere = c.sphere_b - scene.bodies[static_cast<std::size_t>(c.body_b)].sphere_begin;
    p.node = c.node;
    p.local_point = sp.center;
    p.radius = sp.radius - margin;
    p.normal = t.normal;
    p.point = t.point;
    p.velocity = t.velocity;
    p.material_pair = c.material_pair;
    p.other_body = nm.body;
    p.obstacle = -1;
    p.other_sphere = -1;
    p.carrier = -1;  // the plane stays for the scene period: c_ρ stands for the net's give
    p.stiffness_scale = rendered / k;
    p.share = p.stiffness_scale;  // damping c s (write_plane_contacts(): c s² / share)
    p.depth_offset = loaded ? t.force / rendered - t.depth : 0.0;
    p.impulse.setZero();
    p.impulse_point = p.point;
  }
}


/// An organ's net: on an anchored body, which no device holds (its contacts with the
/// god-object's spheres become planes on those spheres).
bool organ_net(const Model& scene, int net) noexcept {
  return scene.bodies[static_cast<std::size_t>(scene.nets[static_cast<std::size_t>(net)].body)]
      .anchored;
}

/// A node's rest position on its net's component (world): where its tie pulls it.
Vec3 rest_anchor(const Model& scene, const Data& data, int node) noexcept {
  const auto u = static_cast<std::size_t>(node);
  const BodyState& g = data.bodies[static_cast<std::size_t>(
      scene.nets[static_cast<std::size_t>(scene.node_net[u])].body)];
  return g.position + g.orientation * scene.node_rest[u];
}

/// build_node_planes(), phase 1: a plane per node contact of a net on the god-object with
/// anything else, and per node contact of an organ with a sphere of the god-object (up to
/// `room`), at w k and the true depth for now; a slot per node with planes, its tie's K_n and,
/// for an organ's, its tie's elastic force (writes out.planes, out.count, out.dropped and the
/// scratch's slots, stiffness, planes_stiffness, planes_depth, force, plane_slot). Returns the
/// slots.
int add_node_contact_planes(const Model& scene, const Data& data, std::span<const int> device_body,
                            double margin, int num_nodes, int room, NodePlaneScratch scratch,
                            ContactPlaneSet& out) noexcept {
  const int np = static_cast<int>(scene.material_pairs.size());
  int slots = 0;
  const int n = std::clamp(data.num_node_contacts, 0, static_cast<int>(data.node_contacts.size()));
  for (int i = 0; i < n; ++i) {
    const NodeContact& c = data.node_contacts[static_cast<std::size_t>(i)];
    if (c.node < 0 || c.node >= num_nodes || c.material_pair < 0 || c.material_pair >= np) continue;
    const int net = scene.node_net[static_cast<std::size_t>(c.node)];
    const NetModel& nm = scene.nets[static_cast<std::size_t>(net)];
    // An organ's node (its net on an anchored body) touching a sphere of the god-object: a plane
    // on that sphere, through the node's compliance, as a god-object node's plane the other way.
    const bool organ = organ_net(scene, net) && in_god_object(device_body, c.body_b) && c.sphere_b >= 0 &&
                       c.sphere_b < static_cast<int>(scene.body_spheres.size());
    if (!organ && (!net_on_god_object(scene, device_body, net) || in_god_object(device_body, c.body_b)))
      continue;
    if (organ && nm.contact_modulus > 0.0) continue;  // a tissue plane (below)
    if (out.count >= kMaxContactPlanes || out.count >= room) {
      ++out.dropped;
      continue;
    }
    const auto node = static_cast<std::size_t>(c.node);
    int& slot = scratch.slot_of_node[node];
    if (slot < 0) {  // a node's first plane: its tie (its springs below)
      slot = slots++;
      scratch.slot_node[static_cast<std::size_t>(slot)] = c.node;
      const double ts = tie_scale(nm, c.node);  // 1 but on a material net
      scratch.stiffness[static_cast<std::size_t>(slot)] = ts * nm.tie_stiffness * Mat3::Identity();
      scratch.planes_stiffness[static_cast<std::size_t>(slot)] = 0.0;
      scratch.planes_depth[static_cast<std::size_t>(slot)] = 0.0;
      scratch.force[static_cast<std::size_t>(slot)] =  // an organ's contacts start from it (below)
          organ ? Vec3(-ts * nm.tie_stiffness * (data.nodes[node].position - rest_anchor(scene, data, c.node)))
                : Vec3::Zero();
    }
    // A triangle contact's share w (NodeContact::share; 1 for a node sphere's contact) counts
    // as a plane of stiffness w k at its node.
    const double k = c.share * scene.material_pairs[static_cast<std::size_t>(c.material_pair)].stiffness;
    const double d0 = c.depth - margin;  // the true depth
    if (d0 > 0.0) {
      scratch.planes_stiffness[static_cast<std::size_t>(slot)] += k;
      scratch.planes_depth[static_cast<std::size_t>(slot)] += c.share * d0;
    }
    const BodyState& g = data.bodies[static_cast<std::size_t>(nm.body)];
    const Vec3& x = data.nodes[node].position;
    const double grown = scene.node_radius[node];
    const int i_plane = out.count++;
    scratch.plane_slot[static_cast<std::size_t>(i_plane)] = slot;
    ContactPlane& p = out.planes[static_cast<std::size_t>(i_plane)];
    p = ContactPlane{};  // the set is reused
    p.body = device_body[static_cast<std::size_t>(nm.body)];
    p.sphere = -1;
    p.node = c.node;
    p.local_point = g.orientation.conjugate() * (x - g.position);
    p.radius = grown - margin;
    p.normal = c.normal;
    p.point = x - (grown - c.depth) * c.normal;  // the other side's surface point
    p.material_pair = c.material_pair;
    p.other_body = c.body_b;
    p.obstacle = c.obstacle;
    p.other_sphere = c.sphere_b;
    p.velocity.setZero();
    if (c.body_b >= 0) {
      const BodyState& o = data.bodies[static_cast<std::size_t>(c.body_b)];
      p.velocity = o.linear_velocity + o.angular_velocity.cross(p.point - o.position);
    }
    if (organ) {  // on the god-object's (grown) sphere; normal from the node to it
      const Sphere& sp = scene.body_spheres[static_cast<std::size_t>(c.sphere_b)];
      p.body = device_body[static_cast<std::size_t>(c.body_b)];
      p.sphere = c.sphere_b - scene.bodies[static_cast<std::size_t>(c.body_b)].sphere_begin;
      p.local_point = sp.center;
      p.radius = sp.radius - margin;
      p.normal = -c.normal;
      p.point = x + scene.node_radius[node] * p.normal;  // the node sphere's surface point
      p.other_body = nm.body;
      p.obstacle = -1;
      p.other_sphere = -1;
      p.velocity = data.nodes[node].velocity;
      if (c.face >= 0) {  // a triangle contact: through the triangle's closest point
        p.point = c.position - (0.5 * c.depth) * c.normal;
        p.velocity = contact_node_value(scene, c, [&](int v) -> const Vec3& {
          return data.nodes[static_cast<std::size_t>(v)].velocity;
        });
      }
    }
    p.carrier = -1;  // the net renders the contact on a scene body in the scene loop
    p.share = c.share;
    p.stiffness_scale = c.share;  // w; times s below
    p.depth_offset = d0;  // for now (below: the offset)
    p.impulse.setZero();
    p.impulse_point = p.point;
  }
  return slots;
}

/// build_node_planes(), phase 2: the springs at the nodes with planes (those with a slot),
/// ascending: the passes below take them in the order of Model::net_springs, as a pass over
/// every spring would, a few nodes' springs instead of every one (~190 k instructions a scene
/// step on the shipped organ). Each slot's node is distinct, so they fit in node_springs.size()
/// (the room checked by the caller). Writes scratch.springs; returns its first entries.
std::span<const std::int32_t> gather_plane_springs(const Model& scene, int slots,
                                                   NodePlaneScratch scratch) noexcept {
  int spring_count = 0;
  for (int s = 0; s < slots; ++s) {
    const auto u = static_cast<std::size_t>(scratch.slot_node[static_cast<std::size_t>(s)]);
    for (std::int32_t e = scene.node_spring_begin[u]; e < scene.node_spring_begin[u + 1]; ++e)
      scratch.springs[static_cast<std::size_t>(spring_count++)] =
          scene.node_springs[static_cast<std::size_t>(e)];
  }
  const auto springs_begin = scratch.springs.begin();
  std::sort(springs_begin, springs_begin + spring_count);
  spring_count =
      static_cast<int>(std::unique(springs_begin, springs_begin + spring_count) - springs_begin);
  const std::span<const std::int32_t> plane_springs(scratch.springs.data(),
                                                    static_cast<std::size_t>(spring_count));
  return plane_springs;
}

/// build_node_planes(), phase 3: the springs of the nodes with planes, their neighbours moving
/// with the component, into the nodes' K_n, and an organ's springs' elastic force into its
/// nodes' (writes scratch.stiffness, scratch.force).
void add_plane_node_springs(const Model& scene, const Data& data, int num_nodes,
                            std::span<const std::int32_t> plane_springs,
                            NodePlaneScratch scratch) noexcept {
  // The springs of the nodes with planes, their neighbours moving with the component.
  for (const std::int32_t s : plane_springs) {
    const NetSpring& sp = scene.net_springs[static_cast<std::size_t>(s)];
    if (sp.node_a < 0 || sp.node_a >= num_nodes || sp.node_b < 0 || sp.node_b >= num_nodes) continue;
    // A spring at a node with a slot (sa or sb ≥ 0): its net is an organ's or on the god-object
    // (the slots' condition above).
    const bool organ = organ_net(scene, scene.node_net[static_cast<std::size_t>(sp.node_a)]);
    const int sa = scratch.slot_of_node[static_cast<std::size_t>(sp.node_a)];
    const int sb = scratch.slot_of_node[static_cast<std::size_t>(sp.node_b)];
    // An organ's spring between two nodes with planes: a triangle contact loads its nodes
    // together, so the spring moves with both and holds neither (counted, it makes the device
    // loop ~20 % stiffer than the net: docs/organs.md, "Organs in multirate").
    Vec3 e = data.nodes[static_cast<std::size_t>(sp.node_b)].position -
             data.nodes[static_cast<std::size_t>(sp.node_a)].position;
    const double l = e.norm();
    if (!(l > 0.0)) continue;
    e /= l;
    if (organ) {  // the spring's elastic force on node_a (an organ's contacts start from it)
      const Vec3 f_a = sp.stiffness * (l - sp.rest_length) * e;
      if (sa >= 0) scratch.force[static_cast<std::size_t>(sa)] += f_a;
      if (sb >= 0) scratch.force[static_cast<std::size_t>(sb)] -= f_a;
      if (sa >= 0 && sb >= 0) continue;
    }
    const Mat3 k_e = sp.stiffness * (e * e.transpose());
    if (sa >= 0) scratch.stiffness[static_cast<std::size_t>(sa)] += k_e;
    if (sb >= 0) scratch.stiffness[static_cast<std::size_t>(sb)] += k_e;
  }
}

/// build_node_planes(), phase 4: each contact's planes [first, out.count) through its nodes'
/// compliance: s and the depth offset they start from at the sample (writes the planes'
/// stiffness_scale, depth_offset). A god-object node's deflection from its rest position on the
/// component along n (it is pushed along its plane's normal), e₀ ≥ 0, is what its tie and
/// springs carried to the component (k_n e₀). An organ's contact starts from its nodes' forces
/// instead (below).
void scale_node_planes(const Model& scene, const Data& data, int first, NodePlaneScratch scratch,
                       ContactPlaneSet& out) noexcept {
  const auto deflection = [&](const ContactPlane& p) {
    return std::max(0.0, p.normal.dot(data.nodes[static_cast<std::size_t>(p.node)].position -
                                      rest_anchor(scene, data, p.node)));
  };
  for (int i = first; i < out.count;) {
    // The planes of one contact: a node sphere's (one plane, w = 1), or a triangle contact's
    // (one per node of weight w > 0, consecutive, through the same point along the same normal).
    const ContactPlane& head = out.planes[static_cast<std::size_t>(i)];
    int j = i + 1;
    if (head.share < 1.0)
      while (j < out.count && out.planes[static_cast<std::size_t>(j)].share < 1.0 &&
             out.planes[static_cast<std::size_t>(j)].point == head.point &&
             out.planes[static_cast<std::size_t>(j)].normal == head.normal)
        ++j;
    const double k = scene.material_pairs[static_cast<std::size_t>(head.material_pair)].stiffness;
    const double d0 = head.depth_offset;
    // The contact (k) in series with its nodes, each node m loaded by its planes in contact in
    // parallel (Σk_m, this one's w_m k included; a plane not in contact at the sample joins them
    // when it engages): s = 1 / (1 + Σ_m w_m Σk_m / k_n,m), each plane w_m k s. A node sphere's
    // plane: s = k_n / (Σk + k_n). At the sample the contact starts from what its nodes carried
    // for it, shared among each node's planes in contact by their weighted depths w d₀:
    // k s (d₀ + offset) = Σ_m (w_m d₀ / Σ w d₀) k_n,m e₀,m. An organ's contact starts from the
    // larger of its law's elastic force k d₀ (what the scene loop's step exchanges with the tool)
    // and what its nodes' ties and springs push along n at the sample, Σ_m (w_m d₀ / Σ w d₀)
    // max(0, n · F_m): k_n e₀ takes the node's neighbours at rest, and in a dent, where they are
    // not, it is up to ~1.8 times what they push (the jaw drawn along the shipped organ's rigid
    // core; docs/organs.md, "Organs in multirate").
    const bool organ = organ_net(scene, scene.node_net[static_cast<std::size_t>(head.node)]);
    double x = 0.0, carried = 0.0, k_n0 = 0.0, k_sum0 = 0.0;
    bool compliant = true;
    for (int m = i; m < j; ++m) {
      const ContactPlane& p = out.planes[static_cast<std::size_t>(m)];
      const auto slot = static_cast<std::size_t>(scratch.plane_slot[static_cast<std::size_t>(m)]);
      const double k_n = p.normal.dot(scratch.stiffness[slot] * p.normal);
      const double k_sum = scratch.planes_stiffness[slot] + (d0 > 0.0 ? 0.0 : p.share * k);
      if (!(k_n > 0.0) || !(k_sum > 0.0)) compliant = false;
      x += p.share * k_sum / k_n;
      k_n0 = k_n;
      k_sum0 = k_sum;
      if (d0 > 0.0 && k_n > 0.0)
        carried += p.share * d0 / scratch.planes_depth[slot] *
                   (organ ? std::max(0.0, p.normal.dot(scratch.force[slot])) : k_n * deflection(p));
    }
    if (organ && d0 > 0.0) carried = std::max(carried, k * d0);
    const bool single = j == i + 1 && head.share == 1.0;
    const double s = !compliant ? 1.0 : single ? k_n0 / (k_sum0 + k_n0) : 1.0 / (1.0 + x);
    const double offset = d0 > 0.0 && compliant && k > 0.0 ? carried / (k * s) - d0 : 0.0;
    for (int m = i; m < j; ++m) {
      ContactPlane& p = out.planes[static_cast<std::size_t>(m)];
      p.stiffness_scale = p.share * s;
      p.depth_offset = offset;
    }
    i = j;
  }
}

/// build_node_planes(), phase 5: an organ's contact nodes move in the device loop: a carrier per
/// node (PlaneCarrier::node), a point mass on K_n with its tie's and springs' elastic force at
/// the sample, and its planes at the law's own stiffness w k from the true depth (no offset):
/// the node gives way within the scene period as the single-rate step lets it, and each period
/// starts from its state. step_god_object() steps it implicitly on its planes (no mass
/// scaling). Nodes beyond the room keep the static planes of phase 4 (writes out.carriers from
/// `first_carrier` on, out.carrier_count, the organ planes' carrier, stiffness_scale,
/// depth_offset).
void add_node_carriers(const Model& scene, const Data& data, int first, int first_carrier,
                       NodePlaneScratch scratch, ContactPlaneSet& out) noexcept {
  for (int i = first; i < out.count; ++i) {
    ContactPlane& p = out.planes[static_cast<std::size_t>(i)];
    const int slot = scratch.plane_slot[static_cast<std::size_t>(i)];
    if (p.node < 0 || slot < 0 || !organ_net(scene, scene.node_net[static_cast<std::size_t>(p.node)]))
      continue;
    int c = first_carrier;
    while (c < out.carrier_count && out.carriers[static_cast<std::size_t>(c)].node != p.node) ++c;
    if (c == out.carrier_count) {
      if (out.carrier_count >= kMaxPlaneCarriers) continue;
      ++out.carrier_count;
      const auto u = static_cast<std::size_t>(p.node);
      const double m = scene.node_mass[u];
      PlaneCarrier& k = out.carriers[static_cast<std::size_t>(c)];
      k = PlaneCarrier{};
      k.body = p.other_body;
      k.node = p.node;
      k.com = data.nodes[u].position;
      k.linear_velocity = data.nodes[u].velocity;
      k.mass.topLeftCorner<3, 3>() = m * Mat3::Identity();
      k.stiffness.topLeftCorner<3, 3>() = scratch.stiffness[static_cast<std::size_t>(slot)];
      k.wrench.head<3>() = scratch.force[static_cast<std::size_t>(slot)] + m * scene.gravity;
      k.inverse_mass = 1.0 / m;
      const NetModel& carrier_net = scene.nets[static_cast<std::size_t>(scene.node_net[u])];
      k.node_damping = tie_scale(carrier_net, p.node) * carrier_net.tie_damping * Mat3::Identity();
    }
    p.carrier = c;
    p.stiffness_scale = p.share;
    p.depth_offset = 0.0;
  }
}

/// build_node_planes(), phase 6: the organ's springs at the node carriers: their damping in D_n,
/// and a spring between two carriers in both carriers' K_n and D_n, with a link through which
/// each meets the other's motion (writes the carriers' node_damping, stiffness, out.links,
/// out.link_count).
void link_node_carriers(const Model& scene, const Data& data, int num_nodes, int first_carrier,
                        std::span<const std::int32_t> plane_springs, NodePlaneScratch scratch,
                        ContactPlaneSet& out) noexcept {
  for (const std::int32_t s : plane_springs) {
    const NetSpring& sp = scene.net_springs[static_cast<std::size_t>(s)];
    if (sp.node_a < 0 || sp.node_a >= num_nodes || sp.node_b < 0 || sp.node_b >= num_nodes ||
        !organ_net(scene, scene.node_net[static_cast<std::size_t>(sp.node_a)]))
      continue;
    int a = first_carrier, b = first_carrier;
    while (a < out.carrier_count && out.carriers[static_cast<std::size_t>(a)].node != sp.node_a)
      ++a;
    while (b < out.carrier_count && out.carriers[static_cast<std::size_t>(b)].node != sp.node_b)
      ++b;
    const bool has_a = a < out.carrier_count, has_b = b < out.carrier_count;
    if (!has_a && !has_b) continue;
    Vec3 e = data.nodes[static_cast<std::size_t>(sp.node_b)].position -
             data.nodes[static_cast<std::size_t>(sp.node_a)].position;
    const double l = e.norm();
    if (!(l > 0.0)) continue;
    e /= l;
    const Mat3 ee = e * e.transpose();
    if (has_a) out.carriers[static_cast<std::size_t>(a)].node_damping += sp.damping * ee;
    if (has_b) out.carriers[static_cast<std::size_t>(b)].node_damping += sp.damping * ee;
    // Left out of K_n above where both its nodes have planes: a carrier counts it, the other
    // end linked to it, or held still like its other neighbours where it has no carrier.
    if (scratch.slot_of_node[static_cast<std::size_t>(sp.node_a)] < 0 ||
        scratch.slot_of_node[static_cast<std::size_t>(sp.node_b)] < 0)
      continue;
    if (has_a)
      out.carriers[static_cast<std::size_t>(a)].stiffness.topLeftCorner<3, 3>() +=
          sp.stiffness * ee;
    if (has_b)
      out.carriers[static_cast<std::size_t>(b)].stiffness.topLeftCorner<3, 3>() +=
          sp.stiffness * ee;
    if (has_a && has_b && out.link_count < kMaxCarrierLinks)
      out.links[static_cast<std::size_t>(out.link_count++)] =
          CarrierLink{a, b, sp.stiffness * ee, sp.damping * ee};
  }
}

}  // namespace

void build_node_planes(const Model& scene, Data& data, std::span<const int> device_body,
                       double margin, NodePlaneScratch scratch, ContactPlaneSet& out) noexcept {
  const int first = out.count;
  const int num_nodes = std::min(scene.num_nodes(), static_cast<int>(scratch.slot_of_node.size()));
  // The nodes' springs come from Model::node_springs into `scratch.springs`: without the lists
  // (a scene not finalized) or their room, there is no room for any plane (counted, dropped).
  const bool spring_lists =
      node_springs_indexed(scene) && scratch.springs.size() >= scene.node_springs.size();
  const int room = !spring_lists ? 0
                   : static_cast<int>(std::min({scratch.slot_node.size(), scratch.stiffness.size(),
                                                scratch.plane_slot.size(), scratch.planes_stiffness.size(),
                                                scratch.planes_depth.size(), scratch.force.size()}));
  const int slots = add_node_contact_planes(scene, data, device_body, margin, num_nodes, room,
                                            scratch, out);
  if (out.count == first) {  // no node plane (nothing touches a net given per spring)
    build_tissue_planes(scene, data, device_body, margin, out);
    return;
  }
  const std::span<const std::int32_t> plane_springs = gather_plane_springs(scene, slots, scratch);
  add_plane_node_springs(scene, data, num_nodes, plane_springs, scratch);
  scale_node_planes(scene, data, first, scratch, out);
  const int first_carrier = out.carrier_count;
  add_node_carriers(scene, data, first, first_carrier, scratch, out);
  if (out.carrier_count > first_carrier)
    link_node_carriers(scene, data, num_nodes, first_carrier, plane_springs, scratch, out);
  for (int s = 0; s < slots; ++s)
    scratch.slot_of_node[static_cast<std::size_t>(scratch.slot_node[static_cast<std::size_t>(s)])] = -1;
  build_tissue_planes(scene, data, device_body, margin, out);
}

}  // namespace numen::core::detail
