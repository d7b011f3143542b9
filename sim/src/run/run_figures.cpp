/// @file run_figures.cpp
/// The table of run figures (run_figures.hpp), in the order of the JSON summary.

#include "numen/sim/run/run_figures.hpp"

#include <array>

#include "numen/sim/run/run_summary.hpp"
#include "numen/sim/run/run_verdict.hpp"
#include "markdown_cell.hpp"

namespace numen::sim {

bool FigureValue::set() const noexcept {
  switch (kind) {
    case FigureKind::kReal: return real != 0.0;
    case FigureKind::kCount: return count != 0;
    case FigureKind::kFlag: return flag;
    case FigureKind::kText: return !text.empty();
    case FigureKind::kTextList: return list != nullptr && !list->empty();
  }
  return false;
}

namespace {

using S = RunSummary;
using K = FigureKind;

constexpr FigureValue real(double v) noexcept {
  FigureValue f;
  f.kind = K::kReal;
  f.real = v;
  return f;
}
constexpr FigureValue count(std::int64_t v) noexcept {
  FigureValue f;
  f.kind = K::kCount;
  f.count = v;
  return f;
}
constexpr FigureValue flag(bool v) noexcept {
  FigureValue f;
  f.kind = K::kFlag;
  f.flag = v;
  return f;
}
constexpr FigureValue text(std::string_view v) noexcept {
  FigureValue f;
  f.kind = K::kText;
  f.text = v;
  return f;
}
constexpr FigureValue list(const std::vector<std::string>& v) noexcept {
  FigureValue f;
  f.kind = K::kTextList;
  f.list = &v;
  return f;
}
constexpr bool admittance_run(const S& s) noexcept { return s.admittance.enabled; }
constexpr bool multirate_run(const S& s) noexcept { return s.multirate.enabled; }
/// A multirate run that sends feedback forces (not an admittance run, which sends poses).
constexpr bool multirate_force_run(const S& s) noexcept {
  return s.multirate.enabled && !s.admittance.enabled;
}

// One row per figure: {name, unit, description, kind, accessor[, present]}.
constexpr RunFigure kFigures[] = {
    {"scene", "", "Scene name", K::kText, [](const S& s) noexcept { return text(s.scene); }},
    {"coupling", "", "Coupling mode (god-object, first-order, direct)", K::kText,
     [](const S& s) noexcept { return text(s.coupling); }},
    {"integrator", "", "Integrator of core::step", K::kText,
     [](const S& s) noexcept { return text(s.integrator); }},
    {"steps", "", "Periods run", K::kCount, [](const S& s) noexcept { return count(s.steps); }},
    {"dt_s", "s", "Control period (the scene's dt)", K::kReal,
     [](const S& s) noexcept { return real(s.dt_s); }},
    {"sim_time_s", "s", "Simulated time (steps × dt)", K::kReal,
     [](const S& s) noexcept { return real(s.sim_time_s); }},
    {"wall_time_s", "s", "Wall-clock time of the run", K::kReal,
     [](const S& s) noexcept { return real(s.wall_time_s); }},
    {"real_time_factor", "1", "Simulated time / wall time (0 when no wall time passed)", K::kReal,
     [](const S& s) noexcept {
       return real(s.wall_time_s > 0 ? s.sim_time_s / s.wall_time_s : 0.0);
     }},
    {"trocar_note", "", "Where the scene placed the trocar (empty: no trocar)", K::kText,
     [](const S& s) noexcept { return text(s.trocar_note); }},
    {"step_time_us.median", "us", "Wall time of core::step per period: median", K::kReal,
     [](const S& s) noexcept { return real(s.step_time_us.median); }},
    {"step_time_us.p99", "us", "... 99th percentile", K::kReal,
     [](const S& s) noexcept { return real(s.step_time_us.p99); }},
    {"step_time_us.p999", "us", "... 99.9th percentile", K::kReal,
     [](const S& s) noexcept { return real(s.step_time_us.p999); }},
    {"step_time_us.max", "us", "... largest", K::kReal,
     [](const S& s) noexcept { return real(s.step_time_us.max); }},
    {"step_time_us.mean", "us", "... mean", K::kReal,
     [](const S& s) noexcept { return real(s.step_time_us.mean); }},
    {"target_penetration_max_mm", "mm",
     "Deepest overlap of the target (the tool's bodies where the encoders put them: the hand in "
     "replay, the handle in closed loop) with obstacles and other bodies",
     K::kReal, [](const S& s) noexcept { return real(s.target_penetration_max_mm); }},
    {"device_loop", "",
     "replay (the encoders read the trajectory), closed (the device moves under the torques "
     "and the hand: [device.plant]), external (a real bus or a bus log: another process's "
     "device), admittance",
     K::kText, [](const S& s) noexcept { return text(s.device_loop); }},
    {"closed_loop", "", "device_loop is closed", K::kFlag,
     [](const S& s) noexcept { return flag(s.closed_loop); }},
    {"hand_penetration_max_mm", "mm",
     "Closed loop: deepest overlap of the held body where the hand means to be (the trajectory)",
     K::kReal, [](const S& s) noexcept { return real(s.hand_penetration_max_mm); }},
    {"device_penetration_max_mm", "mm",
     "Deepest overlap of the held body where the device's handle is (its encoders)", K::kReal,
     [](const S& s) noexcept { return real(s.device_penetration_max_mm); }},
    {"handle_force_max_n", "N", "Closed loop: largest force of the hand on the handle", K::kReal,
     [](const S& s) noexcept { return real(s.handle_force_max_n); }},
    {"device_port_energy_j", "J",
     "Closed loop: energy the hand put into the device (∫ F_hand · v dt; Hannaford & Ryu 2002)",
     K::kReal, [](const S& s) noexcept { return real(s.device_port_energy_j); }},
    {"device_port_energy_min_j", "J", "... its minimum (< 0: the device gave energy back)",
     K::kReal, [](const S& s) noexcept { return real(s.device_port_energy_min_j); }},
    {"device_port_energy_min_time_s", "s", "... when", K::kReal,
     [](const S& s) noexcept { return real(s.device_port_energy_min_time_s); }},
    {"hand_separation_max_mm", "mm", "Closed loop: largest |x_hand − x_handle|", K::kReal,
     [](const S& s) noexcept { return real(s.hand_separation_max_mm); }},
    {"limit_cycle_detected", "", "Closed loop: the handle oscillated (docs/device_plant.md)",
     K::kFlag, [](const S& s) noexcept { return flag(s.limit_cycle_detected); }},
    {"limit_cycle_amplitude_mm", "mm", "... its amplitude", K::kReal,
     [](const S& s) noexcept { return real(s.limit_cycle_amplitude_mm); }},
    {"limit_cycle_hz", "Hz", "... its frequency", K::kReal,
     [](const S& s) noexcept { return real(s.limit_cycle_hz); }},
    {"limit_cycle_time_s", "s", "... when first detected", K::kReal,
     [](const S& s) noexcept { return real(s.limit_cycle_time_s); }},
    {"tool_penetration_max_mm", "mm", "Deepest overlap of the god-object, after the start-up",
     K::kReal, [](const S& s) noexcept { return real(s.tool_penetration_max_mm); }},
    {"startup_tool_penetration_mm", "mm",
     "The god-object's penetration at the first period when it starts inside (0: started free)",
     K::kReal, [](const S& s) noexcept { return real(s.startup_tool_penetration_mm); }},
    {"startup_steps", "", "Periods of the start-up push-out (0: the tool started free)",
     K::kCount, [](const S& s) noexcept { return count(s.startup_steps); }},
    {"any_penetration_max_mm", "mm", "Deepest contact of any body", K::kReal,
     [](const S& s) noexcept { return real(s.any_penetration_max_mm); }},
    {"tracking_error_free_rms_mm", "mm",
     "|x_tool − x_target| RMS over the steps where neither the tool nor the hand touches "
     "anything",
     K::kReal, [](const S& s) noexcept { return real(s.tracking_error_free_rms_mm); }},
    {"tracking_error_free_max_mm", "mm", "Largest of the same", K::kReal,
     [](const S& s) noexcept { return real(s.tracking_error_free_max_mm); }},
    {"free_steps", "", "Steps counted in the free-space error", K::kCount,
     [](const S& s) noexcept { return count(s.free_steps); }},
    {"feedback_force_max_n", "N", "Largest |feedback force| sent (after saturation)", K::kReal,
     [](const S& s) noexcept { return real(s.feedback_force_max_n); }},
    {"feedback_force_jump_max_n", "N",
     "Largest change of the feedback force sent between consecutive periods", K::kReal,
     [](const S& s) noexcept { return real(s.feedback_force_jump_max_n); }},
    {"soft_start_s", "s",
     "The device's soft start: feedback ramped in over this time at start-up and after each "
     "re-arm (0: off)",
     K::kReal, [](const S& s) noexcept { return real(s.soft_start_s); }},
    {"soft_start_ramps", "", "Soft-start ramps run (start-up, re-arms)", K::kCount,
     [](const S& s) noexcept { return count(s.soft_start_ramps); }},
    {"passivity_controller", "",
     "The device's time-domain passivity controller runs ([device.passivity])", K::kFlag,
     [](const S& s) noexcept { return flag(s.passivity_controller); }},
    {"passivity_acting_periods", "", "Periods in which the passivity controller added damping",
     K::kCount, [](const S& s) noexcept { return count(s.passivity_acting_periods); }},
    {"passivity_dissipated_j", "J", "Energy the passivity controller's dampers dissipated",
     K::kReal, [](const S& s) noexcept { return real(s.passivity_dissipated_j); }},
    {"feedback_torque_max_nm", "N·m", "Largest |feedback torque| sent", K::kReal,
     [](const S& s) noexcept { return real(s.feedback_torque_max_nm); }},
    {"axis_torque_max", "N·m or N", "Largest |axis torque| commanded", K::kReal,
     [](const S& s) noexcept { return real(s.axis_torque_max); }},
    {"free_body_speed_max_mps", "m/s", "Fastest body not part of the held tool", K::kReal,
     [](const S& s) noexcept { return real(s.free_body_speed_max_mps); }},
    {"num_bodies", "", "Bodies of the model", K::kCount,
     [](const S& s) noexcept { return count(s.num_bodies); }},
    {"num_joints", "", "Joints of the model", K::kCount,
     [](const S& s) noexcept { return count(s.num_joints); }},
    {"joint_drift_max_mm", "mm", "Largest linear joint error |C| after a step", K::kReal,
     [](const S& s) noexcept { return real(s.joint_drift_max_mm); }},
    {"joint_angle_drift_max_mrad", "mrad", "Largest angular joint error |C| after a step",
     K::kReal, [](const S& s) noexcept { return real(s.joint_angle_drift_max_mrad); }},
    {"rejected_samples", "", "Axis samples rejected by the checks", K::kCount,
     [](const S& s) noexcept { return count(s.rejected_samples); }},
    {"invalid_periods", "", "Periods whose sample was not valid (target held)", K::kCount,
     [](const S& s) noexcept { return count(s.invalid_periods); }},
    {"contact_overflow", "", "Steps that ran out of contact capacity", K::kCount,
     [](const S& s) noexcept { return count(s.contact_overflow); }},
    {"contact_clamped_steps", "",
     "Steps with a contact whose stiffness the time-constant floor lowered", K::kCount,
     [](const S& s) noexcept { return count(s.contact_clamped_steps); }},
    {"contacts_max", "", "Rigid sphere contacts in one step", K::kCount,
     [](const S& s) noexcept { return count(s.contacts_max); }},
    {"solver_iterations_max", "", "Iterations of the implicit solve in one step", K::kCount,
     [](const S& s) noexcept { return count(s.solver_iterations_max); }},
    {"solver_iterations_mean", "", "Mean iterations over the steps", K::kReal,
     [](const S& s) noexcept { return real(s.solver_iterations_mean); }},
    {"solver_residual_max", "1",
     "Largest stopping measure of a step's solve (relative residual ‖r‖/‖b‖; nets without "
     "joints: relative energy-norm error estimate)",
     K::kReal, [](const S& s) noexcept { return real(s.solver_residual_max); }},
    {"solver_not_converged_steps", "",
     "Steps whose implicit solve ended at max_iterations above the tolerance", K::kCount,
     [](const S& s) noexcept { return count(s.solver_not_converged_steps); }},
    {"num_nets", "", "Deformable nets", K::kCount,
     [](const S& s) noexcept { return count(s.num_nets); }},
    {"num_nodes", "", "Nodes of all nets", K::kCount,
     [](const S& s) noexcept { return count(s.num_nodes); }},
    {"node_contacts_max", "", "Node contacts in one step (all nets)", K::kCount,
     [](const S& s) noexcept { return count(s.node_contacts_max); }},
    {"net_penetration_max_mm", "mm", "Deepest node contact of any net, crossed ones included",
     K::kReal, [](const S& s) noexcept { return real(s.net_penetration_max_mm); }},
    {"net_crossed_steps", "",
     "Multirate scene steps in which a sphere of the god-object was past a net's surface",
     K::kCount, [](const S& s) noexcept { return count(s.net_crossed_steps); }},
    {"net_tie_stretch_max_mm", "mm", "Largest |x − a| of a node from its rest position",
     K::kReal, [](const S& s) noexcept { return real(s.net_tie_stretch_max_mm); }},
    {"net_strain_max", "1", "Largest |l − L|/L of a structural spring", K::kReal,
     [](const S& s) noexcept { return real(s.net_strain_max); }},
    {"net_node_speed_max_mps", "m/s", "Fastest node", K::kReal,
     [](const S& s) noexcept { return real(s.net_node_speed_max_mps); }},
    {"nonfinite_steps", "", "Steps that produced a non-finite state", K::kCount,
     [](const S& s) noexcept { return count(s.nonfinite_steps); }},
    {"invalid_target_steps", "", "Steps whose device target was not finite (coupling skipped, feedback held)",
     K::kCount, [](const S& s) noexcept { return count(s.invalid_target_steps); }},
    {"bus_frames_dropped", "", "Simulated bus: frames the link dropped", K::kCount,
     [](const S& s) noexcept { return count(s.bus_frames_dropped); }},
    {"bus_frames_corrupted", "", "Simulated bus: frames the link corrupted", K::kCount,
     [](const S& s) noexcept { return count(s.bus_frames_corrupted); }},
    {"bus", "", "The controller's bus (--bus spec)", K::kText,
     [](const S& s) noexcept { return text(s.bus); }},
    {"bus_frames_replayed", "", "log: records read by the controller", K::kCount,
     [](const S& s) noexcept { return count(s.bus_frames_replayed); }},
    {"bus_log_records", "", "log: frame records in the file", K::kCount,
     [](const S& s) noexcept { return count(s.bus_log_records); }},
    {"bus_log_lost_frames", "", "log: frames the recording itself lost (DROPCOUNT notes)",
     K::kCount, [](const S& s) noexcept { return count(s.bus_log_lost_frames); }},
    {"bus_log_out_of_order", "", "log: records earlier than a record before them", K::kCount,
     [](const S& s) noexcept { return count(s.bus_log_out_of_order); }},
    {"bus_frames_recorded", "", "--record: frames queued for the log", K::kCount,
     [](const S& s) noexcept { return count(s.bus_frames_recorded); }},
    {"bus_record_dropped", "", "--record: frames lost to a full queue (paced runs)", K::kCount,
     [](const S& s) noexcept { return count(s.bus_record_dropped); }},
    {"bus_record_written", "", "--record: lines the writer thread wrote", K::kCount,
     [](const S& s) noexcept { return count(s.bus_record_written); }},
    {"bus_record_io_errors", "", "--record: failed writes / flushes", K::kCount,
     [](const S& s) noexcept { return count(s.bus_record_io_errors); }},
    {"bus_record_format_errors", "", "--record: records that could not be formatted", K::kCount,
     [](const S& s) noexcept { return count(s.bus_record_format_errors); }},
    {"view_streamed", "", "The state stream ran (--record-view, --view)", K::kFlag,
     [](const S& s) noexcept { return flag(s.view_streamed); }},
    {"view_recorded", "", "--record-view: the stream went to a view recording", K::kFlag,
     [](const S& s) noexcept { return flag(s.view_recorded); }},
    {"view_frames_published", "", "State stream: frames queued by the loop", K::kCount,
     [](const S& s) noexcept { return count(s.view_frames_published); }},
    {"view_frames_decimated", "", "State stream: periods left out by the display rate", K::kCount,
     [](const S& s) noexcept { return count(s.view_frames_decimated); }},
    {"view_frames_dropped", "", "State stream: due frames lost, every buffer in use", K::kCount,
     [](const S& s) noexcept { return count(s.view_frames_dropped); }},
    {"view_frames_delivered", "", "State stream: frames handed to the consumers", K::kCount,
     [](const S& s) noexcept { return count(s.view_frames_delivered); }},
    {"view_bytes", "B", "State stream: bytes of the frames delivered", K::kCount,
     [](const S& s) noexcept { return count(s.view_bytes); }},
    {"view_sink_errors", "", "State stream: consumer write or flush failures", K::kCount,
     [](const S& s) noexcept { return count(s.view_sink_errors); }},
    {"view_record_frames", "", "--record-view: frames in the file", K::kCount,
     [](const S& s) noexcept { return count(s.view_record_frames); }},
    {"view_record_io_errors", "", "--record-view: failed writes, flushes, close", K::kCount,
     [](const S& s) noexcept { return count(s.view_record_io_errors); }},
    {"real_bus", "", "The controller ran on a real bus (can:, serial:), paced", K::kFlag,
     [](const S& s) noexcept { return flag(s.real_bus); }},
    {"port_frames_rx", "", "Real bus: frames the controller's port received", K::kCount,
     [](const S& s) noexcept { return count(static_cast<std::int64_t>(s.port.frames_rx)); }},
    {"port_frames_tx", "", "Real bus: frames it sent", K::kCount,
     [](const S& s) noexcept { return count(static_cast<std::int64_t>(s.port.frames_tx)); }},
    {"port_dropped", "", "Real bus: frames it dropped", K::kCount,
     [](const S& s) noexcept { return count(static_cast<std::int64_t>(s.port.dropped)); }},
    {"port_errors", "", "Real bus: read / write errors", K::kCount,
     [](const S& s) noexcept { return count(static_cast<std::int64_t>(s.port.errors)); }},
    {"port_would_block", "", "Real bus: writes refused by a full transmit queue", K::kCount,
     [](const S& s) noexcept { return count(static_cast<std::int64_t>(s.port.tx_would_block)); }},
    {"transport", "", "Real bus: the transport's own counters, one line", K::kText,
     [](const S& s) noexcept { return text(s.transport); }},
    {"bus_state", "", "Real bus: port state at the end", K::kText,
     [](const S& s) noexcept { return text(s.bus_state); }},
    {"bus_error_periods", "", "Periods whose port state was not ok or saw a read / write error",
     K::kCount, [](const S& s) noexcept { return count(s.bus_error_periods); }},
    {"read_errors", "", "Control loop: failed reads", K::kCount,
     [](const S& s) noexcept { return count(s.read_errors); }},
    {"sync_write_failures", "", "Control loop: SYNC writes that failed", K::kCount,
     [](const S& s) noexcept { return count(s.sync_write_failures); }},
    {"command_failures", "", "Control loop: torque command writes that failed", K::kCount,
     [](const S& s) noexcept { return count(s.command_failures); }},
    {"frames_rejected", "", "Frames of a wrong length / kind, malformed drive TPDOs", K::kCount,
     [](const S& s) noexcept { return count(s.frames_rejected); }},
    {"frames_unknown_id", "", "Frames of an id no axis has", K::kCount,
     [](const S& s) noexcept { return count(s.frames_unknown_id); }},
    {"encoder_frames_fd", "", "Encoder frames rejected: CAN FD", K::kCount,
     [](const S& s) noexcept { return count(s.encoder_frames_fd); }},
    {"encoder_frames_remote", "", "Encoder frames rejected: remote requests", K::kCount,
     [](const S& s) noexcept { return count(s.encoder_frames_remote); }},
    {"encoder_frames_wrong_length", "", "Encoder frames rejected: wrong length", K::kCount,
     [](const S& s) noexcept { return count(s.encoder_frames_wrong_length); }},
    {"error_frames", "", "Controller error reports the device ignored", K::kCount,
     [](const S& s) noexcept { return count(s.error_frames); }},
    {"values_out_of_range", "", "Axis values rejected as out of [min, max]", K::kCount,
     [](const S& s) noexcept { return count(s.values_out_of_range); }},
    {"values_jump", "", "Axis values rejected as implausible jumps", K::kCount,
     [](const S& s) noexcept { return count(s.values_jump); }},
    {"loop.periods", "", "Paced loop: valid periods recorded", K::kCount,
     [](const S& s) noexcept { return count(s.loop.periods); }},
    {"loop.overruns", "", "Paced loop: periods that overran their budget", K::kCount,
     [](const S& s) noexcept { return count(s.loop.overruns); }},
    {"loop.longest_overrun_streak", "", "Paced loop: most consecutive overruns", K::kCount,
     [](const S& s) noexcept { return count(s.loop.longest_overrun_streak); }},
    {"loop.skipped_periods", "", "Paced loop: periods skipped to re-phase", K::kCount,
     [](const S& s) noexcept { return count(s.loop.skipped_periods); }},
#define NUMEN_LOOP_HISTOGRAM(key, member, what)                                                 \
  {"loop." key ".count", "", "Paced loop, " what ": periods", K::kCount,                       \
   [](const S& s) noexcept { return count(s.loop.member.count); }},                             \
      {"loop." key ".min", "ns", "Paced loop, " what ": smallest", K::kCount,                   \
       [](const S& s) noexcept { return count(s.loop.member.min); }},                           \
      {"loop." key ".median", "ns", "Paced loop, " what ": median", K::kCount,                  \
       [](const S& s) noexcept { return count(s.loop.member.median); }},                        \
      {"loop." key ".p99", "ns", "Paced loop, " what ": 99th percentile", K::kCount,            \
       [](const S& s) noexcept { return count(s.loop.member.p99); }},                           \
      {"loop." key ".p999", "ns", "Paced loop, " what ": 99.9th percentile", K::kCount,         \
       [](const S& s) noexcept { return count(s.loop.member.p999); }},                          \
      {"loop." key ".max", "ns", "Paced loop, " what ": largest", K::kCount,                    \
       [](const S& s) noexcept { return count(s.loop.member.max); }}
    NUMEN_LOOP_HISTOGRAM("wakeup_ns", wakeup, "wake-up time − deadline"),
    NUMEN_LOOP_HISTOGRAM("step_ns", step, "step time"),
    NUMEN_LOOP_HISTOGRAM("bus_io_ns", bus_io, "bus I/O time (SYNC, reads, torque writes)"),
    NUMEN_LOOP_HISTOGRAM("end_to_end_ns", end_to_end, "SYNC sent to torque out"),
#undef NUMEN_LOOP_HISTOGRAM
    {"loop.period_ns", "ns", "Paced loop: the period", K::kCount,
     [](const S& s) noexcept { return count(s.loop.period_ns); }},
    {"loop.overrun_budget_ns", "ns", "Paced loop: output end − deadline above this overruns",
     K::kCount, [](const S& s) noexcept { return count(s.loop.overrun_budget_ns); }},
    {"loop.invalid_periods", "", "Paced loop: periods rejected for disordered timestamps",
     K::kCount, [](const S& s) noexcept { return count(s.loop.invalid_periods); }},
    {"loop.safe_stops", "", "Paced loop: times the overrun policy raised a safe stop",
     K::kCount, [](const S& s) noexcept { return count(s.loop.safe_stops); }},
    {"loop.safe_stop", "", "Paced loop: the overrun policy's safe stop is raised at the end",
     K::kFlag, [](const S& s) noexcept { return flag(s.loop.safe_stop); }},
    {"last_device_frame_period", "", "Last period that read a frame (-1: none)", K::kCount,
     [](const S& s) noexcept { return count(s.last_device_frame_period); }},
    {"last_torque_stop_period", "",
     "Last period whose torque was zero after a period with torque (-1: none)", K::kCount,
     [](const S& s) noexcept { return count(s.last_torque_stop_period); }},
    {"trace_pushed", "", "Trace (--trace): records taken (real bus: queued to the writer)", K::kCount,
     [](const S& s) noexcept { return count(s.trace_pushed); }},
    {"trace_dropped", "", "Trace: records refused by a full queue or store (must be 0)",
     K::kCount, [](const S& s) noexcept { return count(s.trace_dropped); }},
    {"trace_written", "", "Trace: lines written", K::kCount,
     [](const S& s) noexcept { return count(s.trace_written); }},
    {"trace_io_errors", "", "Trace: failed opens, writes or flushes", K::kCount,
     [](const S& s) noexcept { return count(s.trace_io_errors); }},
    {"stopped", "", "Ended early by a stop signal", K::kFlag,
     [](const S& s) noexcept { return flag(s.stopped); }},
    {"stop_signal", "",
     "The signal that stopped it (1 SIGHUP, 2 SIGINT, 15 SIGTERM; 0: none or unknown)", K::kCount,
     [](const S& s) noexcept { return count(s.stop_signal); }},
    {"shutdown_periods", "", "Periods run to shut down (zero torque, drives disabled)",
     K::kCount, [](const S& s) noexcept { return count(s.shutdown_periods); }},
    {"drives_disabled", "", "Every drive disabled at the end of the shutdown", K::kFlag,
     [](const S& s) noexcept { return flag(s.drives_disabled); }},
    {"realtime_overruns", "", "Paced periods that began after their deadline", K::kCount,
     [](const S& s) noexcept { return count(s.realtime_overruns); }},
    {"realtime_missed_periods", "", "Whole periods skipped to re-phase after overruns",
     K::kCount, [](const S& s) noexcept { return count(s.realtime_missed_periods); }},
    {"overrun_limit", "", "Consecutive overruns that latch the safe state (0: counted only)",
     K::kCount, [](const S& s) noexcept { return count(s.overrun_limit); }},
    {"wakeup_latency_us.median", "us", "Paced runs: wake-up time − deadline, median", K::kReal,
     [](const S& s) noexcept { return real(s.wakeup_latency_us.median); }},
    {"wakeup_latency_us.p99", "us", "... 99th percentile", K::kReal,
     [](const S& s) noexcept { return real(s.wakeup_latency_us.p99); }},
    {"wakeup_latency_us.max", "us", "... largest (0: not paced)", K::kReal,
     [](const S& s) noexcept { return real(s.wakeup_latency_us.max); }},
    {"realtime_setup", "", "Real-time setup outcome, one line per step", K::kTextList,
     [](const S& s) noexcept { return list(s.realtime_setup); }},
    {"managed", "", "The device ran the managed CANopen stack", K::kFlag,
     [](const S& s) noexcept { return flag(s.managed); }},
    {"startup", "", "Managed: start-up phase at the end", K::kText,
     [](const S& s) noexcept { return text(s.startup); }},
    {"periods_to_operational", "", "Managed: period every node was operational (-1: never)",
     K::kCount, [](const S& s) noexcept { return count(s.periods_to_operational); }},
    {"periods_to_active", "", "Managed: period the lifecycle became active (-1: never)",
     K::kCount, [](const S& s) noexcept { return count(s.periods_to_active); }},
    {"periods_to_torque", "", "Managed: period of the first non-zero torque (-1: never)",
     K::kCount, [](const S& s) noexcept { return count(s.periods_to_torque); }},
    {"lifecycle", "", "Lifecycle state at the end", K::kText,
     [](const S& s) noexcept { return text(s.lifecycle); }},
    {"faults", "", "Safe states latched", K::kCount,
     [](const S& s) noexcept { return count(s.faults); }},
    {"fault_records", "", "Fault records written (latching or not)", K::kCount,
     [](const S& s) noexcept { return count(s.fault_records); }},
    {"first_fault.cause", "", "Cause of the first latched fault (empty: none)", K::kText,
     [](const S& s) noexcept { return text(s.first_fault); }},
    {"first_fault.id", "", "Its axis / node / drive", K::kCount,
     [](const S& s) noexcept { return count(s.first_fault_id); }},
    {"first_fault.value", "", "Its value (unit of the cause)", K::kReal,
     [](const S& s) noexcept { return real(s.first_fault_value); }},
    {"first_fault.time_s", "s", "Its bus time", K::kReal,
     [](const S& s) noexcept { return real(s.first_fault_time_s); }},
    {"first_fault.period", "", "Its period index (-1: none)", K::kCount,
     [](const S& s) noexcept { return count(s.first_fault_period); }},
    {"emcys", "", "EMCY messages received", K::kCount,
     [](const S& s) noexcept { return count(s.emcys); }},
    {"emcy_faults", "", "EMCY messages that reported a fault", K::kCount,
     [](const S& s) noexcept { return count(s.emcy_faults); }},
    {"configured_nodes", "", "Node configurations from a DCF written and read back at start-ups",
     K::kCount, [](const S& s) noexcept { return count(s.configured_nodes); }},
    {"sdo_reads", "", "In-loop SDO reads completed (error registers, drive statuswords)", K::kCount,
     [](const S& s) noexcept { return count(s.sdo_reads); }},
    {"sdo_read_errors", "", "In-loop SDO reads aborted by a node or timed out", K::kCount,
     [](const S& s) noexcept { return count(s.sdo_read_errors); }},
    {"heartbeat_losses", "", "Heartbeat losses over all nodes", K::kCount,
     [](const S& s) noexcept { return count(s.heartbeat_losses); }},
    {"zero_torque_periods", "", "Periods that commanded zero torque on every drive", K::kCount,
     [](const S& s) noexcept { return count(s.zero_torque_periods); }},
    {"zero_torque_safe_state", "", "... of which with a safe state latched", K::kCount,
     [](const S& s) noexcept { return count(s.zero_torque_safe_state); }},
    {"zero_torque_shutdown", "", "... of which shutting down (end of a real-bus run)", K::kCount,
     [](const S& s) noexcept { return count(s.zero_torque_shutdown); }},
    {"zero_torque_startup", "", "... of which before the device was active (start-up)",
     K::kCount, [](const S& s) noexcept { return count(s.zero_torque_startup); }},
    {"zero_torque_gated", "",
     "... of which every axis gated (no valid sample, torque not allowed, non-finite)", K::kCount,
     [](const S& s) noexcept { return count(s.zero_torque_gated); }},
    {"zero_torque_soft_start", "", "... of which ramped below the resolution by the soft start",
     K::kCount, [](const S& s) noexcept { return count(s.zero_torque_soft_start); }},
    {"zero_torque_below_resolution", "",
     "... of which every torque under half a per mille of rated (free space)", K::kCount,
     [](const S& s) noexcept { return count(s.zero_torque_below_resolution); }},
    {"rearm_requests", "", "Re-arm requests taken (SIGUSR1)", K::kCount,
     [](const S& s) noexcept { return count(s.rearm_requests); }},
    {"rearms_accepted", "", "Re-arm requests the control loop accepted", K::kCount,
     [](const S& s) noexcept { return count(s.rearms_accepted); }},
    {"rearm_first_period", "", "Period before which the first request was taken (-1: none)",
     K::kCount, [](const S& s) noexcept { return count(s.rearm_first_period); }},
    {"drive_states", "", "\"axis: CiA 402 state\" per drive at the end", K::kTextList,
     [](const S& s) noexcept { return list(s.drive_states); }},
    {"emcy_messages", "", "EMCY messages held at the end (last 16), node, time, code and its CiA 301 (drives: CiA 402) name",
     K::kTextList, [](const S& s) noexcept { return list(s.emcy_messages); }},
    {"warnings", "", "Warnings of the scene and the run", K::kTextList,
     [](const S& s) noexcept { return list(s.warnings); }},
    {"multirate.enabled", "", "The scene ran multirate ([multirate])", K::kFlag,
     [](const S& s) noexcept { return flag(s.multirate.enabled); }, multirate_run},
    {"multirate.scene_dt_s", "s", "The scene loop's period", K::kReal,
     [](const S& s) noexcept { return real(s.multirate.scene_dt_s); }, multirate_run},
    {"multirate.ratio", "", "Device periods per scene period", K::kCount,
     [](const S& s) noexcept { return count(s.multirate.ratio); }, multirate_run},
    {"multirate.margin_mm", "mm", "Proximity margin: the god-object's spheres grown by it for detection",
     K::kReal, [](const S& s) noexcept { return real(s.multirate.margin_mm); }, multirate_run},
    {"multirate.scene_steps", "", "Scene periods stepped", K::kCount,
     [](const S& s) noexcept { return count(s.multirate.scene_steps); }, multirate_run},
    {"multirate.planes_max", "", "Most contact planes handed to the device loop at once",
     K::kCount, [](const S& s) noexcept { return count(s.multirate.planes_max); }, multirate_run},
    {"multirate.planes_dropped", "",
     "God-object contacts beyond the room for planes, summed over scene periods", K::kCount,
     [](const S& s) noexcept { return count(s.multirate.planes_dropped); }, multirate_run},
    {"multirate.stale_models", "",
     "Device periods on planes older than one scene period (0 when the loops share a thread)",
     K::kCount, [](const S& s) noexcept { return count(s.multirate.stale_models); }, multirate_run},
    {"multirate.switches", "", "Tool switches the god-object followed", K::kCount,
     [](const S& s) noexcept { return count(s.multirate.switches); }, multirate_run},
    {"multirate.reset_energy_j", "J",
     "Energy the new planes added at the samples, over what the planes they replaced held at the "
     "god-object's pose, summed", K::kReal,
     [](const S& s) noexcept { return real(s.multirate.reset_energy_j); }, multirate_run},
    {"multirate.reset_energy_max_j", "J", "... the most one sample added", K::kReal,
     [](const S& s) noexcept { return real(s.multirate.reset_energy_max_j); }, multirate_run},
    {"multirate.folded_scene_steps", "",
     "Scene steps taken in sub-steps of at most [multirate] fold_step because an organ's surface "
     "had folded under the tool", K::kCount,
     [](const S& s) noexcept { return count(s.multirate.folded_scene_steps); }, multirate_run},
    {"multirate.model_force_jump_max_n", "N",
     "Largest change of the feedback force sent into a period that took a new scene model",
     K::kReal, [](const S& s) noexcept { return real(s.multirate.model_force_jump_max_n); },
     multirate_force_run},
    {"multirate.other_force_jump_max_n", "N", "... into any other period", K::kReal,
     [](const S& s) noexcept { return real(s.multirate.other_force_jump_max_n); },
     multirate_force_run},
    {"multirate.scene_thread", "", "The scene loop ran on its own thread (a paced run)", K::kFlag,
     [](const S& s) noexcept { return flag(s.multirate.scene_thread); }, multirate_run},
    {"multirate.scene_overruns", "", "Scene periods on the scene thread that ended past the next deadline",
     K::kCount, [](const S& s) noexcept { return count(s.multirate.scene_overruns); }, multirate_run},
    {"multirate.scene_step_us.median", "us", "Wall time of a scene step on the scene thread: median",
     K::kReal, [](const S& s) noexcept { return real(s.multirate.scene_step_us.median); }, multirate_run},
    {"multirate.scene_step_us.p99", "us", "... 99th percentile", K::kReal,
     [](const S& s) noexcept { return real(s.multirate.scene_step_us.p99); }, multirate_run},
    {"multirate.scene_step_us.max", "us", "... largest", K::kReal,
     [](const S& s) noexcept { return real(s.multirate.scene_step_us.max); }, multirate_run},
    {"admittance.enabled", "", "The run was an admittance run", K::kFlag,
     [](const S& s) noexcept { return flag(s.admittance.enabled); }, admittance_run},
    {"admittance.measured_force_max_n", "N", "Largest |measured force| that drove the god-object",
     K::kReal, [](const S& s) noexcept { return real(s.admittance.measured_force_max_n); },
     admittance_run},
    {"admittance.measured_torque_max_nm", "N·m", "Largest |measured torque| (about the COM)",
     K::kReal, [](const S& s) noexcept { return real(s.admittance.measured_torque_max_nm); },
     admittance_run},
    {"admittance.device_error_max_mm", "mm", "Largest |x_device − x_god-object|", K::kReal,
     [](const S& s) noexcept { return real(s.admittance.device_error_max_mm); }, admittance_run},
    {"admittance.device_error_rms_mm", "mm", "Its RMS over the periods", K::kReal,
     [](const S& s) noexcept { return real(s.admittance.device_error_rms_mm); }, admittance_run},
    {"admittance.hand_separation_max_mm", "mm", "Largest |x_hand − x_device|", K::kReal,
     [](const S& s) noexcept { return real(s.admittance.hand_separation_max_mm); },
     admittance_run},
    {"admittance.final_measured_force_n", "N", "|measured force| in the last period", K::kReal,
     [](const S& s) noexcept { return real(s.admittance.final_measured_force_n); },
     admittance_run},
    {"admittance.final_hand_separation_mm", "mm", "|x_hand − x_device| in the last period",
     K::kReal, [](const S& s) noexcept { return real(s.admittance.final_hand_separation_mm); },
     admittance_run},
    {"admittance.k_hand", "N/m", "The simulated hand's stiffness", K::kReal,
     [](const S& s) noexcept { return real(s.admittance.k_hand); }, admittance_run},
    {"admittance.final_hand_force_n", "N",
     "k_hand × final separation: the force the hand pulls with in the last period", K::kReal,
     [](const S& s) noexcept {
       return real(s.admittance.k_hand * s.admittance.final_hand_separation_mm * 1e-3);
     },
     admittance_run},
    {"admittance.sensor_frames", "", "Force sensor TPDOs received", K::kCount,
     [](const S& s) noexcept { return count(s.admittance.sensor_frames); }, admittance_run},
    {"admittance.sensor_rejected_periods", "", "Periods whose reading was rejected", K::kCount,
     [](const S& s) noexcept { return count(s.admittance.sensor_rejected_periods); },
     admittance_run},
    {"admittance.csp_rpdos", "", "csp RPDOs written", K::kCount,
     [](const S& s) noexcept { return count(s.admittance.csp_rpdos); }, admittance_run},
    {"admittance.setpoints_clamped", "", "Set-points clamped to an axis range", K::kCount,
     [](const S& s) noexcept { return count(s.admittance.setpoints_clamped); }, admittance_run},
    {"admittance.setpoints_rate_limited", "", "Set-points limited to max_speed · dt", K::kCount,
     [](const S& s) noexcept { return count(s.admittance.setpoints_rate_limited); },
     admittance_run},
    {"admittance.hold_periods", "", "Periods not active (drives disabled, god-object braked)",
     K::kCount, [](const S& s) noexcept { return count(s.admittance.hold_periods); },
     admittance_run},
    {"nan_detected", "", "A non-finite state was seen (steps, bodies, nodes)", K::kFlag,
     [](const S& s) noexcept { return flag(s.nan_detected); }},
    {"divergence.latched", "", "The divergence monitor latched (speeds, tie stretch, energy)",
     K::kFlag, [](const S& s) noexcept { return flag(s.divergence.latched); }},
    {"divergence.cause", "", "What breached: body speed, node speed, tie stretch, energy, device plant (docs/device_plant.md)",
     K::kText, [](const S& s) noexcept { return text(s.divergence.cause); }},
    {"divergence.subject", "", "The body or net that breached, or the device axis (`device axis N`)", K::kText,
     [](const S& s) noexcept { return text(s.divergence.subject); }},
    {"divergence.value", "", "The quantity at the breach (m/s, m or J; a device axis's speed, m/s or rad/s)", K::kReal,
     [](const S& s) noexcept { return real(s.divergence.value); }},
    {"divergence.limit", "", "Its limit (same unit)", K::kReal,
     [](const S& s) noexcept { return real(s.divergence.limit); }},
    {"divergence.time_s", "s", "Simulated time of the breach", K::kReal,
     [](const S& s) noexcept { return real(s.divergence.time_s); }},
    {"divergence.period", "", "Period of the breach (-1: none)", K::kCount,
     [](const S& s) noexcept { return count(s.divergence.period); }},
    {"divergence.speed_ratio_max", "1", "Largest body or node speed / its limit", K::kReal,
     [](const S& s) noexcept { return real(s.divergence.speed_ratio_max); }},
    {"divergence.stretch_ratio_max", "1", "Largest tie stretch / its limit", K::kReal,
     [](const S& s) noexcept { return real(s.divergence.stretch_ratio_max); }},
    {"divergence.energy_ratio_max", "1", "Largest held energy / (E0 + hand's work)", K::kReal,
     [](const S& s) noexcept { return real(s.divergence.energy_ratio_max); }},
    {"divergence.scene_size_m", "m", "Scene bounding-box diagonal at the start", K::kReal,
     [](const S& s) noexcept { return real(s.divergence.scene_size_m); }},
    {"divergence.speed_limit_mps", "m/s", "Speed limit at the end (10 × v_ref)", K::kReal,
     [](const S& s) noexcept { return real(s.divergence.speed_limit_mps); }},
    {"exit_status", "", "Exit status of the run (0: clean; docs/inputs.md)", K::kCount,
     [](const S& s) noexcept { return count(s.exit_status); }},
    {"exit_status_name", "", "Its name", K::kText,
     [](const S& s) noexcept {
       return text(exit_status_name(s.exit_status));
     }},
    {"exit_reasons", "", "Every condition behind the exit status, most severe first",
     K::kTextList, [](const S& s) noexcept { return list(s.exit_reasons); }},
};

}  // namespace

std::span<const RunFigure> run_figures() noexcept { return kFigures; }

const RunFigure* find_run_figure(std::string_view name) noexcept {
  for (const RunFigure& f : kFigures)
    if (f.name == name) return &f;
  return nullptr;
}

std::string format_run_figures_markdown() {
  std::string out = "| figure | unit | what it measures |\n| --- | --- | --- |\n";
  for (const RunFigure& f : kFigures) {
    out += "| `";
    out += f.name;
    out += "` | ";
    out += f.unit;
    out += " | ";
    append_markdown_cell(out, f.description);
    out += " |\n";
  }
  return out;
}

}  // namespace numen::sim
