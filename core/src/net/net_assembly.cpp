/// @file net_assembly.cpp
/// Assembly of the coupled system of the bodies and the deformable nets
/// (net_solve.hpp): the nets' terms in the bodies' blocks and right-hand
/// sides, the node rows, their inverses in the sweep order and, with joints,
/// the bodies' Schur blocks of the arrowhead preconditioner.

#include "scratch/data_scratch.hpp"
#include "solver/implicit_system.hpp"
#include "net/net_solve.hpp"
#include "net/net_terms.hpp"
#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/rigid_body.hpp"

namespace numen::core {
namespace {

using detail::couples_body;
using detail::node_contact_count;
using detail::point_velocity;
using detail::tie_weight;

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

}  // namespace

void add_net_body_terms(const Model& model, Data& data) noexcept {
  if (model.nets.empty()) return;
  SolverScratch& s = data.scratch->solver;
  NetScratch& ns = data.scratch->net;
  const double h = data.scratch->solver.system_step;  // h_s of the linearised system (integrator.hpp)
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
    ct.weight_isotropic = h * ct.friction;  // the law's coefficients (contact_force.hpp)
    ct.weight_normal = h * ct.damping + h2 * ct.stiffness - ct.weight_isotropic;
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

namespace {

/// Each active node's row of the nets' system: its 3×3 block (the springs' weights
/// linearize_nets() summed, plus its mass and tie weight on the diagonal, NetScratch::
/// node_diagonal) and its right-hand side's force and tie terms; h = h_s.
void add_node_rows(const Model& model, Data& data, double h) noexcept {
  const SolverScratch& s = data.scratch->solver;
  NetScratch& ns = data.scratch->net;
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
  // The nodes in the solve (NetScratch::active_nodes: every node when none rests,
  // net_rest.hpp); a resting node's row is out of the system.
  for (std::size_t n = 0; n < model.nets.size(); ++n) {
    const NetModel& net = model.nets[n];
    const Vec6 u0 = s.twist0[static_cast<std::size_t>(net.body)];
    const double c = tie_weight(net, h);
    const double hk = h2 * net.tie_stiffness;
    const std::int32_t* active = ns.active_nodes.data() + net.node_begin;
    // kScaled: the ties per node (a material net's, anchored: NetModel::tie_scale); else every
    // tie alike, s = 1 folded away.
    const auto rows = [&]<bool kScaled>() {
      for (int a = 0; a < ns.active_count[n]; ++a) {
        const auto i = static_cast<std::size_t>(active[a]);
        const double ts = kScaled ? net.tie_scale[static_cast<std::size_t>(active[a] - net.node_begin)] : 1.0;
        const double diagonal = model.node_mass[i] + ts * c;
        ns.node_diagonal[i] = diagonal;
        const SymmetricBlock w = spring_block[i];
        block[i] << w.entry[0] + diagonal, w.entry[1], w.entry[2], w.entry[1], w.entry[3] + diagonal,
            w.entry[4], w.entry[2], w.entry[4], w.entry[5] + diagonal;
        const Vec3 relative = nodes[i].velocity - point_velocity(u0, lever[i]);
        rhs[i] += h * force[i] - (ts * hk) * relative;
      }
    };
    if (net.tie_scale.empty())
      rows.template operator()<false>();
    else
      rows.template operator()<true>();
  }
}

/// The node contacts' weights into their nodes' blocks and their K u₀ into the right-hand
/// sides.
void add_node_contact_rows(Data& data, int nc, double h2) noexcept {
  NetScratch& ns = data.scratch->net;
  for (int k = 0; k < nc; ++k) {
    const NodeContact& ct = data.node_contacts[static_cast<std::size_t>(k)];
    if (!ct.active) continue;
    const auto i = static_cast<std::size_t>(ct.node);
    add_weight(ct.weight_normal, ct.weight_isotropic, ct.normal, ns.block[i]);
    ns.rhs[i] += (-h2 * ct.stiffness * ct.normal_velocity) * ct.normal;  // k_eff
  }
}

/// The inverses of the active nodes' blocks: in the SSOR sweeps' order with their levers
/// (SweepNode, without joints), else NetScratch::block_inverse (the arrowhead's).
void invert_node_blocks(const Model& model, Data& data) noexcept {
  NetScratch& ns = data.scratch->net;
  const Vec3* lever = ns.lever.data();
  Mat3* block = ns.block.data();
  if (model.joints.empty()) {  // the SSOR sweeps' A_kk⁻¹, in their order
    const std::int32_t* order = model.node_sweep_order.data();
    SweepNode* sweep_nodes = ns.sweep_nodes.data();
    for (std::size_t n = 0; n < model.nets.size(); ++n) {
      const std::int32_t* positions = ns.active_positions.data() + model.nets[n].node_begin;
      for (int a = 0; a < ns.active_count[n]; ++a) {
        const auto p = static_cast<std::size_t>(positions[a]);
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
    }
  } else {
    for (std::size_t n = 0; n < model.nets.size(); ++n) {
      const std::int32_t* active = ns.active_nodes.data() + model.nets[n].node_begin;
      for (int a = 0; a < ns.active_count[n]; ++a) {
        const auto i = static_cast<std::size_t>(active[a]);
        inverse_symmetric(ns.block[i], ns.block_inverse[i]);
      }
    }
  }
}

/// The arrowhead preconditioner of the jointed solve: Schur blocks of the bodies,
/// S_b = A_bb − Σ c² J_iᵀ A_ii⁻¹ J_i over the ties' nodes, then the node–body contacts' part.
void build_body_schur_blocks(const Model& model, Data& data, int nc, double h) noexcept {
  const SolverScratch& s = data.scratch->solver;
  NetScratch& ns = data.scratch->net;
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
  // The node–body contacts' blocks A_ib = −F_ib, F_ib = Σ_k W_k J_k over node i's contacts k
  // with body b (J_k = [I, −[r_k]×]): S_b −= F_ibᵀ A_ii⁻¹ F_ib. A contact's stiffness
  // (h² k ≈ 0.02 kg at 2·10⁴ N/m and 1 ms) outweighs a node's mass and springs many times, so
  // without this the preconditioner splits a node from the body it touches and the contact
  // steps take the most iterations. The cross terms between two bodies that one node touches
  // are left out (the tree solve has no body–body blocks); S_b stays ≻ M_b: A_ii ⪰ Σ_k W_k, and
  // Σ_k J_kᵀ W_k J_k − F_ibᵀ (Σ_k W_k)⁻¹ F_ib ⪰ 0 is the Schur complement of Σ_k [J_k I]ᵀ W_k [J_k I].
  std::int32_t* head = ns.node_contact_head.data();
  std::int32_t* next = ns.node_contact_next.data();
  for (int k = 0; k < nc; ++k) {
    const NodeContact& ct = data.node_contacts[static_cast<std::size_t>(k)];
    if (!couples_body(s, ct)) continue;
    const auto i = static_cast<std::size_t>(ct.node);
    next[k] = head[i];
    head[i] = k;
  }
  for (int k = 0; k < nc; ++k) {
    const NodeContact& first = data.node_contacts[static_cast<std::size_t>(k)];
    if (!couples_body(s, first) || head[first.node] != k) continue;  // each node once
    const Mat3& x = ns.block_inverse[static_cast<std::size_t>(first.node)];
    for (std::int32_t a = k; a >= 0; a = next[a]) {
      const int body = data.node_contacts[static_cast<std::size_t>(a)].body_b;
      bool grouped = false;  // this body's contacts at this node already taken
      for (std::int32_t q = k; q != a; q = next[q])
        grouped = grouped || data.node_contacts[static_cast<std::size_t>(q)].body_b == body;
      if (grouped) continue;
      Eigen::Matrix<double, 3, 6> f = Eigen::Matrix<double, 3, 6>::Zero();
      for (std::int32_t q = a; q >= 0; q = next[q]) {
        const NodeContact& ct = data.node_contacts[static_cast<std::size_t>(q)];
        if (ct.body_b != body) continue;
        Mat3 w = Mat3::Zero();
        add_weight(ct.weight_normal, ct.weight_isotropic, ct.normal, w);
        f.leftCols<3>() += w;
        // −W [r]×: column j is −W (r × e_j) = W (e_j × r).
        for (int j = 0; j < 3; ++j) f.col(3 + j) += w * Vec3::Unit(j).cross(ct.r_b);
      }
      ns.body_schur[static_cast<std::size_t>(body)].noalias() -= f.transpose() * (x * f);
    }
  }
  for (int k = 0; k < nc; ++k) {
    const NodeContact& ct = data.node_contacts[static_cast<std::size_t>(k)];
    if (couples_body(s, ct)) head[ct.node] = -1;
  }
}

}  // namespace

void build_net_system(const Model& model, Data& data) noexcept {
  if (model.nets.empty()) return;
  const double h = data.scratch->solver.system_step;  // h_s of the linearised system (integrator.hpp)
  add_node_rows(model, data, h);
  const int nc = node_contact_count(data);
  add_node_contact_rows(data, nc, h * h);
  invert_node_blocks(model, data);
  // Without joints the bodies' D̃ blocks are SolverScratch::block, factored by
  // build_implicit_system(): no arrowhead.
  if (!model.joints.empty()) build_body_schur_blocks(model, data, nc, h);
}

}  // namespace numen::core
