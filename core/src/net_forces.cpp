/// @file net_forces.cpp
/// Spring, tie, gravity and contact forces of the deformable nets, explicit
/// node step and end-of-step observables (paper §4.2; Meseure & Chaillou 2000).

#include "numen/core/net_forces.hpp"

#include <algorithm>
#include <cmath>

#include "numen/core/contact_force.hpp"
#include "numen/core/data.hpp"
#include "numen/core/model.hpp"

namespace numen::core {
namespace {

/// Running maximum that keeps a NaN once met (std::max(m, NaN) would drop it
/// and report a non-finite net as calm).
inline void raise_max(double& m, double x) noexcept {
  if (x > m || std::isnan(x)) m = std::isnan(m) ? m : x;
}

}  // namespace

void compute_net_forces(const Model& model, Data& data) noexcept {
  if (model.nets.empty()) return;
  NetScratch& s = data.net;
  const std::size_t n = data.nodes.size();
  for (std::size_t i = 0; i < n; ++i) s.force[i] = model.node_mass[i] * model.gravity;

  // Structural and bending springs.
  for (std::size_t e = 0; e < model.net_springs.size(); ++e) {
    const NetSpring& sp = model.net_springs[e];
    SpringTerm& t = s.springs[e];
    const auto a = static_cast<std::size_t>(sp.node_a);
    const auto b = static_cast<std::size_t>(sp.node_b);
    const Vec3 d = data.nodes[b].position - data.nodes[a].position;
    const double l = d.norm();
    if (l > 1e-12 * sp.rest_length) t.direction = d * (1.0 / l);  // else: keep the last direction
    t.length = l;
    const Vec3 dv = data.nodes[b].velocity - data.nodes[a].velocity;
    const Vec3 f =
        (sp.stiffness * (l - sp.rest_length) + sp.damping * t.direction.dot(dv)) * t.direction;
    s.force[a] += f;
    s.force[b] -= f;
  }

  // Zero-length ties to the rigid component, reaction on it.
  for (std::size_t k = 0; k < model.nets.size(); ++k) {
    const NetModel& net = model.nets[k];
    const auto bi = static_cast<std::size_t>(net.body);
    const BodyState& body = data.bodies[bi];
    const Mat3 rot = body.orientation.toRotationMatrix();
    Wrench reaction;
    for (int v = net.node_begin; v < net.node_begin + net.node_count; ++v) {
      const auto i = static_cast<std::size_t>(v);
      const Vec3 lever = rot * model.node_rest[i];
      s.lever[i] = lever;
      const Vec3 anchor = body.position + lever;
      const Vec3 anchor_velocity = body.linear_velocity + body.angular_velocity.cross(lever);
      const Vec3 f = -net.tie_stiffness * (data.nodes[i].position - anchor) -
                     net.tie_damping * (data.nodes[i].velocity - anchor_velocity);
      s.force[i] += f;
      reaction.force -= f;
      reaction.torque -= lever.cross(f);
    }
    data.body_wrench[bi].force += reaction.force;
    data.body_wrench[bi].torque += reaction.torque;
    data.nets[k].tie_wrench = reaction;
  }

  // Node contacts (penalty law of contact_force.hpp, the node on side a).
  const int nc = std::clamp(data.num_node_contacts, 0, static_cast<int>(data.node_contacts.size()));
  for (int c = 0; c < nc; ++c) {
    NodeContact& ct = data.node_contacts[static_cast<std::size_t>(c)];
    const auto i = static_cast<std::size_t>(ct.node);
    Vec3 v_rel = data.nodes[i].velocity;
    ct.r_b.setZero();
    if (ct.body_b >= 0) {
      const BodyState& b = data.bodies[static_cast<std::size_t>(ct.body_b)];
      ct.r_b = ct.position - b.position;
      v_rel -= b.linear_velocity + b.angular_velocity.cross(ct.r_b);
    }
    const MaterialPair& mp = model.material_pairs[static_cast<std::size_t>(ct.material_pair)];
    const ContactForceResult r = contact_penalty_force(ct.normal, ct.depth, v_rel, mp);
    ct.force = r.force;
    ct.active = r.active;
    ct.normal_velocity = ct.normal.dot(v_rel);
    if (!r.active) continue;
    s.force[i] += r.force;
    if (ct.body_b >= 0) {
      Wrench& w = data.body_wrench[static_cast<std::size_t>(ct.body_b)];
      w.force -= r.force;
      w.torque -= ct.r_b.cross(r.force);
    }
  }
}

void integrate_nodes_symplectic(const Model& model, Data& data) noexcept {
  const double h = model.dt;
  for (std::size_t i = 0; i < data.nodes.size(); ++i) {
    NodeState& st = data.nodes[i];
    st.velocity += (h / model.node_mass[i]) * data.net.force[i];
    st.position += h * st.velocity;
  }
}

void integrate_nodes_implicit(const Model& model, Data& data) noexcept {
  const double h = model.dt;
  const double scale = h / data.solver.system_step;  // 1 (Euler) or 2 (trapezoidal), exact
  for (std::size_t i = 0; i < data.nodes.size(); ++i) {
    NodeState& st = data.nodes[i];
    const Vec3 v_move = st.velocity + data.net.delta[i];  // v1 (Euler) or v½ (trapezoidal)
    st.position += h * v_move;
    st.velocity += scale * data.net.delta[i];
  }
}

void measure_nets(const Model& model, Data& data) noexcept {
  for (std::size_t k = 0; k < model.nets.size(); ++k) {
    const NetModel& net = model.nets[k];
    NetOutput& out = data.nets[k];
    const BodyState& body = data.bodies[static_cast<std::size_t>(net.body)];
    double stretch2 = 0.0;
    double speed2 = 0.0;
    double kinetic = 0.0;
    for (int v = net.node_begin; v < net.node_begin + net.node_count; ++v) {
      const auto i = static_cast<std::size_t>(v);
      const NodeState& st = data.nodes[i];
      const Vec3 anchor = body.position + body.orientation * model.node_rest[i];
      raise_max(stretch2, (st.position - anchor).squaredNorm());
      const double v2 = st.velocity.squaredNorm();
      raise_max(speed2, v2);
      kinetic += 0.5 * model.node_mass[i] * v2;
    }
    double strain = 0.0;
    for (int e = net.spring_begin; e < net.spring_begin + net.structural_count; ++e) {
      const NetSpring& sp = model.net_springs[static_cast<std::size_t>(e)];
      const double l = (data.nodes[static_cast<std::size_t>(sp.node_b)].position -
                        data.nodes[static_cast<std::size_t>(sp.node_a)].position)
                           .norm();
      raise_max(strain, std::abs(l - sp.rest_length) / sp.rest_length);
    }
    out.max_tie_stretch = std::sqrt(stretch2);
    out.max_node_speed = std::sqrt(speed2);
    out.kinetic_energy = kinetic;
    out.max_strain = strain;
  }
}

}  // namespace numen::core
