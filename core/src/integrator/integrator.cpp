/// @file integrator.cpp
/// Linearly implicit Euler (Baraff & Witkin 1998) with a block-Jacobi
/// preconditioned conjugate gradient and the linearised trapezoidal rule on the
/// same system (paper Eq. 1, §5); the integrate stage's dispatch. With joints the solve is
/// integrator_joints.cpp's; TR-BDF2 is integrator_tr_bdf2.cpp, symplectic Euler
/// integrator_symplectic.cpp.

#include "numen/core/integrator.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "numen/core/articulation.hpp"
#include "numen/core/capacity.hpp"
#include "numen/core/coupling.hpp"
#include "numen/core/data.hpp"
#include "numen/core/features.hpp"
#include "numen/core/model.hpp"
#include "numen/core/net_forces.hpp"
#include "numen/core/rigid_body.hpp"
#include "numen/core/sliding_tie.hpp"
#include "numen/core/step_stages.hpp"

#include "scratch/data_scratch.hpp"
#include "grasp/grasp_terms.hpp"
#include "solver/implicit_system.hpp"
#include "articulation/joint_system.hpp"
#include "net/net_solve.hpp"
#include "linalg/pcg.hpp"
#include "solver/solver_terms.hpp"

namespace numen::core {
namespace {

using detail::dot;
using detail::is_first_order;
using detail::point_velocity;


int active_contact_count(const Data& data) noexcept {  // within the scratch (capacity.hpp)
  return std::clamp(data.num_contacts, 0, static_cast<int>(data.scratch->solver.contact_terms.size()));
}

/// Adds one body's share of a contact to its 6×6 block and right-hand side.
/// With J = [I, −[r]×] (3×6, the body's part of G up to sign) and
/// W = α n nᵀ + β I:
///   Jᵀ W J = α g gᵀ + β Jᵀ J,  g = Jᵀ n = (n, r × n),
/// and the impulse s n maps to Jᵀ (s n) = s g. The β Jᵀ J part is gathered in
/// the body's IsotropicMoments and added once by add_isotropic_part().
void add_contact_terms(double alpha, double beta, double impulse, const Vec3& n, const Vec3& r,
                       Mat6& block, Vec6& rhs, IsotropicMoments& moments) noexcept {
  Vec6 g;
  g << n, r.cross(n);
  rhs += impulse * g;
  const Vec6 ag = alpha * g;
  for (int j = 0; j < 6; ++j) block.col(j) += g(j) * ag;  // α g gᵀ, column by column
  const Vec3 br = beta * r;
  moments.sum += beta;
  moments.first += br;
  moments.second.noalias() += br * r.transpose();
}

/// Adds Σ β Jᵀ J = [[Σβ I, −[Σβ r]×], [[Σβ r]×, tr(Σβ r rᵀ) I − Σβ r rᵀ]]
/// ([r]×ᵀ [r]× = |r|² I − r rᵀ) to a block. Only the lower triangle is
/// written: mirror_lower() completes the block.
void add_isotropic_part(const IsotropicMoments& m, Mat6& block) noexcept {
  block.topLeftCorner<3, 3>().diagonal().array() += m.sum;
  // [Σβ r]× in the bottom-left block, [v]× = [[0, −z, y], [z, 0, −x], [−y, x, 0]].
  const Vec3& v = m.first;
  block(3, 1) -= v.z();
  block(3, 2) += v.y();
  block(4, 0) += v.z();
  block(4, 2) -= v.x();
  block(5, 0) -= v.y();
  block(5, 1) += v.x();
  block.bottomRightCorner<3, 3>() -= m.second;
  block.bottomRightCorner<3, 3>().diagonal().array() += m.second.trace();
}

/// out = B v for a 6×6 block, as a sum of scaled columns (fixed size, unrolled).
void block_times(const Mat6& blk, const Vec6& v, Vec6& out) noexcept {
  out = blk.col(0) * v(0) + blk.col(1) * v(1) + blk.col(2) * v(2) + blk.col(3) * v(3) +
        blk.col(4) * v(4) + blk.col(5) * v(5);
}

/// Copies the lower triangle of a block into its upper triangle, so that the
/// matrix-free product and the Cholesky factor (which reads the lower
/// triangle) see the same exactly symmetric matrix.
void mirror_lower(Mat6& block) noexcept {
  for (int j = 1; j < 6; ++j)
    for (int i = 0; i < j; ++i) block(i, j) = block(j, i);
}

/// z = P⁻¹ r (block-Jacobi preconditioner; 0 for bodies not in the solve).
/// Returns r · z.
double apply_preconditioner(const SolverScratch& s, std::span<const Vec6> r,
                            std::span<Vec6> z) noexcept {
  double rz = 0.0;
  for (std::size_t i = 0; i < r.size(); ++i) {
    if (s.in_solve[i]) {
      solve_block(s.block_factor[i], r[i], z[i]);
      rz += r[i].dot(z[i]);
    } else {
      z[i].setZero();
    }
  }
  return rz;
}

}  // namespace

void add_cross_contact_terms(const SolverScratch& s, std::span<const Vec6> in,
                             std::span<Vec6> out) noexcept {
  for (int c = 0; c < s.num_cross_contacts; ++c) {
    const CrossContact& x = s.cross_contacts[static_cast<std::size_t>(c)];
    const auto a = static_cast<std::size_t>(x.body_a);
    const auto b = static_cast<std::size_t>(x.body_b);
    // u = G_a in_a − G_b in_b; the cross terms are out_a −= G_aᵀ W G_b in_b and
    // out_b −= G_bᵀ W G_a in_a, with W v = α n (n · v) + β v.
    const Vec3 ua = point_velocity(in[a], x.r_a);
    const Vec3 ub = point_velocity(in[b], x.r_b);
    const Vec3 wa = (x.weight_normal * x.normal.dot(ua)) * x.normal + x.weight_isotropic * ua;
    const Vec3 wb = (x.weight_normal * x.normal.dot(ub)) * x.normal + x.weight_isotropic * ub;
    out[a].head<3>() -= wb;
    out[a].tail<3>() -= x.r_a.cross(wb);
    out[b].head<3>() -= wa;
    out[b].tail<3>() -= x.r_b.cross(wa);
  }
}

void SolverScratch::resize(const Model& model, int written_contacts) {
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
  isotropic_moments.assign(n, IsotropicMoments{});
  block_factor.assign(n, BlockCholesky{});
  in_solve.assign(n, 1);
  contact_terms.assign(
      static_cast<std::size_t>(std::clamp(std::max(contact_capacity(model), written_contacts), 0, kMaxContacts)),
      ContactTerm{});
  cross_contacts.assign(
      static_cast<std::size_t>(cross_contact_capacity(model) + detail::grasp_point_capacity(model)),
      CrossContact{});
  num_cross_contacts = 0;
  coupled.assign(n, 0);
  const auto nj = static_cast<std::size_t>(model.num_joints());
  joint_rhs.assign(nj, JointVector::Zero());
  joint_y.assign(nj, JointVector::Zero());
  joint_y_correction.assign(nj, JointVector::Zero());
  projected_residual.assign(nj > 0 ? n : 0, Vec6::Zero());
  target_coupled.assign(n, 0);
  system_step = model.dt;
  joint_drift_step = model.dt;
  joint_horizon = model.dt;
  joint_rate_from_stage_start = false;
  joint_rows_at_drift_end = false;
  stage_start.assign(n, BodyState{});
  stage_move.assign(n, Vec6::Zero());
  stage_delta.assign(n, Vec6::Zero());
  stage_gyro.assign(n, Vec3::Zero());
  coupled_body = -1;
  first_order = false;
  imposed.assign(n, 0);
}

void prepare_implicit_step(const Model& model, Data& data) noexcept {
  SolverScratch& s = data.scratch->solver;
  const double h = s.system_step;
  for (std::size_t i = 0; i < data.bodies.size(); ++i) {
    BodyState& st = data.bodies[i];
    const BodyModel& bm = model.bodies[i];
    s.twist0[i] << st.linear_velocity, st.angular_velocity;
    const Mat3 rot = st.orientation.toRotationMatrix();
    s.inertia_world[i] = world_inertia(rot, bm.inertia_body);
    const int b = static_cast<int>(i);
    if (s.imposed[i] || is_first_order(s, b)) continue;
    st.angular_velocity = implicit_gyroscopic_velocity(rot, bm.inertia_body, st.angular_velocity, h);
  }
}

void build_implicit_system(const Model& model, Data& data) noexcept {
  SolverScratch& s = data.scratch->solver;
  const double h = s.system_step;
  const double h2 = h * h;
  const std::size_t n = data.bodies.size();

  for (std::size_t i = 0; i < n; ++i) {
    const int b = static_cast<int>(i);
    s.in_solve[i] = s.imposed[i] ? 0 : 1;
    s.coupled[i] = 0;
    s.isotropic_moments[i] = IsotropicMoments{};
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

  // Coupling springs of Eq. 2 / Eq. 6 on every targeted body:
  // K = −diag(k_t I, k_r I), D = −diag(γ_t I, γ_r I).
  for (std::size_t i = 0; i < n; ++i) {
    if (!s.target_coupled[i] || !s.in_solve[i]) continue;
    const CouplingGains& g = model.bodies[i].coupling;
    s.block[i].topLeftCorner<3, 3>().diagonal().array() += h * g.gamma_t + h2 * g.k_t;
    s.block[i].bottomRightCorner<3, 3>().diagonal().array() += h * g.gamma_r + h2 * g.k_r;
    s.rhs[i].head<3>() -= h2 * g.k_t * s.twist0[i].head<3>();
    s.rhs[i].tail<3>() -= h2 * g.k_r * s.twist0[i].tail<3>();
  }

  // Active contacts: A += Gᵀ W G, b += h² K u0 = −h² k Gᵀ n v_n (v_n = n · G u0).
  // W = (h c + h² k) n nᵀ + h μ (I − n nᵀ) = α n nᵀ + β I.
  s.num_cross_contacts = 0;
  const int nc = active_contact_count(data);
  for (int c = 0; c < nc; ++c) {
    ContactTerm& t = s.contact_terms[static_cast<std::size_t>(c)];
    if (!t.active) continue;
    const Contact& ct = data.contacts[static_cast<std::size_t>(c)];
    const double beta = h * t.friction;
    // The law's Jacobian coefficients (contact_force.hpp): the material's, its stiffness
    // clamped by the time-constant floor; faded in by a smoothed onset.
    const double alpha = (h * t.damping + h2 * t.stiffness) - beta;
    t.weight_normal = alpha;
    t.weight_isotropic = beta;
    const double impulse = -h2 * t.stiffness * t.normal_velocity;  // b_a += Gᵀ_a (impulse n)
    const auto a = static_cast<std::size_t>(ct.body_a);
    if (s.in_solve[a])
      add_contact_terms(alpha, beta, impulse, ct.normal, t.r_a, s.block[a], s.rhs[a],
                        s.isotropic_moments[a]);
    if (ct.body_b >= 0) {
      const auto b = static_cast<std::size_t>(ct.body_b);
      if (s.in_solve[b])
        add_contact_terms(alpha, beta, -impulse, ct.normal, t.r_b, s.block[b], s.rhs[b],
                          s.isotropic_moments[b]);
      if (s.in_solve[a] && s.in_solve[b]) {
        s.coupled[a] = 1;
        s.coupled[b] = 1;
        CrossContact& x = s.cross_contacts[static_cast<std::size_t>(s.num_cross_contacts++)];
        x.body_a = ct.body_a;
        x.body_b = ct.body_b;
        x.weight_normal = alpha;
        x.weight_isotropic = beta;
        x.normal = ct.normal;
        x.r_a = t.r_a;
        x.r_b = t.r_b;
      }
    }
  }

  detail::add_grasp_terms(model, data);  // the held bodies' springs
  // Sliding ties (sliding_tie.hpp): W = β I + α a aᵀ, β = h c + h² k, α = h f − β, and the
  // anchor's motion over the step, b += h² Gᵀ k P (w − v₀).
  const int nt = std::clamp(data.num_sliding_ties, 0, kMaxSlidingTies);
  for (int i = 0; i < nt; ++i) {
    const SlidingTie& t = data.sliding_ties[static_cast<std::size_t>(i)];
    if (t.body < 0 || t.body >= static_cast<int>(n) || !s.in_solve[static_cast<std::size_t>(t.body)]) continue;
    const auto b = static_cast<std::size_t>(t.body);
    const Vec3 r = data.bodies[b].orientation * t.local_point;
    const Vec3 dv = t.anchor_velocity - point_velocity(s.twist0[b], r);
    const Vec3 pull = (h2 * t.stiffness) * (dv - t.axis.dot(dv) * t.axis);
    s.rhs[b].head<3>() += pull;
    s.rhs[b].tail<3>() += r.cross(pull);
    const double beta = h * t.damping + h2 * t.stiffness;
    add_contact_terms(h * t.friction - beta, beta, 0.0, t.axis, r, s.block[b], s.rhs[b],
                      s.isotropic_moments[b]);
  }
  if constexpr (kWithDeformable)
    add_net_body_terms(model, data);  // ties and node contacts of the deformable nets
  for (std::size_t i = 0; i < n; ++i) {
    if (s.in_solve[i]) add_isotropic_part(s.isotropic_moments[i], s.block[i]);
    mirror_lower(s.block[i]);
    // With joints the tree solve factors the blocks itself (articulation.hpp;
    // with nets, Schur blocks: net_solve.hpp). Without joints the factors are
    // the block-Jacobi preconditioner, or the bodies' D̃ of the nets' solve.
    if (model.joints.empty()) factor_block(s.block[i], s.block_factor[i]);
  }
}

void apply_implicit_system(const Model& /*model*/, const Data& data, std::span<const Vec6> in,
                           std::span<Vec6> out) noexcept {
  // A = blockdiag(block[i]) + the off-diagonal blocks of body–body contacts.
  // block[i] (build_implicit_system) already holds M_i (or 0 for a first-order
  // body), the coupling terms and every contact's diagonal contribution
  // G_iᵀ W G_i, so only the cross terms −G_aᵀ W G_b remain per body–body
  // contact: static contacts cost nothing per iteration.
  const SolverScratch& s = data.scratch->solver;
  const std::size_t n = data.bodies.size();
  for (std::size_t i = 0; i < n; ++i) {
    if (s.in_solve[i]) {
      block_times(s.block[i], in[i], out[i]);
    } else {
      out[i].setZero();
    }
  }
  add_cross_contact_terms(s, in, out);
}

namespace {

/// The bodies' system for detail::pcg(): A of build_implicit_system(), the
/// block-Jacobi preconditioner of its factored diagonal blocks, ‖r‖ / ‖b‖. A body
/// without cross contacts (SolverScratch::coupled = 0) keeps (A p)_i = B_i p_i
/// and z_i = B_i⁻¹ r_i by their exact recurrences (solve_implicit_system()).
struct BlockJacobiSystem {
  const SolverScratch& s;
  std::span<Vec6> x, r, z, p, ap;
  double b_norm;
  double alpha = 0.0;

  double apply() noexcept {
    // ap = A p on the coupled bodies; the others' ap is kept by recurrence.
    for (std::size_t i = 0; i < p.size(); ++i)
      if (s.coupled[i]) block_times(s.block[i], p[i], ap[i]);
    add_cross_contact_terms(s, p, ap);
    return dot(p, ap);
  }
  double advance(double a) noexcept {
    alpha = a;
    double rr = 0.0;
    for (std::size_t i = 0; i < x.size(); ++i) {
      x[i] += a * p[i];
      r[i] -= a * ap[i];
      rr += r[i].squaredNorm();
    }
    return std::sqrt(rr) / b_norm;
  }
  double precondition() noexcept {
    double rz = 0.0;
    for (std::size_t i = 0; i < r.size(); ++i) {
      if (s.coupled[i]) {
        solve_block(s.block_factor[i], r[i], z[i]);
      } else {
        z[i] -= alpha * p[i];  // B_i⁻¹ (r_i − α B_i p_i)
      }
      rz += r[i].dot(z[i]);
    }
    return rz;
  }
  void direction(double beta) noexcept {
    for (std::size_t i = 0; i < p.size(); ++i) {
      p[i] = z[i] + beta * p[i];
      if (!s.coupled[i]) ap[i] = r[i] + beta * ap[i];  // B_i (z_i + β p_i)
    }
  }
};

}  // namespace

bool solve_implicit_system(const Model& model, Data& data) noexcept {
  SolverScratch& s = data.scratch->solver;
  BlockJacobiSystem sys{s, s.delta, s.residual, s.precond_residual, s.direction, s.a_direction, 0.0};
  const std::span<const Vec6> b(s.rhs);
  for (std::size_t i = 0; i < sys.x.size(); ++i) {
    sys.x[i].setZero();
    sys.r[i] = b[i];
  }
  sys.b_norm = std::sqrt(dot(b, b));
  data.solver_iterations = 0;
  data.solver_residual = 0.0;
  // Non-finite forces or a non-positive pivot of a diagonal block (NaN in the
  // factor): detail::pcg() reports it and the unknowns are poisoned.
  if (!std::isfinite(sys.b_norm)) return detail::poison_solve(data);
  if (sys.b_norm == 0.0) return true;
  const double rz = apply_preconditioner(s, sys.r, sys.z);
  for (std::size_t i = 0; i < sys.p.size(); ++i) {
    sys.p[i] = sys.z[i];
    if (!s.coupled[i]) sys.ap[i] = sys.r[i];  // B_i p_i = B_i B_i⁻¹ r_i
  }
  const detail::PcgStop stop{model.solver.tolerance, model.solver.max_iterations};
  const detail::PcgResult res = detail::pcg(sys, 1.0, rz, stop);  // x0 = 0: ‖r0‖ / ‖b‖ = 1
  if (!res.finite) return detail::poison_solve(data);
  data.solver_iterations = res.iterations;
  data.solver_residual = res.residual;
  return res.converged(stop);
}

bool solve_linearized_system(const Model& model, Data& data) noexcept {
  const std::uint32_t plan = model.stage_plan;  // the solve step() reports (step_stages.hpp)
  bool converged = false;
  if (plan & kStageNetSolve) {
    if constexpr (kWithDeformable) {
      converged = solve_net_system(model, data);
      data.stages_run |= kStageNetSolve;
    }
  } else if (plan & kStageJointSolve) {
#if NUMEN_WITH_ARTICULATION
    converged = solve_constrained_system(model, data);
    data.stages_run |= kStageJointSolve;
#endif
  } else {
    converged = solve_implicit_system(model, data);
  }
  if (!converged) data.status |= kSolverNotConverged;
  return converged;
}

namespace {

/// One linearised step of length h = model.dt through the system of step h_s
/// (SolverScratch::system_step): Δu solves (M − h_s D − h_s² K) Δu = h_s (f0 +
/// h_s K u0) + M (u* − u0); positions move over h with u0 + Δu, twists become
/// u0 + (h / h_s) Δu. h_s = h: the linearly implicit Euler; h_s = h/2: the
/// trapezoidal rule (u0 + Δu is the midpoint twist). h / h_s is 1 or 2 exactly.
void integrate_linearized(const Model& model, Data& data, double system_step) noexcept {
  SolverScratch& s = data.scratch->solver;
  const double h = model.dt;
  s.system_step = system_step;
  s.joint_drift_step = h;
  s.joint_horizon = h;
  s.joint_rate_from_stage_start = false;
  s.joint_rows_at_drift_end = false;
  const double scale = h / system_step;
  // The solve this model runs (Model::stage_plan: the plan step() reports from).
  const std::uint32_t plan = model.stage_plan;
  // Optional parts (features.hpp): compiled out, their models are refused by finalize_model().
  if constexpr (kWithDeformable) {
    // The nets' linearisation over h_s, before the gyroscopic step changes the bodies' ω.
    if (plan & kStageNetSolve) linearize_nets(model, data, system_step);
  }
  prepare_implicit_step(model, data);
  build_implicit_system(model, data);
  if constexpr (kWithDeformable) {
    if (plan & kStageNetSolve) build_net_system(model, data);
  }
  solve_linearized_system(model, data);
  for (std::size_t i = 0; i < data.bodies.size(); ++i) {
    if (!s.in_solve[i]) continue;  // kDirect body: stays at the imposed target
    BodyState& st = data.bodies[i];
    const Vec6 u_move = s.twist0[i] + s.delta[i];  // u1 (Euler) or u½ (trapezoidal)
    st.position += h * u_move.head<3>();
    st.orientation = integrate_orientation(st.orientation, u_move.tail<3>(), h);
    const Vec6 u1 = s.twist0[i] + scale * s.delta[i];
    st.linear_velocity = u1.head<3>();
    st.angular_velocity = u1.tail<3>();
  }
#if NUMEN_WITH_ARTICULATION
  if (scale != 1.0 && !model.joints.empty()) project_joint_velocities(model, data, h, true);
#endif
  if constexpr (kWithDeformable) integrate_nodes_implicit(model, data);
}

}  // namespace

void integrate_linearly_implicit_euler(const Model& model, Data& data) noexcept {
  integrate_linearized(model, data, model.dt);
}

void integrate_trapezoidal(const Model& model, Data& data) noexcept {
  integrate_linearized(model, data, 0.5 * model.dt);  // = linearized_system_step() of a trapezoidal model
}

double linearized_system_step(const Model& model) noexcept {
  switch (model.integrator) {
    case Integrator::kTrapezoidal: return 0.5 * model.dt;
    case Integrator::kTrBdf2: return tr_bdf2::kStageStep * model.dt;
    default: return model.dt;
  }
}

void integrate(const Model& model, Data& data) noexcept {
  data.stages_run |= kStageIntegrate;  // the stage report (step_stages.hpp)
  switch (model.integrator) {
    case Integrator::kSymplecticEuler:
      integrate_symplectic_euler(model, data);
      break;
    case Integrator::kTrapezoidal:
      integrate_trapezoidal(model, data);
      break;
    case Integrator::kTrBdf2:
      integrate_tr_bdf2(model, data);
      break;
    case Integrator::kLinearlyImplicitEuler:
    default:
      integrate_linearly_implicit_euler(model, data);
      break;
  }
}

}  // namespace numen::core
