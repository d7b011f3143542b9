/// @file joint_system.cpp
/// Baumgarte-stabilised joint rows of one step (paper Eq. 4–5); see joint_system.hpp.

#include "articulation/joint_system.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/rigid_body.hpp"
#include "numen/core/step_stages.hpp"
#include "scratch/data_scratch.hpp"

namespace numen::core {
namespace {

const BodyState* parent_state(const JointModel& j, const std::vector<BodyState>& states) noexcept {
  return j.parent >= 0 ? &states[static_cast<std::size_t>(j.parent)] : nullptr;
}

/// State after a free drift over h at twist u (exact rotation).
BodyState drifted(const BodyState& s, const Vec6& u, double h) noexcept {
  BodyState out = s;
  out.position = s.position + h * u.head<3>();
  out.orientation = integrate_orientation(s.orientation, u.tail<3>(), h);
  return out;
}

double prescribed_value(const JointModel& j, const Data& data, std::size_t index) noexcept {
  return j.prescribed ? data.joint_prescribed[index].value : 0.0;
}

/// Twist of body b for the free drift of the step: zero for a known body.
Vec6 moving_twist(const ArticulationScratch& a, std::span<const Vec6> twist0, int b) noexcept {
  const auto i = static_cast<std::size_t>(b);
  return a.known[i] ? Vec6::Zero() : twist0[i];
}

}  // namespace

void build_joint_rows(const Model& model, Data& data, std::span<const Vec6> twist0,
                      std::span<const Vec6> delta_prev, std::span<JointVector> rhs) noexcept {
  const SolverScratch& s = data.scratch->solver;
  // Positions at the solve's end: x0 ⊕ h (twist0 + Δu), reached `horizon` after the step's
  // start (both Model::dt but in TR-BDF2's stages, SolverScratch::joint_drift_step).
  const double h = s.joint_drift_step;
  const double horizon = s.joint_horizon;
  const double alpha_h = model.baumgarte.alpha_dt;        // H α (H: the horizon)
  const double beta_h2 = model.baumgarte.beta_dt2;        // H² β
  const double scale = 1.0 / (1.0 + alpha_h + beta_h2);
  const bool chord_velocities = model.integrator != Integrator::kTrapezoidal &&
                                model.integrator != Integrator::kTrBdf2;
  ArticulationScratch& a = data.scratch->articulation;
  for (std::size_t j = 0; j < model.joints.size(); ++j) {
    const JointModel& jm = model.joints[j];
    const BodyState* parent = parent_state(jm, data.bodies);
    const BodyState& child = data.bodies[static_cast<std::size_t>(jm.child)];
    JointRows& start = a.rows[j];
    const double value = prescribed_value(jm, data, j);
    evaluate_joint(jm, parent, child, value, start);

    // Ċ0 = G u0 − v_ref. A known (imposed) body does not move during the
    // step (its next pose is imposed at the next step): it counts as at rest.
    const Vec6 uc = moving_twist(a, twist0, jm.child);
    const Vec6 up = parent ? moving_twist(a, twist0, jm.parent) : Vec6::Zero();
    JointVector cdot0;
    if (s.joint_rate_from_stage_start) {  // TR-BDF2's BDF2 stage: twist0 is its drift twist
      const auto rate_twist = [&](int b) noexcept {
        const BodyState& st = s.stage_start[static_cast<std::size_t>(b)];
        Vec6 u;
        u << st.linear_velocity, st.angular_velocity;
        return a.known[static_cast<std::size_t>(b)] ? Vec6(Vec6::Zero()) : u;
      };
      cdot0 = start.g_child * rate_twist(jm.child);
      if (parent) cdot0.noalias() += start.g_parent * rate_twist(jm.parent);
    } else {
      cdot0 = start.g_child * uc;
      if (parent) cdot0.noalias() += start.g_parent * up;
    }
    double rate = 0.0;
    if (jm.prescribed) {
      rate = data.joint_prescribed[j].rate;
      cdot0(start.count - 1) -= rate;
    }

    // C_pred: the error after a free drift at u0 (prescribed value moved on by
    // h·rate), with the rows G_pred there. The KKT system keeps G0 (impulses
    // along the start configuration's rows, as SHAKE does: energy is kept, no
    // numerical damping); the linearisation C(q0 ⊕ h u1) ≈ C_pred + h G_pred Δu
    // is then corrected by h (G_pred − G0) Δu_prev, the last step's Δu
    // standing in for this one's: the error left is O(h² |Δu − Δu_prev| |u|).
    JointRows predicted;
    const BodyState child_pred = drifted(child, uc, h);
    if (parent) {
      const BodyState parent_pred = drifted(*parent, up, h);
      evaluate_joint(jm, &parent_pred, child_pred, value + horizon * rate, predicted);
    } else {
      evaluate_joint(jm, nullptr, child_pred, value + horizon * rate, predicted);
    }

    // The error's rate over the last step, consistent with the positions.
    // G u0 is the rate at the step's start; the chord velocities of the
    // integrator (x1 = x0 + h v1, q1 = exp(h ω1) q0) make it exceed the mean
    // rate over the step by ½ h q (q = Ġ u, the velocity-product term), which
    // free drift reveals: (C_pred − C0)/h = G u0 + ½ h q. So
    //   Ċ0 = G u0 − ½ h q = 2 (G u0 − v_ref) − (C_pred − C0)/h.
    // Using G u0 itself would leave a steady error h² q (centripetal).
    const JointVector& c0 = start.position_error;
    JointVector drift_rate = (predicted.position_error - c0) / h;
    if (jm.prescribed && joint_row_is_angular(jm.type, start.count - 1)) {
      // The prescribed twist row is wrapped to (−π, π] at each evaluation:
      // wrap the difference too, or a lag near ±π would jump by 2π/h.
      const int r = start.count - 1;
      drift_rate(r) =
          std::remainder(predicted.position_error(r) - c0(r), 2.0 * std::numbers::pi) / h;
    }
    // The trapezoidal rule's u0 is a node velocity, not a chord, and its end-of-step
    // projection (integrator_joints.cpp, RATTLE) makes G0 u0 = v_ref: there Ċ0 = G0 u0 − v_ref.
    const JointVector cdot = chord_velocities ? JointVector(2.0 * cdot0 - drift_rate) : cdot0;
    const JointVector cdot1 = scale * (cdot - (beta_h2 / horizon) * c0);
    JointVector c = (c0 + horizon * cdot1 - predicted.position_error) / h;
    if (s.joint_rows_at_drift_end) {
      // The solve's rows are those of the drifted configuration (TR-BDF2's BDF2 stage: its
      // constraint impulse acts at the step's end, G(x1) up to O(h²)): C(q_pred ⊕ h Δu) ≈
      // C_pred + h G_pred Δu exactly to first order, no correction by Δu_prev.
      start = predicted;
    } else {
      c.noalias() -=
          (predicted.g_child - start.g_child) * delta_prev[static_cast<std::size_t>(jm.child)];
      if (parent)
        c.noalias() -=
            (predicted.g_parent - start.g_parent) * delta_prev[static_cast<std::size_t>(jm.parent)];
    }
    for (int r = start.count; r < kMaxJointRows; ++r) c(r) = 0.0;
    rhs[j] = c;
    data.joints[j].baumgarte_rhs = c;
  }
}

void add_joint_transpose(const Model& model, const Data& data, std::span<const JointVector> y,
                         std::span<Vec6> out) noexcept {
  const ArticulationScratch& a = data.scratch->articulation;
  for (std::size_t j = 0; j < model.joints.size(); ++j) {
    const JointModel& jm = model.joints[j];
    const JointRows& rows = a.rows[j];
    const auto c = static_cast<std::size_t>(jm.child);
    if (!a.known[c]) out[c].noalias() += rows.g_child.transpose() * y[j];
    if (jm.parent >= 0) {
      const auto p = static_cast<std::size_t>(jm.parent);
      if (!a.known[p]) out[p].noalias() += rows.g_parent.transpose() * y[j];
    }
  }
}

void store_joint_multipliers(const Model& model, Data& data, std::span<const JointVector> y) noexcept {
  const double inv_h = 1.0 / data.scratch->solver.system_step;  // h_s: the step of the KKT system
  for (std::size_t j = 0; j < model.joints.size(); ++j) {
    JointState& js = data.joints[j];
    js.multiplier = -inv_h * y[j];
    const Vec6 w = data.scratch->articulation.rows[j].g_child.transpose() * js.multiplier;
    js.reaction.force = w.head<3>();
    js.reaction.torque = w.tail<3>();
  }
}

void measure_joint_drift(const Model& model, Data& data) noexcept {
  data.stages_run |= kStageJointDrift;  // the stage report (step_stages.hpp)
  double linear = 0.0;
  double angular = 0.0;
  JointRows rows;
  for (std::size_t j = 0; j < model.joints.size(); ++j) {
    const JointModel& jm = model.joints[j];
    const BodyState* parent = parent_state(jm, data.bodies);
    const BodyState& child = data.bodies[static_cast<std::size_t>(jm.child)];
    // The prescribed value the step aimed at: φ* + h·rate (joint_system.hpp).
    const double value = jm.prescribed
                             ? data.joint_prescribed[j].value + model.dt * data.joint_prescribed[j].rate
                             : 0.0;
    evaluate_joint(jm, parent, child, value, rows);
    JointState& js = data.joints[j];
    js.position_error = rows.position_error;
    js.coordinate = joint_coordinate(jm, parent, child);
    // A prescribed row's error is the lag behind the device, not drift.
    const int structural = jm.prescribed ? rows.count - 1 : rows.count;
    for (int r = 0; r < structural; ++r) {
      const double e = std::abs(rows.position_error(r));
      if (joint_row_is_angular(jm.type, r)) {
        angular = std::max(angular, e);
      } else {
        linear = std::max(linear, e);
      }
    }
  }
  data.max_joint_drift = linear;
  data.max_joint_angle_drift = angular;
}

}  // namespace numen::core
