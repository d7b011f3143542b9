/// @file planes.cpp
/// The planes of a multirate god-object and their carriers: built from the scene loop's
/// contacts, evaluated at the device loop's pose (numen/core/multirate/planes.hpp,
/// docs/multirate.md).

#include "numen/core/multirate/planes.hpp"

#include <algorithm>
#include <cmath>

#include "numen/core/capacity.hpp"
#include "numen/core/collision.hpp"
#include "numen/core/contact_force.hpp"
#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/rigid_body.hpp"
#include "numen/core/step.hpp"
#include "numen/core/step_stages.hpp"

#include "multirate/contact.hpp"

namespace numen::core {
namespace {

using detail::god_object_contact;

/// build_contact_planes(), its first phase: a plane for each of the god-object's `n` contacts in
/// `data` (in their order), and a carrier for each moving scene body on their other side at its
/// first plane (writes out.planes, out.carriers, their counts and out.dropped).
void add_contact_planes(const Model& scene, const Data& data, std::span<const int> device_body,
                        int n, ContactPlaneSet& out) noexcept {
  for (int i = 0; i < n; ++i) {
    const Contact& c = data.contacts[static_cast<std::size_t>(i)];
    bool on_a = false;
    if (!god_object_contact(c, device_body, on_a)) continue;  // not the god-object's
    const int body = on_a ? c.body_a : c.body_b;
    const BodyModel& bm = scene.bodies[static_cast<std::size_t>(body)];
    const BodyState& g = data.bodies[static_cast<std::size_t>(body)];
    const int sphere = on_a ? c.sphere_a : c.sphere_b;
    if (sphere < bm.sphere_begin || sphere >= bm.sphere_begin + bm.sphere_count) continue;
    if (out.count >= kMaxContactPlanes) {
      ++out.dropped;
      continue;
    }
    const Sphere& s = scene.body_spheres[static_cast<std::size_t>(sphere)];
    const Vec3 centre = g.position + g.orientation * s.center;
    const Vec3 normal = on_a ? c.normal : Vec3(-c.normal);
    ContactPlane& p = out.planes[static_cast<std::size_t>(out.count++)];
    p = ContactPlane{};  // the set is reused: no field of an earlier sample's node plane stays
    p.body = device_body[static_cast<std::size_t>(body)];
    p.sphere = sphere - bm.sphere_begin;
    p.normal = normal;
    p.point = centre - (s.radius - c.depth) * normal;  // the other side's surface point
    p.material_pair = c.material_pair;
    p.other_body = on_a ? c.body_b : c.body_a;
    p.obstacle = c.obstacle;
    p.other_sphere = on_a ? c.sphere_b : c.sphere_a;
    p.velocity.setZero();
    p.carrier = -1;
    p.impulse.setZero();
    p.impulse_point = p.point;
    if (p.other_body < 0) continue;
    const BodyState& o = data.bodies[static_cast<std::size_t>(p.other_body)];
    p.velocity = o.linear_velocity + o.angular_velocity.cross(p.point - o.position);
    for (int k = 0; k < out.carrier_count && p.carrier < 0; ++k)
      if (out.carriers[static_cast<std::size_t>(k)].body == p.other_body) p.carrier = k;
    if (p.carrier >= 0) continue;
    const BodyModel& om = scene.bodies[static_cast<std::size_t>(p.other_body)];
    bool moves = om.mass > 0.0 && !data.body_targets[static_cast<std::size_t>(p.other_body)].enabled;
    for (const JointModel& j : scene.joints)
      if (j.parent == p.other_body || j.child == p.other_body) moves = false;
    if (!moves || out.carrier_count >= kMaxPlaneCarriers) continue;  // static
    p.carrier = out.carrier_count++;
    PlaneCarrier& k = out.carriers[static_cast<std::size_t>(p.carrier)];
    k.body = p.other_body;
    k.com = o.position;
    k.displacement.setZero();
    k.rotation.setZero();
    k.linear_velocity = o.linear_velocity;
    k.angular_velocity = o.angular_velocity;
    const Mat3 r = o.orientation.toRotationMatrix();
    k.mass.setZero();
    k.mass.topLeftCorner<3, 3>() = om.mass * Mat3::Identity();
    k.mass.bottomRightCorner<3, 3>() = r * om.inertia_body * r.transpose();
    k.stiffness.setZero();
    k.system_inverse.setZero();
    k.wrench.setZero();
    k.wrench.head<3>() = om.mass * scene.gravity;
    k.impulse.setZero();
    k.supports = 0;
    k.inverse_mass = 1.0 / om.mass;
  }
}

/// build_contact_planes(), its second phase: each carrier's own contacts (not with the
/// god-object, `n` of `data`), linearised about the sample: K, F₀ and the supports into the
/// carrier, D into `damping` (per carrier, zeroed by the caller).
void add_carrier_supports(const Model& scene, const Data& data, std::span<const int> device_body,
                          int n, ContactPlaneSet& out, Mat6* damping) noexcept {
  const int nc = out.carrier_count;
  const auto carrier_of = [&out, nc](int b) {
    for (int k = 0; k < nc; ++k)
      if (out.carriers[static_cast<std::size_t>(k)].body == b) return k;
    return -1;
  };
  for (int i = 0; i < n; ++i) {
    const Contact& c = data.contacts[static_cast<std::size_t>(i)];
    bool on_a = false;
    if (god_object_contact(c, device_body, on_a)) continue;  // the planes
    if (c.material_pair < 0 || c.material_pair >= static_cast<int>(scene.material_pairs.size())) continue;
    const MaterialPair& mp = scene.material_pairs[static_cast<std::size_t>(c.material_pair)];
    for (int side = 0; side < 2; ++side) {
      const int b = side == 0 ? c.body_a : c.body_b;
      if (b < 0) continue;
      const int k = carrier_of(b);
      if (k < 0) continue;
      PlaneCarrier& pc = out.carriers[static_cast<std::size_t>(k)];
      const Vec3 nrm = side == 0 ? c.normal : Vec3(-c.normal);  // into the carrier
      const Vec3 arm = c.position - pc.com;
      Eigen::Matrix<double, 3, 6> g;
      g.leftCols<3>() = Mat3::Identity();
      g.rightCols<3>() = -skew(arm);
      const Eigen::Matrix<double, 1, 6> gn = nrm.transpose() * g;
      pc.stiffness += mp.stiffness * gn.transpose() * gn;
      damping[k] += mp.damping * gn.transpose() * gn +
                    mp.friction * (g.transpose() * g - gn.transpose() * gn);
      const Vec3 f = mp.stiffness * c.depth * nrm;
      pc.wrench.head<3>() += f;
      pc.wrench.tail<3>() += arm.cross(f);
      ++pc.supports;
    }
  }
}

/// build_contact_planes(), its last phase: the exchange with the god-object is explicit, so each
/// carrier's M is scaled up by q ≥ 1 until Σk · h² / m' ≤ 1 over its planes' stiffnesses, and
/// (M + h D + h² K)⁻¹ taken for the device period h = `device_dt` (writes the carriers' mass,
/// inverse_mass, system_inverse).
void factor_carriers(const Model& scene, double device_dt, const Mat6* damping,
                     ContactPlaneSet& out) noexcept {
  const int nc = out.carrier_count;
  const double h = device_dt;
  for (int k = 0; k < nc; ++k) {
    PlaneCarrier& c = out.carriers[static_cast<std::size_t>(k)];
    double stiffness = 0.0;
    for (int i = 0; i < out.count; ++i) {
      const ContactPlane& p = out.planes[static_cast<std::size_t>(i)];
      if (p.carrier == k && p.material_pair >= 0 &&
          p.material_pair < static_cast<int>(scene.material_pairs.size()))
        stiffness += scene.material_pairs[static_cast<std::size_t>(p.material_pair)].stiffness;
    }
    const double q = stiffness * c.inverse_mass * h * h;
    if (q > 1.0) {
      c.mass *= q;
      c.inverse_mass /= q;
    }
    const Mat6 system = c.mass + h * damping[k] + (h * h) * c.stiffness;
    c.system_inverse = system.inverse();
  }
}

}  // namespace

void build_contact_planes(const Model& scene, const Data& data, std::span<const int> device_body,
                          double device_dt, ContactPlaneSet& out) noexcept {
  out.count = 0;
  out.carrier_count = 0;
  out.link_count = 0;
  out.dropped = 0;
  if (device_body.size() != scene.bodies.size()) return;
  const int n = std::clamp(data.num_contacts, 0, kMaxContacts);
  add_contact_planes(scene, data, device_body, n, out);
  const int nc = out.carrier_count;
  if (nc == 0) return;
  Mat6 damping[kMaxPlaneCarriers];  // D of each carrier's own contacts
  for (int k = 0; k < nc; ++k) damping[k].setZero();
  add_carrier_supports(scene, data, device_body, n, out, damping);
  factor_carriers(scene, device_dt, damping, out);
}

namespace {

/// Plane `i` of `planes` at the god-object's pose in `data`, moved by its carrier.
struct PlaneAtPose {
  bool valid = false;          // a body, sphere and material pair of the model
  Sphere sphere;               // the sphere it acts on (a node plane's own), in its body's frame
  Vec3 centre = Vec3::Zero();  // the sphere's centre (m, world)
  Vec3 normal = Vec3::UnitZ();
  Vec3 surface_velocity = Vec3::Zero();
  double depth = 0.0;  // d, a node plane's with its depth_offset (m)
};

PlaneAtPose plane_at_pose(const Model& model, const ContactPlaneSet& planes, int i,
                          const Data& data) noexcept {
  PlaneAtPose out;
  const ContactPlane& p = planes.planes[static_cast<std::size_t>(i)];
  if (p.body < 0 || p.body >= model.num_bodies() || p.material_pair < 0 ||
      p.material_pair >= static_cast<int>(model.material_pairs.size()))
    return out;
  const BodyModel& bm = model.bodies[static_cast<std::size_t>(p.body)];
  const BodyState& g = data.bodies[static_cast<std::size_t>(p.body)];
  const bool node = p.node >= 0;  // a node plane: its own sphere, through the node's compliance
  if (!node && (p.sphere < 0 || p.sphere >= bm.sphere_count)) return out;
  out.sphere = node ? Sphere{p.local_point, p.radius}
                    : model.body_spheres[static_cast<std::size_t>(bm.sphere_begin + p.sphere)];
  out.centre = g.position + g.orientation * out.sphere.center;
  Vec3 point = p.point;
  out.normal = p.normal;
  const int nc = std::clamp(planes.carrier_count, 0, kMaxPlaneCarriers);
  if (p.carrier >= 0 && p.carrier < nc) {
    const PlaneCarrier& k = planes.carriers[static_cast<std::size_t>(p.carrier)];
    point += k.displacement + k.rotation.cross(p.point - k.com);
    if (k.node < 0) out.normal = (out.normal + k.rotation.cross(out.normal)).normalized();
    out.surface_velocity =
        k.linear_velocity + k.angular_velocity.cross(point - (k.com + k.displacement));
  }
  out.depth =
      out.normal.dot(point - out.centre) + out.sphere.radius + (node ? p.depth_offset : 0.0);
  out.valid = true;
  return out;
}

}  // namespace

double plane_elastic_energy(const Model& model, const ContactPlaneSet& planes,
                            const Data& data) noexcept {
  double energy = 0.0;
  const int n = std::clamp(planes.count, 0, kMaxContactPlanes);
  for (int i = 0; i < n; ++i) {
    const PlaneAtPose a = plane_at_pose(model, planes, i, data);
    if (!a.valid) continue;
    const ContactPlane& p = planes.planes[static_cast<std::size_t>(i)];
    const MaterialPair& mp = model.material_pairs[static_cast<std::size_t>(p.material_pair)];
    energy += (p.node >= 0 ? p.stiffness_scale : 1.0) * contact_elastic_energy(a.depth, mp);
  }
  return energy;
}

void write_plane_contacts(const Model& model, const ContactPlaneSet& planes, Data& data) noexcept {
  // A composite god-object (several devices): its articulations' mutual contacts, at the device
  // rate, as the single-rate step finds them (the model has no obstacle, net or mesh).
  if (cross_contact_capacity(model) > 0) {
    detect_contacts(model, data);
  } else {
    data.stages_run |= kStageContacts;  // the stage report (step_stages.hpp)
    data.num_contacts = 0;
    data.max_penetration = 0.0;
    data.contacts_dropped = 0;
  }
  const int n = std::clamp(planes.count, 0, kMaxContactPlanes);
  for (int i = 0; i < n; ++i) {
    const PlaneAtPose a = plane_at_pose(model, planes, i, data);
    if (!a.valid) continue;
    const ContactPlane& p = planes.planes[static_cast<std::size_t>(i)];
    const BodyModel& bm = model.bodies[static_cast<std::size_t>(p.body)];
    const bool node = p.node >= 0;
    const double depth = a.depth;
    if (!(depth > 0.0)) continue;
    Contact c;
    c.body_a = p.body;
    c.body_b = -1;
    c.obstacle = -1;
    c.sphere_a = node ? -1 : bm.sphere_begin + p.sphere;
    c.material_pair = p.material_pair;
    c.stiffness_scale = node ? p.stiffness_scale : 1.0;
    c.damping_scale = node && p.share > 0.0 ? c.stiffness_scale * c.stiffness_scale / p.share : 1.0;
    c.position = a.centre - (a.sphere.radius - 0.5 * depth) * a.normal;  // middle of the overlap
    c.normal = a.normal;
    c.depth = depth;
    c.force.setZero();
    c.surface_velocity = a.surface_velocity;
    c.sphere_b = i;  // the plane
    // The overlap itself (a node plane's depth holds the node's deflection too).
    if (!add_contact(data, c)) continue;  // dropped and counted: step_from_contacts() reports it
    data.max_penetration = std::max(data.max_penetration, node ? depth - p.depth_offset : depth);
  }
}

}  // namespace numen::core
