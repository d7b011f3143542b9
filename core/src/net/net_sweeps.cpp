/// @file net_sweeps.cpp
/// The SSOR sweeps of the coupled system of the bodies and the deformable nets
/// without joints, and Eisenstat's CG on them (detail::pcg(); net_solve.hpp):
/// one backward and one forward block sweep per iteration.

#include <algorithm>
#include <cmath>
#include <span>

#include "scratch/data_scratch.hpp"
#include "solver/implicit_system.hpp"
#include "net/net_rest.hpp"
#include "net/net_solve.hpp"
#include "net/net_terms.hpp"
#include "linalg/pcg.hpp"
#include "numen/core/data.hpp"
#include "numen/core/integrator.hpp"
#include "numen/core/model.hpp"

namespace numen::core::detail {
namespace {

/// D̃ v: blockdiag(SolverScratch::block, NetScratch::block) times v, into
/// out; returns vᵀ D̃ v. Bodies not in the solve give 0.
double apply_block_diagonal(const Model& model, const Data& data, std::span<const Vec6> v_b,
                            std::span<const Vec3> v_n, std::span<Vec6> out_b,
                            std::span<Vec3> out_n) noexcept {
  const SolverScratch& s = data.scratch->solver;
  const NetScratch& ns = data.scratch->net;
  double vdv = 0.0;
  for (std::size_t b = 0; b < v_b.size(); ++b) {
    if (s.in_solve[b]) {
      out_b[b].noalias() = s.block[b] * v_b[b];
      vdv += v_b[b].dot(out_b[b]);
    } else {
      out_b[b].setZero();
    }
  }
  for_active_nodes(model, ns, [&](std::size_t i) {  // the nodes in the solve (net_rest.hpp)
    out_n[i].noalias() = ns.block[i] * v_n[i];
    vdv += v_n[i].dot(out_n[i]);
  });
  return vdv;
}

/// The node loop of backward_sweep() over one net's sweep positions in the solve
/// (positions[0, count): NetScratch::active_positions, net_rest.hpp), last to first: g_k = −Σ W_e
/// t_j over node k's springs to later nodes, (with kUpdateQ) q_k ← d_k + β q_k, t_k = A_kk⁻¹ (q_k −
/// g_k). Returns Σ J_kᵀ t_k over the net when kTied (else 0). A function of its own, as
/// forward_nodes().
template <bool kUpdateQ, bool kTied>
Vec6 backward_nodes(const SpringView& sp, const std::int32_t* order, const SweepNode* nodes,
                    const std::int32_t* positions, int count, double beta, const Vec3* d_n,
                    Vec3* q_n, Vec3* t_n, Vec3* g_n) noexcept {
  Vec3 force = Vec3::Zero(), torque = Vec3::Zero();  // Σ J_iᵀ t_i = (Σ t_i, Σ ρ_i × t_i)
  for (int a = count - 1; a >= 0; --a) {
    const auto p = static_cast<std::size_t>(positions[a]);
    const auto k = static_cast<std::size_t>(order[p]);
    const Vec3 sum = gather_springs(sp, sp.low_begin[p], sp.low_begin[p + 1], t_n);
    g_n[k] = -sum;
    if constexpr (kUpdateQ) q_n[k] = d_n[k] + beta * q_n[k];
    const Vec3 t = inverse_times(nodes[p], q_n[k] + sum);
    t_n[k] = t;
    if constexpr (kTied) {
      force += t;
      torque += nodes[p].lever.cross(t);
    }
  }
  Vec6 tie;
  tie << force, torque;
  return tie;
}

/// The backward sweep of net_backward_sweep(). With kUpdateQ it first makes
/// each node's q the CG direction, q_k ← d_k + β q_k (d = D̃ w, in place),
/// as it reaches the node (the bodies' q are updated by the caller).
template <bool kUpdateQ>
void backward_sweep(const Model& model, const Data& data, double beta, const Vec3* d_n,
                    std::span<const Vec6> q_b, Vec3* q_n, std::span<Vec6> t_b, Vec3* t_n,
                    std::span<Vec6> g_b, Vec3* g_n) noexcept {
  const SolverScratch& s = data.scratch->solver;
  const NetScratch& ns = data.scratch->net;
  const double h = data.scratch->solver.system_step;  // h_s of the linearised system (integrator.hpp)
  const std::size_t nb = q_b.size();
  const SpringView sp(ns);
  const std::int32_t* order = model.node_sweep_order.data();
  const SweepNode* nodes = ns.sweep_nodes.data();
  for (Vec6& v : g_b) v.setZero();
  // Nodes, last to first in the sweep order: (D̃+Lᵀ) has, in node k's row,
  // −W_e towards every later node of a spring (and nothing towards the
  // bodies, which come first): t_k = A_kk⁻¹ (q_k + Σ W_e t_j), g_k = (Lᵀ t)_k
  // = −Σ W_e t_j, gathered over node k's springs (grouped by their earlier node).
  // Nets share no spring, so they are swept one after the other. A resting node (net_rest.hpp)
  // is out: its t is 0 (the Dirichlet value) where a spring gathers it.
  for (std::size_t n = model.nets.size(); n-- > 0;) {
    const NetModel& net = model.nets[n];
    const auto body = static_cast<std::size_t>(net.body);
    const std::int32_t* positions = ns.active_positions.data() + net.node_begin;
    const int count = ns.active_count[n];
    if (s.in_solve[body] != 0) {
      const Vec6 tie = backward_nodes<kUpdateQ, true>(sp, order, nodes, positions, count, beta, d_n,
                                                      q_n, t_n, g_n);
      g_b[body] -= tie_weight(net, h) * tie;  // A_bi = −c J_iᵀ
    } else {
      backward_nodes<kUpdateQ, false>(sp, order, nodes, positions, count, beta, d_n, q_n, t_n, g_n);
    }
  }
  // Node contacts with a body: A_bi = −J_rᵀ W.
  const int nc = node_contact_count(data);
  for (int c = 0; c < nc; ++c) {
    const NodeContact& ct = data.node_contacts[static_cast<std::size_t>(c)];
    if (!couples_body(s, ct)) continue;
    const auto i = static_cast<std::size_t>(ct.node);
    g_b[static_cast<std::size_t>(ct.body_b)] -= generalized_force(
        weight_times(ct.weight_normal, ct.weight_isotropic, ct.normal, t_n[i]), ct.r_b);
  }
  // Bodies: their D̃ blocks, then the body–body contacts' blocks of D − D̃.
  for (std::size_t b = 0; b < nb; ++b) {
    if (s.in_solve[b]) {
      solve_block(s.block_factor[b], Vec6(q_b[b] - g_b[b]), t_b[b]);
    } else {
      t_b[b].setZero();
      g_b[b].setZero();
    }
  }
  add_cross_contact_terms(s, t_b, g_b);
}

/// The node loop of forward_sweep() over one net's sweep positions in the solve
/// (positions[0, count), as backward_nodes()): y_k = A_kk⁻¹ (y_k + c J_k y_b) with c J_k y_b = cv +
/// cw × ρ_k when kTied, then the scatter of W_e y_k to the later nodes; with kAddT y_k ← y_k + t_k
/// and the return is Σ q_k · y_k over the net (else 0). A function of its own, the net's constants
/// hoisted: the node loop's pointers stay in registers.
template <bool kAddT, bool kTied>
double forward_nodes(const SpringView& sp, const std::int32_t* order, const SweepNode* nodes,
                     const std::int32_t* positions, int count, const Vec3 cv, const Vec3 cw,
                     Vec3* y_n, const Vec3* t_n, const Vec3* q_n) noexcept {
  double qkq = 0.0;
  for (int a = 0; a < count; ++a) {
    const auto p = static_cast<std::size_t>(positions[a]);
    const auto k = static_cast<std::size_t>(order[p]);
    Vec3 acc = y_n[k];
    if constexpr (kTied) acc += cv + cw.cross(nodes[p].lever);
    const Vec3 y = inverse_times(nodes[p], acc);
    if constexpr (kAddT) {
      const Vec3 kq = y + t_n[k];
      y_n[k] = kq;
      qkq += q_n[k].dot(kq);
    } else {
      y_n[k] = y;
    }
    scatter_springs(sp, sp.low_begin[p], sp.low_begin[p + 1], y, y_n);
  }
  return qkq;
}

/// The forward sweep of net_forward_sweep(), y = (D̃+L)⁻¹ g; y_n may be g_n
/// (in place). With kAddT it writes K q = y + t instead of y (Eisenstat's
/// product) and returns qᵀ K q; otherwise it returns 0.
template <bool kAddT>
double forward_sweep(const Model& model, const Data& data, std::span<const Vec6> g_b,
                     const Vec3* g_n, std::span<Vec6> y_b, Vec3* y_n, std::span<const Vec6> t_b,
                     const Vec3* t_n, std::span<const Vec6> q_b, const Vec3* q_n) noexcept {
  const SolverScratch& s = data.scratch->solver;
  const NetScratch& ns = data.scratch->net;
  const double h = data.scratch->solver.system_step;  // h_s of the linearised system (integrator.hpp)
  const std::size_t nb = g_b.size();
  const SpringView sp(ns);
  const std::int32_t* order = model.node_sweep_order.data();
  const SweepNode* nodes = ns.sweep_nodes.data();
  // Bodies first: no block of (D̃+L) left of their diagonal.
  for (std::size_t b = 0; b < nb; ++b) {
    if (s.in_solve[b]) {
      solve_block(s.block_factor[b], g_b[b], y_b[b]);
    } else {
      y_b[b].setZero();
    }
  }
  // Node rows' right-hand sides: g_i − A_ib y_b for the node–body contacts
  // (the ties' are added in the sweep).
  if (y_n != g_n)
    for (std::size_t i = 0; i < ns.sweep_nodes.size(); ++i) y_n[i] = g_n[i];
  const int nc = node_contact_count(data);
  for (int c = 0; c < nc; ++c) {
    const NodeContact& ct = data.node_contacts[static_cast<std::size_t>(c)];
    if (!couples_body(s, ct)) continue;
    y_n[static_cast<std::size_t>(ct.node)] +=
        weight_times(ct.weight_normal, ct.weight_isotropic, ct.normal,
                     point_velocity(y_b[static_cast<std::size_t>(ct.body_b)], ct.r_b));
  }
  // Nodes, first to last in the sweep order: y_k = A_kk⁻¹ (g_k + c J_k y_b +
  // Σ W_e y_j) over the springs to earlier nodes j, each of which has already
  // added its W_e y_j to y_k (scattered over its springs, grouped by their
  // earlier node).
  // A resting node (net_rest.hpp) is out: what its springs scatter to it is never read.
  double qkq = 0.0;
  for (std::size_t n = 0; n < model.nets.size(); ++n) {
    const NetModel& net = model.nets[n];
    const auto body = static_cast<std::size_t>(net.body);
    const std::int32_t* positions = ns.active_positions.data() + net.node_begin;
    const int count = ns.active_count[n];
    if (s.in_solve[body] != 0) {
      // c J_k y_b = c v_b + (c ω_b) × ρ_k.
      const double c = tie_weight(net, h);
      const Vec3 cv = c * y_b[body].head<3>(), cw = c * y_b[body].tail<3>();
      qkq += forward_nodes<kAddT, true>(sp, order, nodes, positions, count, cv, cw, y_n, t_n, q_n);
    } else {
      qkq += forward_nodes<kAddT, false>(sp, order, nodes, positions, count, Vec3::Zero(),
                                         Vec3::Zero(), y_n, t_n, q_n);
    }
  }
  if constexpr (kAddT) {
    for (std::size_t b = 0; b < nb; ++b) {
      y_b[b] += t_b[b];
      qkq += q_b[b].dot(y_b[b]);
    }
  }
  return qkq;
}

/// The start of Eisenstat's CG in one forward sweep, for x0 = (0 on the
/// bodies, x0_n on the nodes): w = (D̃+L)⁻¹ (b − A x0); returns the stopping
/// test's reference ‖b‖²_{D̃⁻¹} = bᵀ D̃⁻¹ b. Since A = (D̃+L) + (Lᵀ + D − D̃),
///   (D̃+L)⁻¹ (b − A x0) = (D̃+L)⁻¹ (b − (Lᵀ + D − D̃) x0) − x0,
/// and (Lᵀ + D − D̃) x0 needs no product with A: its body rows are the node
/// columns of Lᵀ (ties −c J_iᵀ, node contacts −J_rᵀ W; the body–body cross
/// terms of D − D̃ meet x0_b = 0), its node rows −Σ W_e x0_j over the springs
/// to later nodes j (sweep order) — gathered in the sweep over the same springs that
/// scatter. `y_b` is scratch (D̃_b⁻¹ b_b).
double net_start_sweep(const Model& model, Data& data, std::span<const Vec3> x0_n,
                       std::span<Vec6> w_b, std::span<Vec3> w_n, std::span<Vec6> y_b) noexcept {
  const SolverScratch& s = data.scratch->solver;
  NetScratch& ns = data.scratch->net;
  const double h = data.scratch->solver.system_step;  // h_s of the linearised system (integrator.hpp)
  const std::size_t nb = w_b.size();
  const SpringView sp(ns);
  const std::int32_t* order = model.node_sweep_order.data();
  const SweepNode* nodes = ns.sweep_nodes.data();
  const std::span<Vec6> g_b(ns.body_tmp);
  // Body rows: g_b = b_b − (Lᵀ x0)_b.
  for (std::size_t b = 0; b < nb; ++b) g_b[b] = s.in_solve[b] ? s.rhs[b] : Vec6::Zero();
  add_tie_transpose(model, data, x0_n, g_b);
  const int nc = node_contact_count(data);
  for (int c = 0; c < nc; ++c) {
    const NodeContact& ct = data.node_contacts[static_cast<std::size_t>(c)];
    if (!couples_body(s, ct)) continue;
    g_b[static_cast<std::size_t>(ct.body_b)] +=
        generalized_force(weight_times(ct.weight_normal, ct.weight_isotropic, ct.normal,
                                       x0_n[static_cast<std::size_t>(ct.node)]),
                          ct.r_b);
  }
  double ref = 0.0;
  for (std::size_t b = 0; b < nb; ++b) {
    if (s.in_solve[b]) {
      solve_block(s.block_factor[b], g_b[b], w_b[b]);  // x0_b = 0: w_b = y'_b
      solve_block(s.block_factor[b], s.rhs[b], y_b[b]);
      ref += y_b[b].dot(s.rhs[b]);
    } else {
      w_b[b].setZero();
      y_b[b].setZero();
    }
  }
  // Node rows: b_i, minus the node–body contacts' A_ib times the bodies' values.
  for (std::size_t i = 0; i < w_n.size(); ++i) w_n[i] = ns.rhs[i];
  for (int c = 0; c < nc; ++c) {
    const NodeContact& ct = data.node_contacts[static_cast<std::size_t>(c)];
    if (!couples_body(s, ct)) continue;
    const auto i = static_cast<std::size_t>(ct.node);
    const auto b = static_cast<std::size_t>(ct.body_b);
    w_n[i] += weight_times(ct.weight_normal, ct.weight_isotropic, ct.normal,
                           point_velocity(w_b[b], ct.r_b));
  }
  Vec3* w = w_n.data();
  const Vec3* rhs = ns.rhs.data();
  const Vec3* x0 = x0_n.data();
  for (std::size_t n = 0; n < model.nets.size(); ++n) {  // the nodes in the solve (net_rest.hpp)
    const NetModel& net = model.nets[n];
    const auto body = static_cast<std::size_t>(net.body);
    const bool tied = s.in_solve[body] != 0;
    const double c = tie_weight(net, h);
    const std::int32_t* positions = ns.active_positions.data() + net.node_begin;
    for (int a = 0; a < ns.active_count[n]; ++a) {
      const auto p = static_cast<std::size_t>(positions[a]);
      const auto k = static_cast<std::size_t>(order[p]);
      Vec3 acc_w = w[k];
      if (tied) acc_w += c * point_velocity(w_b[body], nodes[p].lever);
      acc_w += gather_springs(sp, sp.low_begin[p], sp.low_begin[p + 1], x0);
      const Vec3 wk = inverse_times(nodes[p], acc_w);  // before subtracting x0_k
      ref += rhs[k].dot(inverse_times(nodes[p], rhs[k]));
      w[k] = wk - x0[k];
      scatter_springs(sp, sp.low_begin[p], sp.low_begin[p + 1], wk, w);
    }
  }
  return ref;
}

/// The nets' system without joints for detail::pcg(): Eisenstat's CG with the
/// SSOR preconditioner (net_solve.hpp) on Â = G̃ᵀ (D̃+L)⁻¹ A (D̃+Lᵀ)⁻¹ G̃, with
/// x += α t, w −= α K q, d = D̃ w and ρ' = wᵀ D̃ w in one pass (advance()); the
/// new direction q = D̃ w + β q is formed node by node inside the next backward
/// sweep (direction() only records β). Residual measure ‖r‖_{M⁻¹} / ‖b‖_{D̃⁻¹};
/// bᵀ x for the error rule. The CG's Â-norm error of x̂ is the A-norm error of x
/// (x̂ = G̃⁻¹ (D̃+Lᵀ) x), so the error rule bounds the error of Δu, Δv in A's norm.
struct EisenstatSystem {
  const Model& model;
  Data& data;
  // g: the backward sweep's output (bodies); d = D̃ w (nodes).
  std::span<Vec6> xb, wb, tb, qb, kqb, gb;
  std::span<Vec3> xn, wn, tn, qn, kqn, dn;
  double ref = 1.0;
  double beta = 0.0;
  double rho_new = 0.0;
  bool first = true;

  /// The backward sweep (after the first iteration it first makes q = D̃ w + β q,
  /// node by node), the forward sweep (K q = y + t and qᵀ K q as it goes; g_n is
  /// swept in place in K q's storage). Returns qᵀ K q.
  double apply() noexcept {
    const SolverScratch& s = data.scratch->solver;
    if (first) {
      backward_sweep<false>(model, data, 0.0, nullptr, qb, qn.data(), tb, tn.data(), gb,
                            kqn.data());
    } else {
      for (std::size_t b = 0; b < qb.size(); ++b)  // D̃ w recomputed: a few bodies, no array for it
        qb[b] = s.in_solve[b] ? Vec6(s.block[b] * wb[b] + beta * qb[b]) : Vec6::Zero();
      backward_sweep<true>(model, data, beta, dn.data(), qb, qn.data(), tb, tn.data(), gb,
                           kqn.data());
    }
    return forward_sweep<true>(model, data, gb, kqn.data(), kqb, kqn.data(), tb, tn.data(), qb,
                               qn.data());
  }
  double advance(double alpha) noexcept {
    const SolverScratch& s = data.scratch->solver;
    double rho = 0.0;
    for (std::size_t b = 0; b < xb.size(); ++b) {
      if (!s.in_solve[b]) continue;  // x and w stay 0
      xb[b] += alpha * tb[b];
      wb[b] -= alpha * kqb[b];
      rho += wb[b].dot(s.block[b] * wb[b]);
    }
    const Mat3* block = data.scratch->net.block.data();
    for_active_nodes(model, data.scratch->net, [&](std::size_t i) {
      xn[i] += alpha * tn[i];
      wn[i] -= alpha * kqn[i];
      dn[i].noalias() = block[i] * wn[i];
      rho += wn[i].dot(dn[i]);
    });
    rho_new = rho;
    return std::sqrt(rho / ref);
  }
  double precondition() const noexcept { return rho_new; }  // wᵀ D̃ w = rᵀ M⁻¹ r
  /// bᵀ x of the current iterate, x in the original unknowns (b̂ᵀ x̂ = bᵀ x):
  /// the error rule's ‖x‖²_A to first order.
  double solution_energy() const noexcept {
    const SolverScratch& s = data.scratch->solver;
    double e = 0.0;
    for (std::size_t b = 0; b < xb.size(); ++b)
      if (s.in_solve[b]) e += s.rhs[b].dot(xb[b]);
    const Vec3* rhs = data.scratch->net.rhs.data();
    for_active_nodes(model, data.scratch->net, [&](std::size_t i) { e += rhs[i].dot(xn[i]); });
    return e;
  }
  void direction(double b) noexcept {
    beta = b;
    first = false;
  }
};

}  // namespace

bool solve_net_eisenstat(const Model& model, Data& data) noexcept {
  SolverScratch& s = data.scratch->solver;
  NetScratch& ns = data.scratch->net;
  EisenstatSystem sys{
      model,          data,        s.delta,  s.residual,  s.precond_residual,  s.direction,
      s.a_direction,  ns.body_tmp, ns.delta, ns.residual, ns.precond_residual, ns.direction,
      ns.a_direction, ns.sweep};

  // Start: bodies at 0, nodes at the last step's Δv (warm start);
  // w = (D̃+L)⁻¹ (b − A x0) and the reference ‖b‖²_{D̃⁻¹} in one forward
  // sweep (t serves as scratch for the bodies' D̃_b⁻¹ b_b).
  for (Vec6& v : sys.xb) v.setZero();
  for (Vec3& v : sys.xn)
    if (!v.allFinite()) v.setZero();
  double ref = net_start_sweep(model, data, sys.xn, sys.wb, sys.wn, sys.tb);
  if (!std::isfinite(ref)) return poison_solve(data);
  // The solution's least scale (SolverSettings::velocity_floor): the nets' kinetic energy at v_f.
  const SolverSettings& set = model.solver;
  double mass = 0.0;
  for (const NetModel& net : model.nets) mass += net.mass;
  const double floor = mass * set.velocity_floor * set.velocity_floor;
  ref = std::max(ref, floor);
  sys.ref = ref > 0.0 ? ref : 1.0;
  const double rho = apply_block_diagonal(model, data, sys.wb, sys.wn, sys.qb, sys.qn);  // q = D̃ w
  const double rel = std::sqrt(rho / sys.ref);

  // The stopping rule: the energy-norm error estimate (error_estimate_delay ≥ 1),
  // or the residual ratio ‖r‖_{M⁻¹}/max(‖b‖_{D̃⁻¹}, √F) (0), F the floor above.
  static_assert(kMaxErrorEstimateDelay <= kMaxPcgErrorDelay);
  PcgResult res;
  bool converged = false;
  if (set.error_estimate_delay > 0) {
    const double tolerance = set.error_tolerance > 0.0 ? set.error_tolerance : set.tolerance;
    const PcgErrorStop stop{tolerance, set.max_iterations, set.error_estimate_delay, floor};
    res = pcg(sys, rho, stop);
    converged = res.converged(stop);
  } else {
    const PcgStop stop{set.tolerance, set.max_iterations};
    res = pcg(sys, rel, rho, stop);
    converged = res.converged(stop);
  }
  if (!res.finite) return poison_solve(data);
  data.solver_iterations = res.iterations;
  data.solver_residual = res.residual;
  return converged;
}

}  // namespace numen::core::detail

namespace numen::core {

using detail::backward_sweep;
using detail::forward_sweep;

void net_backward_sweep(const Model& model, const Data& data, std::span<const Vec6> q_b,
                        std::span<const Vec3> q_n, std::span<Vec6> t_b, std::span<Vec3> t_n,
                        std::span<Vec6> g_b, std::span<Vec3> g_n) noexcept {
  // kUpdateQ = false: q is only read.
  backward_sweep<false>(model, data, 0.0, nullptr, q_b, const_cast<Vec3*>(q_n.data()), t_b,
                        t_n.data(), g_b, g_n.data());
}

void net_forward_sweep(const Model& model, const Data& data, std::span<const Vec6> g_b,
                       std::span<const Vec3> g_n, std::span<Vec6> y_b,
                       std::span<Vec3> y_n) noexcept {
  forward_sweep<false>(model, data, g_b, g_n.data(), y_b, y_n.data(), {}, nullptr, {}, nullptr);
}

double apply_net_preconditioned(const Model& model, Data& data, std::span<const Vec6> q_b,
                                std::span<const Vec3> q_n, std::span<Vec6> t_b, std::span<Vec3> t_n,
                                std::span<Vec6> kq_b, std::span<Vec3> kq_n) noexcept {
  NetScratch& ns = data.scratch->net;
  const std::span<Vec6> g_b(ns.body_tmp);
  net_backward_sweep(model, data, q_b, q_n, t_b, t_n, g_b, kq_n);  // g_n in K q's place
  return forward_sweep<true>(model, data, g_b, kq_n.data(), kq_b, kq_n.data(), t_b, t_n.data(), q_b,
                             q_n.data());
}

}  // namespace numen::core
