/// @file integrator_joints.cpp
/// The linearised step's solve with joints (paper Eq. 4, 5, 7): the bodies' implicit system
/// on the null space of the joints' rows by projected CG with the tree solve as constraint
/// preconditioner (solve_constrained_system()), and the velocities projected onto the joints'
/// rows at a step's or stage's end (project_joint_velocities(), RATTLE). Declared in
/// solver/implicit_system.hpp; left out of a build without articulation (NUMEN_WITH_ARTICULATION).

#include <algorithm>
#include <cmath>

#include "numen/core/articulation.hpp"
#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/rigid_body.hpp"

#include "scratch/data_scratch.hpp"
#include "solver/implicit_system.hpp"
#include "articulation/joint_system.hpp"
#include "linalg/pcg.hpp"
#include "solver/solver_terms.hpp"

namespace numen::core {

using detail::dot;

namespace {

/// The joints' projected system for detail::pcg() (solve_constrained_system()):
/// A of build_implicit_system() on the null space of G, the tree solve as
/// constraint preconditioner with Gould, Hribar & Nocedal's residual update,
/// ‖r‖ / ref.
struct ProjectedJointSystem {
  const Model& model;
  Data& data;
  std::span<Vec6> x, r, z, p, ap, rp;
  std::span<JointVector> y, yz;
  double ref;

  /// z = P r (tree solve with zero constraint right-hand side); then r is
  /// replaced by r − Gᵀ yz, which has the same z (P Gᵀ = 0) and tends to 0
  /// instead of to Gᵀ y (no cancellation, no loss of accuracy), and yz is added
  /// to y. Returns ‖r‖ / ref.
  double project() noexcept {
    SolverScratch& s = data.scratch->solver;
    const std::size_t n = r.size();
    for (JointVector& v : s.joint_rhs) v.setZero();
    solve_articulation(model, data.scratch->articulation, r, s.joint_rhs, z, yz);
    for (std::size_t i = 0; i < n; ++i) rp[i].setZero();
    add_joint_transpose(model, data, yz, rp);
    double rr = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      r[i] -= rp[i];
      rr += r[i].squaredNorm();
    }
    for (std::size_t j = 0; j < y.size(); ++j) y[j] += yz[j];
    return std::sqrt(rr) / ref;
  }
  double apply() noexcept {
    apply_implicit_system(model, data, p, ap);
    return dot(p, ap);
  }
  double advance(double alpha) noexcept {
    for (std::size_t i = 0; i < x.size(); ++i) {
      x[i] += alpha * p[i];
      r[i] -= alpha * ap[i];
    }
    return project();
  }
  double precondition() noexcept { return dot(r, z); }  // z: project()'s
  void direction(double beta) noexcept {
    for (std::size_t i = 0; i < p.size(); ++i) p[i] = z[i] + beta * p[i];
  }
};

}  // namespace

bool solve_constrained_system(const Model& model, Data& data) noexcept {
  SolverScratch& s = data.scratch->solver;
  ArticulationScratch& art = data.scratch->articulation;
  const std::size_t n = data.bodies.size();
  for (std::size_t i = 0; i < n; ++i) art.known[i] = s.in_solve[i] ? 0 : 1;
  build_joint_rows(model, data, s.twist0, s.delta, s.joint_rhs);
  data.solver_iterations = 0;
  data.solver_residual = 0.0;

  ProjectedJointSystem sys{model,          data,         s.delta,       s.residual,
                           s.precond_residual, s.direction, s.a_direction, s.projected_residual,
                           s.joint_y,      s.joint_y_correction, 1.0};
  const std::span<const Vec6> b(s.rhs);

  // Tree solve with the block-diagonal part of A: exact without cross contacts.
  factor_articulation(model, s.block, art);  // a bad pivot leaves NaN: rejected below / by step()
  solve_articulation(model, art, b, s.joint_rhs, sys.x, sys.y);
  bool converged = true;

  if (s.num_cross_contacts > 0) {
    // Projected PCG on the null space of G: r = b − A x − Gᵀ y.
    apply_implicit_system(model, data, sys.x, sys.ap);
    // Relative to ‖b‖, or to ‖A x0‖ when the joints' c drives the step.
    const double b_norm = std::max(std::sqrt(dot(b, b)), std::sqrt(dot(sys.ap, sys.ap)));
    sys.ref = b_norm > 0.0 ? b_norm : 1.0;
    for (std::size_t i = 0; i < n; ++i)
      sys.r[i] = s.in_solve[i] ? Vec6(b[i] - sys.ap[i]) : Vec6::Zero();
    for (std::size_t i = 0; i < n; ++i) sys.ap[i].setZero();
    add_joint_transpose(model, data, sys.y, sys.ap);
    for (std::size_t i = 0; i < n; ++i) sys.r[i] -= sys.ap[i];

    const double rel = sys.project();
    const double rz = dot(sys.r, sys.z);
    for (std::size_t i = 0; i < n; ++i) sys.p[i] = sys.z[i];
    const detail::PcgStop stop{model.solver.tolerance, model.solver.max_iterations};
    const detail::PcgResult res = detail::pcg(sys, rel, rz, stop);
    if (!res.finite) return detail::poison_solve(data);
    data.solver_iterations = res.iterations;
    data.solver_residual = res.residual;
    converged = res.converged(stop);
  }
  store_joint_multipliers(model, data, sys.y);
  return converged;
}

// RATTLE's velocity step (implicit_system.hpp).
void project_joint_velocities(const Model& model, Data& data, double elapsed,
                              bool remove_half_impulse) noexcept {
  SolverScratch& s = data.scratch->solver;
  ArticulationScratch& art = data.scratch->articulation;
  const double h = elapsed;
  // Second half of the step without the first half's joint impulse: u0 + 2Δu½ counts the
  // impulse −Gᵀy of the half step (along the rows at the step's start) twice; RATTLE gives the
  // second half its own impulse along the rows at the end (the projection below). Remove one
  // copy, A⁻¹ G0ᵀ y per body with its diagonal block of A (exact without body–body contacts
  // and nets; the cross terms of those are left out of this correction).
  for (std::size_t i = 0; i < data.bodies.size(); ++i) s.projected_residual[i].setZero();
  if (remove_half_impulse) add_joint_transpose(model, data, s.joint_y, s.projected_residual);
  for (std::size_t i = 0; i < data.bodies.size(); ++i) {
    if (art.known[i] || !remove_half_impulse) continue;
    factor_block(s.block[i], s.block_factor[i]);
    Vec6 z;
    solve_block(s.block_factor[i], s.projected_residual[i], z);
    data.bodies[i].linear_velocity += z.head<3>();
    data.bodies[i].angular_velocity += z.tail<3>();
  }
  const auto twist = [&](int b) noexcept {
    const auto i = static_cast<std::size_t>(b);
    Vec6 u;
    if (art.known[i]) {
      u.setZero();
    } else {
      u << data.bodies[i].linear_velocity, data.bodies[i].angular_velocity;
    }
    return u;
  };
  for (std::size_t j = 0; j < model.joints.size(); ++j) {
    const JointModel& jm = model.joints[j];
    const BodyState* parent =
        jm.parent >= 0 ? &data.bodies[static_cast<std::size_t>(jm.parent)] : nullptr;
    const BodyState& child = data.bodies[static_cast<std::size_t>(jm.child)];
    const JointPrescription& jp = data.joint_prescribed[j];
    JointRows& rows = art.rows[j];
    evaluate_joint(jm, parent, child, jm.prescribed ? jp.value + h * jp.rate : 0.0, rows);
    JointVector rate = rows.g_child * twist(jm.child);
    if (parent) rate.noalias() += rows.g_parent * twist(jm.parent);
    if (jm.prescribed) rate(rows.count - 1) -= jp.rate;
    JointVector c = -rate;
    for (int r = rows.count; r < kMaxJointRows; ++r) c(r) = 0.0;
    s.joint_rhs[j] = c;
  }
  for (std::size_t i = 0; i < data.bodies.size(); ++i) s.residual[i].setZero();
  factor_articulation(model, s.block, art);  // a failed pivot gives NaN: rolled back by step()
  solve_articulation(model, art, s.residual, s.joint_rhs, s.a_direction, s.joint_y_correction);
  for (std::size_t i = 0; i < data.bodies.size(); ++i) {
    if (art.known[i]) continue;
    data.bodies[i].linear_velocity += s.a_direction[i].head<3>();
    data.bodies[i].angular_velocity += s.a_direction[i].tail<3>();
  }
}

}  // namespace numen::core
