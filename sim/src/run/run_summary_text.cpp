/// @file run_summary_text.cpp
/// The text summary of a run: its layout (segments with figure placeholders) and the renderer.

#include "numen/sim/run/run_summary_text.hpp"

#include <algorithm>
#include <iomanip>
#include <sstream>
#include <stdexcept>

#include "numen/sim/input/input_error.hpp"
#include "numen/sim/run/divergence.hpp"
#include "numen/sim/run/run_figures.hpp"
#include "numen/sim/run/run_summary.hpp"

namespace numen::sim {
namespace {

using T = RunSummaryCondition::Test;

constexpr RunSummaryCondition always() noexcept { return {}; }
constexpr RunSummaryCondition set(std::string_view f, std::string_view or_f = {}) noexcept {
  return {f, T::kSet, or_f};
}
constexpr RunSummaryCondition unset(std::string_view f) noexcept { return {f, T::kUnset}; }

// The text summary, line by line. Lines that scripts read (tests/hil) keep their wording:
// "x real time", "invalid periods ", "active at period ", "safety: ", "first: ",
// "trace records N, dropped ", "loop overruns: ", "end-to-end (SYNC", "re-arm: ",
// "nan detected: no", "exit status".
constexpr RunSummarySegment kLayout[] = {
    {"scene {scene}: {coupling} coupling, {integrator}, dt {dt_s:ms} ms, device {device_loop}\n"},
    {"  {trocar_note}\n", set("trocar_note")},
    {"  {steps} steps, {sim_time_s} s simulated in {wall_time_s} s wall ({real_time_factor}x "
     "real time)\n"},
    {"  step time us: median {step_time_us.median}, p99 {step_time_us.p99}, p99.9 "
     "{step_time_us.p999}, max {step_time_us.max}, mean {step_time_us.mean}\n"},
    {"  penetration max: target (where the encoders put the tool) {target_penetration_max_mm} mm, god-object "
     "{tool_penetration_max_mm} mm"},
    {" after a start-up of {startup_steps} steps from {startup_tool_penetration_mm} mm (the tool "
     "started inside)",
     set("startup_steps")},
    {"; any body {any_penetration_max_mm} mm\n"},
    {"  closed loop: hand {hand_penetration_max_mm} mm deep, handle "
     "{device_penetration_max_mm} mm; force on the hand max {handle_force_max_n} N, hand–handle "
     "separation max {hand_separation_max_mm} mm; port energy {device_port_energy_j} J, min "
     "{device_port_energy_min_j} J at {device_port_energy_min_time_s} s\n",
     set("closed_loop")},
    {"  device: limit cycle at {limit_cycle_time_s} s: {limit_cycle_amplitude_mm} mm at "
     "{limit_cycle_hz} Hz\n",
     set("limit_cycle_detected")},
    {"  threads: tension max {thread.tension_max_n} N at {thread.tension_max_s} s, stretch max {thread.stretch_max}, breaks "
     "{thread.breaks}",
     set("thread.tension_max_n", "thread.breaks")},
    {" (the first at {thread.first_break_s} s)", set("thread.breaks")},
    {", Newton unconverged steps {thread.newton_not_converged_steps}",
     set("thread.newton_not_converged_steps")},
    {"; through tissue: {thread.eyelets_taken} puncture points taken over, {thread.eyelets_let_go} let "
     "go, {thread.eyelets_dropped} dropped",
     set("thread.eyelets_taken", "thread.eyelets_dropped")},
    {"\n", set("thread.tension_max_n", "thread.breaks")},
    {"  needles: {needle.punctures} punctures, {needle.exits} exits, {needle.releases} releases, "
     "{needle.tunnels} tunnels",
     set("needle.lines")},
    {" ({needle.tunnels_stopped} steps held back at the surface)", set("needle.tunnels_stopped")},
    {"; {needle.passes} through; tip force at the last puncture "
     "{needle.puncture_tip_force_n} N (threshold {needle.puncture_force_n} N; its contacts asked "
     "{needle.puncture_contact_force_n} N); deviation from the "
     "arc max {needle.deviation_max_mm} mm; force on the tissue max {needle.tissue_force_max_n} N at "
     "{needle.tissue_force_max_s} s",
     set("needle.lines")},
    {"; from the marks: entry {needle.entry_error_mm} mm, exit {needle.exit_error_mm} mm",
     set("needle.lines"), set("needle.marks")},
    {"\n", set("needle.lines")},
    {"  needle {*}\n", set("needle.lines"), {}, {}, "needle.lines"},
    {"  servos: offset max {servo.offset_max_mm} mm, error max {servo.error_max_mm} mm, saturated "
     "{servo.saturated_periods} periods\n",
     set("servo.lines")},
    {"  servo {*}\n", set("servo.lines"), {}, {}, "servo.lines"},
    {"  grasps: {grasp.started} started, {grasp.released} released, {grasp.slipped} slipped\n",
     set("grasp.started")},
    {"  grasp event: {*}\n", set("grasp.started"), {}, {}, "grasp.events"},
    {"  grasper {*}\n", set("grasp.graspers"), {}, {}, "grasp.graspers"},
    {"  task: {task.transferred} of {task.objects} objects transferred ({task.placed} placed); "
     "hand-overs {task.handovers}, drops {task.drops}; time {task.time_s} s\n",
     set("task.objects")},
    {"  task object: {*}\n", set("task.objects"), {}, {}, "task.lines"},
    {"  device {*}\n", set("device_lines"), {}, {}, "device_lines"},

    {"  tracking error in free space (tool and hand out of contact): rms "
     "{tracking_error_free_rms_mm} mm, max {tracking_error_free_max_mm} mm over {free_steps} "
     "steps\n",
     unset("admittance.enabled")},
    {"  admittance: measured force max {admittance.measured_force_max_n} N (torque "
     "{admittance.measured_torque_max_nm} N·m), final {admittance.final_measured_force_n} N at "
     "hand–device separation {admittance.final_hand_separation_mm} mm (k_hand {admittance.k_hand} "
     "N/m × sep = {admittance.final_hand_force_n} N), separation max "
     "{admittance.hand_separation_max_mm} mm\n",
     set("admittance.enabled")},
    {"  admittance: device vs god-object error max {admittance.device_error_max_mm} mm, rms "
     "{admittance.device_error_rms_mm} mm; sensor frames {admittance.sensor_frames}, rejected "
     "periods {admittance.sensor_rejected_periods}, csp RPDOs {admittance.csp_rpdos}, set-points "
     "clamped {admittance.setpoints_clamped}, rate limited {admittance.setpoints_rate_limited}, "
     "hold periods {admittance.hold_periods}\n",
     set("admittance.enabled")},
    {"  multirate: scene loop every {multirate.scene_dt_s:ms} ms ({multirate.ratio} device "
     "periods), margin {multirate.margin_mm} mm; {multirate.scene_steps} scene steps, planes max "
     "{multirate.planes_max}, dropped {multirate.planes_dropped}, stale models "
     "{multirate.stale_models}, tool switches {multirate.switches}, folded scene steps "
     "{multirate.folded_scene_steps}; the new planes added "
     "{multirate.reset_energy_j} J (at most {multirate.reset_energy_max_j} J at a sample)",
     set("multirate.enabled")},
    // An admittance device is sent poses, not forces: no feedback force to jump.
    {"; feedback force jump max {multirate.model_force_jump_max_n} N at a new model, "
     "{multirate.other_force_jump_max_n} N otherwise",
     set("multirate.enabled"), unset("admittance.enabled")},
    {"\n", set("multirate.enabled")},
    {"  multirate scene thread: {multirate.scene_overruns} overruns; scene step us: median "
     "{multirate.scene_step_us.median}, p99 {multirate.scene_step_us.p99}, max "
     "{multirate.scene_step_us.max}\n",
     set("multirate.scene_thread")},
    {"  feedback: force max {feedback_force_max_n} N (largest jump between periods "
     "{feedback_force_jump_max_n} N), torque max {feedback_torque_max_nm} N·m, axis torque max "
     "{axis_torque_max}\n"},
    {"  soft start: feedback ramped in over {soft_start_s:ms} ms, {soft_start_ramps} ramp(s)\n",
     set("soft_start_s"), unset("admittance.enabled")},
    {"  soft start: off\n", unset("soft_start_s"), unset("admittance.enabled")},
    {"  passivity controller: acted in {passivity_acting_periods} periods, dissipated "
     "{passivity_dissipated_j} J\n",
     set("passivity_controller")},
    {"  joints: {num_joints}, drift max {joint_drift_max_mm} mm, {joint_angle_drift_max_mrad} "
     "mrad\n",
     set("num_joints")},
    {"  fastest body not held: {free_body_speed_max_mps} m/s ({num_bodies} bodies)\n"},
    {"  deformable: {num_nets} net(s), {num_nodes} nodes; node contacts max {node_contacts_max}, "
     "net penetration max {net_penetration_max_mm} mm, tie stretch max {net_tie_stretch_max_mm} "
     "mm, strain max {net_strain_max}, node speed max {net_node_speed_max_mps} m/s\n",
     set("num_nets")},
    {"  deformable: a sphere of the tool past a net's surface (or the surface folded over it) in "
     "{net_crossed_steps} scene steps (multirate: those contacts dropped, their depth in the net "
     "penetration max; docs/organs.md, \"Organs in multirate\")\n",
     set("net_crossed_steps")},
    {"  deformable: up to {net_inverted_tetrahedra_max} tetrahedra of an organ given by its material "
     "inside out at once (see the warning)\n",
     set("net_inverted_tetrahedra_max")},
    {"  contacts max {contacts_max}, overflow steps {contact_overflow}, solver iterations mean "
     "{solver_iterations_mean}, max {solver_iterations_max}, residual max "
     "{solver_residual_max:e2}, not converged {solver_not_converged_steps} steps\n"},
    {"  stiff contacts: stiffness clamped to the time-constant floor in {contact_clamped_steps} "
     "steps (docs/dynamics.md, \"Stiff contacts\")\n",
     set("contact_clamped_steps")},
    {"  instruments crossing: a sphere pair of two bodies past each other, pushed back the way "
     "it came, in {crossed_contact_steps} steps; went through {pass_throughs} times\n",
     set("crossed_contact_steps")},
    {"  pass-through: sphere pairs of two bodies went through each other {pass_throughs} "
     "times, the first at {first_pass_through_s} s (docs/dynamics.md, \"Crossing\")\n",
     set("pass_throughs")},
    {"  rejected samples: {rejected_causes}\n", set("rejected_causes")},
    {"  stale samples: {stale_stretches} stretch(es), {stale_periods} periods; the longest "
     "{stale_longest_s} s from t = {stale_longest_from_s} s; {stale_rejoins} return(s) glided "
     "the target over at most {stale_rejoin_gap_mm} mm and {stale_rejoin_gap_deg} deg\n",
     set("stale_stretches")},
    {"  bus: rejected samples {rejected_samples}, invalid periods {invalid_periods}, frames "
     "dropped {bus_frames_dropped}, corrupted {bus_frames_corrupted}\n"},
    {"  bus {bus}: {bus_frames_replayed} frames replayed of {bus_log_records} records; lost by "
     "the recording {bus_log_lost_frames}, out of order {bus_log_out_of_order}\n",
     {"bus", T::kLogBus}},
    // The OpenIGTLink tracker (--bus igtl; docs/openigtlink.md).
    {"  OpenIGTLink {igtl}: {igtl_messages} messages, tool poses {igtl_poses} (taken "
     "{igtl_poses_taken}), other devices {igtl_other_devices}, ignored {igtl_ignored}; rejected "
     "{igtl_faults}, dropped {igtl_dropped}; connections {igtl_connects}, refused "
     "{igtl_connect_failures}, lost {igtl_disconnects}; periods before the first pose "
     "{igtl_syncs_without_pose}, waits run out {igtl_wait_timeouts}, periods after the stream's "
     "end {igtl_periods_after_end}; stamps refused: backwards {igtl_stamps_backwards}, ahead "
     "{igtl_stamps_ahead}, unstamped {igtl_stamps_unstamped}, clock re-basings "
     "{igtl_stamp_resyncs}, re-basings after a silence {igtl_silence_rebases}; "
     "received to applied us: median {igtl_latency_us.median}, p99 {igtl_latency_us.p99}, max "
     "{igtl_latency_us.max}; following the tracker's clock {igtl_follows}\n",
     set("igtl")},
    {"  OpenIGTLink rejected: {*}\n", set("igtl"), {}, {}, "igtl_fault_records"},
    {"  OpenIGTLink other device names: {*}\n", set("igtl"), {}, {}, "igtl_names_seen"},
    // Real buses (can:, serial:).
    {"  bus {bus}: frames rx {port_frames_rx}, tx {port_frames_tx}, dropped {port_dropped}, "
     "errors {port_errors}, would-block {port_would_block}; state {bus_state}, error periods "
     "{bus_error_periods}\n",
     set("real_bus")},
    {"  {transport}\n", set("real_bus"), set("transport")},
    {"  loop: read errors {read_errors}, SYNC write failures {sync_write_failures}, command "
     "failures {command_failures}; frames rejected {frames_rejected} (unknown id "
     "{frames_unknown_id}), error frames ignored {error_frames}, values out of range "
     "{values_out_of_range}, jumps {values_jump}\n",
     set("real_bus")},
    // The simulated bus and a log replay: the frames rejected are named (they were silent).
    {"  frames rejected {frames_rejected} (encoder frames: CAN FD {encoder_frames_fd}, remote "
     "{encoder_frames_remote}, wrong length {encoder_frames_wrong_length}), unknown id "
     "{frames_unknown_id}\n",
     unset("real_bus"), set("frames_rejected", "frames_unknown_id")},
    {"  loop period {loop.period_ns:us1} us, overrun budget {loop.overrun_budget_ns:us1} us, "
     "{loop.periods} periods\n",
     set("real_bus")},
    {"  loop wake-up latency us: min {loop.wakeup_ns.min:us1}, median "
     "{loop.wakeup_ns.median:us1}, p99 {loop.wakeup_ns.p99:us1}, p99.9 {loop.wakeup_ns.p999:us1}, "
     "max {loop.wakeup_ns.max:us1} ({loop.wakeup_ns.count} periods)\n",
     set("real_bus")},
    {"  loop step time us: min {loop.step_ns.min:us1}, median {loop.step_ns.median:us1}, p99 "
     "{loop.step_ns.p99:us1}, p99.9 {loop.step_ns.p999:us1}, max {loop.step_ns.max:us1} "
     "({loop.step_ns.count} periods)\n",
     set("real_bus")},
    {"  loop bus I/O time us: min {loop.bus_io_ns.min:us1}, median {loop.bus_io_ns.median:us1}, "
     "p99 {loop.bus_io_ns.p99:us1}, p99.9 {loop.bus_io_ns.p999:us1}, max "
     "{loop.bus_io_ns.max:us1} ({loop.bus_io_ns.count} periods)\n",
     set("real_bus")},
    {"  loop end-to-end (SYNC to torque out) us: min {loop.end_to_end_ns.min:us1}, median "
     "{loop.end_to_end_ns.median:us1}, p99 {loop.end_to_end_ns.p99:us1}, p99.9 "
     "{loop.end_to_end_ns.p999:us1}, max {loop.end_to_end_ns.max:us1} "
     "({loop.end_to_end_ns.count} periods)\n",
     set("real_bus")},
    {"  loop overruns: {loop.overruns} (longest streak {loop.longest_overrun_streak}), skipped "
     "periods {loop.skipped_periods}, invalid periods {loop.invalid_periods}",
     set("real_bus")},
    {", SAFE STOP raised", set("real_bus"), set("loop.safe_stops"), set("loop.safe_stop")},
    {", safe stop raised before", set("real_bus"), set("loop.safe_stops"),
     unset("loop.safe_stop")},
    {"\n", set("real_bus")},
    {"  device frames: last at period {last_device_frame_period}; last torque stop at period "
     "{last_torque_stop_period}\n",
     set("real_bus")},
    {"  end: stopped by signal", set("real_bus"), set("stopped")},
    {" {stop_signal}", set("real_bus"), set("stopped"), set("stop_signal")},
    {"  end: duration reached", set("real_bus"), unset("stopped")},
    {", shutdown {shutdown_periods} periods, drives ", set("real_bus")},
    {"disabled", set("real_bus"), set("drives_disabled")},
    {"NOT disabled", set("real_bus"), unset("drives_disabled")},
    {"; trace records {trace_pushed}, dropped {trace_dropped}, written {trace_written}, I/O "
     "errors {trace_io_errors}\n",
     set("real_bus")},
    {"  recorded {bus_frames_recorded} frames, {bus_record_dropped} dropped by the recorder, "
     "{bus_record_written} written, {bus_record_io_errors} I/O errors, "
     "{bus_record_format_errors} format errors\n",
     set("bus_frames_recorded", "bus_record_dropped")},
    {"  state stream: {view_frames_published} frames published, {view_frames_decimated} "
     "periods decimated, {view_frames_dropped} dropped, {view_frames_delivered} delivered "
     "({view_bytes} B), {view_sink_errors} consumer errors\n",
     set("view_streamed")},
    {"  view recording: {view_record_frames} frames written, {view_record_io_errors} I/O "
     "errors\n",
     set("view_recorded")},
    // Device lifecycle and safety.
    {"  canopen: start-up {startup} at period {periods_to_operational}, active at period "
     "{periods_to_active}, first torque at period {periods_to_torque}; lifecycle {lifecycle}\n",
     set("managed")},
    {"  safety: {faults} safe stop(s), {fault_records} fault record(s)", set("managed")},
    {"; first: {first_fault.cause} (id {first_fault.id}, value {first_fault.value}) at "
     "{first_fault.time_s} s, period {first_fault.period}",
     set("managed"), set("first_fault.cause")},
    {"; EMCY {emcys} ({emcy_faults} faults), heartbeat losses {heartbeat_losses}, zero-torque "
     "periods {zero_torque_periods} (start-up {zero_torque_startup}, safe state "
     "{zero_torque_safe_state}, shutdown {zero_torque_shutdown}, gated {zero_torque_gated}, soft "
     "start {zero_torque_soft_start}, below resolution {zero_torque_below_resolution})\n",
     set("managed")},
    {"  SDO: {configured_nodes} node configuration(s) from DCFs; in-loop reads {sdo_reads}, "
     "errors {sdo_read_errors}\n",
     set("managed")},
    {"  re-arm: {rearm_requests} request(s), {rearms_accepted} accepted, first before period "
     "{rearm_first_period}\n",
     set("rearm_requests")},  // any run that took a request (managed, minimal, admittance)
    {"  EMCY: {*}\n", set("managed"), {}, {}, "emcy_messages"},
    {"  drives:", set("managed"), set("drive_states")},
    {", {*}", set("managed"), {}, {}, "drive_states", " {*}"},
    {"\n", set("managed"), set("drive_states")},
    {"  admittance protocol: SYNC, force/torque TPDOs, csp RPDOs (docs/protocol.md); "
     "lifecycle {lifecycle}, {faults} safe stop(s)\n",
     unset("managed"), set("admittance.enabled")},
    {"  canopen: minimal protocol (no start-up, no lifecycle)\n", unset("managed"),
     unset("admittance.enabled")},
    {"  nan detected: YES", set("nan_detected")},
    {"  nan detected: no", unset("nan_detected")},
    {" (non-finite steps {nonfinite_steps})"},
    {"; INVALID TARGETS: {invalid_target_steps} steps (coupling skipped, feedback held)",
     set("invalid_target_steps")},

    // Speed and stretch are ratios to their limits; energy_ratio_max is E / (E0 + W_in), whose
    // limit is DivergenceLimits::energy_factor (static_assert below).
    {"\n  divergence: speed {divergence.speed_ratio_max}, tie stretch "
     "{divergence.stretch_ratio_max} of their limits; energy {divergence.energy_ratio_max}x "
     "what the scene started with plus the hand's work (limit 100x) (speed limit "
     "{divergence.speed_limit_mps} m/s, scene {divergence.scene_size_m} m)"},
    {"; DIVERGED at {divergence.time_s} s (period {divergence.period}): {divergence.cause} of "
     "{divergence.subject} {divergence.value}, limit {divergence.limit}",
     set("divergence.latched")},
    {"\n  realtime setup: {*}", always(), {}, {}, "realtime_setup"},
    {"\n  realtime: wake-up latency us median {wakeup_latency_us.median}, p99 "
     "{wakeup_latency_us.p99}, max {wakeup_latency_us.max}; overruns {realtime_overruns}, missed "
     "periods {realtime_missed_periods}",
     set("wakeup_latency_us.max")},
    {"; overrun policy: latch after {overrun_limit}", set("wakeup_latency_us.max"),
     set("overrun_limit")},
    {"; overrun policy: count only", set("wakeup_latency_us.max"), unset("overrun_limit")},
    {"\n"},
    {"  warning: {*}\n", always(), {}, {}, "warnings"},
    {"  exit status {exit_status} ({exit_status_name})"},
    {"; {*}", always(), {}, {}, "exit_reasons", ": {*}"},
    {"\n"},
};
static_assert(DivergenceLimits{}.energy_factor == 100.0,
              "the divergence line of kLayout says the energy limit is 100x");

const RunFigure& figure(std::string_view name) {
  const RunFigure* f = find_run_figure(name);
  if (f == nullptr)
    throw std::logic_error("text summary layout: no run figure '" + std::string(name) + "'");
  return *f;
}

bool holds_one(const RunSummary& s, std::string_view name, T test) {
  const FigureValue v = figure(name).get(s);
  switch (test) {
    case T::kAlways: return true;
    case T::kSet: return v.set();
    case T::kUnset: return !v.set();
    case T::kLogBus: return v.kind == FigureKind::kText && v.text.rfind("log:", 0) == 0;
  }
  return false;
}

bool holds(const RunSummary& s, const RunSummaryCondition& c) {
  if (c.test == T::kAlways) return true;
  const bool a = holds_one(s, c.figure, c.test);
  return c.or_figure.empty() ? a : a || holds_one(s, c.or_figure, c.test);
}

/// Adds the figures of a printed segment's condition to `written`: the wording depends on them.
void note(const RunSummaryCondition& c, std::vector<std::string_view>* written) {
  if (written == nullptr || c.test == T::kAlways) return;
  written->push_back(c.figure);
  if (!c.or_figure.empty()) written->push_back(c.or_figure);
}

void write_value(std::ostream& os, const FigureValue& v, std::string_view spec) {
  switch (v.kind) {
    case FigureKind::kReal:
    case FigureKind::kCount: {
      const double x = v.kind == FigureKind::kReal ? v.real : static_cast<double>(v.count);
      if (spec == "e2")
        os << std::scientific << std::setprecision(2) << x << std::fixed << std::setprecision(3);
      else if (spec == "ms")
        os << x * 1e3;
      else if (spec == "us1")
        os << std::setprecision(1) << x * 1e-3 << std::setprecision(3);
      else if (!spec.empty())
        throw std::logic_error("text summary layout: unknown format '" + std::string(spec) + "'");
      else if (v.kind == FigureKind::kReal)
        os << v.real;
      else
        os << v.count;
      break;
    }
    case FigureKind::kFlag: os << (v.flag ? "true" : "false"); break;
    case FigureKind::kText: os << InputError::visible(v.text); break;
    case FigureKind::kTextList:
      throw std::logic_error("text summary layout: a list figure outside `each`");
  }
}

/// Writes `text` with its placeholders replaced; `element` stands for {*}.
void write_template(std::ostream& os, const RunSummary& s, std::string_view text,
                    std::string_view element, std::vector<std::string_view>* written) {
  std::size_t i = 0;
  while (i < text.size()) {
    const std::size_t open = text.find('{', i);
    if (open == std::string_view::npos) {
      os << text.substr(i);
      break;
    }
    os << text.substr(i, open - i);
    const std::size_t close = text.find('}', open);
    if (close == std::string_view::npos)
      throw std::logic_error("text summary layout: unclosed '{' in " + std::string(text));
    const std::string_view field = text.substr(open + 1, close - open - 1);
    if (field == "*") {
      // Names come from scene files and the network: a control byte is written as \xNN, so
      // that a grasper named "g\x1B[2J" cannot clear the terminal or forge a summary line.
      os << InputError::visible(element);
    } else {
      const std::size_t colon = field.find(':');
      const std::string_view name = field.substr(0, colon);
      const std::string_view spec =
          colon == std::string_view::npos ? std::string_view{} : field.substr(colon + 1);
      write_value(os, figure(name).get(s), spec);
      if (written != nullptr) written->push_back(name);
    }
    i = close + 1;
  }
}

}  // namespace

std::span<const RunSummarySegment> run_summary_text_layout() noexcept { return kLayout; }

std::string format_summary_text(const RunSummary& s, std::vector<std::string_view>* written) {
  std::ostringstream os;
  os << std::fixed << std::setprecision(3);
  for (const RunSummarySegment& seg : kLayout) {
    if (!holds(s, seg.when) || !holds(s, seg.and_when) || !holds(s, seg.and_also)) continue;
    for (const RunSummaryCondition* c : {&seg.when, &seg.and_when, &seg.and_also}) note(*c, written);
    if (seg.each.empty()) {
      write_template(os, s, seg.text, {}, written);
      continue;
    }
    const FigureValue v = figure(seg.each).get(s);
    if (v.kind != FigureKind::kTextList)
      throw std::logic_error("text summary layout: `each` of a figure that is not a list");
    if (written != nullptr && !v.list->empty()) written->push_back(seg.each);
    for (std::size_t i = 0; i < v.list->size(); ++i)
      write_template(os, s, i == 0 && !seg.first.empty() ? seg.first : seg.text, (*v.list)[i],
                     written);
  }
  return os.str();
}

std::string format_summary(const RunSummary& s) { return format_summary_text(s, nullptr); }

}  // namespace numen::sim
