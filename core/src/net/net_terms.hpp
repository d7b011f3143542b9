#pragma once
/// @file net_terms.hpp
/// Private to numen::core (core/src/net): the terms of the nets' coupled
/// system (net_solve.hpp) shared by its assembly (net_assembly.cpp), the SSOR
/// sweeps with Eisenstat's CG (net_sweeps.cpp) and the arrowhead projected CG
/// (net_arrowhead.cpp): tie weights, contact weights, the springs' weights in
/// the sweep order, and the two solves solve_net_system() dispatches to.

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cstdint>
#include <span>

#include "scratch/data_scratch.hpp"
#include "solver/solver_terms.hpp"
#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/types.hpp"

namespace numen::core::detail {

/// c = h γ_tie + h² k_tie: a tie's weight in A (kg = N·s²/m).
inline double tie_weight(const NetModel& net, double h) noexcept {
  return h * net.tie_damping + h * h * net.tie_stiffness;
}

/// W v = α n (n · v) + β v.
inline Vec3 weight_times(double alpha, double beta, const Vec3& n, const Vec3& v) noexcept {
  return (alpha * n.dot(v)) * n + beta * v;
}

/// Node contacts of this step within the scratch (Data::node_contacts), the grasp springs on held
/// nodes after them (Data::num_node_grasp_springs), the needles' puncture ties after those
/// (Data::num_node_needle_ties) and the threads' eyelet springs last (Data::num_node_thread_ties)
/// included: what the solve takes.
inline int node_contact_count(const Data& data) noexcept {
  return std::clamp(data.num_node_contacts + data.num_node_grasp_springs + data.num_node_needle_ties +
                        data.num_node_thread_ties,
                    0, static_cast<int>(data.node_contacts.size()));
}

/// Writes `c` as a held node contact (NodeContact::held): a spring along the unit `axis` between
/// node `node` and the point `at` (world, m; lever `r_b` from body `body`'s COM) of stiffness `k`
/// (N/m) and damping `damping` (N·s/m), its force on the node at the step's start `force` (N,
/// along `axis`) and the node's velocity along `axis` relative to the point (m/s). What a grasp's
/// springs on held nodes, a needle's puncture ties and a thread's eyelets on tissue write
/// (grasp.hpp, needle_puncture.hpp, thread.hpp). `body` −1: the point moves as given, no body
/// takes the reaction (a thread's point: the thread's step takes it).
inline void set_held_spring(NodeContact& c, int node, int body, const Vec3& at, const Vec3& r_b,
                            const Vec3& axis, double k, double damping, const Vec3& force,
                            double normal_velocity) noexcept {
  c = NodeContact{};
  c.node = node;
  c.body_b = body;
  c.position = at;
  c.r_b = r_b;
  c.normal = axis;
  c.stiffness = k;
  c.damping = damping;
  c.force = force;
  c.normal_velocity = normal_velocity;
  c.active = true;
  c.held = true;
}

/// Writes the held springs (set_held_spring()) that carry a force on the material point of net
/// triangle `face` (barycentric `weights`) to its nodes: for each node with weight w > 0, one
/// spring along each of the three orthonormal `axes`, of stiffness w k[a] (N/m) and damping
/// w c[a] (N·s/m), its force on the node w (axes[a] · force) axes[a] (`force`: the whole force
/// on the point, N, world), tied to the point `at` (world, m) moving at `v_at` (m/s) of `body`
/// (lever `r_b`; −1: no body). They go at Data::node_contacts[base + count], `count` counting
/// them (a needle's puncture ties, Data::num_node_needle_ties; a thread's eyelets on tissue,
/// Data::num_node_thread_ties); stops when the buffer is full (make_data() gives them room).
inline void write_face_springs(const Model& model, Data& data, int face, const Vec3& weights,
                               const std::array<Vec3, 3>& axes, const std::array<double, 3>& k,
                               const std::array<double, 3>& c, const Vec3& force, int body,
                               const Vec3& at, const Vec3& r_b, const Vec3& v_at, int base,
                               int& count) noexcept {
  const std::array<int, 3>& f = model.net_faces[static_cast<std::size_t>(face)];
  for (int m = 0; m < 3; ++m) {
    const double w = weights[m];
    if (!(w > 0.0)) continue;
    const int node = f[static_cast<std::size_t>(m)];
    const Vec3& v_node = data.nodes[static_cast<std::size_t>(node)].velocity;
    for (std::size_t a = 0; a < 3; ++a) {
      const auto slot = static_cast<std::size_t>(base + count);
      if (slot >= data.node_contacts.size()) return;
      const Vec3& e = axes[a];
      set_held_spring(data.node_contacts[slot], node, body, at, r_b, e, w * k[a], w * c[a],
                      (w * e.dot(force)) * e, e.dot(v_node - v_at));
      ++count;
    }
  }
}

/// A node contact with a dynamic body in the solve: an off-diagonal block.
inline bool couples_body(const SolverScratch& s, const NodeContact& c) noexcept {
  return c.active && c.body_b >= 0 && s.in_solve[static_cast<std::size_t>(c.body_b)];
}

/// out_b += c Σ_i J_iᵀ v_i over each net's nodes, for the rigid components
/// in the solve (−A_bi v_i summed over a net's ties, A_bi = −c J_iᵀ).
inline void add_tie_transpose(const Model& model, const Data& data, std::span<const Vec3> v_n,
                              std::span<Vec6> out_b) noexcept {
  const double h = data.scratch->solver.system_step;  // h_s of the linearised system (integrator.hpp)
  for (const NetModel& net : model.nets) {
    const auto b = static_cast<std::size_t>(net.body);
    if (!data.scratch->solver.in_solve[b]) continue;
    Vec6 acc = Vec6::Zero();
    for (int v = net.node_begin; v < net.node_begin + net.node_count; ++v) {
      const auto i = static_cast<std::size_t>(v);
      acc += generalized_force(v_n[i], data.scratch->net.lever[i]);
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

/// The springs [begin, end) of node k (value xk) in a product with A: w_j = W_j (xk − x_high(j))
/// is taken from out_high(j), and Σ_j w_j returned for row k; two springs at a time. Always
/// inlined, as gather_springs().
[[gnu::always_inline]] inline Vec3 spring_differences(const SpringView& s, std::int32_t begin,
                                                      std::int32_t end, const Vec3& xk,
                                                      const Vec3* x, Vec3* out) noexcept {
  const Pair kx = Pair::Constant(xk.x()), ky = Pair::Constant(xk.y()), kz = Pair::Constant(xk.z());
  Pair ax = Pair::Zero(), ay = Pair::Zero(), az = Pair::Zero();
  std::int32_t j = begin;
  for (; j + 1 < end; j += 2) {
    const auto h0 = static_cast<std::size_t>(s.high[j]);
    const auto h1 = static_cast<std::size_t>(s.high[j + 1]);
    const Vec3& a = x[h0];
    const Vec3& b = x[h1];
    const Pair dx = kx - Pair(a.x(), b.x()), dy = ky - Pair(a.y(), b.y()), dz = kz - Pair(a.z(), b.z());
    const Pair nx = load_pair(s.nx + j), ny = load_pair(s.ny + j), nz = load_pair(s.nz + j);
    const Pair t = load_pair(s.alpha + j) * (nx * dx + ny * dy + nz * dz);
    const Pair beta = load_pair(s.beta + j);
    const Pair wx = t * nx + beta * dx, wy = t * ny + beta * dy, wz = t * nz + beta * dz;
    ax += wx;
    ay += wy;
    az += wz;
    out[h0] -= Vec3(wx(0), wy(0), wz(0));
    out[h1] -= Vec3(wx(1), wy(1), wz(1));
  }
  Vec3 sum(ax(0) + ax(1), ay(0) + ay(1), az(0) + az(1));
  if (j < end) {
    const auto h = static_cast<std::size_t>(s.high[j]);
    const Vec3 w = spring_times(s, j, xk - x[h]);
    sum += w;
    out[h] -= w;
  }
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

/// Eisenstat's CG with the SSOR preconditioner (models without joints;
/// net_solve.hpp), through detail::pcg(). Writes Δu, Δv, Data::solver_iterations
/// and solver_residual; true when converged. net_sweeps.cpp.
bool solve_net_eisenstat(const Model& model, Data& data) noexcept;

/// The arrowhead-preconditioned projected CG (models with joints;
/// net_solve.hpp), through detail::pcg(). Also writes the joint multipliers.
/// net_arrowhead.cpp.
bool solve_net_arrowhead(const Model& model, Data& data) noexcept;

}  // namespace numen::core::detail
