/// @file net_solve.cpp
/// Coupled linearly implicit Euler of the bodies and the deformable nets:
/// system assembly on a fixed sparsity and a preconditioned conjugate
/// gradient — SSOR with Eisenstat's trick without joints, the arrowhead
/// preconditioner in a projected CG with joints (net_solve.hpp).

#include "numen/core/net_solve.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <span>

#include "numen/core/articulation.hpp"
#include "numen/core/data.hpp"
#include "numen/core/features.hpp"
#include "numen/core/integrator.hpp"
#include "numen/core/joint_system.hpp"
#include "numen/core/model.hpp"
#include "numen/core/rigid_body.hpp"

namespace numen::core {
namespace {

/// c = h γ_tie + h² k_tie: a tie's weight in A (kg = N·s²/m).
double tie_weight(const NetModel& net, double h) noexcept {
  return h * net.tie_damping + h * h * net.tie_stiffness;
}

/// J u = v + ω × r: velocity of the point at lever arm r of a body with twist u.
inline Vec3 point_velocity(const Vec6& u, const Vec3& r) noexcept {
  return u.head<3>() + u.tail<3>().cross(r);
}

/// Jᵀ f = (f, r × f): generalized force of a force f at lever arm r.
inline Vec6 generalized_force(const Vec3& f, const Vec3& r) noexcept {
  Vec6 g;
  g << f, r.cross(f);
  return g;
}

/// W v = α n (n · v) + β v.
inline Vec3 weight_times(double alpha, double beta, const Vec3& n, const Vec3& v) noexcept {
  return (alpha * n.dot(v)) * n + beta * v;
}

/// Jᵀ J = [[I, −[r]×], [[r]×, |r|² I − r rᵀ]] summed over lever arms, from
/// their count, Σ r and Σ r rᵀ; times `weight`, added to `block` (full).
void add_lever_moments(double weight, double count, const Vec3& sum_r, const Mat3& sum_rr,
                       Mat6& block) noexcept {
  const Mat3 k = skew(sum_r);
  block.topLeftCorner<3, 3>().diagonal().array() += weight * count;
  block.topRightCorner<3, 3>() -= weight * k;
  block.bottomLeftCorner<3, 3>() += weight * k;
  block.bottomRightCorner<3, 3>() += weight * (sum_rr.trace() * Mat3::Identity() - sum_rr);
}

/// block += α n nᵀ + β I, exactly symmetric (each product computed once).
inline void add_weight(double alpha, double beta, const Vec3& n, Mat3& block) noexcept {
  const double ax = alpha * n.x(), ay = alpha * n.y(), az = alpha * n.z();
  const double xy = ax * n.y(), xz = ax * n.z(), yz = ay * n.z();
  block(0, 0) += ax * n.x() + beta;
  block(1, 1) += ay * n.y() + beta;
  block(2, 2) += az * n.z() + beta;
  block(0, 1) += xy;
  block(1, 0) += xy;
  block(0, 2) += xz;
  block(2, 0) += xz;
  block(1, 2) += yz;
  block(2, 1) += yz;
}

/// out = m⁻¹ for a symmetric 3×3 m (its upper triangle is read) by the
/// adjugate; exactly symmetric. A singular m gives non-finite entries.
inline void inverse_symmetric(const Mat3& m, Mat3& out) noexcept {
  const double a = m(0, 0), b = m(0, 1), c = m(0, 2), d = m(1, 1), e = m(1, 2), f = m(2, 2);
  const double c00 = d * f - e * e, c01 = c * e - b * f, c02 = b * e - c * d;
  const double inv = 1.0 / (a * c00 + b * c01 + c * c02);
  const double i01 = c01 * inv, i02 = c02 * inv, i12 = (b * c - a * e) * inv;
  out(0, 0) = c00 * inv;
  out(1, 1) = (a * f - c * c) * inv;
  out(2, 2) = (a * d - b * b) * inv;
  out(0, 1) = i01;
  out(1, 0) = i01;
  out(0, 2) = i02;
  out(2, 0) = i02;
  out(1, 2) = i12;
  out(2, 1) = i12;
}

double dot6(std::span<const Vec6> a, std::span<const Vec6> b) noexcept {
  double s = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) s += a[i].dot(b[i]);
  return s;
}

double dot3(std::span<const Vec3> a, std::span<const Vec3> b) noexcept {
  double s = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) s += a[i].dot(b[i]);
  return s;
}

int node_contact_count(const Data& data) noexcept {
  return std::clamp(data.num_node_contacts, 0, static_cast<int>(data.node_contacts.size()));
}

/// A node contact with a dynamic body in the solve: an off-diagonal block.
bool couples_body(const SolverScratch& s, const NodeContact& c) noexcept {
  return c.active && c.body_b >= 0 && s.in_solve[static_cast<std::size_t>(c.body_b)];
}

/// out_b += c Σ_i J_iᵀ v_i over each net's nodes, for the rigid components
/// in the solve (−A_bi v_i summed over a net's ties, A_bi = −c J_iᵀ).
void add_tie_transpose(const Model& model, const Data& data, std::span<const Vec3> v_n,
                       std::span<Vec6> out_b) noexcept {
  const double h = data.solver.system_step;  // h_s of the linearised system (integrator.hpp)
  for (const NetModel& net : model.nets) {
    const auto b = static_cast<std::size_t>(net.body);
    if (!data.solver.in_solve[b]) continue;
    Vec6 acc = Vec6::Zero();
    for (int v = net.node_begin; v < net.node_begin + net.node_count; ++v) {
      const auto i = static_cast<std::size_t>(v);
      acc += generalized_force(v_n[i], data.net.lever[i]);
    }
    out_b[b] += tie_weight(net, h) * acc;
  }
}

/// The springs of NetScratch::sweep_springs as raw pointers (the sweeps'
/// stores would otherwise make the compiler reload the vectors' data
/// pointers) and their grouping by earlier node in the sweep order.
struct SpringView {
  const double* nx;
  const double* ny;
  const double* nz;
  const double* alpha;
  const double* beta;
  const std::int32_t* high;
  const std::int32_t* low_begin;
  explicit SpringView(const NetScratch& ns) noexcept
      : nx(ns.sweep_springs.direction_x.data()),
        ny(ns.sweep_springs.direction_y.data()),
        nz(ns.sweep_springs.direction_z.data()),
        alpha(ns.sweep_springs.weight_axial.data()),
        beta(ns.sweep_springs.weight_isotropic.data()),
        high(ns.sweep_springs.high.data()),
        low_begin(ns.spring_low_begin.data()) {}
};

/// W_j v = α d̂ (d̂ · v) + β v for spring j, in plain scalar code.
inline Vec3 spring_times(const SpringView& s, std::int32_t j, const Vec3& v) noexcept {
  const double nx = s.nx[j], ny = s.ny[j], nz = s.nz[j], b = s.beta[j];
  const double t = s.alpha[j] * (nx * v.x() + ny * v.y() + nz * v.z());
  return Vec3(t * nx + b * v.x(), t * ny + b * v.y(), t * nz + b * v.z());
}

/// A_kk⁻¹ v from a sweep node's 6 entries (the same products and sums as
/// the full 3×3 product).
inline Vec3 inverse_times(const SweepNode& nd, const Vec3& v) noexcept {
  const double* m = nd.inverse;
  return Vec3(m[0] * v.x() + m[1] * v.y() + m[2] * v.z(),
              m[1] * v.x() + m[3] * v.y() + m[4] * v.z(),
              m[2] * v.x() + m[4] * v.y() + m[5] * v.z());
}

/// One component of two consecutive springs (one SSE2 register): the sweeps
/// handle a node's springs two at a time, lane by lane.
using Pair = Eigen::Array2d;

inline Pair load_pair(const double* p) noexcept { return Eigen::Map<const Pair>(p); }

/// Σ_j W_j v_high(j) over springs [begin, end) (the backward sweep's gather).
/// Always inlined: called once per node, its set-up must be hoisted.
[[gnu::always_inline]] inline Vec3 gather_springs(const SpringView& s, std::int32_t begin,
                                                  std::int32_t end, const Vec3* v) noexcept {
  Pair ax = Pair::Zero(), ay = Pair::Zero(), az = Pair::Zero();
  std::int32_t j = begin;
  for (; j + 1 < end; j += 2) {
    const Vec3& a = v[s.high[j]];
    const Vec3& b = v[s.high[j + 1]];
    const Pair vx(a.x(), b.x()), vy(a.y(), b.y()), vz(a.z(), b.z());
    const Pair nx = load_pair(s.nx + j), ny = load_pair(s.ny + j), nz = load_pair(s.nz + j);
    const Pair t = load_pair(s.alpha + j) * (nx * vx + ny * vy + nz * vz);
    const Pair beta = load_pair(s.beta + j);
    ax += t * nx + beta * vx;
    ay += t * ny + beta * vy;
    az += t * nz + beta * vz;
  }
  Vec3 sum(ax(0) + ax(1), ay(0) + ay(1), az(0) + az(1));
  if (j < end) sum += spring_times(s, j, v[s.high[j]]);
  return sum;
}

/// out_high(j) += W_j y over springs [begin, end) (the forward sweep's scatter).
[[gnu::always_inline]] inline void scatter_springs(const SpringView& s, std::int32_t begin,
                                                   std::int32_t end, const Vec3& y,
                                                   Vec3* out) noexcept {
  const Pair yx = Pair::Constant(y.x()), yy = Pair::Constant(y.y()), yz = Pair::Constant(y.z());
  std::int32_t j = begin;
  for (; j + 1 < end; j += 2) {
    const Pair nx = load_pair(s.nx + j), ny = load_pair(s.ny + j), nz = load_pair(s.nz + j);
    const Pair t = load_pair(s.alpha + j) * (nx * yx + ny * yy + nz * yz);
    const Pair beta = load_pair(s.beta + j);
    const Pair wx = t * nx + beta * yx, wy = t * ny + beta * yy, wz = t * nz + beta * yz;
    Vec3& a = out[s.high[j]];
    a.x() += wx(0);
    a.y() += wy(0);
    a.z() += wz(0);
    Vec3& b = out[s.high[j + 1]];
    b.x() += wx(1);
    b.y() += wy(1);
    b.z() += wz(1);
  }
  if (j < end) out[s.high[j]] += spring_times(s, j, y);
}

/// out = A · in over bodies and nodes (see net_solve.hpp for A).
void apply_coupled(const Model& model, const Data& data, std::span<const Vec6> in_b,
                   std::span<const Vec3> in_n, std::span<Vec6> out_b,
                   std::span<Vec3> out_n) noexcept {
  const SolverScratch& s = data.solver;
  const NetScratch& ns = data.net;
  apply_implicit_system(model, data, in_b, out_b);
  // Node rows: (m + c) p_i, then each spring's S (p_a − p_b) (its diagonal and
  // off-diagonal blocks at once), each node contact's W p_i, the ties' and
  // node–body contacts' off-diagonal blocks.
  for (std::size_t i = 0; i < in_n.size(); ++i) out_n[i] = ns.node_diagonal[i] * in_n[i];
  // Springs by their earlier node k in the sweep order: w = W_e (p_k − p_high), + on row k,
  // − on row high.
  const Vec3* x = in_n.data();
  Vec3* y = out_n.data();
  const SpringView sp(ns);
  const std::int32_t* order = model.node_sweep_order.data();
  for (std::size_t p = 0; p < in_n.size(); ++p) {
    const auto k = static_cast<std::size_t>(order[p]);
    Vec3 acc = Vec3::Zero();
    for (std::int32_t j = sp.low_begin[p]; j < sp.low_begin[p + 1]; ++j) {
      const auto hi = static_cast<std::size_t>(sp.high[j]);
      const Vec3 w = spring_times(sp, j, x[k] - x[hi]);
      acc += w;
      y[hi] -= w;
    }
    y[k] += acc;
  }
  const double h = data.solver.system_step;  // h_s of the linearised system (integrator.hpp)
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

/// D̃ v: blockdiag(SolverScratch::block, NetScratch::block) times v, into
/// out; returns vᵀ D̃ v. Bodies not in the solve give 0.
double apply_block_diagonal(const Data& data, std::span<const Vec6> v_b, std::span<const Vec3> v_n,
                            std::span<Vec6> out_b, std::span<Vec3> out_n) noexcept {
  const SolverScratch& s = data.solver;
  const NetScratch& ns = data.net;
  double vdv = 0.0;
  for (std::size_t b = 0; b < v_b.size(); ++b) {
    if (s.in_solve[b]) {
      out_b[b].noalias() = s.block[b] * v_b[b];
      vdv += v_b[b].dot(out_b[b]);
    } else {
      out_b[b].setZero();
    }
  }
  for (std::size_t i = 0; i < v_n.size(); ++i) {
    out_n[i].noalias() = ns.block[i] * v_n[i];
    vdv += v_n[i].dot(out_n[i]);
  }
  return vdv;
}

}  // namespace

void add_net_body_terms(const Model& model, Data& data) noexcept {
  if (model.nets.empty()) return;
  SolverScratch& s = data.solver;
  NetScratch& ns = data.net;
  const double h = data.solver.system_step;  // h_s of the linearised system (integrator.hpp)
  const double h2 = h * h;
  // Ties: their sums over the nodes come from linearize_nets().
  for (std::size_t k = 0; k < model.nets.size(); ++k) {
    const NetModel& net = model.nets[k];
    const auto b = static_cast<std::size_t>(net.body);
    if (!s.in_solve[b]) continue;
    const NetTieSums& t = ns.tie_sums[k];
    add_lever_moments(tie_weight(net, h), net.node_count, t.lever_sum, t.lever_moment, s.block[b]);
    s.rhs[b] += (h2 * net.tie_stiffness) * t.relative;  // Σ Jᵀ (v_i0 − v_a0)
  }
  // Node contacts: weights (for the node rows too), then the body side.
  const int nc = node_contact_count(data);
  for (int k = 0; k < nc; ++k) {
    NodeContact& ct = data.node_contacts[static_cast<std::size_t>(k)];
    if (!ct.active) continue;
    const MaterialPair& mp = model.material_pairs[static_cast<std::size_t>(ct.material_pair)];
    ct.weight_isotropic = h * mp.friction;
    ct.weight_normal = h * mp.damping + h2 * ct.stiffness - ct.weight_isotropic;  // k_eff
    if (!couples_body(s, ct)) continue;
    const auto b = static_cast<std::size_t>(ct.body_b);
    Vec6 g;
    g << ct.normal, ct.r_b.cross(ct.normal);
    Mat6& blk = s.block[b];
    blk.noalias() += ct.weight_normal * (g * g.transpose());
    add_lever_moments(ct.weight_isotropic, 1.0, ct.r_b, ct.r_b * ct.r_b.transpose(), blk);
    const double impulse = -h2 * ct.stiffness * ct.normal_velocity;  // on the node along n
    s.rhs[b] -= impulse * g;
  }
}

void build_net_system(const Model& model, Data& data) noexcept {
  if (model.nets.empty()) return;
  const SolverScratch& s = data.solver;
  NetScratch& ns = data.net;
  const double h = data.solver.system_step;  // h_s of the linearised system (integrator.hpp)
  const double h2 = h * h;

  // The springs' weights, their sum at each node (spring_block) and their
  // part of the right-hand side are already there (linearize_nets()).
  // Raw pointers: the stores would otherwise make the compiler reload every
  // vector's data pointer per node.
  const SymmetricBlock* spring_block = ns.spring_block.data();
  const Vec3* force = ns.force.data();
  const Vec3* lever = ns.lever.data();
  const NodeState* nodes = data.nodes.data();
  Mat3* block = ns.block.data();
  Vec3* rhs = ns.rhs.data();
  for (const NetModel& net : model.nets) {
    const Vec6 u0 = s.twist0[static_cast<std::size_t>(net.body)];
    const double c = tie_weight(net, h);
    const double hk = h2 * net.tie_stiffness;
    for (int v = net.node_begin; v < net.node_begin + net.node_count; ++v) {
      const auto i = static_cast<std::size_t>(v);
      const double diagonal = model.node_mass[i] + c;
      ns.node_diagonal[i] = diagonal;
      const SymmetricBlock w = spring_block[i];
      block[i] << w.entry[0] + diagonal, w.entry[1], w.entry[2], w.entry[1], w.entry[3] + diagonal,
          w.entry[4], w.entry[2], w.entry[4], w.entry[5] + diagonal;
      const Vec3 relative = nodes[i].velocity - point_velocity(u0, lever[i]);
      rhs[i] += h * force[i] - hk * relative;
    }
  }
  const int nc = node_contact_count(data);
  for (int k = 0; k < nc; ++k) {
    const NodeContact& ct = data.node_contacts[static_cast<std::size_t>(k)];
    if (!ct.active) continue;
    const auto i = static_cast<std::size_t>(ct.node);
    add_weight(ct.weight_normal, ct.weight_isotropic, ct.normal, ns.block[i]);
    ns.rhs[i] += (-h2 * ct.stiffness * ct.normal_velocity) * ct.normal;  // k_eff
  }
  if (model.joints.empty()) {  // the SSOR sweeps' A_kk⁻¹, in their order
    const std::int32_t* order = model.node_sweep_order.data();
    SweepNode* sweep_nodes = ns.sweep_nodes.data();
    const std::size_t n = ns.sweep_nodes.size();
    for (std::size_t p = 0; p < n; ++p) {
      const auto k = static_cast<std::size_t>(order[p]);
      Mat3 x;
      inverse_symmetric(block[k], x);
      SweepNode& nd = sweep_nodes[p];
      nd.inverse[0] = x(0, 0);
      nd.inverse[1] = x(0, 1);
      nd.inverse[2] = x(0, 2);
      nd.inverse[3] = x(1, 1);
      nd.inverse[4] = x(1, 2);
      nd.inverse[5] = x(2, 2);
      nd.lever = lever[k];
    }
  } else {
    for (std::size_t i = 0; i < ns.block.size(); ++i)
      inverse_symmetric(ns.block[i], ns.block_inverse[i]);
  }

  // The arrowhead preconditioner of the jointed solve: Schur blocks of the
  // bodies, S_b = A_bb − Σ c² J_iᵀ A_ii⁻¹ J_i (without joints the bodies' D̃
  // blocks are SolverScratch::block, factored by build_implicit_system()).
  if (model.joints.empty()) return;
  for (std::size_t b = 0; b < ns.body_schur.size(); ++b) ns.body_schur[b] = s.block[b];
  for (const NetModel& net : model.nets) {
    const auto b = static_cast<std::size_t>(net.body);
    if (!s.in_solve[b]) continue;
    const double c = tie_weight(net, h);
    Mat6 reduction = Mat6::Zero();
    for (int v = net.node_begin; v < net.node_begin + net.node_count; ++v) {
      const auto i = static_cast<std::size_t>(v);
      // c² Jᵀ X J with J = [I, −K], K = [ρ]×: [[X, −XK], [KX, −KXK]].
      // Columns of X K: K e_0 = (0, ρz, −ρy), K e_1 = (−ρz, 0, ρx), K e_2 = (ρy, −ρx, 0).
      const Mat3& x = ns.block_inverse[i];
      const Vec3& r = ns.lever[i];
      Mat3 xk;
      xk.col(0) = r.z() * x.col(1) - r.y() * x.col(2);
      xk.col(1) = r.x() * x.col(2) - r.z() * x.col(0);
      xk.col(2) = r.y() * x.col(0) - r.x() * x.col(1);
      // K (X K): row j of K times XK; K is skew: (K M)_j = (r × M_col)_j per column.
      Mat3 kxk;
      for (int j = 0; j < 3; ++j) kxk.col(j) = r.cross(xk.col(j));
      reduction.topLeftCorner<3, 3>() += x;
      reduction.topRightCorner<3, 3>() -= xk;
      reduction.bottomLeftCorner<3, 3>() -= xk.transpose();
      reduction.bottomRightCorner<3, 3>() -= kxk;
    }
    ns.body_schur[b] -= (c * c) * reduction;
  }
}

namespace {

#if NUMEN_WITH_ARTICULATION
/// The arrowhead-preconditioned projected CG (models with joints; see
/// net_solve.hpp).
bool solve_arrowhead(const Model& model, Data& data) noexcept {
  SolverScratch& s = data.solver;
  NetScratch& ns = data.net;
  ArticulationScratch& art = data.articulation;
  const double h = data.solver.system_step;  // h_s of the linearised system (integrator.hpp)
  const std::size_t nb = data.bodies.size();

  for (std::size_t i = 0; i < nb; ++i) art.known[i] = s.in_solve[i] ? 0 : 1;
  build_joint_rows(model, data, s.twist0, s.delta, s.joint_rhs);  // s.delta: Δu_prev
  factor_articulation(model, ns.body_schur, art);  // a bad pivot leaves NaN: rejected below

  const std::span<Vec6> xb(s.delta), rb(s.residual), zb(s.precond_residual), pb(s.direction),
      apb(s.a_direction), tb(ns.body_tmp);
  const std::span<const Vec6> bb(s.rhs);
  const std::span<Vec3> xn(ns.delta), rn(ns.residual), zn(ns.precond_residual), pn(ns.direction),
      apn(ns.a_direction);
  const std::span<const Vec3> bn(ns.rhs);
  const std::span<JointVector> y(s.joint_y), yz(s.joint_y_correction);
  const std::span<Vec6> rp(s.projected_residual);

  const auto poison = [&]() noexcept {
    constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
    for (Vec6& v : xb) v.setConstant(kNaN);
    for (Vec3& v : xn) v.setConstant(kNaN);
    data.solver_residual = kNaN;
    return false;
  };

  // z = P⁻¹ r with the arrowhead preconditioner: nodes eliminated onto the
  // bodies, body part by the tree solve with the Schur blocks S_b and
  // `constraint_rhs` (yz holds the constraint part).
  const auto precondition = [&](std::span<const JointVector> constraint_rhs) noexcept {
    for (std::size_t i = 0; i < rn.size(); ++i) zn[i].noalias() = ns.block_inverse[i] * rn[i];
    for (std::size_t b = 0; b < nb; ++b) tb[b] = rb[b];
    add_tie_transpose(model, data, zn, tb);
    solve_articulation(model, art, tb, constraint_rhs, zb, yz);
    for (const NetModel& net : model.nets) {
      const auto b = static_cast<std::size_t>(net.body);
      if (!s.in_solve[b]) continue;
      const double c = tie_weight(net, h);
      for (int v = net.node_begin; v < net.node_begin + net.node_count; ++v) {
        const auto i = static_cast<std::size_t>(v);
        zn[i].noalias() += c * (ns.block_inverse[i] * point_velocity(zb[b], ns.lever[i]));
      }
    }
  };
  // r ← r − Gᵀ yz (same z, since P Gᵀ = 0) and y += yz (Gould, Hribar &
  // Nocedal's residual update; see solve_constrained_system).
  const auto update_residual = [&]() noexcept {
    for (std::size_t b = 0; b < nb; ++b) rp[b].setZero();
    add_joint_transpose(model, data, yz, rp);
    for (std::size_t b = 0; b < nb; ++b) rb[b] -= rp[b];
    for (std::size_t j = 0; j < y.size(); ++j) y[j] += yz[j];
  };
  const auto residual_norm = [&]() noexcept { return std::sqrt(dot6(rb, rb) + dot3(rn, rn)); };

  // Start: bodies at 0, nodes at the last step's Δv (warm start).
  for (Vec6& v : xb) v.setZero();
  for (Vec3& v : xn)
    if (!v.allFinite()) v.setZero();
  for (JointVector& v : y) v.setZero();
  apply_coupled(model, data, xb, xn, apb, apn);
  for (std::size_t b = 0; b < nb; ++b) rb[b] = s.in_solve[b] ? Vec6(bb[b] - apb[b]) : Vec6::Zero();
  for (std::size_t i = 0; i < rn.size(); ++i) rn[i] = bn[i] - apn[i];
  double ref = std::sqrt(dot6(bb, bb) + dot3(bn, bn));
  if (!std::isfinite(ref)) return poison();

  {
    // Feasible start: x += P_KKT⁻¹ (r, c), so that G Δu = c from here on.
    precondition(s.joint_rhs);
    for (std::size_t j = 0; j < y.size(); ++j) y[j] = yz[j];
    for (std::size_t b = 0; b < nb; ++b) xb[b] += zb[b];
    for (std::size_t i = 0; i < xn.size(); ++i) xn[i] += zn[i];
    apply_coupled(model, data, zb, zn, apb, apn);
    ref = std::max(ref, std::sqrt(dot6(apb, apb) + dot3(apn, apn)));
    for (std::size_t b = 0; b < nb; ++b) rb[b] -= apb[b];
    for (std::size_t i = 0; i < rn.size(); ++i) rn[i] -= apn[i];
    for (std::size_t b = 0; b < nb; ++b) rp[b].setZero();
    add_joint_transpose(model, data, y, rp);
    for (std::size_t b = 0; b < nb; ++b) rb[b] -= rp[b];
    for (JointVector& v : s.joint_rhs) v.setZero();  // the iterations stay on G Δ = 0
  }
  if (!(ref > 0.0)) ref = 1.0;

  precondition(s.joint_rhs);
  update_residual();
  double rel = residual_norm() / ref;
  double rz = dot6(rb, zb) + dot3(rn, zn);
  if (!std::isfinite(rel) || !std::isfinite(rz)) return poison();
  for (std::size_t b = 0; b < nb; ++b) pb[b] = zb[b];
  for (std::size_t i = 0; i < pn.size(); ++i) pn[i] = zn[i];
  int it = 0;
  const int max_it = std::max(1, model.solver.max_iterations);
  while (rel > model.solver.tolerance && it < max_it) {
    ++it;
    apply_coupled(model, data, pb, pn, apb, apn);
    const double pap = dot6(pb, apb) + dot3(pn, apn);
    if (!std::isfinite(pap)) return poison();
    if (!(pap > 0.0)) break;  // breakdown, or converged exactly
    const double alpha = rz / pap;
    for (std::size_t b = 0; b < nb; ++b) {
      xb[b] += alpha * pb[b];
      rb[b] -= alpha * apb[b];
    }
    for (std::size_t i = 0; i < xn.size(); ++i) {
      xn[i] += alpha * pn[i];
      rn[i] -= alpha * apn[i];
    }
    precondition(s.joint_rhs);
    update_residual();
    rel = residual_norm() / ref;
    const double rz_new = dot6(rb, zb) + dot3(rn, zn);
    if (!std::isfinite(rel) || !std::isfinite(rz_new)) return poison();
    if (!(rz_new > 0.0)) break;  // converged to rounding
    const double beta = rz_new / rz;
    rz = rz_new;
    for (std::size_t b = 0; b < nb; ++b) pb[b] = zb[b] + beta * pb[b];
    for (std::size_t i = 0; i < pn.size(); ++i) pn[i] = zn[i] + beta * pn[i];
  }
  store_joint_multipliers(model, data, y);
  data.solver_iterations = it;
  data.solver_residual = rel;
  return rel <= model.solver.tolerance;
}
#endif  // NUMEN_WITH_ARTICULATION

/// The node loop of backward_sweep() over one net's sweep positions
/// [begin, end), last to first: g_k = −Σ W_e t_j over node k's springs to
/// later nodes, (with kUpdateQ) q_k ← d_k + β q_k, t_k = A_kk⁻¹ (q_k − g_k).
/// Returns Σ J_kᵀ t_k over the net when kTied (else 0). A function of its
/// own, as forward_nodes().
template <bool kUpdateQ, bool kTied>
Vec6 backward_nodes(const SpringView& sp, const std::int32_t* order, const SweepNode* nodes,
                    int begin, int end, double beta, const Vec3* d_n, Vec3* q_n, Vec3* t_n,
                    Vec3* g_n) noexcept {
  Vec3 force = Vec3::Zero(), torque = Vec3::Zero();  // Σ J_iᵀ t_i = (Σ t_i, Σ ρ_i × t_i)
  for (int p = end - 1; p >= begin; --p) {
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
  const SolverScratch& s = data.solver;
  const NetScratch& ns = data.net;
  const double h = data.solver.system_step;  // h_s of the linearised system (integrator.hpp)
  const std::size_t nb = q_b.size();
  const SpringView sp(ns);
  const std::int32_t* order = model.node_sweep_order.data();
  const SweepNode* nodes = ns.sweep_nodes.data();
  for (Vec6& v : g_b) v.setZero();
  // Nodes, last to first in the sweep order: (D̃+Lᵀ) has, in node k's row,
  // −W_e towards every later node of a spring (and nothing towards the
  // bodies, which come first): t_k = A_kk⁻¹ (q_k + Σ W_e t_j), g_k = (Lᵀ t)_k
  // = −Σ W_e t_j, gathered over node k's springs (grouped by their earlier node).
  // Nets share no spring, so they are swept one after the other.
  for (auto net = model.nets.rbegin(); net != model.nets.rend(); ++net) {
    const auto body = static_cast<std::size_t>(net->body);
    const int begin = net->node_begin, end = net->node_begin + net->node_count;
    if (s.in_solve[body] != 0) {
      const Vec6 tie = backward_nodes<kUpdateQ, true>(sp, order, nodes, begin, end, beta, d_n,
                                                      q_n, t_n, g_n);
      g_b[body] -= tie_weight(*net, h) * tie;  // A_bi = −c J_iᵀ
    } else {
      backward_nodes<kUpdateQ, false>(sp, order, nodes, begin, end, beta, d_n, q_n, t_n, g_n);
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

/// The node loop of forward_sweep() over one net's sweep positions
/// [begin, end): y_k = A_kk⁻¹ (y_k + c J_k y_b) with c J_k y_b = cv + cw × ρ_k
/// when kTied, then the scatter of W_e y_k to the later nodes; with kAddT
/// y_k ← y_k + t_k and the return is Σ q_k · y_k over the net (else 0).
/// A function of its own, the net's constants hoisted: the node loop's
/// pointers stay in registers.
template <bool kAddT, bool kTied>
double forward_nodes(const SpringView& sp, const std::int32_t* order, const SweepNode* nodes,
                     int begin, int end, const Vec3 cv, const Vec3 cw, Vec3* y_n,
                     const Vec3* t_n, const Vec3* q_n) noexcept {
  double qkq = 0.0;
  for (int p = begin; p < end; ++p) {
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
  const SolverScratch& s = data.solver;
  const NetScratch& ns = data.net;
  const double h = data.solver.system_step;  // h_s of the linearised system (integrator.hpp)
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
  double qkq = 0.0;
  for (const NetModel& net : model.nets) {
    const auto body = static_cast<std::size_t>(net.body);
    const int begin = net.node_begin, end = net.node_begin + net.node_count;
    if (s.in_solve[body] != 0) {
      // c J_k y_b = c v_b + (c ω_b) × ρ_k.
      const double c = tie_weight(net, h);
      const Vec3 cv = c * y_b[body].head<3>(), cw = c * y_b[body].tail<3>();
      qkq += forward_nodes<kAddT, true>(sp, order, nodes, begin, end, cv, cw, y_n, t_n, q_n);
    } else {
      qkq += forward_nodes<kAddT, false>(sp, order, nodes, begin, end, Vec3::Zero(), Vec3::Zero(),
                                         y_n, t_n, q_n);
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
  const SolverScratch& s = data.solver;
  NetScratch& ns = data.net;
  const double h = data.solver.system_step;  // h_s of the linearised system (integrator.hpp)
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
    g_b[static_cast<std::size_t>(ct.body_b)] += generalized_force(
        weight_times(ct.weight_normal, ct.weight_isotropic, ct.normal,
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
  for (const NetModel& net : model.nets) {
    const auto body = static_cast<std::size_t>(net.body);
    const bool tied = s.in_solve[body] != 0;
    const double c = tie_weight(net, h);
    for (int p = net.node_begin; p < net.node_begin + net.node_count; ++p) {
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

/// Eisenstat's CG with the SSOR preconditioner (models without joints; see
/// net_solve.hpp).
bool solve_eisenstat(const Model& model, Data& data) noexcept {
  SolverScratch& s = data.solver;
  NetScratch& ns = data.net;
  // g: the backward sweep's output (bodies); d = D̃ w (nodes).
  const std::span<Vec6> xb(s.delta), wb(s.residual), tb(s.precond_residual), qb(s.direction),
      kqb(s.a_direction), gb(ns.body_tmp);
  const std::span<Vec3> xn(ns.delta), wn(ns.residual), tn(ns.precond_residual), qn(ns.direction),
      kqn(ns.a_direction), dn(ns.sweep);
  const std::size_t nb = xb.size(), nn = xn.size();

  const auto poison = [&]() noexcept {
    constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
    for (Vec6& v : xb) v.setConstant(kNaN);
    for (Vec3& v : xn) v.setConstant(kNaN);
    data.solver_residual = kNaN;
    return false;
  };

  // Start: bodies at 0, nodes at the last step's Δv (warm start);
  // w = (D̃+L)⁻¹ (b − A x0) and the reference ‖b‖²_{D̃⁻¹} in one forward
  // sweep (t serves as scratch for the bodies' D̃_b⁻¹ b_b).
  for (Vec6& v : xb) v.setZero();
  for (Vec3& v : xn)
    if (!v.allFinite()) v.setZero();
  double ref = net_start_sweep(model, data, xn, wb, wn, tb);
  if (!std::isfinite(ref)) return poison();
  if (!(ref > 0.0)) ref = 1.0;
  double rho = apply_block_diagonal(data, wb, wn, qb, qn);  // q = D̃ w
  double rel = std::sqrt(rho / ref);
  if (!std::isfinite(rel)) return poison();

  // One iteration: the backward sweep (which first makes q = D̃ w + β q, node
  // by node, after the first iteration), the forward sweep (K q = y + t and
  // qᵀ K q as it goes; g_n is swept in place in K q's storage), then
  // x += α t, w −= α K q, d = D̃ w and ρ' = wᵀ D̃ w in one pass.
  int it = 0;
  double beta = 0.0;
  const int max_it = std::max(1, model.solver.max_iterations);
  while (rel > model.solver.tolerance && it < max_it) {
    if (it == 0) {
      backward_sweep<false>(model, data, 0.0, nullptr, qb, qn.data(), tb, tn.data(), gb,
                            kqn.data());
    } else {
      for (std::size_t b = 0; b < nb; ++b)  // D̃ w recomputed: a few bodies, no array for it
        qb[b] = s.in_solve[b] ? Vec6(s.block[b] * wb[b] + beta * qb[b]) : Vec6::Zero();
      backward_sweep<true>(model, data, beta, dn.data(), qb, qn.data(), tb, tn.data(), gb,
                           kqn.data());
    }
    ++it;
    const double qkq = forward_sweep<true>(model, data, gb, kqn.data(), kqb, kqn.data(), tb,
                                           tn.data(), qb, qn.data());
    if (!std::isfinite(qkq)) return poison();
    if (!(qkq > 0.0)) break;  // breakdown, or converged exactly
    const double alpha = rho / qkq;
    double rho_new = 0.0;
    for (std::size_t b = 0; b < nb; ++b) {
      if (!s.in_solve[b]) continue;  // x and w stay 0
      xb[b] += alpha * tb[b];
      wb[b] -= alpha * kqb[b];
      rho_new += wb[b].dot(s.block[b] * wb[b]);
    }
    const Mat3* block = ns.block.data();
    for (std::size_t i = 0; i < nn; ++i) {
      xn[i] += alpha * tn[i];
      wn[i] -= alpha * kqn[i];
      dn[i].noalias() = block[i] * wn[i];
      rho_new += wn[i].dot(dn[i]);
    }
    rel = std::sqrt(rho_new / ref);
    if (!std::isfinite(rel)) return poison();
    if (rel <= model.solver.tolerance || !(rho_new > 0.0)) break;
    beta = rho_new / rho;
    rho = rho_new;
  }
  data.solver_iterations = it;
  data.solver_residual = rel;
  return rel <= model.solver.tolerance;
}

}  // namespace

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
  NetScratch& ns = data.net;
  const std::span<Vec6> g_b(ns.body_tmp);
  net_backward_sweep(model, data, q_b, q_n, t_b, t_n, g_b, kq_n);  // g_n in K q's place
  return forward_sweep<true>(model, data, g_b, kq_n.data(), kq_b, kq_n.data(), t_b, t_n.data(),
                             q_b, q_n.data());
}

bool solve_net_system(const Model& model, Data& data) noexcept {
  data.solver_iterations = 0;
  data.solver_residual = 0.0;
#if NUMEN_WITH_ARTICULATION
  if (!model.joints.empty()) return solve_arrowhead(model, data);
#endif
  return solve_eisenstat(model, data);
}

}  // namespace numen::core
