/// @file multirate_net.cpp
/// The nets of a multirate god-object (detail/multirate_net.hpp, docs/multirate.md).

#include "detail/multirate_net.hpp"
#include "detail/net_tissue.hpp"
#include "detail/net_surface.hpp"
#include "numen/core/features.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace numen::core::detail {

bool net_on_god_object(const Model& scene, std::span<const int> device_body, int net) noexcept {
  if (net < 0 || net >= scene.num_nets()) return false;
  return in_god_object(device_body, scene.nets[static_cast<std::size_t>(net)].body);
}

std::string lump_nets(const Model& scene, std::span<const int> device_body, Model& out) {
  for (int k = 0; k < scene.num_nets(); ++k) {
    if (!net_on_god_object(scene, device_body, k)) continue;
    const NetModel& net = scene.nets[static_cast<std::size_t>(k)];
    BodyModel& bm = out.bodies[static_cast<std::size_t>(device_body[static_cast<std::size_t>(net.body)])];
    double mass = 0.0;
    Vec3 moment = Vec3::Zero();
    Mat3 inertia = Mat3::Zero();
    for (int i = net.node_begin; i < net.node_begin + net.node_count; ++i) {
      const double m = scene.node_mass[static_cast<std::size_t>(i)];
      const Vec3& r = scene.node_rest[static_cast<std::size_t>(i)];
      mass += m;
      moment += m * r;
      inertia += m * (r.squaredNorm() * Mat3::Identity() - r * r.transpose());
    }
    const double offset = bm.mass + mass > 0.0 ? moment.norm() / (bm.mass + mass) : 0.0;
    if (!(offset <= 1e-4)) {
      std::ostringstream os;
      os << "multirate: net '" << net.name << "' has its centre of mass " << offset * 1e3
         << " mm from that of its rigid component '" << bm.name
         << "' (the device loop lumps the net onto the component, which keeps its own centre "
            "of mass: at most 0.1 mm)";
      return os.str();
    }
    bm.mass += mass;
    bm.inertia_body += inertia;
  }
  return "";
}

void grow_god_object_nodes(std::span<const int> device_body, double margin, Model& m) {
  for (int i = 0; i < m.num_nodes(); ++i)
    if (net_on_god_object(m, device_body, m.node_net[static_cast<std::size_t>(i)]))
      m.node_radius[static_cast<std::size_t>(i)] += margin;
}

namespace {

/// The tissue planes of build_node_planes() (multirate_net.hpp): one per sphere's primary contact
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
    p.sphere = -1;
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
  const int np = static_cast<int>(scene.material_pairs.size());
  int slots = 0;
  // An organ's net: on an anchored body, which no device holds (its contacts with the god-object's
  // spheres become planes on those spheres, below).
  const auto organ_net = [&](int net) {
    return scene.bodies[static_cast<std::size_t>(scene.nets[static_cast<std::size_t>(net)].body)]
        .anchored;
  };
  // A node's rest position on its net's component (world): where its tie pulls it.
  const auto rest_anchor = [&](int node) -> Vec3 {
    const auto u = static_cast<std::size_t>(node);
    const BodyState& g = data.bodies[static_cast<std::size_t>(
        scene.nets[static_cast<std::size_t>(scene.node_net[u])].body)];
    return g.position + g.orientation * scene.node_rest[u];
  };
  const int n = std::clamp(data.num_node_contacts, 0, static_cast<int>(data.node_contacts.size()));
  for (int i = 0; i < n; ++i) {
    const NodeContact& c = data.node_contacts[static_cast<std::size_t>(i)];
    if (c.node < 0 || c.node >= num_nodes || c.material_pair < 0 || c.material_pair >= np) continue;
    const int net = scene.node_net[static_cast<std::size_t>(c.node)];
    const NetModel& nm = scene.nets[static_cast<std::size_t>(net)];
    // An organ's node (its net on an anchored body) touching a sphere of the god-object: a plane
    // on that sphere, through the node's compliance, as a god-object node's plane the other way.
    const bool organ = organ_net(net) && in_god_object(device_body, c.body_b) && c.sphere_b >= 0 &&
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
          organ ? Vec3(-ts * nm.tie_stiffness * (data.nodes[node].position - rest_anchor(c.node)))
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
  if (out.count == first) {  // no node plane (nothing touches a net given per spring)
    build_tissue_planes(scene, data, device_body, margin, out);
    return;
  }
  // The springs at the nodes with planes (those with a slot), ascending: the passes below take
  // them in the order of Model::net_springs, as a pass over every spring would, a few nodes'
  // springs instead of every one (~190 k instructions a scene step on the shipped organ).
  // Each slot's node is distinct, so they fit in node_springs.size() (the room checked above).
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
  // The springs of the nodes with planes, their neighbours moving with the component.
  for (const std::int32_t s : plane_springs) {
    const NetSpring& sp = scene.net_springs[static_cast<std::size_t>(s)];
    if (sp.node_a < 0 || sp.node_a >= num_nodes || sp.node_b < 0 || sp.node_b >= num_nodes) continue;
    // A spring at a node with a slot (sa or sb ≥ 0): its net is an organ's or on the god-object
    // (the slots' condition above).
    const bool organ = organ_net(scene.node_net[static_cast<std::size_t>(sp.node_a)]);
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
  // A god-object node's deflection from its rest position on the component along n (it is
  // pushed along its plane's normal), e₀ ≥ 0, is what its tie and springs carried to the
  // component (k_n e₀). An organ's contact starts from its nodes' forces instead (below).
  const auto deflection = [&](const ContactPlane& p) {
    return std::max(0.0, p.normal.dot(data.nodes[static_cast<std::size_t>(p.node)].position -
                                      rest_anchor(p.node)));
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
    const bool organ = organ_net(scene.node_net[static_cast<std::size_t>(head.node)]);
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
  // An organ's contact nodes move in the device loop: a carrier per node (PlaneCarrier::node), a
  // point mass on K_n with its tie's and springs' elastic force at the sample, and its planes at
  // the law's own stiffness w k from the true depth (no offset): the node gives way within the
  // scene period as the single-rate step lets it, and each period starts from its state.
  // step_god_object() steps it implicitly on its planes (no mass scaling). Nodes beyond the room
  // keep the static planes above.
  const int first_carrier = out.carrier_count;
  for (int i = first; i < out.count; ++i) {
    ContactPlane& p = out.planes[static_cast<std::size_t>(i)];
    const int slot = scratch.plane_slot[static_cast<std::size_t>(i)];
    if (p.node < 0 || slot < 0 || !organ_net(scene.node_net[static_cast<std::size_t>(p.node)]))
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
  // The organ's springs at the node carriers: their damping in D_n, and a spring between two
  // carriers in both carriers' K_n and D_n, with a link through which each meets the other's
  // motion.
  if (out.carrier_count > first_carrier) {
    for (const std::int32_t s : plane_springs) {
      const NetSpring& sp = scene.net_springs[static_cast<std::size_t>(s)];
      if (sp.node_a < 0 || sp.node_a >= num_nodes || sp.node_b < 0 || sp.node_b >= num_nodes ||
          !organ_net(scene.node_net[static_cast<std::size_t>(sp.node_a)]))
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
  for (int s = 0; s < slots; ++s)
    scratch.slot_of_node[static_cast<std::size_t>(scratch.slot_node[static_cast<std::size_t>(s)])] = -1;
  build_tissue_planes(scene, data, device_body, margin, out);
}

bool anchor_reaches(const Model& scene, const Data& data, const NodeContact& c, double step) noexcept {
  const auto i = static_cast<std::size_t>(c.node);
  const NetModel& net = scene.nets[static_cast<std::size_t>(scene.node_net[i])];
  const BodyState& g = data.bodies[static_cast<std::size_t>(net.body)];
  const Vec3 lever = g.orientation * scene.node_rest[i];
  const Vec3 anchor = g.position + lever + step * (g.linear_velocity + g.angular_velocity.cross(lever));
  Vec3 surface_motion = Vec3::Zero();  // the other side's point over the step
  if (c.body_b >= 0) {
    const BodyState& b = data.bodies[static_cast<std::size_t>(c.body_b)];
    surface_motion = step * (b.linear_velocity + b.angular_velocity.cross(c.position - b.position));
  }
  // The depth of a point x + δ on the contact's tangent plane is d − n · δ.
  return c.depth - c.normal.dot(anchor - data.nodes[i].position - surface_motion) > 0.0;
}

void drop_back_face_contacts(const Model& scene, Data& data, std::span<const int> device_body,
                             double margin) noexcept {
  for (NetOutput& o : data.nets) {
    o.crossed_contacts = 0;
    o.crossed_depth = 0.0;
  }
  bool crossed = false;
  int kept = 0;
  const int n = std::clamp(data.num_node_contacts, 0, static_cast<int>(data.node_contacts.size()));
  const int num_spheres = static_cast<int>(scene.body_spheres.size());
  for (int i = 0; i < n; ++i) {
    const NodeContact& c = data.node_contacts[static_cast<std::size_t>(i)];
    if (c.face >= 0 && in_god_object(device_body, c.body_b) && c.sphere_b >= 0 && c.sphere_b < num_spheres) {
      // True depth d − δ ≥ r: the sphere's centre on the triangle's inner side, where the law
      // would push the triangle around the sphere's far side and hook it onto the tool.
      const double r = scene.body_spheres[static_cast<std::size_t>(c.sphere_b)].radius - margin;
      const double depth = c.depth - margin;
      // An organ given by its material takes a sphere deeper than its radius (the half-space's
      // approach; its law acts through the load patch's plane, not the triangle's):
      // its contacts are kept to 2 r, the backstop's reach (net_tissue_contact.hpp).
      const int tissue_net = c.node >= 0 && c.node < scene.num_nodes()
                                 ? scene.node_net[static_cast<std::size_t>(c.node)]
                                 : -1;
      if (tissue_net >= 0 && scene.nets[static_cast<std::size_t>(tissue_net)].contact_modulus > 0.0 &&
          depth < 2.0 * r) {
        data.node_contacts[static_cast<std::size_t>(kept++)] = c;
        continue;
      }
      if (!(depth < r)) {
        // Below 2 r the true sphere overlaps the triangle from behind: the tool is past the
        // surface by that much, which is counted, not hidden (beyond, only the grown sphere
        // reaches the triangle's back face).
        const int net = c.node >= 0 && c.node < scene.num_nodes()
                            ? scene.node_net[static_cast<std::size_t>(c.node)]
                            : -1;
        if (net >= 0 && static_cast<std::size_t>(net) < data.nets.size() && depth < 2.0 * r) {
          NetOutput& o = data.nets[static_cast<std::size_t>(net)];
          ++o.crossed_contacts;
          o.crossed_depth = std::max(o.crossed_depth, depth);
          crossed = true;
        }
        continue;
      }
    }
    data.node_contacts[static_cast<std::size_t>(kept++)] = c;
  }
  data.num_node_contacts = kept;
  if (crossed) ++data.net_crossed_steps;
}

void drop_look_ahead_contacts(Data& data) noexcept {
  int kept = 0;
  const int n = std::clamp(data.num_node_contacts, 0, static_cast<int>(data.node_contacts.size()));
  for (int i = 0; i < n; ++i) {
    const NodeContact& c = data.node_contacts[static_cast<std::size_t>(i)];
    if (c.depth > 0.0) data.node_contacts[static_cast<std::size_t>(kept++)] = c;
  }
  data.num_node_contacts = kept;
}

bool organ_surface_folded(const Model& scene, const Data& data) noexcept {
  const int n = std::clamp(data.num_node_contacts, 0, static_cast<int>(data.node_contacts.size()));
  const int faces = static_cast<int>(scene.net_faces.size());
  for (int i = 0; i < n; ++i) {
    const NodeContact& c = data.node_contacts[static_cast<std::size_t>(i)];
    if (c.face < 0 || c.face >= faces) continue;
    const std::array<int, 3>& f = scene.net_faces[static_cast<std::size_t>(c.face)];
    const NetModel& net =
        scene.nets[static_cast<std::size_t>(scene.node_net[static_cast<std::size_t>(f[0])])];
    if (!scene.bodies[static_cast<std::size_t>(net.body)].anchored) continue;
    const auto x = [&](int k) {
      return data.nodes[static_cast<std::size_t>(f[static_cast<std::size_t>(k)])].position;
    };
    const auto r = [&](int k) {
      return scene.node_rest[static_cast<std::size_t>(f[static_cast<std::size_t>(k)])];
    };
    const Vec3 now = (x(1) - x(0)).cross(x(2) - x(0));
    const Vec3 rest = data.bodies[static_cast<std::size_t>(net.body)].orientation *
                      (r(1) - r(0)).cross(r(2) - r(0));
    if (now.dot(rest) < 0.0) return true;
  }
  return false;
}

void cut_back_node_contacts(const Model& scene, Data& data, std::span<const int> device_body,
                            double margin, double body_deepest, double step) noexcept {
  const bool look_ahead = step > 0.0;
  for (NetOutput& o : data.nets) o.max_penetration = o.crossed_depth;
  int kept = 0;
  const int n = std::clamp(data.num_node_contacts, 0, static_cast<int>(data.node_contacts.size()));
  for (int i = 0; i < n; ++i) {
    NodeContact c = data.node_contacts[static_cast<std::size_t>(i)];
    const int net = c.node >= 0 && c.node < scene.num_nodes() ? scene.node_net[static_cast<std::size_t>(c.node)] : -1;
    if (net < 0) continue;
    if (net_on_god_object(scene, device_body, net)) {  // the node's sphere was grown
      if (in_god_object(device_body, c.body_b)) continue;  // see the header
      c.depth -= margin;
      // The look-ahead (NodeContact::engaged): a touching node, and one touching nothing else
      // within kLookAheadGap of a surface or whose anchor is beyond it at the step's end, may
      // reach it within the scene step.
      if (c.depth > 0.0) {
        c.engaged = look_ahead;
      } else {
        if (!look_ahead) continue;
        if (!(c.depth > -kLookAheadGap) && !anchor_reaches(scene, data, c, step)) continue;
        bool touching = false;  // a node's contacts are consecutive (detect_node_contacts)
        for (int j = kept - 1; j >= 0 && data.node_contacts[static_cast<std::size_t>(j)].node == c.node; --j)
          touching = touching || data.node_contacts[static_cast<std::size_t>(j)].depth > 0.0;
        for (int j = i + 1; j < n && data.node_contacts[static_cast<std::size_t>(j)].node == c.node; ++j)
          touching = touching || data.node_contacts[static_cast<std::size_t>(j)].depth > margin;
        if (touching) continue;
        c.engaged = true;
      }
      c.position += (0.5 * margin) * c.normal;  // towards the node
      if (c.body_b >= 0) c.r_b += (0.5 * margin) * c.normal;
    } else if (in_god_object(device_body, c.body_b)) {  // the god-object's sphere was grown
      c.depth -= margin;
      // An organ's triangle within kLookAheadGap: a look-ahead candidate (engaged where the
      // triangle's point is predicted inside the sphere at the step's end, compute_net_forces).
      if (c.depth > 0.0) {
        c.engaged = look_ahead && c.face >= 0;
      } else {
        if (!look_ahead || c.face < 0 || !(c.depth > -kLookAheadGap)) continue;
        c.engaged = true;
      }
      c.position -= (0.5 * margin) * c.normal;  // towards the god-object
      c.r_b -= (0.5 * margin) * c.normal;
    }
    double& deepest = data.nets[static_cast<std::size_t>(net)].max_penetration;
    deepest = std::max(deepest, c.depth);  // a look-ahead contact's depth ≤ 0 counts nothing
    data.node_contacts[static_cast<std::size_t>(kept++)] = c;
  }
  data.num_node_contacts = kept;
  double deepest = body_deepest;
  for (const NetOutput& o : data.nets) deepest = std::max(deepest, o.max_penetration);
  data.max_penetration = deepest;
}

}  // namespace numen::core::detail
