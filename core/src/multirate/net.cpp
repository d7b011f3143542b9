/// @file net.cpp
/// The nets of a multirate god-object and the organs it touches (multirate/net.hpp,
/// docs/multirate.md): lumping, growing, the contacts cut back; the node planes are
/// net_planes.cpp's.

#include "multirate/net.hpp"
#include "net/net_surface.hpp"
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
