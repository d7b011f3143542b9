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

namespace {

/// The springs' pass of compute_net_forces(), in the sweep order (grouped by
/// their smaller node k, whose sums stay in registers): forces, and with
/// kImplicit the linearisation of the implicit solve — the weights
/// W_e = α d̂d̂ᵀ + β I (SweepSpring), their sum into both nodes' diagonal
/// blocks, and the spring part of the node rows' right-hand side,
/// −h² k K̃ (v_i − v_j) with k K̃ = (h² k − β)/h² d̂d̂ᵀ + β/h² I
/// (net_solve.hpp). Expects force = gravity + ties and, with kImplicit,
/// block = 0 and rhs = 0 on entry.
template <bool kImplicit>
void spring_pass(const Model& model, Data& data) noexcept {
  NetScratch& s = data.net;
  const double h = data.solver.system_step;  // h_s of the linearised system (integrator.hpp)
  const double h2 = h * h;
  // Raw pointers: the stores below would otherwise make the compiler reload
  // every vector's data pointer per spring.
  const NodeState* nodes = data.nodes.data();
  const SweepSpringConstants* constants = s.spring_constants.data();
  const std::int32_t* low_begin = s.spring_low_begin.data();
  SweepSpring* springs = s.sweep_springs.data();
  double* lengths = s.spring_length.data();
  Vec3* force = s.force.data();
  Mat3* block = s.block.data();
  Vec3* rhs = s.rhs.data();
  const std::size_t n = data.nodes.size();
  for (std::size_t k = 0; k < n; ++k) {
    const Vec3 xk = nodes[k].position;
    const Vec3 vk = nodes[k].velocity;
    Vec3 fk = Vec3::Zero();
    Vec3 bk = Vec3::Zero();
    double s00 = 0.0, s01 = 0.0, s02 = 0.0, s11 = 0.0, s12 = 0.0, s22 = 0.0;
    for (std::int32_t j = low_begin[k]; j < low_begin[k + 1]; ++j) {
      const SweepSpringConstants& c = constants[j];
      SweepSpring& sp = springs[j];
      const auto hi = static_cast<std::size_t>(sp.high);
      const Vec3 d = nodes[hi].position - xk;
      const double l = d.norm();
      const double inv_l = 1.0 / l;
      if (l > 1e-12 * c.rest_length) sp.direction = d * inv_l;  // else: keep the last direction
      lengths[j] = l;
      const Vec3 n_ = sp.direction;
      const Vec3 dv = nodes[hi].velocity - vk;
      const double n_dv = n_.dot(dv);
      const Vec3 f = (c.stiffness * (l - c.rest_length) + c.damping * n_dv) * n_;
      fk += f;
      force[hi] -= f;
      if constexpr (kImplicit) {
        // K̃ = (1 − τ) d̂d̂ᵀ + τ I, τ = max(0, 1 − L/l): −∂f_k/∂x_k / k.
        const double hk = h2 * c.stiffness;
        const double beta = l > c.rest_length ? hk * (1.0 - c.rest_length * inv_l) : 0.0;
        const double alpha = h * c.damping + hk - beta;
        sp.weight_axial = alpha;
        sp.weight_isotropic = beta;
        const double ax = alpha * n_.x(), ay = alpha * n_.y(), az = alpha * n_.z();
        const double w00 = ax * n_.x() + beta, w11 = ay * n_.y() + beta, w22 = az * n_.z() + beta;
        const double w01 = ax * n_.y(), w02 = ax * n_.z(), w12 = ay * n_.z();
        s00 += w00;
        s01 += w01;
        s02 += w02;
        s11 += w11;
        s12 += w12;
        s22 += w22;
        Mat3& bh = block[hi];
        bh(0, 0) += w00;
        bh(0, 1) += w01;
        bh(0, 2) += w02;
        bh(1, 0) += w01;
        bh(1, 1) += w11;
        bh(1, 2) += w12;
        bh(2, 0) += w02;
        bh(2, 1) += w12;
        bh(2, 2) += w22;
        // h² k K̃ (v_h − v_k) = (hk − β) d̂ (d̂ · dv) + β dv: + on row k, − on row h.
        const Vec3 kv = ((hk - beta) * n_dv) * n_ + beta * dv;
        bk += kv;
        rhs[hi] -= kv;
      }
    }
    force[k] += fk;
    if constexpr (kImplicit) {
      rhs[k] += bk;
      Mat3& b = block[k];
      b(0, 0) += s00;
      b(0, 1) += s01;
      b(0, 2) += s02;
      b(1, 0) += s01;
      b(1, 1) += s11;
      b(1, 2) += s12;
      b(2, 0) += s02;
      b(2, 1) += s12;
      b(2, 2) += s22;
    }
  }
}

}  // namespace

void compute_net_forces(const Model& model, Data& data) noexcept {
  if (model.nets.empty()) return;
  NetScratch& s = data.net;
  // The linearised schemes (implicit Euler, trapezoidal) need the springs' Jacobian blocks too.
  const bool implicit = model.integrator != Integrator::kSymplecticEuler;

  // Gravity, and the zero-length ties to the rigid component with their
  // reaction on it.
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
      s.force[i] = model.node_mass[i] * model.gravity + f;
      if (implicit) {
        s.block[i].setZero();
        s.rhs[i].setZero();
      }
      reaction.force -= f;
      reaction.torque -= lever.cross(f);
    }
    data.body_wrench[bi].force += reaction.force;
    data.body_wrench[bi].torque += reaction.torque;
    data.nets[k].tie_wrench = reaction;
  }

  // Structural and bending springs (and their linearisation).
  if (implicit) {
    spring_pass<true>(model, data);
  } else {
    spring_pass<false>(model, data);
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
    const Mat3 rot = body.orientation.toRotationMatrix();
    double stretch2 = 0.0;
    double speed2 = 0.0;
    double kinetic = 0.0;
    for (int v = net.node_begin; v < net.node_begin + net.node_count; ++v) {
      const auto i = static_cast<std::size_t>(v);
      const NodeState& st = data.nodes[i];
      const Vec3 anchor = body.position + rot * model.node_rest[i];
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
    out.max_tie_stretch = std::sqrt(stretch2);
    out.max_node_speed = std::sqrt(speed2);
    out.kinetic_energy = kinetic;
    out.max_strain = std::max(std::sqrt(ratio2_max) - 1.0, 1.0 - std::sqrt(ratio2_min));
    if (std::isnan(ratio2_max)) out.max_strain = ratio2_max;  // a NaN met is kept (raise_max)
  }
}

}  // namespace numen::core
