/// @file multirate.cpp
/// The intermediate contact model of a multirate god-object (multirate.hpp, docs/multirate.md).

#include "numen/core/multirate.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include "numen/core/capacity.hpp"
#include "numen/core/collision.hpp"
#include "numen/core/contact_force.hpp"
#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/rigid_body.hpp"
#include "numen/core/step.hpp"

#include "detail/data_scratch.hpp"
#include "detail/multirate_contact.hpp"
#include "detail/multirate_net.hpp"

namespace numen::core {
namespace {

void write_planes(const Model& model, Data& data, const void* context) noexcept {
  write_plane_contacts(model, *static_cast<const ContactPlaneSet*>(context), data);
}

using detail::effective_contact_force;
using detail::god_object_contact;

/// "" when `body` is a body of `scene`, else the message both model makers give.
std::string body_error(const Model& scene, int body) {
  if (body >= 0 && body < scene.num_bodies()) return "";
  return "multirate: god-object body " + std::to_string(body) + " is not a body of the scene (" +
         std::to_string(scene.num_bodies()) + " bodies)";
}

}  // namespace

std::vector<int> god_object_bodies(const Model& scene, int body, std::span<const int> others) {
  std::vector<int> out;
  if (body < 0 || body >= scene.num_bodies()) return out;
  const std::vector<int>& tree = scene.articulation.body_tree;
  std::vector<char> in(scene.bodies.size(), 0);
  const auto add = [&](int root) {
    if (root < 0 || root >= scene.num_bodies()) return;
    if (tree.size() != scene.bodies.size()) {
      in[static_cast<std::size_t>(root)] = 1;
      return;
    }
    for (int b = 0; b < scene.num_bodies(); ++b)
      if (tree[static_cast<std::size_t>(b)] == tree[static_cast<std::size_t>(root)])
        in[static_cast<std::size_t>(b)] = 1;
  };
  add(body);
  for (int o : others) add(o);
  for (int b = 0; b < scene.num_bodies(); ++b)
    if (in[static_cast<std::size_t>(b)]) out.push_back(b);
  return out;
}

std::string make_god_object_model(const Model& scene, int body, double device_dt, Model& out,
                                  std::span<const int> others) {
  if (std::string e = body_error(scene, body); !e.empty()) return e;
  for (int o : others)
    if (o < 0 || o >= scene.num_bodies())
      return "multirate: another device's body " + std::to_string(o) + " is not a body of the scene (" +
             std::to_string(scene.num_bodies()) + " bodies)";
  if (!(device_dt > 0.0) || !std::isfinite(device_dt))
    return "multirate: the device period must be > 0 s and finite (got " + std::to_string(device_dt) + ")";
  if (scene.integrator != Integrator::kLinearlyImplicitEuler &&
      scene.integrator != Integrator::kSymplecticEuler)
    return "multirate: the god-object's integrator must be the linearly implicit or the "
           "symplectic Euler (the impulse hand-back needs the step's effective contact force)";
  const std::vector<int> bodies = god_object_bodies(scene, body, others);
  for (int b : bodies)
    if (scene.bodies[static_cast<std::size_t>(b)].mesh >= 0)
      return "multirate: god-object body '" + scene.bodies[static_cast<std::size_t>(b)].name +
             "' carries a mesh (BodyModel::mesh): the contact planes stand for the god-object's "
             "spheres only; give the mesh to a body the tool touches";
  std::vector<int> local(scene.bodies.size(), -1);
  for (std::size_t i = 0; i < bodies.size(); ++i) local[static_cast<std::size_t>(bodies[i])] = static_cast<int>(i);
  Model m = scene;  // the scene's settings; its bodies, joints and obstacles replaced below
  m.dt = device_dt;
  m.bodies.clear();
  m.body_spheres.clear();
  for (int b : bodies) {
    BodyModel bm = scene.bodies[static_cast<std::size_t>(b)];
    bm.sphere_begin = static_cast<int>(m.body_spheres.size());
    m.body_spheres.insert(m.body_spheres.end(),
                          scene.body_spheres.begin() + scene.bodies[static_cast<std::size_t>(b)].sphere_begin,
                          scene.body_spheres.begin() + scene.bodies[static_cast<std::size_t>(b)].sphere_begin +
                              bm.sphere_count);
    m.bodies.push_back(bm);
  }
  m.joints.clear();
  for (const JointModel& j : scene.joints) {
    if (local[static_cast<std::size_t>(j.child)] < 0) continue;  // another articulation's
    JointModel jm = j;
    jm.child = local[static_cast<std::size_t>(j.child)];
    jm.parent = j.parent < 0 ? -1 : local[static_cast<std::size_t>(j.parent)];
    m.joints.push_back(jm);
  }
  m.obstacles.clear();
  m.static_spheres.clear();
  // The nets are the scene loop's; those on the god-object ride on their components here.
  if (std::string e = detail::lump_nets(scene, local, m); !e.empty()) return e;
  m.nets.clear();
  m.net_springs.clear();
  m.net_faces.clear();
  m.node_rest.clear();
  m.node_mass.clear();
  m.node_radius.clear();
  m.node_net.clear();
  m.node_sweep_order.clear();
  m.node_spring_begin.clear();
  m.node_springs.clear();
  m.initial_held_body = local[static_cast<std::size_t>(body)];
  m.caller_contacts = true;
  std::string error = finalize_model(m);
  if (!error.empty()) return "multirate: god-object model: " + error;
  out = std::move(m);
  return "";
}

std::string make_proximity_model(const Model& scene, int body, double margin, Model& out,
                                 std::span<const int> others) {
  if (std::string e = body_error(scene, body); !e.empty()) return e;
  if (!(margin >= 0.0) || !std::isfinite(margin))
    return "multirate: the contact margin must be >= 0 m and finite (got " + std::to_string(margin) + ")";
  Model m = scene;
  std::vector<int> device_body(scene.bodies.size(), -1);
  for (int g : god_object_bodies(scene, body, others)) {
    device_body[static_cast<std::size_t>(g)] = 0;
    BodyModel& b = m.bodies[static_cast<std::size_t>(g)];
    b.sphere_margin = margin;
    for (int s = b.sphere_begin; s < b.sphere_begin + b.sphere_count; ++s)
      m.body_spheres[static_cast<std::size_t>(s)].radius += margin;
  }
  detail::grow_god_object_nodes(device_body, margin, m);
  std::string error = finalize_model(m);
  if (!error.empty()) return "multirate: proximity model: " + error;
  out = std::move(m);
  return "";
}

void build_contact_planes(const Model& scene, const Data& data, std::span<const int> device_body,
                          double device_dt, ContactPlaneSet& out) noexcept {
  out.count = 0;
  out.carrier_count = 0;
  out.link_count = 0;
  out.dropped = 0;
  if (device_body.size() != scene.bodies.size()) return;
  const int n = std::clamp(data.num_contacts, 0, kMaxContacts);
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
  const int nc = out.carrier_count;
  if (nc == 0) return;
  // The carriers' own contacts (not with the god-object), linearised about the sample.
  Mat6 damping[kMaxPlaneCarriers];
  for (int k = 0; k < nc; ++k) damping[k].setZero();
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
  // The exchange with the god-object is explicit: Σk · h² / m' ≤ 1 (M scaled up by q ≥ 1).
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
    data.num_contacts = 0;
    data.max_penetration = 0.0;
    data.contacts_dropped = 0;
  }
  const bool overflowed = data.contacts_dropped > 0;  // counted by detect_contacts()
  const int n = std::clamp(planes.count, 0, kMaxContactPlanes);
  for (int i = 0; i < n; ++i) {
    const PlaneAtPose a = plane_at_pose(model, planes, i, data);
    if (!a.valid) continue;
    const ContactPlane& p = planes.planes[static_cast<std::size_t>(i)];
    const BodyModel& bm = model.bodies[static_cast<std::size_t>(p.body)];
    const bool node = p.node >= 0;
    const double depth = a.depth;
    if (!(depth > 0.0)) continue;
    if (data.num_contacts >= kMaxContacts) {
      ++data.contacts_dropped;
      continue;
    }
    Contact& c = data.contacts[static_cast<std::size_t>(data.num_contacts++)];
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
    data.max_penetration = std::max(data.max_penetration, node ? depth - p.depth_offset : depth);
  }
  if (data.contacts_dropped > 0 && !overflowed) {
    data.status |= kContactOverflow;
    ++data.contact_overflow_steps;
  }
}

void step_god_object(const Model& model, ContactPlaneSet& planes, Data& data) noexcept {
  step_with_contacts(model, data, &write_planes, &planes);
  const std::vector<BodyState>& before = data.scratch->solver.saved_state;  // the step's start
  const double h = model.dt;
  const int np = std::clamp(planes.count, 0, kMaxContactPlanes);
  const int nc = std::clamp(planes.carrier_count, 0, kMaxPlaneCarriers);
  for (int i = 0; i < np; ++i) planes.planes[static_cast<std::size_t>(i)].impulse.setZero();
  // A node carrier's planes' stiffness and damping (K, C below), from the god-object's step.
  std::array<Mat3, kMaxPlaneCarriers> node_k, node_c;
  for (int i = 0; i < nc; ++i) {
    if (planes.carriers[static_cast<std::size_t>(i)].node < 0) continue;
    node_k[static_cast<std::size_t>(i)].setZero();
    node_c[static_cast<std::size_t>(i)].setZero();
  }
  if ((data.status & kNonFinite) == 0) {
    const bool implicit = model.integrator == Integrator::kLinearlyImplicitEuler;
    const int n = std::clamp(data.num_contacts, 0, kMaxContacts);
    for (int i = 0; i < n; ++i) {
      const Contact& c = data.contacts[static_cast<std::size_t>(i)];
      const ContactTerm& t = data.scratch->solver.contact_terms[static_cast<std::size_t>(i)];
      // Not a plane's: a contact between two of its articulations (body_b ≥ 0).
      if (!t.active || c.body_b >= 0 || c.sphere_b < 0 || c.sphere_b >= np) continue;
      ContactPlane& p = planes.planes[static_cast<std::size_t>(c.sphere_b)];
      // The plane's motion is prescribed over the period: the relative velocity's change is
      // the god-object's alone.
      const auto a = static_cast<std::size_t>(c.body_a);
      const Vec3 f = effective_contact_force(c, t, implicit, h, before[a], data.bodies[a], nullptr, nullptr);
      p.impulse = h * f;
      p.impulse_point = c.position;
      if (p.carrier < 0 || p.carrier >= nc) continue;
      PlaneCarrier& k = planes.carriers[static_cast<std::size_t>(p.carrier)];
      const Vec3 j = -p.impulse;  // on the carrier
      k.impulse.head<3>() += j;
      k.impulse.tail<3>() += (c.position - (k.com + k.displacement)).cross(j);
      if (k.node < 0) continue;
      const Mat3 nn = c.normal * c.normal.transpose();
      node_k[static_cast<std::size_t>(p.carrier)] += t.stiffness * nn;
      node_c[static_cast<std::size_t>(p.carrier)] +=
          t.damping * nn + t.friction * (Mat3::Identity() - nn);
    }
  }
  // The organs' node carriers: the god-object's impulse J on the node over the period (its
  // planes moving at v₀), and beyond v₀ the planes' stiffness K and damping C, linearly
  // implicit with the node's tie and springs and its links at the period's start:
  //   (m + h (D_n + C) + h² (K_n + K)) v₁ = m v₀ + h (F₀ − K_n u₀ + Σ links) + J + h (C + h K) v₀.
  // A 70 mg node on a plane of 2·10⁴ N/m and 10 N·s/m at 10 kHz (k h²/m = 2.9, c h/m = 14) is
  // out of reach of the explicit exchange of the bodies' carriers below.
  const int nl = std::clamp(planes.link_count, 0, kMaxCarrierLinks);
  for (int l = 0; l < nl; ++l) {  // the springs between node carriers, at the period's start
    const CarrierLink& e = planes.links[static_cast<std::size_t>(l)];
    if (e.a < 0 || e.a >= nc || e.b < 0 || e.b >= nc) continue;
    PlaneCarrier& a = planes.carriers[static_cast<std::size_t>(e.a)];
    PlaneCarrier& b = planes.carriers[static_cast<std::size_t>(e.b)];
    a.impulse.head<3>() += h * (e.stiffness * b.displacement + e.damping * b.linear_velocity);
    b.impulse.head<3>() += h * (e.stiffness * a.displacement + e.damping * a.linear_velocity);
  }
  for (int i = 0; i < nc; ++i) {
    PlaneCarrier& k = planes.carriers[static_cast<std::size_t>(i)];
    if (k.node >= 0) {
      const auto c = static_cast<std::size_t>(i);
      const double m = k.mass(0, 0);
      const Mat3 k_n = k.stiffness.topLeftCorner<3, 3>();
      const Mat3 reaction = h * node_c[c] + (h * h) * node_k[c];
      const Mat3 system = m * Mat3::Identity() + h * k.node_damping + (h * h) * k_n + reaction;
      const Vec3 rhs = m * k.linear_velocity + h * (k.wrench.head<3>() - k_n * k.displacement) +
                       k.impulse.head<3>() + reaction * k.linear_velocity;
      k.linear_velocity = system.inverse() * rhs;
      k.displacement += h * k.linear_velocity;
      k.impulse.setZero();
      continue;
    }
    Vec6 q0, v0;
    q0 << k.displacement, k.rotation;
    v0 << k.linear_velocity, k.angular_velocity;
    const Vec6 v1 = k.system_inverse * (k.mass * v0 + h * (k.wrench - k.stiffness * q0) + k.impulse);
    k.linear_velocity = v1.head<3>();
    k.angular_velocity = v1.tail<3>();
    k.displacement += h * k.linear_velocity;
    k.rotation += h * k.angular_velocity;
    k.impulse.setZero();
  }
}

}  // namespace numen::core
