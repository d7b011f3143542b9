/// @file net_forces.cpp
/// Tie, gravity and contact forces of the deformable nets (the springs' in net_springs.cpp),
/// explicit node step and end-of-step observables (paper §4.2; Meseure & Chaillou 2000).

#include "numen/core/net_forces.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "numen/core/contact_force.hpp"
#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/net_material.hpp"
#include "numen/core/net_tissue_contact.hpp"
#include "numen/core/step_stages.hpp"

#include "scratch/data_scratch.hpp"
#include "net/net_rest.hpp"
#include "net/net_solve.hpp"
#include "net/net_springs.hpp"
#include "net/net_surface.hpp"
#include "net/net_terms.hpp"
#include "net/net_tissue.hpp"

namespace numen::core {
namespace {

/// Running maximum that keeps a NaN once met (std::max(m, NaN) would drop it
/// and report a non-finite net as calm).
inline void raise_max(double& m, double x) noexcept {
  if (x > m || std::isnan(x)) m = std::isnan(m) ? m : x;
}

}  // namespace

namespace {

/// Gravity and the zero-length ties to the rigid component, with their reaction on it, into
/// NetScratch::force and Data::body_wrench; each node's lever (NetScratch::lever), each net's
/// energy at the step's start but the springs' (NetState::start_energy) and its ties' wrench.
void add_ties_and_gravity(const Model& model, Data& data) noexcept {
  NetScratch& s = data.scratch->net;
  // Raw pointers: the stores would otherwise make the
  // compiler reload the vectors' data pointers per node.
  const Vec3* rest = model.node_rest.data();
  const double* mass = model.node_mass.data();
  const NodeState* nodes = data.nodes.data();
  Vec3* lever_out = s.lever.data();
  Vec3* force = s.force.data();
  for (std::size_t k = 0; k < model.nets.size(); ++k) {
    const NetModel& net = model.nets[k];
    const auto bi = static_cast<std::size_t>(net.body);
    const BodyState& body = data.bodies[bi];
    const Mat3 rot = body.orientation.toRotationMatrix();
    Wrench reaction;
    double twice_kinetic = 0.0, tie2 = 0.0;  // Σ m |v|², Σ s |x − a|²
    Vec3 mass_moment = Vec3::Zero();         // Σ m x
    // kScaled: the ties per node (NetModel::tie_scale); else every tie alike, s = 1 folded away.
    const auto tie_pass = [&]<bool kScaled>() {
      for (int v = net.node_begin; v < net.node_begin + net.node_count; ++v) {
        const auto i = static_cast<std::size_t>(v);
        const Vec3 lever = rot * rest[i];
        lever_out[i] = lever;
        const Vec3 anchor = body.position + lever;
        const Vec3 anchor_velocity = body.linear_velocity + body.angular_velocity.cross(lever);
        const Vec3 dv = nodes[i].velocity - anchor_velocity;
        const Vec3 stretch = nodes[i].position - anchor;
        const double ts = kScaled ? net.tie_scale[static_cast<std::size_t>(v - net.node_begin)] : 1.0;
        const Vec3 f = -(ts * net.tie_stiffness) * stretch - (ts * net.tie_damping) * dv;
        force[i] = mass[i] * model.gravity + f;
        reaction.force -= f;
        reaction.torque -= lever.cross(f);
        twice_kinetic += mass[i] * nodes[i].velocity.squaredNorm();
        tie2 += ts * stretch.squaredNorm();
        mass_moment += mass[i] * nodes[i].position;
      }
    };
    if (net.tie_scale.empty())
      tie_pass.template operator()<false>();
    else
      tie_pass.template operator()<true>();
    // The springs' part is added by detail::add_spring_forces() (net_springs.cpp).
    data.nets[k].start_energy =
        0.5 * twice_kinetic + 0.5 * net.tie_stiffness * tie2 - model.gravity.dot(mass_moment);
    data.body_wrench[bi].force += reaction.force;
    data.body_wrench[bi].torque += reaction.torque;
    data.nets[k].tie_wrench = reaction;
  }
}

/// The look-ahead of the triangle contacts (NodeContact::engaged, face ≥ 0), decided for all
/// their shares alike before any contact force joins the nodes' forces: each node of the
/// triangle alone over the step, implicit, with its tie and its force at the start (gravity,
/// tie, springs); the triangle's point Σ w_m (v_m + Δv_m) against the body's point.
void look_ahead_triangle_contacts(const Model& model, Data& data, int nc) noexcept {
  const NetScratch& s = data.scratch->net;
  const NodeState* node_states = data.nodes.data();
  for (int c = 0; c < nc; ++c) {
    NodeContact& ct = data.node_contacts[static_cast<std::size_t>(c)];
    if (!ct.engaged || ct.face < 0) continue;
    const std::array<int, 3>& t = model.net_faces[static_cast<std::size_t>(ct.face)];
    const double h = model.dt;
    Vec3 v_point = Vec3::Zero();
    for (int m = 0; m < 3; ++m) {
      const auto v = static_cast<std::size_t>(t[static_cast<std::size_t>(m)]);
      const NetModel& net = model.nets[static_cast<std::size_t>(model.node_net[v])];
      const BodyState& body = data.bodies[static_cast<std::size_t>(net.body)];
      const Vec3 anchor_velocity = body.linear_velocity + body.angular_velocity.cross(s.lever[v]);
      const double ts = tie_scale(net, static_cast<int>(v));
      const Vec3 dv =
          h * (s.force[v] - h * ts * net.tie_stiffness * (node_states[v].velocity - anchor_velocity)) /
          (model.node_mass[v] + ts * (h * net.tie_damping + h * h * net.tie_stiffness));
      v_point += ct.face_weights[m] * (node_states[v].velocity + dv);
    }
    if (ct.body_b >= 0) {
      const BodyState& b = data.bodies[static_cast<std::size_t>(ct.body_b)];
      v_point -= b.linear_velocity + b.angular_velocity.cross(ct.position - b.position);
    }
    ct.engaged = ct.depth - h * ct.normal.dot(v_point) > 0.0;
  }
}

/// The time-constant floor (contact_force.hpp, SolverSettings::node_contact_max_omega_dt) on
/// the pair's stiffness `mp` of node contact `ct`: the node is a point mass (a tissue contact's
/// load patch, `on_patch`: the mass that moves its mean, 1 / Σ w_j² / m_j); a body on the other
/// side adds its mobility along n at the contact point (imposed: none). Counts
/// Data::contacts_clamped.
void floor_contact_stiffness(const Model& model, Data& data, const NodeContact& ct, bool on_patch,
                             MaterialPair& mp) noexcept {
  if (mp.stiffness > 0.0 &&
      model.solver.node_contact_max_omega_dt < std::numeric_limits<double>::infinity()) {
    double inv_mass = on_patch ? detail::patch_inverse_mass(model, data.scratch->net)
                               : detail::contact_node_inverse_mass(model, ct);
    if (ct.body_b >= 0 &&
        data.scratch->solver.imposed[static_cast<std::size_t>(ct.body_b)] == 0) {
      const auto b = static_cast<std::size_t>(ct.body_b);
      inv_mass += 1.0 / contact_effective_mass(model.bodies[b], data.bodies[b], ct.r_b, false,
                                               nullptr, nullptr, ct.r_b, false, ct.normal);
    }
    const double limit =
        contact_stiffness_limit(1.0 / inv_mass, model.dt, model.solver.node_contact_max_omega_dt);
    if (mp.stiffness > limit) {
      mp.stiffness = limit;
      ++data.contacts_clamped;
    }
  }
}

/// The force of a node contact `ct` that the law leaves inactive but NodeContact::engaged holds
/// (the look-ahead: below the surface at the step's end), into `r`: a node's, decided here over
/// the step; a tissue contact's (`tissue`, its law's elastic force `elastic`) or a triangle's,
/// decided by look_ahead_triangle_contacts(). `v_rel`: the contact point's velocity relative to
/// the body; `mp` the pair under the floor.
void engaged_contact_force(const Model& model, Data& data, NodeContact& ct, bool tissue,
                           double elastic, const Vec3& v_rel, const MaterialPair& mp,
                           ContactForceResult& r) noexcept {
  const auto i = static_cast<std::size_t>(ct.node);
  const NetScratch& s = data.scratch->net;
  if (ct.face < 0) {
    // The look-ahead (NodeContact::engaged): the node alone over the step, implicit, with its
    // tie (the component moving at its twist) and its force at the step's start.
    const NetModel& net = model.nets[static_cast<std::size_t>(model.node_net[i])];
    const BodyState& body = data.bodies[static_cast<std::size_t>(net.body)];
    const Vec3 anchor_velocity = body.linear_velocity + body.angular_velocity.cross(s.lever[i]);
    const double h = model.dt;
    const double ts = tie_scale(net, static_cast<int>(i));
    const Vec3 dv =
        h * (s.force[i] - h * ts * net.tie_stiffness * (data.nodes[i].velocity - anchor_velocity)) /
        (model.node_mass[i] + ts * (h * net.tie_damping + h * h * net.tie_stiffness));
    ct.engaged = ct.depth - h * ct.normal.dot(v_rel + dv) > 0.0;
    if (ct.engaged) {  // below the surface at the step's end: k d − c v_n, unclamped
      r.normal_force = mp.stiffness * ct.depth - mp.damping * ct.normal.dot(v_rel);
      r.force = r.normal_force * ct.normal;
      r.active = true;
      r.stiffness = mp.stiffness;
      r.damping = mp.damping;
      r.friction = 0.0;
    }
  } else if (tissue) {
    // A tissue contact's, decided above: its share of F(d) − c v_n ≥ 0 (r's coefficients
    // are the law's at d, already the share's).
    r.normal_force = std::max(0.0, ct.share * elastic - r.damping * ct.normal.dot(v_rel));
    r.force = r.normal_force * ct.normal;
    r.active = true;
    r.friction = 0.0;
  } else {  // a triangle's, decided above: its share of k d − c v_n ≥ 0
    r.normal_force =
        ct.share * std::max(0.0, mp.stiffness * ct.depth - mp.damping * ct.normal.dot(v_rel));
    r.force = r.normal_force * ct.normal;
    r.active = true;
    r.stiffness = ct.share * mp.stiffness;
    r.damping = ct.share * mp.damping;
    r.friction = 0.0;
  }
}

/// Node contact `c`'s force (of the `nc`, NodeContact; penalty law of contact_force.hpp, the node
/// on side a; the two-scale law of an organ given by its material, `any_tissue`): on its node
/// (a tissue contact's F(d) on its load patch) in NetScratch::force and the reaction on its body
/// in Data::body_wrench; its force, activity and the law's Jacobian coefficients in the contact.
/// A triangle contact's share (NodeContact::face) takes the law at the triangle's point,
/// Σ w_m v_m, and keeps its node's share w of the force and of the coefficients (net_surface.hpp).
void add_node_contact_force(const Model& model, Data& data, int c, int nc, bool any_tissue) noexcept {
  NetScratch& s = data.scratch->net;
  const NodeState* node_states = data.nodes.data();
  NodeContact& ct = data.node_contacts[static_cast<std::size_t>(c)];
  const auto i = static_cast<std::size_t>(ct.node);
  if (ct.held) {  // a grasp spring along its axis, its force set by the grasp stage (grasp.hpp)
    s.force[i] += ct.force;
    if (ct.body_b < 0) return;  // a thread's eyelet: the thread's step took the reaction
    Wrench& w = data.body_wrench[static_cast<std::size_t>(ct.body_b)];
    w.force -= ct.force;
    w.torque -= ct.r_b.cross(ct.force);
    return;
  }
  const NetModel* tissue = any_tissue ? detail::tissue_net(model, ct) : nullptr;
  if (tissue && ct.primary &&
      (c == 0 || !detail::same_contact(data.node_contacts[static_cast<std::size_t>(c - 1)], ct))) {
    // The sphere's deepest contact, at its first entry: all its entries seen through its load
    // patch (the others then find it in NetScratch::patch_*).
    int last = c + 1;
    while (last < nc && detail::same_contact(data.node_contacts[static_cast<std::size_t>(last)], ct)) ++last;
    detail::see_through_patch(model, data, s, *tissue, c, last);
  }
  // As detected, on the fine surface: the backstop's depth.
  const double fine_depth = tissue && ct.primary ? s.patch_fine_depth : ct.depth;
  const Vec3 v_point = detail::contact_node_value(
      model, ct, [&](int v) -> const Vec3& { return node_states[v].velocity; });
  Vec3 v_rel = v_point;
  ct.r_b.setZero();
  if (ct.body_b >= 0) {
    const BodyState& b = data.bodies[static_cast<std::size_t>(ct.body_b)];
    ct.r_b = ct.position - b.position;
    v_rel -= b.linear_velocity + b.angular_velocity.cross(ct.r_b);
  }
  MaterialPair mp = model.material_pairs[static_cast<std::size_t>(ct.material_pair)];
  floor_contact_stiffness(model, data, ct, tissue && ct.primary && s.patch_count > 0, mp);
  ct.stiffness = ct.share * mp.stiffness;
  double elastic = 0.0, patch = 0.0;  // a tissue contact's elastic force, and F(d) of it
  ContactForceResult r = tissue ? detail::tissue_node_contact_force(model, *tissue, ct, fine_depth, v_rel, mp,
                                                               elastic, patch)
                                : contact_penalty_force(ct.normal, ct.depth, v_rel, mp);
  if (ct.face >= 0) {  // the node's share of the triangle's contact
    r.force *= ct.share;
    r.normal_force *= ct.share;
    r.stiffness *= ct.share;
    r.damping *= ct.share;
    r.friction *= ct.share;
  }
  if (ct.engaged && !r.active) engaged_contact_force(model, data, ct, tissue != nullptr, elastic, v_rel, mp, r);
  ct.force = r.force;
  ct.active = r.active;
  if (r.active) {  // the law's Jacobian coefficients (k_eff, c, μ for the linear law)
    ct.stiffness = r.stiffness;
    ct.damping = r.damping;
    ct.friction = r.friction;
  }
  // The implicit step's h² K v₀ term uses the node's own relative velocity: with a triangle
  // contact's Jacobian lumped on its nodes (docs/organs.md, "Surface contacts") the same
  // K̃ must stand on both sides, else the triangle's nodes chatter.
  ct.normal_velocity =
      ct.normal.dot(ct.face < 0 ? v_rel : Vec3(v_rel - v_point + data.nodes[i].velocity));
  if (!r.active) return;
  if (tissue) {  // F(d) on the load patch, the excess, damping and friction on the node
    const Vec3 on_patch = std::min(ct.share * patch, r.normal_force) * ct.normal;
    if (ct.primary) detail::lay_on_patch(s, ct.node, on_patch);
    s.force[i] += r.force - on_patch;
  } else {
    s.force[i] += r.force;
  }
  if (ct.body_b >= 0) {
    Wrench& w = data.body_wrench[static_cast<std::size_t>(ct.body_b)];
    w.force -= r.force;
    w.torque -= ct.r_b.cross(r.force);
  }
}

}  // namespace

void compute_net_forces(const Model& model, Data& data) noexcept {
  if (model.nets.empty()) return;
  data.stages_run |= kStageNetForces;  // the stage report (step_stages.hpp)
  detail::hold_resting_nodes(model, data);  // the nodes found at rest last step: held, v = 0
  add_ties_and_gravity(model, data);
  // Structural and bending springs; a still node's from its last pass (net_still.hpp).
  detail::add_spring_forces(model, data);
  // Node contacts, the held nodes' grasp springs included: the triangle contacts' look-ahead
  // decided for all their shares before any contact force joins the nodes' forces.
  const int nc = detail::node_contact_count(data);
  look_ahead_triangle_contacts(model, data, nc);
  bool any_tissue = false;  // an organ given by its material among the nets (detail::tissue_net())
  for (const NetModel& net : model.nets) any_tissue = any_tissue || net.contact_modulus > 0.0;
  for (int c = 0; c < nc; ++c) add_node_contact_force(model, data, c, nc, any_tissue);
  // Which nodes rest in this step's solve, from their forces and contacts (net_rest.hpp).
  detail::update_resting_nodes(model, data);
}

void integrate_nodes_symplectic(const Model& model, Data& data) noexcept {
  const double h = model.dt;
  for (std::size_t i = 0; i < data.nodes.size(); ++i) {
    NodeState& st = data.nodes[i];
    st.velocity += (h / model.node_mass[i]) * data.scratch->net.force[i];
    st.position += h * st.velocity;
  }
}

void integrate_nodes_implicit(const Model& model, Data& data) noexcept {
  const double h = model.dt;
  const double scale = h / data.scratch->solver.system_step;  // 1 (Euler) or 2 (trapezoidal), exact
  for (std::size_t i = 0; i < data.nodes.size(); ++i) {
    NodeState& st = data.nodes[i];
    const Vec3 v_move = st.velocity + data.scratch->net.delta[i];  // v1 (Euler) or v½ (trapezoidal)
    st.position += h * v_move;
    st.velocity += scale * data.scratch->net.delta[i];
  }
}

void measure_nets(const Model& model, Data& data) noexcept {
  data.stages_run |= kStageMeasureNets;  // the stage report (step_stages.hpp)
  for (std::size_t k = 0; k < model.nets.size(); ++k) {
    const NetModel& net = model.nets[k];
    NetOutput& out = data.nets[k];
    const auto bi = static_cast<std::size_t>(net.body);
    const BodyState& body = data.bodies[bi];
    const Mat3 rot = body.orientation.toRotationMatrix();
    // An anchored body (an organ's) is imposed at the same pose every step, also after a
    // rollback: its levers R r_i are the ones the force pass stored (NetScratch::lever), the
    // same to the bit. (Not a kDirect body's: a rollback restores the pose it had before.)
    const bool anchored = model.bodies[bi].anchored;
    const Vec3* lever = data.scratch->net.lever.data();
    double stretch2 = 0.0;
    double speed2 = 0.0;
    double kinetic = 0.0;
    for (int v = net.node_begin; v < net.node_begin + net.node_count; ++v) {
      const auto i = static_cast<std::size_t>(v);
      const NodeState& st = data.nodes[i];
      const Vec3 anchor = body.position + (anchored ? lever[i] : Vec3(rot * model.node_rest[i]));
      raise_max(stretch2, (st.position - anchor).squaredNorm());
      const double v2 = st.velocity.squaredNorm();
      raise_max(speed2, v2);
      kinetic += 0.5 * model.node_mass[i] * v2;
    }
    // |l − L| / L = |√(l²/L²) − 1| is largest at the largest or the smallest
    // l²/L²: one square root per net, not per spring.
    double ratio2_max = 1.0;
    double ratio2_min = 1.0;
    for (int e = net.spring_begin; e < net.spring_begin + net.structural_count; ++e) {
      const NetSpring& sp = model.net_springs[static_cast<std::size_t>(e)];
      const double l2 = (data.nodes[static_cast<std::size_t>(sp.node_b)].position -
                         data.nodes[static_cast<std::size_t>(sp.node_a)].position)
                            .squaredNorm();
      const double ratio2 = l2 / (sp.rest_length * sp.rest_length);
      raise_max(ratio2_max, ratio2);
      if (ratio2 < ratio2_min) ratio2_min = ratio2;
    }
    // The watched tetrahedra (well shaped at rest) turned inside out, flat or not finite.
    int inverted = 0;
    const auto x = [&](int v) -> const Vec3& { return data.nodes[static_cast<std::size_t>(v)].position; };
    for (int e = net.tetrahedron_begin; e < net.tetrahedron_begin + net.tetrahedron_count; ++e) {
      const std::array<int, 4>& t = model.net_tetrahedra[static_cast<std::size_t>(e)];
      inverted += tetrahedron_six_volume(x(t[0]), x(t[1]), x(t[2]), x(t[3])) > 0.0 ? 0 : 1;
    }
    out.inverted_tetrahedra = inverted;
    out.max_tie_stretch = std::sqrt(stretch2);
    out.max_node_speed = std::sqrt(speed2);
    out.kinetic_energy = kinetic;
    out.max_strain = std::max(std::sqrt(ratio2_max) - 1.0, 1.0 - std::sqrt(ratio2_min));
    if (std::isnan(ratio2_max)) out.max_strain = ratio2_max;  // a NaN met is kept (raise_max)
  }
}

}  // namespace numen::core
