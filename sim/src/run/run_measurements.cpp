/// @file run_measurements.cpp
/// The measurements of SceneRunner's periods, outside the timed step: the tool's and the
/// target's contacts, free-space tracking, the start-up push-out, and the running maxima and
/// sums of the step (RunSummary).

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>

#include "numen/core/data.hpp"
#include "numen/sim/run/run.hpp"
#include "numen/sim/run/needle_summary.hpp"
#include "numen/sim/run/thread_summary.hpp"

#include "contact_depths.hpp"

namespace numen::sim {

SceneRunner::PeriodContacts SceneRunner::measure_contacts() noexcept {
  const core::Model& model = scene_->model;
  PeriodContacts c;
  const int held = data_.held_body;
  if (held < 0) return c;
  c.held = true;
  // The tool: every body of the held body's articulation (the held body alone for a rigid
  // tool), its contacts as the step found them.
  const int tree = model.articulation.body_tree[static_cast<std::size_t>(held)];
  for (int b = 0; b < model.num_bodies(); ++b) {
    if (model.articulation.body_tree[static_cast<std::size_t>(b)] != tree) continue;
    int n = 0, deepest = -1;
    const double pen = detail::deepest_contact_of(data_, b, &n, &deepest);
    if (pen > c.tool_pen) {
      c.deepest_tool_contact = deepest;
      c.deepest_tool_body = b;
    }
    c.tool_pen = std::max(c.tool_pen, pen);
    c.tool_contacts += n;
  }
  if (model.num_nets() > 0) {
    // The tool's nets as deformed (god-object), and the tool on the organs (nets of anchored
    // bodies) as they are.
    int n = 0;
    c.tool_pen = std::max(c.tool_pen, detail::deepest_node_contact_of_tree(model, data_, tree, &n));
    c.tool_contacts += n;
    c.tool_pen = std::max(c.tool_pen, detail::deepest_tool_contact_on_nets(model, data_, tree, &n));
    c.tool_contacts += n;
  }
  // The target (and the closed loop's hand) is detected anew in its periods only
  // (ghost_every_: every period but in a multirate run, where it is at most 1 kHz), and held
  // between them.
  // A paced run measures it on its own thread (target_measurement.hpp): the loop hands over
  // its inputs and reads the newest result.
  if ((k_ - 1) % ghost_every_ == 0 || held != ghost_held_) {
    if (target_thread_) {
      fill_target_inputs(tree, target_thread_->inputs());
      target_thread_->submit();
    } else {
      fill_target_inputs(tree, target_inputs_);
      target_ = target_measurement_.measure(target_inputs_);
    }
    ghost_held_ = held;
  }
  if (target_thread_) target_ = target_thread_->latest();
  c.target_pen = target_.target_pen;
  c.target_contacts = target_.target_contacts;
  c.hand_pen = target_.hand_pen;
  return c;
}

void SceneRunner::fill_target_inputs(int tree, TargetInputs& in) const noexcept {
  in.bodies = data_.bodies;              // same sizes: no allocation
  in.body_targets = data_.body_targets;
  if (!in.nodes.empty()) in.nodes = data_.nodes;
  in.target = data_.target;
  in.held = data_.held_body;
  in.tree = tree;
  in.closed_loop = false;
  if (const PlantMotion* plant = instrument_.plant()) {
    // Closed loop: each bound body at its link's pose at the intent's axis values (this
    // period's SYNC).
    in.closed_loop = true;
    std::fill(in.hand_bound.begin(), in.hand_bound.end(), std::uint8_t{0});
    const hal::Kinematics& kin = instrument_.kinematics();
    for (const platform::LinkBinding& lb : scene_->binding.links) {
      const int b = platform::bound_body(lb, data_, explicit_bound_);
      if (b < 0) continue;
      core::Twist twist;
      platform::body_target_of(lb, kin.link_pose(lb.link, plant->intent_axes()), core::Twist{},
                               in.hand_pose[static_cast<std::size_t>(b)], twist);
      in.hand_bound[static_cast<std::size_t>(b)] = 1;
    }
  }
}

void SceneRunner::track_free_space(const PeriodContacts& c) noexcept {
  // Free space: neither the tool nor the hand touches anything. A step where the tool has
  // come off a surface while the hand is still inside the obstacle is not free-space
  // tracking: the error there is the god-object's constraint, not its lag.
  if (!c.held || c.tool_contacts != 0 || c.target_contacts != 0) return;
  const double e =
      (data_.bodies[static_cast<std::size_t>(data_.held_body)].position - data_.target.position)
          .norm();
  free_sq_ += e * e;
  acc_.tracking_error_free_max_mm = std::max(acc_.tracking_error_free_max_mm, e * 1e3);
  ++acc_.free_steps;
}

bool SceneRunner::any_startup() const noexcept {
  if (in_startup_) return true;
  for (const DeviceStartup& u : device_startup_)
    if (u.in) return true;
  return false;
}

bool SceneRunner::track_device_startups() noexcept {
  const core::Model& model = scene_->model;
  const std::vector<int>& trees = model.articulation.body_tree;
  const int held = data_.held_body;
  const int held_tree = held >= 0 ? trees[static_cast<std::size_t>(held)] : -1;
  bool ended = false;
  for (std::size_t i = 0; i < extra_devices_.size() && i < device_startup_.size(); ++i) {
    const int body = extra_trace_body_[i];
    if (body < 0) continue;
    const int tree = trees[static_cast<std::size_t>(body)];
    if (tree == held_tree) continue;  // device 0's tool: track_startup() itself
    // Its tool (every body of its articulation), as measure_contacts() takes device 0's.
    double pen = 0.0;
    int contacts = 0, deepest = -1, deepest_body = -1;
    for (int b = 0; b < model.num_bodies(); ++b) {
      if (trees[static_cast<std::size_t>(b)] != tree) continue;
      int n = 0, d = -1;
      const double p = detail::deepest_contact_of(data_, b, &n, &d);
      if (p > pen) {
        deepest = d;
        deepest_body = b;
      }
      pen = std::max(pen, p);
      contacts += n;
    }
    if (model.num_nets() > 0) {
      int n = 0;
      pen = std::max(pen, detail::deepest_node_contact_of_tree(model, data_, tree, &n));
      contacts += n;
      pen = std::max(pen, detail::deepest_tool_contact_on_nets(model, data_, tree, &n));
      contacts += n;
    }
    DeviceStartup& u = device_startup_[i];
    const std::int64_t k = k_ - startup_from_ + 1;  // periods since the start-up's first
    if (k == 1 && contacts > 0) {
      u = DeviceStartup{};
      u.in = true;
      u.min = pen;
      u.first_mm = pen * 1e3;
      u.steps = 1;
      if (deepest >= 0) {
        const core::Contact& d = data_.contacts[static_cast<std::size_t>(deepest)];
        u.obstacle = d.obstacle;
        u.other_body = d.body_a == deepest_body ? d.body_b : d.body_a;
      }
    } else if (u.in) {
      if (contacts > 0 && pen < u.min) {  // still being pushed out
        u.min = pen;
        u.steps = k;
      } else if (contacts == 0 || k - u.steps >= startup_settle_periods_) {
        u.in = false;
        ended = true;
      }
    }
  }
  return ended;
}

void SceneRunner::track_startup(const PeriodContacts& c) noexcept {
  RunSummary& s = acc_;
  // Start-up (RunSummary): the tool was spawned where the hand is, inside an obstacle, and the
  // contact forces push it out. It runs from the first period (startup_from_: a live input's,
  // the period its first sample placed the tool) through the last period that lowers the
  // tool's penetration to a new minimum before kStartupSettle without one (or a period without
  // contact); the periods after that minimum count as the god-object's again. Every other
  // device's tool likewise (track_device_startups()); the divergence bounds leave the push-out
  // when no tool is being pushed out any more.
  const std::int64_t k = k_ - startup_from_ + 1;
  bool ended = track_device_startups();
  if (k == 1 && c.tool_contacts > 0) {
    in_startup_ = true;
    startup_min_ = c.tool_pen;
    startup_window_max_ = 0.0;
    s.startup_steps = 1;
    s.startup_tool_penetration_mm = c.tool_pen * 1e3;
    if (c.deepest_tool_contact >= 0) {
      const core::Contact& d = data_.contacts[static_cast<std::size_t>(c.deepest_tool_contact)];
      startup_obstacle_ = d.obstacle;
      startup_other_body_ = d.body_a == c.deepest_tool_body ? d.body_b : d.body_a;
    }
  } else if (in_startup_) {
    if (c.tool_contacts > 0 && c.tool_pen < startup_min_) {  // still being pushed out
      startup_min_ = c.tool_pen;
      startup_window_max_ = 0.0;
      s.startup_steps = k;
    } else {
      startup_window_max_ = std::max(startup_window_max_, c.tool_pen);
      if (c.tool_contacts == 0 || k - s.startup_steps >= startup_settle_periods_) {
        in_startup_ = false;
        s.tool_penetration_max_mm = std::max(s.tool_penetration_max_mm, startup_window_max_ * 1e3);
        ended = true;
      }
    }
  }
  if (ended && !any_startup())
    divergence_.end_startup(scene_->model, data_);  // the push-out no longer sets its bounds
  if (!in_startup_)
    s.tool_penetration_max_mm = std::max(s.tool_penetration_max_mm, c.tool_pen * 1e3);
}

void SceneRunner::accumulate_step_figures(const platform::PeriodReport& report,
                                          const PeriodContacts& c) noexcept {
  const core::Model& model = scene_->model;
  RunSummary& s = acc_;
  s.joint_drift_max_mm = std::max(s.joint_drift_max_mm, data_.max_joint_drift * 1e3);
  s.joint_angle_drift_max_mrad =
      std::max(s.joint_angle_drift_max_mrad, data_.max_joint_angle_drift * 1e3);
  s.target_penetration_max_mm = std::max(s.target_penetration_max_mm, c.target_pen * 1e3);
  s.device_penetration_max_mm = s.target_penetration_max_mm;
  s.hand_penetration_max_mm = std::max(s.hand_penetration_max_mm, c.hand_pen * 1e3);
  s.any_penetration_max_mm = std::max(s.any_penetration_max_mm, data_.max_penetration * 1e3);
  // What the drives were sent (after the gate and clamp of hal::ImpedanceDevice::write()).
  s.feedback_force_max_n = std::max(s.feedback_force_max_n, report.feedback.force.norm());
  const double jump = (report.feedback.force - last_feedback_force_).norm();
  last_feedback_force_ = report.feedback.force;
  s.feedback_force_jump_max_n = std::max(s.feedback_force_jump_max_n, jump);
  if (multirate_.enabled()) {
    double& at = multirate_.took_model() ? s.multirate.model_force_jump_max_n
                                          : s.multirate.other_force_jump_max_n;
    at = std::max(at, jump);
  }
  s.feedback_torque_max_nm = std::max(s.feedback_torque_max_nm, report.feedback.torque.norm());
  // The torques sent (the device face's output; none from a device that sends no torque).
  for (const double tau : loop_->device().output().torque)
    s.axis_torque_max = std::max(s.axis_torque_max, std::abs(tau));
  const int held = data_.held_body;
  const int held_tree = held >= 0 ? model.articulation.body_tree[static_cast<std::size_t>(held)] : -1;
  for (int b = 0; b < model.num_bodies(); ++b)
    if (model.articulation.body_tree[static_cast<std::size_t>(b)] != held_tree)
      s.free_body_speed_max_mps = std::max(
          s.free_body_speed_max_mps, data_.bodies[static_cast<std::size_t>(b)].linear_velocity.norm());
  s.contacts_max = std::max(s.contacts_max, data_.num_contacts);
  if (s.first_pass_through_s < 0.0 && data_.pass_throughs > 0) s.first_pass_through_s = data_.time;
  s.solver_iterations_max = std::max(s.solver_iterations_max, data_.solver_iterations);
  solver_iterations_sum_ += data_.solver_iterations;
  // A NaN residual (a rejected solve) is kept, not dropped by std::max.
  if (std::isnan(data_.solver_residual) || data_.solver_residual > s.solver_residual_max)
    if (!std::isnan(s.solver_residual_max)) s.solver_residual_max = data_.solver_residual;
  if (data_.status & core::kSolverNotConverged) ++s.solver_not_converged_steps;
  s.node_contacts_max = std::max(s.node_contacts_max, data_.num_node_contacts);
  accumulate_thread_figures(data_, s);
  accumulate_needle_figures(model, data_, s);
  for (std::size_t k = 0; k < data_.nets.size(); ++k) {
    const core::NetOutput& net = data_.nets[k];
    s.net_penetration_max_mm = std::max(s.net_penetration_max_mm, net.max_penetration * 1e3);
    s.net_tie_stretch_max_mm = std::max(s.net_tie_stretch_max_mm, net.max_tie_stretch * 1e3);
    s.net_strain_max = std::max(s.net_strain_max, net.max_strain);
    s.net_node_speed_max_mps = std::max(s.net_node_speed_max_mps, net.max_node_speed);
    s.net_inverted_tetrahedra_max = std::max<std::int64_t>(s.net_inverted_tetrahedra_max, net.inverted_tetrahedra);
    if (net.inverted_tetrahedra > 0 && s.net_first_inversion_s < 0.0) {  // the first: when, which net
      s.net_first_inversion_s = data_.time;
      first_inversion_net_ = static_cast<int>(k);  // its name in summary(): no copy in the period
    }
  }
}

}  // namespace numen::sim
