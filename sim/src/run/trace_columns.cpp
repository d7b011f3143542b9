/// @file trace_columns.cpp
/// The column table of the traces (trace_columns.hpp).

#include "numen/sim/run/trace_columns.hpp"

#include "markdown_cell.hpp"

namespace numen::sim {
namespace {

using R = TraceRecord;

/// Device `i` + 1's record of `r` (a zero record past the trace's devices).
DeviceTraceRecord device(const R& r, int i) noexcept {
  return i >= 0 && i < r.num_extra_devices ? r.devices[static_cast<std::size_t>(i)] : DeviceTraceRecord{};
}

// The streamed columns keep their order (tests/hil/scenarios read frames_read … target_z by
// position: columns 4–10 after period, time_ns, flags).
constexpr TraceColumn kColumns[] = {
    {"time_s", "s", "Simulated time after the step",
     [](const R& r, int) noexcept { return r.time_s; }},
    // The column keeps its earlier name (a contract, docs/outputs.md): the held body's index.
    {"attached_body", "", "Held body index (-1: none)",
     [](const R& r, int) noexcept { return static_cast<double>(r.held_body); }},
    {"frames_read", "", "Frames taken from the bus this period",
     [](const R& r, int) noexcept { return static_cast<double>(r.frames_read); }, false, true},
    {"sample_valid", "", "1: the period's sample was valid",
     [](const R& r, int) noexcept { return r.sample_valid ? 1.0 : 0.0; }, false, true},
    {"torque_commanded", "", "1: non-zero torque was commanded",
     [](const R& r, int) noexcept { return r.torque_commanded ? 1.0 : 0.0; }, false, true},
    {"lifecycle", "", "Lifecycle state after the period (hal::LifecycleState value)",
     [](const R& r, int) noexcept { return static_cast<double>(r.lifecycle); }, false, true},
    {"target_x", "m", "Device target of the held body's COM frame: x",
     [](const R& r, int) noexcept { return r.target.position.x(); }, false, true},
    {"target_y", "m", "... y", [](const R& r, int) noexcept { return r.target.position.y(); },
     false, true},
    {"target_z", "m", "... z", [](const R& r, int) noexcept { return r.target.position.z(); },
     false, true},
    {"target_qw", "", "... orientation quaternion w",
     [](const R& r, int) noexcept { return r.target.orientation.w(); }},
    {"target_qx", "", "... x", [](const R& r, int) noexcept { return r.target.orientation.x(); }},
    {"target_qy", "", "... y", [](const R& r, int) noexcept { return r.target.orientation.y(); }},
    {"target_qz", "", "... z", [](const R& r, int) noexcept { return r.target.orientation.z(); }},
    {"tool_x", "m", "Held body's (god-object's) pose: x",
     [](const R& r, int) noexcept { return r.tool.position.x(); }, false, true},
    {"tool_y", "m", "... y", [](const R& r, int) noexcept { return r.tool.position.y(); }, false,
     true},
    {"tool_z", "m", "... z", [](const R& r, int) noexcept { return r.tool.position.z(); }, false,
     true},
    {"tool_qw", "", "... orientation quaternion w",
     [](const R& r, int) noexcept { return r.tool.orientation.w(); }},
    {"tool_qx", "", "... x", [](const R& r, int) noexcept { return r.tool.orientation.x(); }},
    {"tool_qy", "", "... y", [](const R& r, int) noexcept { return r.tool.orientation.y(); }},
    {"tool_qz", "", "... z", [](const R& r, int) noexcept { return r.tool.orientation.z(); }},
    {"contacts", "", "All rigid contacts this step",
     [](const R& r, int) noexcept { return static_cast<double>(r.contacts); }},
    {"tool_contacts", "", "Contacts of the tool",
     [](const R& r, int) noexcept { return static_cast<double>(r.tool_contacts); }},
    {"tool_penetration_mm", "mm", "Deepest contact of the tool",
     [](const R& r, int) noexcept { return r.tool_penetration_mm; }},
    {"target_penetration_mm", "mm",
     "Deepest contact of the target (where the encoders put it: the hand in replay, the handle "
     "in closed loop)",
     [](const R& r, int) noexcept { return r.target_penetration_mm; }},
    {"hand_penetration_mm", "mm",
     "Closed loop: deepest contact of the tool where the hand means it to be (0 in replay)",
     [](const R& r, int) noexcept { return r.hand_penetration_mm; }},
    {"handle_force_n", "N", "Closed loop: |force of the hand on the handle| (0 in replay)",
     [](const R& r, int) noexcept { return r.handle_force_n; }},
    {"device_port_energy_j", "J",
     "Closed loop: energy the hand has put into the device so far (0 in replay)",
     [](const R& r, int) noexcept { return r.device_port_energy_j; }},
    {"feedback_fx", "N", "Feedback wrench sent (Eq. 8): force x",
     [](const R& r, int) noexcept { return r.feedback.force.x(); }, false, true},
    {"feedback_fy", "N", "... force y",
     [](const R& r, int) noexcept { return r.feedback.force.y(); }, false, true},
    {"feedback_fz", "N", "... force z",
     [](const R& r, int) noexcept { return r.feedback.force.z(); }, false, true},
    {"feedback_tx", "N·m", "... torque x",
     [](const R& r, int) noexcept { return r.feedback.torque.x(); }},
    {"feedback_ty", "N·m", "... torque y",
     [](const R& r, int) noexcept { return r.feedback.torque.y(); }},
    {"feedback_tz", "N·m", "... torque z",
     [](const R& r, int) noexcept { return r.feedback.torque.z(); }},
    {"axis_torque_", "N·m or N", "Torque commanded on each axis (named by the axis)",
     [](const R& r, int a) noexcept {
       return a < r.num_axes ? r.axis_torque[static_cast<std::size_t>(a)] : 0.0;
     },
     true, true},
    {"step_time_us", "us", "Wall time of core::step",
     [](const R& r, int) noexcept { return r.step_time_us; }, false, true},
    {"end_to_end_us", "us", "SYNC sent to the torque writes returned",
     [](const R& r, int) noexcept { return r.end_to_end_us; }, false, true},
    {"wakeup_latency_us", "us", "Wake-up time − deadline",
     [](const R& r, int) noexcept { return r.wakeup_latency_us; }, false, true},
    {"solver_iterations", "", "Iterations of the implicit solve",
     [](const R& r, int) noexcept { return static_cast<double>(r.solver_iterations); }},
    {"joint_drift_mm", "mm", "Largest linear joint error |C| after the step",
     [](const R& r, int) noexcept { return r.joint_drift_mm; }},
    {"joint_angle_drift_mrad", "mrad", "Largest angular joint error |C| after the step",
     [](const R& r, int) noexcept { return r.joint_angle_drift_mrad; }},
    {"joint_reaction_max_n", "N", "Largest |reaction force| of a joint on its child",
     [](const R& r, int) noexcept { return r.joint_reaction_max_n; }},
    {"baumgarte_rhs_max", "m/s or rad/s", "Largest |c| of a joint row: the Baumgarte correction",
     [](const R& r, int) noexcept { return r.baumgarte_rhs_max; }},
    {"solver_residual", "1",
     "Stopping measure of the implicit solve (relative residual ‖r‖/‖b‖; nets without joints: "
     "relative energy-norm error estimate)",
     [](const R& r, int) noexcept { return r.solver_residual; }},
    {"node_contacts", "", "Node contacts of all nets",
     [](const R& r, int) noexcept { return static_cast<double>(r.node_contacts); }},
    {"net_penetration_mm", "mm", "Deepest node contact",
     [](const R& r, int) noexcept { return r.net_penetration_mm; }},
    {"net_tie_stretch_mm", "mm", "Largest |x − a| of a node from its rest position",
     [](const R& r, int) noexcept { return r.net_tie_stretch_mm; }},
    {"net_strain_max", "1", "Largest |l − L|/L of a structural spring",
     [](const R& r, int) noexcept { return r.net_strain_max; }},
    {"emcys", "", "CANopen EMCY messages received this period",
     [](const R& r, int) noexcept { return static_cast<double>(r.emcys); }, false, true},
    {"emcy_node", "", "Node of the newest EMCY this period (0: none)",
     [](const R& r, int) noexcept { return static_cast<double>(r.emcy_node); }, false, true},
    {"emcy_code", "", "Its error code (0: none; named by CiA 301/402 in the summary's EMCY list)",
     [](const R& r, int) noexcept { return static_cast<double>(r.emcy_code); }, false, true},
    {"grasps_held", "", "Graspers holding a body, a thread or tissue after the step (docs/grasping.md)",
     [](const R& r, int) noexcept { return static_cast<double>(r.grasps_held); }},
    {"thread_tension_n", "N", "Largest segment tension of the threads after the step (docs/thread.md)",
     [](const R& r, int) noexcept { return r.thread_tension_n; }},
    {"thread_stretch", "1", "Largest segment strain (l − l0)/l0 of the threads after the step",
     [](const R& r, int) noexcept { return r.thread_stretch; }},
    {"thread_contacts", "", "Contacts of the threads this step (bodies' spheres, obstacles, tissue, self)",
     [](const R& r, int) noexcept { return static_cast<double>(r.thread_contacts); }},
    {"thread_newton_iterations", "", "Most Newton iterations a thread's step took",
     [](const R& r, int) noexcept { return static_cast<double>(r.thread_newton_iterations); }},
    {"thread_unconverged", "", "Threads whose Newton iteration ran out this step (the step took its last iterate)",
     [](const R& r, int) noexcept { return static_cast<double>(r.thread_unconverged); }},
    {"needle_tip_force_n", "N",
     "Force of the tissue on a needle's tip against its tangent this step (> 0 resists it; at most the "
     "threshold in a puncture's step; docs/suturing.md)",
     [](const R& r, int) noexcept { return r.needle_tip_force_n; }},
    {"needle_points", "", "Puncture points the needles hold after the step (entries and exits)",
     [](const R& r, int) noexcept { return static_cast<double>(r.needle_points); }},
    {"needle_event", "", "The step's needle event: 0 none, 1 puncture, 2 exit, 3 release",
     [](const R& r, int) noexcept { return static_cast<double>(r.needle_event); }},
    // Devices 1 .. N−1 of a scene of several (device 0's are the columns above).
    {"sample_valid@", "", "Each other device (a scene of several): 1: its sample was valid",
     [](const R& r, int i) noexcept { return device(r, i).sample_valid ? 1.0 : 0.0; }, false, false, true},
    {"target_x@", "m", "... the coupling target of the body it drives (its tool link's, else the first with spheres): x",
     [](const R& r, int i) noexcept { return static_cast<double>(device(r, i).target[0]); }, false, false, true},
    {"target_y@", "m", "... y", [](const R& r, int i) noexcept { return static_cast<double>(device(r, i).target[1]); }, false, false, true},
    {"target_z@", "m", "... z", [](const R& r, int i) noexcept { return static_cast<double>(device(r, i).target[2]); }, false, false, true},
    {"tool_x@", "m", "... that body's position: x",
     [](const R& r, int i) noexcept { return static_cast<double>(device(r, i).tool[0]); }, false, false, true},
    {"tool_y@", "m", "... y", [](const R& r, int i) noexcept { return static_cast<double>(device(r, i).tool[1]); }, false, false, true},
    {"tool_z@", "m", "... z", [](const R& r, int i) noexcept { return static_cast<double>(device(r, i).tool[2]); }, false, false, true},
    {"feedback_fx@", "N", "... the feedback force sent to it (Eq. 8): x",
     [](const R& r, int i) noexcept { return static_cast<double>(device(r, i).feedback_force[0]); }, false, false, true},
    {"feedback_fy@", "N", "... y",
     [](const R& r, int i) noexcept { return static_cast<double>(device(r, i).feedback_force[1]); }, false, false, true},
    {"feedback_fz@", "N", "... z",
     [](const R& r, int i) noexcept { return static_cast<double>(device(r, i).feedback_force[2]); }, false, false, true},
};

}  // namespace

std::span<const TraceColumn> trace_columns() noexcept { return kColumns; }

std::vector<std::string> trace_column_names(TraceKind kind,
                                            std::span<const std::string> axis_names,
                                            std::span<const std::string> device_names) {
  std::vector<std::string> names;
  for (const TraceColumn& c : kColumns) {
    if (!in_trace(c, kind)) continue;
    if (c.per_device) {
      for (const std::string& d : device_names) names.push_back(std::string(c.name) + d);
      continue;
    }
    if (!c.per_axis) {
      names.emplace_back(c.name);
      continue;
    }
    for (const std::string& a : axis_names) names.push_back(std::string(c.name) + a);
  }
  return names;
}

std::size_t trace_column_values(TraceKind kind, const TraceRecord& row, int num_axes,
                                std::span<double> out, int num_extra_devices) noexcept {
  std::size_t n = 0;
  for (const TraceColumn& c : kColumns) {
    if (!in_trace(c, kind)) continue;
    const int repeat = c.per_device ? num_extra_devices : c.per_axis ? num_axes : 1;
    for (int a = 0; a < repeat && n < out.size(); ++a) out[n++] = c.get(row, a);
  }
  return n;
}

std::string format_trace_columns_markdown() {
  std::string out = "| column | unit | traces | what it holds |\n| --- | --- | --- | --- |\n";
  for (const TraceColumn& c : kColumns) {
    out += "| `";
    out += c.name;
    if (c.per_axis) out += "<axis>";
    if (c.per_device) out += "<device>";
    out += "` | ";
    out += c.unit;
    out += c.streamed ? " | csv, stream | " : " | csv | ";
    append_markdown_cell(out, c.description);
    out += " |\n";
  }
  return out;
}

}  // namespace numen::sim
