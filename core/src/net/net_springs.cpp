/// @file net_springs.cpp
/// The deformable nets' springs: their forces and energy in one sweep over the nodes
/// (detail::add_spring_forces(), called by compute_net_forces()), and their linearisation with
/// the ties' sums for the implicit step (linearize_nets(), net_forces.hpp; docs/net-solver.md).

#include <cstdint>

#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/net_forces.hpp"

#include "scratch/data_scratch.hpp"
#include "net/net_solve.hpp"
#include "net/net_springs.hpp"
#include "net/net_still.hpp"
#include "net/net_terms.hpp"

namespace numen::core {
namespace {

/// Raw pointers to the arrays of the springs' pass (the stores would
/// otherwise make the compiler reload every vector's data pointer per spring).
struct SpringPass {
  const NodeState* nodes;
  const double* rest_length;
  const double* stiffness;
  const double* damping;
  double* dir_x;
  double* dir_y;
  double* dir_z;
  double* weight_axial;
  double* weight_isotropic;
  const std::int32_t* high;
  double* length;
  Vec3* force;
  SymmetricBlock* spring_block;
  Vec3* rhs;
  double h;   ///< h_s of the linearised system (integrator.hpp).
  double h2;  ///< h_s².
};

/// Node k's sums over its springs in the sweep order: force, the weights'
/// sum (symmetric, upper triangle) and the right-hand side.
struct NodeSums {
  Vec3 force = Vec3::Zero();
  double energy = 0.0;  ///< Σ k (l − L)² (twice the springs' elastic energy, J).
  Vec3 rhs = Vec3::Zero();
  double w00 = 0.0, w01 = 0.0, w02 = 0.0, w11 = 0.0, w12 = 0.0, w22 = 0.0;
};

/// One component of two consecutive springs (one SSE2 register), or two
/// consecutive entries of a node's SymmetricBlock.
using Pair = Eigen::Array2d;

inline Pair load_pair(const double* p) noexcept { return Eigen::Map<const Pair>(p); }
inline void store_pair(double* p, const Pair& v) noexcept {
  Eigen::Map<Pair> m(p);
  m = v;
}

/// Adds the symmetric 3×3 with upper triangle (a, b, c; d, e; f) to m, two
/// entries per SIMD addition (each entry gets the same one addition as in
/// scalar code).
inline void add_symmetric(SymmetricBlock& m, double a, double b, double c, double d, double e,
                          double f) noexcept {
  Eigen::Map<Pair>(m.entry) += Pair(a, b);
  Eigen::Map<Pair>(m.entry + 2) += Pair(c, d);
  Eigen::Map<Pair>(m.entry + 4) += Pair(e, f);
}

/// Spring j of node k (position xk, velocity vk) in scalar code: the law of
/// spring_pass(), for a node's odd spring out.
inline void one_spring(const SpringPass& a, std::int32_t j, const Vec3& xk, const Vec3& vk,
                       NodeSums& sum) noexcept {
  const auto hi = static_cast<std::size_t>(a.high[j]);
  const double rest = a.rest_length[j];
  const Vec3 d = a.nodes[hi].position - xk;
  const double l = d.norm();
  const double inv_l = 1.0 / l;
  if (l > 1e-12 * rest) {  // else: keep the last direction
    a.dir_x[j] = d.x() * inv_l;
    a.dir_y[j] = d.y() * inv_l;
    a.dir_z[j] = d.z() * inv_l;
  }
  a.length[j] = l;
  const Vec3 n(a.dir_x[j], a.dir_y[j], a.dir_z[j]);
  const Vec3 dv = a.nodes[hi].velocity - vk;
  const double n_dv = n.dot(dv);
  const double stretch = l - rest;
  sum.energy += a.stiffness[j] * stretch * stretch;
  const Vec3 f = (a.stiffness[j] * stretch + a.damping[j] * n_dv) * n;
  sum.force += f;
  a.force[hi] -= f;
}

/// Spring j of node k (velocity vk) in scalar code: the linearisation of
/// linearization_pass(), for a node's odd spring out, from the direction and
/// length the forces stage stored.
inline void one_spring_linearization(const SpringPass& a, std::int32_t j, const Vec3& vk,
                                     NodeSums& sum) noexcept {
  const auto hi = static_cast<std::size_t>(a.high[j]);
  const double rest = a.rest_length[j];
  const double l = a.length[j];
  const double inv_l = 1.0 / l;
  const Vec3 n(a.dir_x[j], a.dir_y[j], a.dir_z[j]);
  const Vec3 dv = a.nodes[hi].velocity - vk;
  const double n_dv = n.dot(dv);
  // K̃ = (1 − τ) d̂d̂ᵀ + τ I, τ = max(0, 1 − L/l): −∂f_k/∂x_k / k.
  const double hk = a.h2 * a.stiffness[j];
  const double beta = l > rest ? hk * (1.0 - rest * inv_l) : 0.0;
  const double alpha = a.h * a.damping[j] + hk - beta;
  a.weight_axial[j] = alpha;
  a.weight_isotropic[j] = beta;
  const double ax = alpha * n.x(), ay = alpha * n.y(), az = alpha * n.z();
  const double w00 = ax * n.x() + beta, w11 = ay * n.y() + beta, w22 = az * n.z() + beta;
  const double w01 = ax * n.y(), w02 = ax * n.z(), w12 = ay * n.z();
  sum.w00 += w00;
  sum.w01 += w01;
  sum.w02 += w02;
  sum.w11 += w11;
  sum.w12 += w12;
  sum.w22 += w22;
  add_symmetric(a.spring_block[hi], w00, w01, w02, w11, w12, w22);
  // h² k K̃ (v_h − v_k) = (hk − β) d̂ (d̂ · dv) + β dv: + on row k, − on row h.
  const Vec3 kv = ((hk - beta) * n_dv) * n + beta * dv;
  sum.rhs += kv;
  a.rhs[hi] -= kv;
}

/// The arrays of the springs' passes for `h` (h_s of the linearised system; unused by the
/// forces' pass).
SpringPass spring_arrays(Data& data, double h) noexcept {
  NetScratch& s = data.scratch->net;
  SweepSprings& sw = s.sweep_springs;
  return SpringPass{data.nodes.data(),
                    s.spring_constants.rest_length.data(),
                    s.spring_constants.stiffness.data(),
                    s.spring_constants.damping.data(),
                    sw.direction_x.data(),
                    sw.direction_y.data(),
                    sw.direction_z.data(),
                    sw.weight_axial.data(),
                    sw.weight_isotropic.data(),
                    sw.high.data(),
                    s.spring_length.data(),
                    s.force.data(),
                    s.spring_block.data(),
                    s.rhs.data(),
                    h,
                    h * h};
}

/// The springs' pass of compute_net_forces(), in the sweep order (grouped by
/// their earlier node k in Model::node_sweep_order, whose sums stay in
/// registers), two springs of a node at a time (the same law as
/// one_spring(), lane by lane: the same operations and roundings): forces,
/// and the directions and lengths linearization_pass() starts from; adds the springs' elastic
/// energy to their net's NetOutput::start_energy. Expects force = gravity + ties on entry.
/// (Linearising in the same pass was measured and not kept: docs/net-solver.md.)
///
/// With kStill (net_still.hpp; NetScratch::still_flags marked for this pass): a still node's
/// force after the springs and its energy term are its last pass's (NetScratch::still_force,
/// still_energy), and its springs to still later nodes are skipped when all of them are; a node
/// not still stores its own for the next pass. The same results to the bit as without.
template <bool kStill>
[[gnu::always_inline]] inline void spring_pass(const Model& model, Data& data) noexcept {
  NetScratch& s = data.scratch->net;
  const SpringPass a = spring_arrays(data, 0.0);
  const std::int32_t* low_begin = s.spring_low_begin.data();
  const std::int32_t* order = model.node_sweep_order.data();
  const int* node_net = model.node_net.data();
  const std::uint8_t* still = s.still_flags.data();
  Vec3* still_force = s.still_force.data();
  double* still_energy = s.still_energy.data();
  NetOutput* out = data.nets.data();
  const std::size_t n = data.nodes.size();
  for (std::size_t p = 0; p < n; ++p) {
    const auto k = static_cast<std::size_t>(order[p]);
    if constexpr (kStill) {
      if (still[k] == 0) {
        // Every spring to a later node skipped if that node is still too: its force and its
        // lengths come from the pass that last computed them, from the same states.
        std::uint8_t later = 0;
        for (std::int32_t j = low_begin[p]; j < low_begin[p + 1]; ++j)
          later |= still[static_cast<std::size_t>(a.high[j])];
        if (later == 0) {
          a.force[k] = still_force[k];
          out[node_net[k]].start_energy += still_energy[k];
          continue;
        }
      }
    }
    const Vec3 xk = a.nodes[k].position;
    const Vec3 vk = a.nodes[k].velocity;
    const Pair xx = Pair::Constant(xk.x()), xy = Pair::Constant(xk.y()),
               xz = Pair::Constant(xk.z());
    const Pair vx = Pair::Constant(vk.x()), vy = Pair::Constant(vk.y()),
               vz = Pair::Constant(vk.z());
    Pair fx = Pair::Zero(), fy = Pair::Zero(), fz = Pair::Zero();
    Pair energy = Pair::Zero();  // Σ k (l − L)² of the node's springs
    std::int32_t j = low_begin[p];
    const std::int32_t end = low_begin[p + 1];
    for (; j + 1 < end; j += 2) {
      const auto h0 = static_cast<std::size_t>(a.high[j]);
      const auto h1 = static_cast<std::size_t>(a.high[j + 1]);
      const NodeState& n0 = a.nodes[h0];
      const NodeState& n1 = a.nodes[h1];
      const Pair dx = Pair(n0.position.x(), n1.position.x()) - xx;
      const Pair dy = Pair(n0.position.y(), n1.position.y()) - xy;
      const Pair dz = Pair(n0.position.z(), n1.position.z()) - xz;
      const Pair l = (dx * dx + dy * dy + dz * dz).sqrt();
      const Pair inv_l = l.inverse();
      const Pair rest = load_pair(a.rest_length + j);
      Pair nx = dx * inv_l, ny = dy * inv_l, nz = dz * inv_l;
      if (!(l(0) > 1e-12 * rest(0) && l(1) > 1e-12 * rest(1))) {
        for (int e = 0; e < 2; ++e) {  // a spring of zero length keeps its last direction
          if (l(e) > 1e-12 * rest(e)) continue;
          nx(e) = a.dir_x[j + e];
          ny(e) = a.dir_y[j + e];
          nz(e) = a.dir_z[j + e];
        }
      }
      store_pair(a.dir_x + j, nx);
      store_pair(a.dir_y + j, ny);
      store_pair(a.dir_z + j, nz);
      store_pair(a.length + j, l);
      const Pair dvx = Pair(n0.velocity.x(), n1.velocity.x()) - vx;
      const Pair dvy = Pair(n0.velocity.y(), n1.velocity.y()) - vy;
      const Pair dvz = Pair(n0.velocity.z(), n1.velocity.z()) - vz;
      const Pair n_dv = nx * dvx + ny * dvy + nz * dvz;
      const Pair stiffness = load_pair(a.stiffness + j), damping = load_pair(a.damping + j);
      const Pair stretch = l - rest;
      energy += stiffness * stretch * stretch;
      const Pair fs = stiffness * stretch + damping * n_dv;
      const Pair gx = fs * nx, gy = fs * ny, gz = fs * nz;
      fx += gx;
      fy += gy;
      fz += gz;
      a.force[h0] -= Vec3(gx(0), gy(0), gz(0));
      a.force[h1] -= Vec3(gx(1), gy(1), gz(1));
    }
    NodeSums sum;
    sum.force = Vec3(fx(0) + fx(1), fy(0) + fy(1), fz(0) + fz(1));
    if (j < end) one_spring(a, j, xk, vk, sum);
    a.force[k] += sum.force;
    const double node_energy = 0.5 * (energy(0) + energy(1) + sum.energy);
    out[node_net[k]].start_energy += node_energy;
    if constexpr (kStill) {
      if (still[k] == 0) {
        a.force[k] = still_force[k];  // an earlier still node skipped its springs to this one
      } else {
        still_force[k] = a.force[k];
        still_energy[k] = node_energy;
      }
    }
  }
}

/// The springs' linearisation for the implicit solve (linearize_nets()), in the
/// order of spring_pass() and two springs at a time (the same operations and
/// roundings as one_spring_linearization(), lane by lane), from the directions
/// and lengths spring_pass() stored: the weights W_e = α d̂d̂ᵀ + β I
/// (SweepSprings), their sum at both nodes (NetScratch::spring_block: 6
/// entries, the later node's scattered two at a time), and the spring part of
/// the node rows' right-hand side, −h² k K̃ (v_i − v_j) with
/// k K̃ = (h² k − β)/h² d̂d̂ᵀ + β/h² I (net_solve.hpp). Expects spring_block = 0
/// and rhs = 0 on entry.
void linearization_pass(const Model& model, Data& data, double h) noexcept {
  const NetScratch& s = data.scratch->net;
  const SpringPass a = spring_arrays(data, h);
  const std::int32_t* low_begin = s.spring_low_begin.data();
  const std::int32_t* order = model.node_sweep_order.data();
  const Pair hp = Pair::Constant(a.h), h2p = Pair::Constant(a.h2);
  // The springs that touch a node in the solve (NetScratch::pass_positions: every node's
  // when none rests, net_rest.hpp).
  for (std::size_t net = 0; net < model.nets.size(); ++net) {
    const std::int32_t* positions = s.pass_positions.data() + model.nets[net].node_begin;
    const int count = s.pass_count[net];
    for (int q = 0; q < count; ++q) {
      const auto p = static_cast<std::size_t>(positions[q]);
      const auto k = static_cast<std::size_t>(order[p]);
      const Vec3 vk = a.nodes[k].velocity;
      const Pair vx = Pair::Constant(vk.x()), vy = Pair::Constant(vk.y()),
                 vz = Pair::Constant(vk.z());
      Pair bx = Pair::Zero(), by = Pair::Zero(), bz = Pair::Zero();
      Pair s00 = Pair::Zero(), s01 = Pair::Zero(), s02 = Pair::Zero(), s11 = Pair::Zero(),
           s12 = Pair::Zero(), s22 = Pair::Zero();
      std::int32_t j = low_begin[p];
      const std::int32_t end = low_begin[p + 1];
      for (; j + 1 < end; j += 2) {
        const auto h0 = static_cast<std::size_t>(a.high[j]);
        const auto h1 = static_cast<std::size_t>(a.high[j + 1]);
        const NodeState& n0 = a.nodes[h0];
        const NodeState& n1 = a.nodes[h1];
        const Pair l = load_pair(a.length + j);
        const Pair inv_l = l.inverse();
        const Pair rest = load_pair(a.rest_length + j);
        const Pair nx = load_pair(a.dir_x + j), ny = load_pair(a.dir_y + j),
                   nz = load_pair(a.dir_z + j);
        const Pair dvx = Pair(n0.velocity.x(), n1.velocity.x()) - vx;
        const Pair dvy = Pair(n0.velocity.y(), n1.velocity.y()) - vy;
        const Pair dvz = Pair(n0.velocity.z(), n1.velocity.z()) - vz;
        const Pair n_dv = nx * dvx + ny * dvy + nz * dvz;
        const Pair stiffness = load_pair(a.stiffness + j), damping = load_pair(a.damping + j);
        const Pair hk = h2p * stiffness;
        // β = hk (1 − L/l) if l > L else 0, as max(0, ·) (SSE2 maxpd; Eigen's pmax(a, b)
        // returns a when b is NaN: 0 for l = 0, as the comparison gives).
        const Pair beta = Pair::Zero().max(hk * (1.0 - rest * inv_l));
        const Pair alpha = hp * damping + hk - beta;
        store_pair(a.weight_axial + j, alpha);
        store_pair(a.weight_isotropic + j, beta);
        const Pair ax = alpha * nx, ay = alpha * ny, az = alpha * nz;
        const Pair w00 = ax * nx + beta, w11 = ay * ny + beta, w22 = az * nz + beta;
        const Pair w01 = ax * ny, w02 = ax * nz, w12 = ay * nz;
        s00 += w00;
        s01 += w01;
        s02 += w02;
        s11 += w11;
        s12 += w12;
        s22 += w22;
        add_symmetric(a.spring_block[h0], w00(0), w01(0), w02(0), w11(0), w12(0), w22(0));
        add_symmetric(a.spring_block[h1], w00(1), w01(1), w02(1), w11(1), w12(1), w22(1));
        const Pair c = (hk - beta) * n_dv;
        const Pair kx = c * nx + beta * dvx, ky = c * ny + beta * dvy, kz = c * nz + beta * dvz;
        bx += kx;
        by += ky;
        bz += kz;
        a.rhs[h0] -= Vec3(kx(0), ky(0), kz(0));
        a.rhs[h1] -= Vec3(kx(1), ky(1), kz(1));
      }
      NodeSums sum;
      sum.rhs = Vec3(bx(0) + bx(1), by(0) + by(1), bz(0) + bz(1));
      sum.w00 = s00(0) + s00(1);
      sum.w01 = s01(0) + s01(1);
      sum.w02 = s02(0) + s02(1);
      sum.w11 = s11(0) + s11(1);
      sum.w12 = s12(0) + s12(1);
      sum.w22 = s22(0) + s22(1);
      if (j < end) one_spring_linearization(a, j, vk, sum);
      a.rhs[k] += sum.rhs;
      add_symmetric(a.spring_block[k], sum.w00, sum.w01, sum.w02, sum.w11, sum.w12, sum.w22);
    }
  }
}

}  // namespace

namespace detail {

void add_spring_forces(const Model& model, Data& data) noexcept {
  if (mark_still_nodes(model, data))
    spring_pass<true>(model, data);
  else
    spring_pass<false>(model, data);
}

}  // namespace detail

void linearize_nets(const Model& model, Data& data, double system_step) noexcept {
  if (model.nets.empty()) return;
  NetScratch& s = data.scratch->net;
  // The ties' sums of the rigid component's rows (NetTieSums; the anchor's
  // velocity at the step's start is that of the twist u0 the integrator
  // starts from), and the node rows' accumulators cleared. Raw pointers, as
  // in compute_net_forces().
  const NodeState* nodes = data.nodes.data();
  const Vec3* lever_in = s.lever.data();
  Vec3* rhs = s.rhs.data();
  SymmetricBlock* spring_block = s.spring_block.data();
  for (std::size_t k = 0; k < model.nets.size(); ++k) {
    const NetModel& net = model.nets[k];
    const auto bi = static_cast<std::size_t>(net.body);
    if (data.scratch->solver.imposed[bi]) {
      // A body imposed this step (kDirect, or anchored: an organ's) is not in the solve: its
      // rows and so these sums are not used (add_net_body_terms()); only the clearing.
      for (int v = net.node_begin; v < net.node_begin + net.node_count; ++v) {
        spring_block[static_cast<std::size_t>(v)] = SymmetricBlock{};
        rhs[static_cast<std::size_t>(v)].setZero();
      }
      s.tie_sums[k] = NetTieSums{};
      continue;
    }
    const BodyState& body = data.bodies[bi];
    Vec3 sum_r = Vec3::Zero();
    double rr00 = 0.0, rr01 = 0.0, rr02 = 0.0, rr11 = 0.0, rr12 = 0.0, rr22 = 0.0;
    Vec3 sum_dv = Vec3::Zero(), sum_r_dv = Vec3::Zero();
    for (int v = net.node_begin; v < net.node_begin + net.node_count; ++v) {
      const auto i = static_cast<std::size_t>(v);
      const Vec3 lever = lever_in[i];
      const Vec3 anchor_velocity = body.linear_velocity + body.angular_velocity.cross(lever);
      const Vec3 dv = nodes[i].velocity - anchor_velocity;
      spring_block[i] = SymmetricBlock{};
      rhs[i].setZero();
      sum_r += lever;
      rr00 += lever.x() * lever.x();
      rr01 += lever.x() * lever.y();
      rr02 += lever.x() * lever.z();
      rr11 += lever.y() * lever.y();
      rr12 += lever.y() * lever.z();
      rr22 += lever.z() * lever.z();
      sum_dv += dv;
      sum_r_dv += lever.cross(dv);
    }
    NetTieSums& t = s.tie_sums[k];
    t.lever_sum = sum_r;
    t.lever_moment << rr00, rr01, rr02, rr01, rr11, rr12, rr02, rr12, rr22;
    t.relative << sum_dv, sum_r_dv;
  }
  // The springs' weights, their sums per node and their part of the node rows' b.
  linearization_pass(model, data, system_step);
}

}  // namespace numen::core
