/// @file integrator_symplectic.cpp
/// Symplectic (semi-implicit) Euler (paper Eq. 1, §5): the bodies' twists from the step's
/// explicit forces, then their poses; with joints the impulses go through the KKT system with
/// A = M (Eq. 4, 7); the first-order held body takes the massless limit of Eq. 2; the nets'
/// nodes stepped explicitly (integrate_nodes_symplectic()).

#include <cstddef>

#include "numen/core/articulation.hpp"
#include "numen/core/coupling.hpp"
#include "numen/core/data.hpp"
#include "numen/core/features.hpp"
#include "numen/core/integrator.hpp"
#include "numen/core/model.hpp"
#include "numen/core/net_forces.hpp"
#include "numen/core/rigid_body.hpp"
#include "numen/core/step_stages.hpp"

#include "scratch/data_scratch.hpp"
#include "articulation/joint_system.hpp"
#include "solver/solver_terms.hpp"

namespace numen::core {

using detail::is_first_order;

namespace {

/// Massless limit of Eq. 2 for the first-order held body:
/// k e + γ (v_t − v) + F_other = 0 per axis group; sets its twist.
void set_first_order_velocity(const Model& model, Data& data, std::size_t i) noexcept {
  BodyState& st = data.bodies[i];
  const CouplingGains& g = model.bodies[i].coupling;
  const Wrench& f = data.body_wrench[i];
  const Wrench& cw = data.coupling_wrench;
  const Vec3 e = data.target.position - st.position;
  const Vec3 theta_u = rotation_error(data.target.orientation, st.orientation);
  st.linear_velocity = data.target_twist.linear + (g.k_t * e + (f.force - cw.force)) / g.gamma_t;
  st.angular_velocity =
      data.target_twist.angular + (g.k_r * theta_u + (f.torque - cw.torque)) / g.gamma_r;
}

/// Symplectic Euler with joints: the explicit impulses h(f + gyroscopic) go
/// through the KKT system with A = M (paper Eq. 4 with the tendency and
/// correction of Eq. 7 solved at once), then positions. Imposed bodies
/// (kDirect) keep their twist; a first-order body enters with the block
/// h·diag(γ_t I, γ_r I) and the right-hand side that takes it to its
/// first-order twist (the joints' force adds λ/γ to it).
#if NUMEN_WITH_ARTICULATION
void integrate_symplectic_euler_constrained(const Model& model, Data& data) noexcept {
  SolverScratch& s = data.scratch->solver;
  ArticulationScratch& art = data.scratch->articulation;
  const double h = model.dt;
  for (std::size_t i = 0; i < data.bodies.size(); ++i) {
    const int b = static_cast<int>(i);
    BodyState& st = data.bodies[i];
    Mat6& blk = s.block[i];
    const bool known = s.imposed[i] != 0;
    art.known[i] = known ? 1 : 0;
    s.twist0[i] << st.linear_velocity, st.angular_velocity;  // the last step's twist
    if (is_first_order(s, b)) {
      // Massless body: its twist is the first-order law's u_fo, plus the
      // joints' force through γ: u1 = u_fo + λ/γ. As a KKT block: B = h·diag(γ_t,
      // γ_r), b = B (u_fo − u0), so that Δu = (u_fo − u0) + B⁻¹ h λ.
      set_first_order_velocity(model, data, i);
      const CouplingGains& g = model.bodies[i].coupling;
      blk.setZero();
      blk.topLeftCorner<3, 3>().diagonal().setConstant(h * g.gamma_t);
      blk.bottomRightCorner<3, 3>().diagonal().setConstant(h * g.gamma_r);
      s.rhs[i] << h * g.gamma_t * (st.linear_velocity - s.twist0[i].head<3>()),
          h * g.gamma_r * (st.angular_velocity - s.twist0[i].tail<3>());
      continue;
    }
    if (known) continue;
    const BodyModel& bm = model.bodies[i];
    const Wrench& f = data.body_wrench[i];
    const Mat3 iw = world_inertia(st.orientation, bm.inertia_body);
    blk.setZero();
    blk.topLeftCorner<3, 3>().diagonal().setConstant(bm.mass);
    blk.bottomRightCorner<3, 3>() = iw;
    s.rhs[i] << h * f.force, h * (f.torque + gyroscopic_torque(iw, st.angular_velocity));
  }
  build_joint_rows(model, data, s.twist0, s.delta, s.joint_rhs);
  factor_articulation(model, s.block, art);
  solve_articulation(model, art, s.rhs, s.joint_rhs, s.delta, s.joint_y);
  store_joint_multipliers(model, data, s.joint_y);
  for (std::size_t i = 0; i < data.bodies.size(); ++i) {
    if (s.imposed[i]) continue;
    BodyState& st = data.bodies[i];
    if (!art.known[i]) {
      st.linear_velocity = s.twist0[i].head<3>() + s.delta[i].head<3>();
      st.angular_velocity = s.twist0[i].tail<3>() + s.delta[i].tail<3>();
    }
    st.position += h * st.linear_velocity;
    st.orientation = integrate_orientation(st.orientation, st.angular_velocity, h);
  }
}
#endif  // NUMEN_WITH_ARTICULATION

}  // namespace

void integrate_symplectic_euler(const Model& model, Data& data) noexcept {
  data.scratch->solver.system_step = model.dt;
  data.scratch->solver.joint_drift_step = model.dt;
  data.scratch->solver.joint_horizon = model.dt;
  data.scratch->solver.joint_rate_from_stage_start = false;
  data.scratch->solver.joint_rows_at_drift_end = false;
  data.solver_iterations = 0;
  data.solver_residual = 0.0;
  if constexpr (kWithDeformable)
    integrate_nodes_symplectic(model, data);  // forces of the step's start, like the bodies'
#if NUMEN_WITH_ARTICULATION
  if (model.stage_plan & kStageJointSolve) {
    integrate_symplectic_euler_constrained(model, data);
    data.stages_run |= kStageJointSolve;
    return;
  }
#endif
  const SolverScratch& s = data.scratch->solver;
  const double h = model.dt;
  for (std::size_t i = 0; i < data.bodies.size(); ++i) {
    const int b = static_cast<int>(i);
    if (s.imposed[i]) continue;
    BodyState& st = data.bodies[i];
    if (is_first_order(s, b)) {
      set_first_order_velocity(model, data, i);
    } else {
      const BodyModel& bm = model.bodies[i];
      const Wrench& f = data.body_wrench[i];
      const Mat3 iw = world_inertia(st.orientation, bm.inertia_body);
      const Mat3 iw_inv = world_inertia_inverse(st.orientation, bm.inertia_body_inv);
      st.linear_velocity += (h / bm.mass) * f.force;
      st.angular_velocity +=
          h * (iw_inv * (f.torque + gyroscopic_torque(iw, st.angular_velocity)));
    }
    st.position += h * st.linear_velocity;
    st.orientation = integrate_orientation(st.orientation, st.angular_velocity, h);
  }
}

}  // namespace numen::core
