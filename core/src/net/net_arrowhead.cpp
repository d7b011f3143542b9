/// @file net_arrowhead.cpp
/// The coupled solve of the bodies and the deformable nets with joints
/// (net_solve.hpp): the arrowhead preconditioner — every body block, every
/// node's 3×3 block and the tie blocks inverted exactly by eliminating the
/// nodes onto the bodies, the body part by the tree solve with the Schur
/// blocks — as constraint preconditioner of a projected CG (detail::pcg()).

#include <algorithm>
#include <cmath>
#include <span>

#include "scratch/data_scratch.hpp"
#include "solver/implicit_system.hpp"
#include "articulation/joint_system.hpp"
#include "net/net_rest.hpp"
#include "net/net_solve.hpp"
#include "net/net_terms.hpp"
#include "linalg/pcg.hpp"
#include "numen/core/articulation.hpp"
#include "numen/core/data.hpp"
#include "numen/core/features.hpp"
#include "numen/core/integrator.hpp"
#include "numen/core/model.hpp"

#if NUMEN_WITH_ARTICULATION
namespace numen::core::detail {
namespace {

/// out = A · in over bodies and nodes (see net_solve.hpp for A).
void apply_coupled(const Model& model, const Data& data, std::span<const Vec6> in_b,
                   std::span<const Vec3> in_n, std::span<Vec6> out_b,
                   std::span<Vec3> out_n) noexcept {
  const SolverScratch& s = data.scratch->solver;
  const NetScratch& ns = data.scratch->net;
  apply_implicit_system(model, data, in_b, out_b);
  // Node rows: (m + c) p_i, then each spring's S (p_a − p_b) (its diagonal and
  // off-diagonal blocks at once), each node contact's W p_i, the ties' and
  // node–body contacts' off-diagonal blocks.
  // The rows of the nodes in the solve (net_rest.hpp); a resting node's entry of `in` is 0
  // (the Dirichlet value) and its row of `out` is never read.
  for_active_nodes(model, ns, [&](std::size_t i) { out_n[i] = ns.node_diagonal[i] * in_n[i]; });
  // Springs by their earlier node k in the sweep order: w = W_e (p_k − p_high), + on row k,
  // − on row high; those that touch a node in the solve.
  const Vec3* x = in_n.data();
  Vec3* y = out_n.data();
  const SpringView sp(ns);
  const std::int32_t* order = model.node_sweep_order.data();
  for (std::size_t n = 0; n < model.nets.size(); ++n) {
    const std::int32_t* positions = ns.pass_positions.data() + model.nets[n].node_begin;
    for (int a = 0; a < ns.pass_count[n]; ++a) {
      const auto p = static_cast<std::size_t>(positions[a]);
      const auto k = static_cast<std::size_t>(order[p]);
      y[k] += spring_differences(sp, sp.low_begin[p], sp.low_begin[p + 1], x[k], x, y);
    }
  }
  const double h = data.scratch->solver.system_step;  // h_s of the linearised system (integrator.hpp)
  for (const NetModel& net : model.nets) {
    const auto b = static_cast<std::size_t>(net.body);
    if (!s.in_solve[b]) continue;
    const double c = tie_weight(net, h);
    Vec6 acc = Vec6::Zero();
    for (int v = net.node_begin; v < net.node_begin + net.node_count; ++v) {
      const auto i = static_cast<std::size_t>(v);
      out_n[i] -= c * point_velocity(in_b[b], ns.lever[i]);
      acc += generalized_force(in_n[i], ns.lever[i]);
    }
    out_b[b] -= c * acc;
  }
  const int nc = node_contact_count(data);
  for (int k = 0; k < nc; ++k) {
    const NodeContact& ct = data.node_contacts[static_cast<std::size_t>(k)];
    if (!ct.active) continue;
    const auto i = static_cast<std::size_t>(ct.node);
    out_n[i] += weight_times(ct.weight_normal, ct.weight_isotropic, ct.normal, in_n[i]);
    if (!couples_body(s, ct)) continue;
    const auto b = static_cast<std::size_t>(ct.body_b);
    out_n[i] -= weight_times(ct.weight_normal, ct.weight_isotropic, ct.normal,
                             point_velocity(in_b[b], ct.r_b));
    out_b[b] -= generalized_force(
        weight_times(ct.weight_normal, ct.weight_isotropic, ct.normal, in_n[i]), ct.r_b);
  }
}

/// The coupled system with joints for detail::pcg(): A over bodies and nodes
/// (apply_coupled()), the arrowhead preconditioner as constraint
/// preconditioner with Gould, Hribar & Nocedal's residual update, the
/// Euclidean ‖r‖ / ref over bodies and nodes.
struct ArrowheadSystem {
  const Model& model;
  Data& data;
  std::span<Vec6> xb, rb, zb, pb, apb, tb, rp;
  std::span<Vec3> xn, rn, zn, pn, apn;
  std::span<JointVector> y, yz;
  double ref = 1.0;

  /// z = P⁻¹ r with the arrowhead preconditioner: nodes eliminated onto the
  /// bodies, body part by the tree solve with the Schur blocks S_b and
  /// `constraint_rhs` (yz holds the constraint part).
  void precondition_with(std::span<const JointVector> constraint_rhs) noexcept {
    const SolverScratch& s = data.scratch->solver;
    const NetScratch& ns = data.scratch->net;
    const double h = s.system_step;  // h_s of the linearised system (integrator.hpp)
    for_active_nodes(model, ns,
                     [&](std::size_t i) { zn[i].noalias() = ns.block_inverse[i] * rn[i]; });
    for (std::size_t b = 0; b < rb.size(); ++b) tb[b] = rb[b];
    add_tie_transpose(model, data, zn, tb);
    // The node–body contacts' blocks (build_net_system()): t_b += Σ J_kᵀ W_k z_i.
    const int nc = node_contact_count(data);
    for (int k = 0; k < nc; ++k) {
      const NodeContact& ct = data.node_contacts[static_cast<std::size_t>(k)];
      if (!couples_body(s, ct)) continue;
      tb[static_cast<std::size_t>(ct.body_b)] += generalized_force(
          weight_times(ct.weight_normal, ct.weight_isotropic, ct.normal,
                       zn[static_cast<std::size_t>(ct.node)]),
          ct.r_b);
    }
    solve_articulation(model, data.scratch->articulation, tb, constraint_rhs, zb, yz);
    for (int k = 0; k < nc; ++k) {
      const NodeContact& ct = data.node_contacts[static_cast<std::size_t>(k)];
      if (!couples_body(s, ct)) continue;
      const auto i = static_cast<std::size_t>(ct.node);
      zn[i].noalias() += ns.block_inverse[i] *
                         weight_times(ct.weight_normal, ct.weight_isotropic, ct.normal,
                                      point_velocity(zb[static_cast<std::size_t>(ct.body_b)], ct.r_b));
    }
    for (const NetModel& net : model.nets) {
      const auto b = static_cast<std::size_t>(net.body);
      if (!s.in_solve[b]) continue;
      const double c = tie_weight(net, h);
      for (int v = net.node_begin; v < net.node_begin + net.node_count; ++v) {
        const auto i = static_cast<std::size_t>(v);
        zn[i].noalias() += c * (ns.block_inverse[i] * point_velocity(zb[b], ns.lever[i]));
      }
    }
  }
  /// r ← r − Gᵀ yz (same z, since P Gᵀ = 0) and y += yz (Gould, Hribar &
  /// Nocedal's residual update; see solve_constrained_system()).
  void update_residual() noexcept {
    for (std::size_t b = 0; b < rb.size(); ++b) rp[b].setZero();
    add_joint_transpose(model, data, yz, rp);
    for (std::size_t b = 0; b < rb.size(); ++b) rb[b] -= rp[b];
    for (std::size_t j = 0; j < y.size(); ++j) y[j] += yz[j];
  }
  /// The preconditioned and projected residual's measure ‖r‖ / ref.
  double project() noexcept {
    precondition_with(data.scratch->solver.joint_rhs);
    update_residual();
    return std::sqrt(dot(rb, rb) + node_dot(rn, rn)) / ref;
  }
  /// Σ a_i · b_i over the nodes in the solve.
  double node_dot(std::span<const Vec3> a, std::span<const Vec3> b) const noexcept {
    double sum = 0.0;
    for_active_nodes(model, data.scratch->net, [&](std::size_t i) { sum += a[i].dot(b[i]); });
    return sum;
  }
  double apply() noexcept {
    apply_coupled(model, data, pb, pn, apb, apn);
    return dot(pb, apb) + node_dot(pn, apn);
  }
  double advance(double alpha) noexcept {
    for (std::size_t b = 0; b < xb.size(); ++b) {
      xb[b] += alpha * pb[b];
      rb[b] -= alpha * apb[b];
    }
    for_active_nodes(model, data.scratch->net, [&](std::size_t i) {
      xn[i] += alpha * pn[i];
      rn[i] -= alpha * apn[i];
    });
    return project();
  }
  double precondition() noexcept { return dot(rb, zb) + node_dot(rn, zn); }  // z: project()'s
  void direction(double beta) noexcept {
    for (std::size_t b = 0; b < pb.size(); ++b) pb[b] = zb[b] + beta * pb[b];
    for_active_nodes(model, data.scratch->net,
                     [&](std::size_t i) { pn[i] = zn[i] + beta * pn[i]; });
  }
};

}  // namespace

bool solve_net_arrowhead(const Model& model, Data& data) noexcept {
  SolverScratch& s = data.scratch->solver;
  NetScratch& ns = data.scratch->net;
  ArticulationScratch& art = data.scratch->articulation;
  const std::size_t nb = data.bodies.size();

  for (std::size_t i = 0; i < nb; ++i) art.known[i] = s.in_solve[i] ? 0 : 1;
  build_joint_rows(model, data, s.twist0, s.delta, s.joint_rhs);  // s.delta: Δu_prev
  factor_articulation(model, ns.body_schur, art);  // a bad pivot leaves NaN: rejected below

  ArrowheadSystem sys{model,
                      data,
                      s.delta,
                      s.residual,
                      s.precond_residual,
                      s.direction,
                      s.a_direction,
                      ns.body_tmp,
                      s.projected_residual,
                      ns.delta,
                      ns.residual,
                      ns.precond_residual,
                      ns.direction,
                      ns.a_direction,
                      s.joint_y,
                      s.joint_y_correction};
  const std::span<const Vec6> bb(s.rhs);
  const std::span<const Vec3> bn(ns.rhs);

  // Start: bodies at 0, nodes at the last step's Δv (warm start).
  for (Vec6& v : sys.xb) v.setZero();
  for (Vec3& v : sys.xn)
    if (!v.allFinite()) v.setZero();
  for (JointVector& v : sys.y) v.setZero();
  apply_coupled(model, data, sys.xb, sys.xn, sys.apb, sys.apn);
  for (std::size_t b = 0; b < nb; ++b)
    sys.rb[b] = s.in_solve[b] ? Vec6(bb[b] - sys.apb[b]) : Vec6::Zero();
  for_active_nodes(model, ns, [&](std::size_t i) { sys.rn[i] = bn[i] - sys.apn[i]; });
  double ref = std::sqrt(dot(bb, bb) + sys.node_dot(bn, bn));
  if (!std::isfinite(ref)) return poison_solve(data);

  {
    // Feasible start: x += P_KKT⁻¹ (r, c), so that G Δu = c from here on.
    sys.precondition_with(s.joint_rhs);
    for (std::size_t j = 0; j < sys.y.size(); ++j) sys.y[j] = sys.yz[j];
    for (std::size_t b = 0; b < nb; ++b) sys.xb[b] += sys.zb[b];
    for_active_nodes(model, ns, [&](std::size_t i) { sys.xn[i] += sys.zn[i]; });
    apply_coupled(model, data, sys.zb, sys.zn, sys.apb, sys.apn);
    ref = std::max(ref, std::sqrt(dot(sys.apb, sys.apb) + sys.node_dot(sys.apn, sys.apn)));
    for (std::size_t b = 0; b < nb; ++b) sys.rb[b] -= sys.apb[b];
    for_active_nodes(model, ns, [&](std::size_t i) { sys.rn[i] -= sys.apn[i]; });
    for (std::size_t b = 0; b < nb; ++b) sys.rp[b].setZero();
    add_joint_transpose(model, data, sys.y, sys.rp);
    for (std::size_t b = 0; b < nb; ++b) sys.rb[b] -= sys.rp[b];
    for (JointVector& v : s.joint_rhs) v.setZero();  // the iterations stay on G Δ = 0
  }
  sys.ref = ref > 0.0 ? ref : 1.0;

  const double rel = sys.project();
  const double rz = sys.precondition();
  for (std::size_t b = 0; b < nb; ++b) sys.pb[b] = sys.zb[b];
  for_active_nodes(model, ns, [&](std::size_t i) { sys.pn[i] = sys.zn[i]; });
  const PcgStop stop{model.solver.tolerance, model.solver.max_iterations};
  const PcgResult res = pcg(sys, rel, rz, stop);
  if (!res.finite) return poison_solve(data);
  // A last preconditioned Richardson step, x += z with the z = P⁻¹ r that the last project()
  // made (no product with A). It cannot increase the A-norm error where the spectrum of P⁻¹A
  // lies in (0, 2) (NetSolve.Jointed* check it densely: [0.70, 1.21]), and it takes the nodes'
  // share of the error that the Euclidean ‖r‖ leaves (a node's rows weigh ~1e-3 kg against the
  // instrument's 0.05 kg), which would otherwise keep quiet nodes from resting
  // (docs/net-solver.md, "Arrowhead preconditioner"). z keeps G z = 0.
  for (std::size_t b = 0; b < nb; ++b) sys.xb[b] += sys.zb[b];
  for_active_nodes(model, ns, [&](std::size_t i) { sys.xn[i] += sys.zn[i]; });
  store_joint_multipliers(model, data, sys.y);
  data.solver_iterations = res.iterations;
  data.solver_residual = res.residual;
  return res.converged(stop);
}

}  // namespace numen::core::detail
#endif  // NUMEN_WITH_ARTICULATION
