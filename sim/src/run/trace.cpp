/// @file trace.cpp

#include "numen/sim/run/trace.hpp"

#include <algorithm>
#include <fstream>
#include <span>
#include <stdexcept>
#include <vector>

#include "numen/core/needle_puncture.hpp"
#include "numen/core/thread.hpp"
#include "numen/sim/run/trace_columns.hpp"

namespace numen::sim {

TraceRecord make_trace_record(const core::Data& data, int held, int tool_contacts,
                              double tool_penetration_m, double target_penetration_m,
                              const platform::PeriodReport& report,
                              std::span<const double> axis_torques) noexcept {
  TraceRecord r;
  r.time_s = data.time;
  r.held_body = held;
  r.frames_read = report.frames_read;
  r.sample_valid = report.sample_valid;
  r.torque_commanded = report.torque_commanded;
  r.lifecycle = static_cast<int>(report.lifecycle);
  r.target = data.target;
  if (held >= 0) {
    const core::BodyState& b = data.bodies[static_cast<std::size_t>(held)];
    r.tool = core::Pose{b.position, b.orientation};
  }
  r.contacts = data.num_contacts;
  r.tool_contacts = tool_contacts;
  r.tool_penetration_mm = tool_penetration_m * 1e3;
  r.target_penetration_mm = target_penetration_m * 1e3;
  r.feedback = report.feedback;  // the wrench whose torques were sent (hal::ImpedanceDevice::write)
  r.num_axes = static_cast<int>(axis_torques.size());
  for (int i = 0; i < r.num_axes; ++i)
    r.axis_torque[static_cast<std::size_t>(i)] = axis_torques[static_cast<std::size_t>(i)];
  r.step_time_us = static_cast<double>(report.step_ns) * 1e-3;
  r.end_to_end_us = static_cast<double>(report.output_end_ns - report.sync_sent_ns) * 1e-3;
  r.wakeup_latency_us = static_cast<double>(report.woke_ns - report.deadline_ns) * 1e-3;
  r.solver_iterations = data.solver_iterations;
  r.joint_drift_mm = data.max_joint_drift * 1e3;
  r.joint_angle_drift_mrad = data.max_joint_angle_drift * 1e3;
  for (const core::JointState& j : data.joints) {
    r.joint_reaction_max_n = std::max(r.joint_reaction_max_n, j.reaction.force.norm());
    r.baumgarte_rhs_max = std::max(r.baumgarte_rhs_max, j.baumgarte_rhs.cwiseAbs().maxCoeff());
  }
  r.node_contacts = data.num_node_contacts;
  for (const core::GraspState& g : data.grasps) r.grasps_held += g.holding() ? 1 : 0;
  for (const core::NetOutput& n : data.nets) {
    r.net_penetration_mm = std::max(r.net_penetration_mm, n.max_penetration * 1e3);
    r.net_tie_stretch_mm = std::max(r.net_tie_stretch_mm, n.max_tie_stretch * 1e3);
    r.net_strain_max = std::max(r.net_strain_max, n.max_strain);
  }
  r.solver_residual = data.solver_residual;
  for (const core::ThreadState& t : data.threads) {
    const core::ThreadOutput& o = t.output;
    r.thread_tension_n = std::max(r.thread_tension_n, o.max_tension);
    r.thread_stretch = std::max(r.thread_stretch, o.max_stretch);
    r.thread_contacts += o.body_contacts + o.obstacle_contacts + o.tissue_contacts + o.self_contacts;
    r.thread_newton_iterations = std::max(r.thread_newton_iterations, o.iterations);
    r.thread_unconverged += o.converged ? 0 : 1;
  }
  for (std::size_t i = 0; i < data.needles.size(); ++i) {
    const core::NeedleState& n = data.needles[i];
    const double tip = n.tip_force + 0.0;  // −F · t of no force is −0: written as 0
    r.needle_tip_force_n = i == 0 ? tip : std::max(r.needle_tip_force_n, tip);
    r.needle_points += n.num_punctures;
    if (n.event != core::PunctureEvent::kNone) r.needle_event = static_cast<int>(n.event);
  }
  return r;
}

void Trace::write_csv(const std::string& path) const {
  std::ofstream out(path);
  if (!out) throw std::runtime_error(path + ": cannot open the trace file for writing");
  const int axes = records_.empty() ? 0 : records_.front().num_axes;
  std::vector<std::string> axis_names;
  for (int i = 0; i < axes; ++i)
    axis_names.push_back(static_cast<std::size_t>(i) < axis_names_.size()
                             ? axis_names_[static_cast<std::size_t>(i)]
                             : std::to_string(i));
  const int devices = records_.empty() ? 0 : records_.front().num_extra_devices;
  std::vector<std::string> device_names;
  for (int i = 0; i < devices; ++i)
    device_names.push_back(static_cast<std::size_t>(i) < device_names_.size()
                               ? device_names_[static_cast<std::size_t>(i)]
                               : std::to_string(i + 1));
  const std::vector<std::string> names = trace_column_names(TraceKind::kCsv, axis_names, device_names);
  for (std::size_t c = 0; c < names.size(); ++c) out << (c ? "," : "") << names[c];
  out << '\n';
  out.precision(9);
  std::vector<double> row(names.size());
  for (const TraceRecord& r : records_) {
    const std::size_t n = trace_column_values(TraceKind::kCsv, r, axes, std::span(row), devices);
    for (std::size_t c = 0; c < n; ++c) out << (c ? "," : "") << row[c];
    out << '\n';
  }
  out.flush();  // a write error of the last buffered block must not pass silently
  if (!out) throw std::runtime_error(path + ": error while writing the trace");
}

}  // namespace numen::sim
