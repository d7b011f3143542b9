/// @file integrator_tr_bdf2.cpp
/// Linearised TR-BDF2 (Integrator::kTrBdf2; Bank et al. 1985, Hosea & Shampine 1996) on the
/// systems of the linearly implicit Euler (integrator.hpp, implicit_system.hpp): a trapezoidal
/// stage to t + γh, γ = 2 − √2, then BDF2 to t + h, both applied to the step's linearisation,
/// with the one system matrix A = M − h_s D − h_s² K, h_s = γh/2 = (1 − γ)/(2 − γ) h, of both
/// stages. docs/dynamics.md derives the stage equations.

#include <algorithm>
#include <cstddef>
#include <cstdint>

#include "numen/core/capacity.hpp"
#include "numen/core/data.hpp"
#include "numen/core/features.hpp"
#include "numen/core/integrator.hpp"
#include "numen/core/model.hpp"
#include "numen/core/rigid_body.hpp"
#include "numen/core/step_stages.hpp"

#include "scratch/data_scratch.hpp"
#include "solver/implicit_system.hpp"
#include "net/net_solve.hpp"
#include "net/net_terms.hpp"
#include "solver/solver_terms.hpp"

namespace numen::core {
namespace {

using detail::couples_body;
using detail::node_contact_count;
using detail::point_velocity;

Vec6 twist_of(const BodyState& st) noexcept {
  Vec6 u;
  u << st.linear_velocity, st.angular_velocity;
  return u;
}

/// Pose x0 ⊕ d of a body at `start` moved by d = (Δx, θ) (m; rotation vector, rad, world):
/// x0 + Δx, exp(½ θ) ⊗ q0 (unit).
void move_pose(const BodyState& start, const Vec6& d, BodyState& st) noexcept {
  st.position = start.position + d.head<3>();
  st.orientation = integrate_orientation(start.orientation, d.tail<3>(), 1.0);
}

/// Adds the contacts' part of a h_s K w to the bodies' and the nodes' right-hand sides, w the
/// displacement per body (SolverScratch::stage_move) and node (NetScratch::stage_move) scaled
/// by a / h_s: b += −h_s² k Gᵀ n (n · G w̃), w̃ = (a / h_s) Δx_γ. The builders take the contacts'
/// K u0 from the normal velocities the forces stage stored (ContactTerm::normal_velocity,
/// NodeContact::normal_velocity), which stay those of the step's start; this adds the rest of
/// K ũ (ũ = u0 + w̃) for them.
void add_contact_stage_terms(const Model& model, Data& data, double weight) noexcept {
  SolverScratch& s = data.scratch->solver;
  const double h = s.system_step;
  const double h2 = h * h;
  const auto moved = [&](int b, const Vec3& r) noexcept {
    return b >= 0 ? point_velocity(s.stage_move[static_cast<std::size_t>(b)], r) : Vec3(Vec3::Zero());
  };
  const int nc = std::min(data.num_contacts, static_cast<int>(s.contact_terms.size()));
  for (int c = 0; c < nc; ++c) {
    const ContactTerm& t = s.contact_terms[static_cast<std::size_t>(c)];
    if (!t.active) continue;
    const Contact& ct = data.contacts[static_cast<std::size_t>(c)];
    const Vec3& n = ct.normal;
    const double wn = weight * n.dot(moved(ct.body_a, t.r_a) - moved(ct.body_b, t.r_b));
    const double impulse = -h2 * t.stiffness * wn;  // along n on a, −n on b
    const auto a = static_cast<std::size_t>(ct.body_a);
    if (s.in_solve[a]) {
      s.rhs[a].head<3>() += impulse * n;
      s.rhs[a].tail<3>() += impulse * t.r_a.cross(n);
    }
    if (ct.body_b >= 0 && s.in_solve[static_cast<std::size_t>(ct.body_b)]) {
      const auto b = static_cast<std::size_t>(ct.body_b);
      s.rhs[b].head<3>() -= impulse * n;
      s.rhs[b].tail<3>() -= impulse * t.r_b.cross(n);
    }
  }
  if constexpr (kWithDeformable) {
    if (model.nets.empty()) return;
    NetScratch& ns = data.scratch->net;
    const int nn = node_contact_count(data);
    for (int c = 0; c < nn; ++c) {
      const NodeContact& ct = data.node_contacts[static_cast<std::size_t>(c)];
      if (!ct.active) continue;
      const auto i = static_cast<std::size_t>(ct.node);
      const double wn =
          weight * ct.normal.dot(ns.stage_move[i] - moved(ct.body_b, ct.r_b));
      const double impulse = -h2 * ct.stiffness * wn;  // on the node along n, −n on the body
      ns.rhs[i] += impulse * ct.normal;
      if (couples_body(s, ct)) {
        const auto b = static_cast<std::size_t>(ct.body_b);
        s.rhs[b].head<3>() -= impulse * ct.normal;
        s.rhs[b].tail<3>() -= impulse * ct.r_b.cross(ct.normal);
      }
    }
  }
}

/// Stage 1: the linearised trapezoidal rule over γh (system step h_s = γh/2), as
/// integrate_trapezoidal() over a step γh: Δu½ solves A Δu½ = h_s (f0 + h_s K u0) + M (u* − u0),
/// u_γ = u0 + 2 Δu½, x_γ = x0 ⊕ γh (u0 + Δu½). Writes the stage's start (SolverScratch::
/// stage_start, NetScratch::stage_velocity), its gyroscopic change ω* − ω0 (stage_gyro), its
/// move Δx_γ (stage_move) and velocity change Δu_γ (stage_delta) per body and node.
void trapezoidal_stage(const Model& model, Data& data, bool nets, double hs) noexcept {
  SolverScratch& s = data.scratch->solver;
  const double h_gamma = 2.0 * hs;  // γh: the trapezoidal stage's length
  const std::size_t nb = data.bodies.size();
  for (std::size_t i = 0; i < nb; ++i) s.stage_start[i] = data.bodies[i];
  if constexpr (kWithDeformable) {
    if (nets) {
      NetScratch& ns = data.scratch->net;
      for (std::size_t k = 0; k < data.nodes.size(); ++k) ns.stage_velocity[k] = data.nodes[k].velocity;
      linearize_nets(model, data, hs);  // before the gyroscopic step changes the bodies' ω
    }
  }
  s.joint_drift_step = h_gamma;
  s.joint_horizon = h_gamma;
  s.joint_rate_from_stage_start = false;
  s.joint_rows_at_drift_end = false;
  prepare_implicit_step(model, data);
  for (std::size_t i = 0; i < nb; ++i)
    s.stage_gyro[i] = data.bodies[i].angular_velocity - s.twist0[i].tail<3>();  // ω* − ω0
  build_implicit_system(model, data);
  if constexpr (kWithDeformable) {
    if (nets) build_net_system(model, data);
  }
  solve_linearized_system(model, data);
  for (std::size_t i = 0; i < nb; ++i) {
    if (!s.in_solve[i]) {  // kDirect: moves with its imposed twist
      s.stage_move[i] = h_gamma * s.twist0[i];
      s.stage_delta[i].setZero();
      continue;
    }
    s.stage_move[i] = h_gamma * (s.twist0[i] + s.delta[i]);
    s.stage_delta[i] = 2.0 * s.delta[i];
  }
  if constexpr (kWithDeformable) {
    if (nets) {
      NetScratch& ns = data.scratch->net;
      for (std::size_t k = 0; k < data.nodes.size(); ++k) {
        ns.stage_move[k] = h_gamma * (ns.stage_velocity[k] + ns.delta[k]);
        ns.stage_delta[k] = 2.0 * ns.delta[k];
      }
    }
  }
}

#if NUMEN_WITH_ARTICULATION
/// RATTLE at stage 1's end, x_γ (as the trapezoidal rule at its step's end): u_γ without the
/// second copy of the stage's joint impulse, projected onto G(x_γ) u_γ = v_ref; rewrites
/// stage_delta and puts the bodies back at x0 (the rows of stage 2 start there).
void project_stage_end(const Model& model, Data& data, double h_gamma) noexcept {
  SolverScratch& s = data.scratch->solver;
  const std::size_t nb = data.bodies.size();
  for (std::size_t i = 0; i < nb; ++i) {
    if (!s.in_solve[i]) continue;
    BodyState& st = data.bodies[i];
    move_pose(s.stage_start[i], s.stage_move[i], st);
    const Vec6 u = s.twist0[i] + s.stage_delta[i];
    st.linear_velocity = u.head<3>();
    st.angular_velocity = u.tail<3>();
  }
  project_joint_velocities(model, data, h_gamma, true);
  for (std::size_t i = 0; i < nb; ++i) {
    if (!s.in_solve[i]) continue;
    s.stage_delta[i] = twist_of(data.bodies[i]) - s.twist0[i];
    data.bodies[i].position = s.stage_start[i].position;
    data.bodies[i].orientation = s.stage_start[i].orientation;
  }
}
#endif

/// Stage 2: BDF2 to t + h on the same linearisation, y1 = a y_γ − (a − 1) y0 + h_s F(y1):
///   A Δu = h_s (f0 + h_s K ũ) + a M Δu_γ + M (u* − u0),   ũ = u0 + (a / h_s) Δx_γ.
/// The builders take K ũ from the twists and node velocities they read: they are set to ũ
/// (the gyroscopic impulse M (u* − u0) of stage 1 kept through ω = ũ_ω + ω* − ω0); the
/// contacts' stored normal velocities are completed by add_contact_stage_terms(). Solves for
/// Δu (SolverScratch::delta, NetScratch::delta).
void bdf2_stage(const Model& model, Data& data, bool nets, double hs) noexcept {
  SolverScratch& s = data.scratch->solver;
  const double a = tr_bdf2::kStageWeight;
  const std::size_t nb = data.bodies.size();
  const double w = a / hs;
  for (std::size_t i = 0; i < nb; ++i) {
    BodyState& st = data.bodies[i];
    const Vec6 u0 = twist_of(s.stage_start[i]);
    s.twist0[i] = u0 + w * s.stage_move[i];  // ũ
    st.linear_velocity = s.twist0[i].head<3>();
    st.angular_velocity = s.twist0[i].tail<3>();
  }
  if constexpr (kWithDeformable) {
    if (nets) {
      NetScratch& ns = data.scratch->net;
      for (std::size_t k = 0; k < data.nodes.size(); ++k)
        data.nodes[k].velocity = ns.stage_velocity[k] + w * ns.stage_move[k];
      linearize_nets(model, data, hs);  // the springs' and ties' K ṽ
    }
  }
  for (std::size_t i = 0; i < nb; ++i) data.bodies[i].angular_velocity += s.stage_gyro[i];
  build_implicit_system(model, data);
  for (std::size_t i = 0; i < nb; ++i) {
    if (!s.in_solve[i] || (s.first_order && static_cast<int>(i) == s.coupled_body)) continue;
    s.rhs[i].head<3>() += (a * model.bodies[i].mass) * s.stage_delta[i].head<3>();
    s.rhs[i].tail<3>() += a * (s.inertia_world[i] * s.stage_delta[i].tail<3>());
  }
  if constexpr (kWithDeformable) {
    if (nets) {
      build_net_system(model, data);
      NetScratch& ns = data.scratch->net;
      for (std::size_t k = 0; k < data.nodes.size(); ++k)
        ns.rhs[k] += (a * model.node_mass[k]) * ns.stage_delta[k];
    }
  }
  add_contact_stage_terms(model, data, w);
  s.joint_drift_step = hs;
  s.joint_horizon = model.dt;
  s.joint_rate_from_stage_start = true;
  s.joint_rows_at_drift_end = true;
  solve_linearized_system(model, data);
}

/// The step's end: u1 = u0 + Δu, x1 = x0 ⊕ (a Δx_γ + h_s u1) per body (a kDirect body stays at
/// its imposed target) and node.
void advance_to_step_end(Data& data, bool nets, double hs) noexcept {
  SolverScratch& s = data.scratch->solver;
  const double a = tr_bdf2::kStageWeight;
  for (std::size_t i = 0; i < data.bodies.size(); ++i) {
    BodyState& st = data.bodies[i];
    if (!s.in_solve[i]) {  // kDirect: stays at the imposed target
      st = s.stage_start[i];
      continue;
    }
    const Vec6 u1 = twist_of(s.stage_start[i]) + s.delta[i];
    move_pose(s.stage_start[i], a * s.stage_move[i] + hs * u1, st);
    st.linear_velocity = u1.head<3>();
    st.angular_velocity = u1.tail<3>();
  }
  if constexpr (kWithDeformable) {
    if (nets) {
      NetScratch& ns = data.scratch->net;
      for (std::size_t k = 0; k < data.nodes.size(); ++k) {
        NodeState& nd = data.nodes[k];
        const Vec3 v1 = ns.stage_velocity[k] + ns.delta[k];
        nd.position += a * ns.stage_move[k] + hs * v1;
        nd.velocity = v1;
      }
    }
  }
}

}  // namespace

void integrate_tr_bdf2(const Model& model, Data& data) noexcept {
  SolverScratch& s = data.scratch->solver;
  const double hs = tr_bdf2::kStageStep * model.dt;  // h_s of both stages
  const bool nets = kWithDeformable && (model.stage_plan & kStageNetSolve) != 0;
  s.system_step = hs;
  trapezoidal_stage(model, data, nets, hs);
  const int stage1_iterations = data.solver_iterations;
  const double stage1_residual = data.solver_residual;
#if NUMEN_WITH_ARTICULATION
  if (!model.joints.empty()) project_stage_end(model, data, 2.0 * hs);
#endif
  bdf2_stage(model, data, nets, hs);
  data.solver_iterations += stage1_iterations;
  if (stage1_residual > data.solver_residual) data.solver_residual = stage1_residual;
  advance_to_step_end(data, nets, hs);
#if NUMEN_WITH_ARTICULATION
  if (!model.joints.empty()) project_joint_velocities(model, data, model.dt, false);  // onto G(x1) u1 = v_ref
#endif
  s.joint_rate_from_stage_start = false;
  s.joint_rows_at_drift_end = false;
}

}  // namespace numen::core
