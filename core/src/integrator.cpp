/// @file integrator.cpp
/// Linearly implicit Euler (Baraff & Witkin 1998) with a block-Jacobi
/// preconditioned conjugate gradient, and symplectic Euler (paper Eq. 1, §5).

#include "numen/core/integrator.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "numen/core/capacity.hpp"
#include "numen/core/coupling.hpp"
#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/rigid_body.hpp"

namespace numen::core {
namespace {


int active_contact_count(const Data& data) noexcept {
  return std::clamp(data.num_contacts, 0, kMaxContacts);
}

bool is_first_order(const SolverScratch& s, int body) noexcept {
  return s.first_order && body == s.coupled_body;
}

/// Velocity of the contact point of a body moving with twist u at lever arm r.
Vec3 point_velocity(const Vec6& u, const Vec3& r) noexcept {
  return u.head<3>() + u.tail<3>().cross(r);
}

/// Adds Jᵀ W J, J = [I, −[r]×] (3×6), to a body's 6×6 block.
void add_contact_block(const Mat3& w, const Vec3& r, Mat6& block) noexcept {
  // Jᵀ W J with J = [I, −S], S = [r]×, Sᵀ = −S and W symmetric:
  //   [[W, −W S], [S W, −S W S]]; (W S)ᵀ = −S W, so only W S and S (W S) are formed.
  const Mat3 sk = skew(r);
  const Mat3 ws = w * sk;
  block.topLeftCorner<3, 3>() += w;
  block.topRightCorner<3, 3>() -= ws;
  block.bottomLeftCorner<3, 3>() -= ws.transpose();
  block.bottomRightCorner<3, 3>().noalias() -= sk * ws;
}

double dot(std::span<const Vec6> a, std::span<const Vec6> b) noexcept {
  double s = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) s += a[i].dot(b[i]);
  return s;
}

void apply_preconditioner(const SolverScratch& s, std::span<const Vec6> r,
                          std::span<Vec6> z) noexcept {
  for (std::size_t i = 0; i < r.size(); ++i) {
    if (s.in_solve[i]) {
      z[i] = r[i];
      s.block_llt[i].solveInPlace(z[i]);
    } else {
      z[i].setZero();
    }
  }
}

}  // namespace

void SolverScratch::resize(const Model& model) {
  const auto n = static_cast<std::size_t>(model.num_bodies());
  saved_state.assign(n, BodyState{});
  inertia_world.assign(n, Mat3::Identity());
  twist0.assign(n, Vec6::Zero());
  rhs.assign(n, Vec6::Zero());
  delta.assign(n, Vec6::Zero());
  residual.assign(n, Vec6::Zero());
  precond_residual.assign(n, Vec6::Zero());
  direction.assign(n, Vec6::Zero());
  a_direction.assign(n, Vec6::Zero());
  block.assign(n, Mat6::Identity());
  block_llt.assign(n, Eigen::LLT<Mat6>(Mat6::Identity()));
  in_solve.assign(n, 1);
  contact_terms.assign(static_cast<std::size_t>(kMaxContacts), ContactTerm{});
  coupled_body = -1;
  first_order = false;
  direct_body = -1;
}

void prepare_implicit_step(const Model& model, Data& data) noexcept {
  SolverScratch& s = data.solver;
  const double h = model.dt;
  for (std::size_t i = 0; i < data.bodies.size(); ++i) {
    BodyState& st = data.bodies[i];
    const BodyModel& bm = model.bodies[i];
    s.twist0[i] << st.linear_velocity, st.angular_velocity;
    s.inertia_world[i] = world_inertia(st.orientation, bm.inertia_body);
    const int b = static_cast<int>(i);
    if (b == s.direct_body || is_first_order(s, b)) continue;
    st.angular_velocity =
        implicit_gyroscopic_velocity(st.orientation, bm.inertia_body, st.angular_velocity, h);
  }
}

void build_implicit_system(const Model& model, Data& data) noexcept {
  SolverScratch& s = data.solver;
  const double h = model.dt;
  const double h2 = h * h;
  const std::size_t n = data.bodies.size();

  for (std::size_t i = 0; i < n; ++i) {
    const int b = static_cast<int>(i);
    s.in_solve[i] = b != s.direct_body ? 1 : 0;
    Mat6& blk = s.block[i];
    Vec6& rhs = s.rhs[i];
    if (!s.in_solve[i]) {
      blk.setIdentity();
      rhs.setZero();
      continue;
    }
    const BodyState& st = data.bodies[i];
    const Wrench& f = data.body_wrench[i];
    rhs << h * f.force, h * f.torque;
    blk.setZero();
    if (!is_first_order(s, b)) {
      const double m = model.bodies[i].mass;
      blk.topLeftCorner<3, 3>().diagonal().setConstant(m);
      blk.bottomRightCorner<3, 3>() = s.inertia_world[i];
      // M (u* − u0): the implicit gyroscopic impulse (only ω changes).
      rhs.tail<3>() += s.inertia_world[i] * (st.angular_velocity - s.twist0[i].tail<3>());
    }
  }

  // Coupling springs of Eq. 2: K = −diag(k_t I, k_r I), D = −diag(γ_t I, γ_r I).
  const int cb = s.coupled_body;
  if (cb >= 0 && cb < static_cast<int>(n) && s.in_solve[static_cast<std::size_t>(cb)]) {
    const auto i = static_cast<std::size_t>(cb);
    const CouplingGains& g = model.bodies[i].coupling;
    s.block[i].topLeftCorner<3, 3>().diagonal().array() += h * g.gamma_t + h2 * g.k_t;
    s.block[i].bottomRightCorner<3, 3>().diagonal().array() += h * g.gamma_r + h2 * g.k_r;
    s.rhs[i].head<3>() -= h2 * g.k_t * s.twist0[i].head<3>();
    s.rhs[i].tail<3>() -= h2 * g.k_r * s.twist0[i].tail<3>();
  }

  // Active contacts: A += Gᵀ W G, b += h² K u0 = −h² k Gᵀ n (n · G u0).
  const int nc = active_contact_count(data);
  for (int c = 0; c < nc; ++c) {
    ContactTerm& t = s.contact_terms[static_cast<std::size_t>(c)];
    if (!t.active) continue;
    const Contact& ct = data.contacts[static_cast<std::size_t>(c)];
    const MaterialPair& mp = model.material_pairs[static_cast<std::size_t>(ct.material_pair)];
    const Vec3& nrm = ct.normal;
    const Mat3 nn = nrm * nrm.transpose();
    t.weight = (h * mp.damping + h2 * mp.stiffness) * nn + (h * mp.friction) * (Mat3::Identity() - nn);
    const auto a = static_cast<std::size_t>(ct.body_a);
    Vec3 v_rel0 = point_velocity(s.twist0[a], t.r_a);
    if (ct.body_b >= 0) v_rel0 -= point_velocity(s.twist0[static_cast<std::size_t>(ct.body_b)], t.r_b);
    const Vec3 imp = (-h2 * mp.stiffness * nrm.dot(v_rel0)) * nrm;
    if (s.in_solve[a]) {
      s.rhs[a].head<3>() += imp;
      s.rhs[a].tail<3>() += t.r_a.cross(imp);
      add_contact_block(t.weight, t.r_a, s.block[a]);
    }
    if (ct.body_b >= 0) {
      const auto b = static_cast<std::size_t>(ct.body_b);
      if (s.in_solve[b]) {
        s.rhs[b].head<3>() -= imp;
        s.rhs[b].tail<3>() -= t.r_b.cross(imp);
        add_contact_block(t.weight, t.r_b, s.block[b]);
      }
    }
  }

  for (std::size_t i = 0; i < n; ++i) s.block_llt[i].compute(s.block[i]);
}

void apply_implicit_system(const Model& /*model*/, const Data& data, std::span<const Vec6> in,
                           std::span<Vec6> out) noexcept {
  // A = blockdiag(block[i]) + the off-diagonal blocks of body–body contacts.
  // block[i] (build_implicit_system) already holds M_i (or 0 for a first-order
  // body), the coupling terms and every contact's diagonal contribution
  // G_iᵀ W G_i, so only the cross terms −G_aᵀ W G_b remain per body–body
  // contact: static contacts cost nothing per iteration.
  const SolverScratch& s = data.solver;
  const std::size_t n = data.bodies.size();
  for (std::size_t i = 0; i < n; ++i) {
    if (s.in_solve[i]) {
      out[i].noalias() = s.block[i] * in[i];
    } else {
      out[i].setZero();
    }
  }
  const int nc = active_contact_count(data);
  for (int c = 0; c < nc; ++c) {
    const Contact& ct = data.contacts[static_cast<std::size_t>(c)];
    if (ct.body_b < 0) continue;
    const ContactTerm& t = s.contact_terms[static_cast<std::size_t>(c)];
    if (!t.active) continue;
    const auto a = static_cast<std::size_t>(ct.body_a);
    const auto b = static_cast<std::size_t>(ct.body_b);
    if (!s.in_solve[a] || !s.in_solve[b]) continue;
    // u = G_a in_a − G_b in_b; the cross terms are out_a −= G_aᵀ W G_b in_b and
    // out_b −= G_bᵀ W G_a in_a.
    const Vec3 wa = t.weight * point_velocity(in[a], t.r_a);
    const Vec3 wb = t.weight * point_velocity(in[b], t.r_b);
    out[a].head<3>() -= wb;
    out[a].tail<3>() -= t.r_a.cross(wb);
    out[b].head<3>() -= wa;
    out[b].tail<3>() -= t.r_b.cross(wa);
  }
}

bool solve_implicit_system(const Model& model, Data& data) noexcept {
  SolverScratch& s = data.solver;
  const std::span<Vec6> x(s.delta);
  const std::span<Vec6> r(s.residual);
  const std::span<Vec6> z(s.precond_residual);
  const std::span<Vec6> p(s.direction);
  const std::span<Vec6> ap(s.a_direction);
  const std::span<const Vec6> b(s.rhs);

  for (std::size_t i = 0; i < x.size(); ++i) {
    x[i].setZero();
    r[i] = b[i];
  }
  const double b_norm = std::sqrt(dot(b, b));
  data.solver_iterations = 0;
  data.solver_residual = 0.0;
  if (!std::isfinite(b_norm)) {
    // Non-finite forces: make the result non-finite so that step()'s checks
    // reject it, rather than silently dropping them.
    for (Vec6& v : x) v.setConstant(std::numeric_limits<double>::quiet_NaN());
    data.solver_residual = std::numeric_limits<double>::quiet_NaN();
    return false;
  }
  if (b_norm == 0.0) return true;

  apply_preconditioner(s, r, z);
  for (std::size_t i = 0; i < p.size(); ++i) p[i] = z[i];
  double rz = dot(r, z);
  double rel = 1.0;
  int it = 0;
  const int max_it = std::max(1, model.solver.max_iterations);
  while (it < max_it) {
    ++it;
    apply_implicit_system(model, data, p, ap);
    const double pap = dot(p, ap);
    if (!(pap > 0.0)) break;  // breakdown (A not SPD numerically, or converged exactly)
    const double alpha = rz / pap;
    for (std::size_t i = 0; i < x.size(); ++i) {
      x[i] += alpha * p[i];
      r[i] -= alpha * ap[i];
    }
    rel = std::sqrt(dot(r, r)) / b_norm;
    if (rel <= model.solver.tolerance) break;
    apply_preconditioner(s, r, z);
    const double rz_new = dot(r, z);
    const double beta = rz_new / rz;
    rz = rz_new;
    for (std::size_t i = 0; i < p.size(); ++i) p[i] = z[i] + beta * p[i];
  }
  data.solver_iterations = it;
  data.solver_residual = rel;
  return rel <= model.solver.tolerance;
}

void integrate_linearly_implicit_euler(const Model& model, Data& data) noexcept {
  SolverScratch& s = data.solver;
  const double h = model.dt;
  prepare_implicit_step(model, data);
  build_implicit_system(model, data);
  if (!solve_implicit_system(model, data)) data.status |= kSolverNotConverged;
  for (std::size_t i = 0; i < data.bodies.size(); ++i) {
    if (!s.in_solve[i]) continue;  // kDirect body: stays at the imposed target
    BodyState& st = data.bodies[i];
    const Vec6 u1 = s.twist0[i] + s.delta[i];
    st.linear_velocity = u1.head<3>();
    st.angular_velocity = u1.tail<3>();
    st.position += h * st.linear_velocity;
    st.orientation = integrate_orientation(st.orientation, st.angular_velocity, h);
  }
}

void integrate_symplectic_euler(const Model& model, Data& data) noexcept {
  const SolverScratch& s = data.solver;
  const double h = model.dt;
  for (std::size_t i = 0; i < data.bodies.size(); ++i) {
    const int b = static_cast<int>(i);
    if (b == s.direct_body) continue;
    BodyState& st = data.bodies[i];
    const BodyModel& bm = model.bodies[i];
    const Wrench& f = data.body_wrench[i];
    if (is_first_order(s, b)) {
      // Massless limit of Eq. 2: k e + γ (v_t − v) + F_other = 0, per axis group.
      const CouplingGains& g = bm.coupling;
      const Wrench& cw = data.coupling_wrench;
      const Vec3 e = data.target.position - st.position;
      const Vec3 theta_u = rotation_error(data.target.orientation, st.orientation);
      st.linear_velocity =
          data.target_twist.linear + (g.k_t * e + (f.force - cw.force)) / g.gamma_t;
      st.angular_velocity =
          data.target_twist.angular + (g.k_r * theta_u + (f.torque - cw.torque)) / g.gamma_r;
    } else {
      const Mat3 iw = world_inertia(st.orientation, bm.inertia_body);
      const Mat3 iw_inv = world_inertia_inverse(st.orientation, bm.inertia_body_inv);
      st.linear_velocity += (h / bm.mass) * f.force;
      st.angular_velocity +=
          h * (iw_inv * (f.torque + gyroscopic_torque(iw, st.angular_velocity)));
    }
    st.position += h * st.linear_velocity;
    st.orientation = integrate_orientation(st.orientation, st.angular_velocity, h);
  }
  data.solver_iterations = 0;
  data.solver_residual = 0.0;
}

void integrate(const Model& model, Data& data) noexcept {
  switch (model.integrator) {
    case Integrator::kSymplecticEuler:
      integrate_symplectic_euler(model, data);
      break;
    case Integrator::kLinearlyImplicitEuler:
    default:
      integrate_linearly_implicit_euler(model, data);
      break;
  }
}

}  // namespace numen::core
