/// @file device_loop.cpp
/// The models of a multirate god-object's two loops and the device loop's step against the
/// planes (numen/core/multirate/device_loop.hpp, docs/multirate.md).

#include "numen/core/multirate/device_loop.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include "numen/core/data.hpp"
#include "numen/core/grasp.hpp"
#include "numen/core/model.hpp"
#include "numen/core/rigid_body.hpp"
#include "numen/core/step.hpp"
#include "numen/core/step_stages.hpp"

#include "scratch/data_scratch.hpp"
#include "multirate/contact.hpp"
#include "multirate/net.hpp"

namespace numen::core {
namespace {

using detail::effective_contact_force;

/// "" when `body` is a body of `scene`, else the message both model makers give.
std::string body_error(const Model& scene, int body) {
  if (body >= 0 && body < scene.num_bodies()) return "";
  return "multirate: god-object body " + std::to_string(body) + " is not a body of the scene (" +
         std::to_string(scene.num_bodies()) + " bodies)";
}

}  // namespace

std::string detail::finalize_scene_loop_model(Model& m, std::span<const int> god) {
  if (std::string error = finalize_model(m); !error.empty()) return error;
  std::vector<int>& tree = m.articulation.body_tree;
  if (god.empty() || tree.size() != m.bodies.size()) return "";
  const int one = tree[static_cast<std::size_t>(god.front())];
  for (int g : god) tree[static_cast<std::size_t>(g)] = one;
  m.stage_plan = compiled_stages(m);  // what can collide changed
  return "";
}

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
  // The graspers whose jaws are both here grasp in the device step, what they hold carried here
  // too (MultirateSettings::carried); the scene loop does not grasp (make_proximity_model()).
  m.grasps.clear();
  for (const GraspModel& g : scene.grasps) {
    if (g.jaws[0] < 0 || g.jaws[1] < 0) continue;
    const int j0 = local[static_cast<std::size_t>(g.jaws[0])];
    const int j1 = local[static_cast<std::size_t>(g.jaws[1])];
    if (j0 < 0 || j1 < 0) continue;
    GraspModel gm = g;
    gm.jaws = {j0, j1};
    gm.jaw_joints = {-1, -1};  // derived again by finalize_model()
    m.grasps.push_back(std::move(gm));
  }
  m.obstacles.clear();
  m.static_spheres.clear();
  // The nets are the scene loop's; those on the god-object ride on their components here.
  if (std::string e = detail::lump_nets(scene, local, m); !e.empty()) return e;
  m.nets.clear();
  m.net_springs.clear();
  m.net_faces.clear();
  m.net_tetrahedra.clear();
  m.node_rest.clear();
  m.node_mass.clear();
  m.node_radius.clear();
  m.node_net.clear();
  m.node_sweep_order.clear();
  m.node_spring_begin.clear();
  m.node_springs.clear();
  m.threads.clear();  // the threads are the scene loop's (thread.hpp): their ties name its bodies
  // The needles' stages are the scene loop's, which holds the tissue; the device loop holds a
  // needle on its puncture points by the sample's ties (PunctureTie).
  m.needles.clear();
  m.initial_held_body = local[static_cast<std::size_t>(body)];
  std::string error = finalize_model(m);
  if (!error.empty()) return "multirate: god-object model: " + error;
  out = std::move(m);
  return "";
}

Data make_god_object_data(const Model& god_object) {
  return make_data(god_object, DataOptions{kMaxContacts});
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
  m.grasps.clear();  // the device step grasps (make_god_object_model())
  std::string error = detail::finalize_scene_loop_model(m, god_object_bodies(scene, body, others));
  if (!error.empty()) return "multirate: proximity model: " + error;
  out = std::move(m);
  return "";
}

void step_god_object(const Model& model, ContactPlaneSet& planes, Data& data) noexcept {
  step_to_contacts(model, data);
  write_plane_contacts(model, planes, data);  // the contact stage: the planes'
  step_from_contacts(model, data);
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
