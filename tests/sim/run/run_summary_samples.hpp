#pragma once
// Run summaries that switch on every conditional part of the summaries (shared by the tests of
// run_figures, run_summary_text and run_summary_json): between them, every figure of
// run_figures() is printed in the text.
#include "numen/sim/run/run_summary.hpp"

namespace numen::test {

/// A managed run on a real bus with every optional part set: start-up, joints, nets,
/// stiff contacts, recording, a first fault, a re-arm, drive states, transport counters, the
/// real-time setup, paced timing, the loop's statistics with a safe stop, warnings, reasons.
inline sim::RunSummary full_managed_summary() {
  sim::RunSummary s;
  s.scene = "sample";
  s.coupling = "god-object";
  s.integrator = "implicit-euler";
  s.steps = 500;
  s.dt_s = 0.001;
  s.sim_time_s = 0.5;
  s.wall_time_s = 0.25;
  s.trocar_note = "trocar placed at the port";
  s.step_time_us = {11.5, 12.5, 13.5, 14.5, 11.75};
  s.target_penetration_max_mm = 1.25;
  s.device_loop = "closed";
  s.closed_loop = true;
  s.hand_penetration_max_mm = 24.25;
  s.device_penetration_max_mm = 1.25;
  s.handle_force_max_n = 5.5;
  s.device_port_energy_j = 0.08;
  s.device_port_energy_min_j = -0.0125;
  s.device_port_energy_min_time_s = 0.125;
  s.hand_separation_max_mm = 29.5;
  s.limit_cycle_detected = true;
  s.limit_cycle_amplitude_mm = 1.875;
  s.limit_cycle_hz = 15.0;
  s.limit_cycle_time_s = 0.375;
  s.tool_penetration_max_mm = 0.5;
  s.startup_tool_penetration_mm = 2.5;
  s.startup_steps = 3;
  s.any_penetration_max_mm = 3.5;
  s.tracking_error_free_rms_mm = 0.125;
  s.tracking_error_free_max_mm = 0.375;
  s.free_steps = 10;
  s.feedback_force_max_n = 4.5;
  s.feedback_force_jump_max_n = 0.375;
  s.soft_start_s = 0.1;
  s.soft_start_ramps = 2;
  s.passivity_controller = true;
  s.passivity_acting_periods = 12;
  s.passivity_dissipated_j = 0.25;
  s.feedback_torque_max_nm = 0.0625;
  s.axis_torque_max = 0.75;
  s.free_body_speed_max_mps = 0.875;
  s.num_bodies = 4;
  s.num_joints = 2;
  s.joint_drift_max_mm = 0.015625;
  s.joint_angle_drift_max_mrad = 0.03125;
  s.rejected_samples = 5;
  s.invalid_periods = 6;
  s.stale_stretches = 1;
  s.stale_periods = 4;
  s.stale_longest_s = 0.004;
  s.stale_longest_from_s = 1.5;
  s.stale_rejoins = 1;
  s.stale_rejoin_gap_mm = 29.5;
  s.stale_rejoin_gap_deg = 3.25;
  s.contact_overflow = 7;
  s.contact_clamped_steps = 8;
  s.rejected_causes = "4 stale (older than max_sample_age, or none came), 1 implausible jump";
  s.crossed_contact_steps = 15;
  s.pass_throughs = 2;
  s.first_pass_through_s = 0.125;
  s.contacts_max = 9;
  s.solver_iterations_max = 10;
  s.solver_iterations_mean = 4.5;
  s.solver_residual_max = 1.5e-7;
  s.solver_not_converged_steps = 11;
  s.num_nets = 1;
  s.num_nodes = 12;
  s.node_contacts_max = 13;
  s.net_penetration_max_mm = 0.25;
  s.net_crossed_steps = 74;
  s.net_tie_stretch_max_mm = 1.75;
  s.net_strain_max = 0.125;
  s.net_node_speed_max_mps = 0.0625;
  s.net_inverted_tetrahedra_max = 3;
  s.net_first_inversion_s = 9.85;
  s.net_first_inversion_net = "organ";
  s.nan_detected = true;
  s.nonfinite_steps = 14;
  s.invalid_target_steps = 3;
  s.threads = true;
  s.thread_tension_max_n = 1.5;
  s.thread_tension_max_s = 2.75;
  s.thread_stretch_max = 0.004;
  s.thread_breaks = 1;
  s.thread_newton_not_converged_steps = 3;
  s.thread_first_break_s = 3.25;
  s.thread_eyelets_taken = 2;
  s.thread_eyelets_let_go = 1;
  s.thread_eyelets_dropped = 1;
  s.needles = true;
  s.needle_punctures = 1;
  s.needle_exits = 1;
  s.needle_releases = 2;
  s.needle_tunnels = 1;
  s.needle_tunnels_stopped = 2;
  s.needle_passes = 1;
  s.needle_puncture_tip_force_n = 1.0;
  s.needle_puncture_contact_force_n = 1.125;
  s.needle_puncture_force_n = 1.0;
  s.needle_deviation_max_mm = 0.375;
  s.needle_tissue_force_max_n = 0.625;
  s.needle_tissue_force_max_s = 2.5;
  s.needle_marks = true;
  s.needle_entry_error_mm = 0.25;
  s.needle_exit_error_mm = 0.5;
  s.needle_lines = {
      "needle: 1 puncture, 1 exit, 2 releases, 1 tunnel; through (in at 1.250 s, out at 2.500 s); "
      "tip force at the last puncture 1.000 N (threshold 1.000 N; its contacts asked 1.125 N); "
      "deviation from the arc max "
      "0.375 mm; entry 0.250 mm from its mark; exit 0.500 mm from its mark"};
  s.servos = true;
  s.servo_offset_max_mm = 1.25;
  s.servo_error_max_mm = 0.875;
  s.servo_saturated_periods = 3;
  s.servo_lines = {"right watches needle: offset max 1.250 mm (at most 4.000), error max 0.875 mm, saturated 3 periods"};
  s.grasping = true;
  s.grasps_started = 2;
  s.grasps_released = 1;
  s.grasps_slipped = 1;
  s.grasp_events = {"6.968 s grasp grasper: organ (5 nodes)",
                    "7.026 s release grasper: organ (5 nodes, pull 0.738 N)"};
  s.grasper_lines = {"grasper (device left): 2 started, 1 released, 1 slipped; hand-overs 1 given, 0 taken; "
                     "feedback force on its hand max 1.500 N"};
  s.task.enabled = true;
  s.task.objects = 2;
  s.task.transferred = 1;
  s.task.placed = 1;
  s.task.handovers = 1;
  s.task.drops = 1;
  s.task.time_s = 4.25;
  s.task.lines = {"ring_1: 2 grasps, 1 hand-over, 0 drops; placed on peg_1 at 5.470 s",
                  "ring_2: 1 grasp, 0 hand-overs, 1 drop; ends on no peg at (-6.1, -17.8, 2.0) mm"};
  // Two devices (a [[device]] scene): device 0's figures are the summary's own.
  for (const char* name : {"left", "right"}) {
    sim::DeviceRunSummary d;
    d.name = name;
    d.feedback_force_max_n = 1.5;
    d.closed_loop = true;
    d.handle_force_max_n = 2.25;
    d.lifecycle = "active";
    s.device_lines.push_back(sim::format_device_line(d));
    s.devices.push_back(d);
  }
  s.divergence.latched = true;
  s.divergence.cause = "node speed";
  s.divergence.subject = "net \"bag\"";
  s.divergence.value = 933.5;
  s.divergence.limit = 24.5;
  s.divergence.time_s = 0.412;
  s.divergence.period = 412;
  s.divergence.speed_ratio_max = 38.125;
  s.divergence.stretch_ratio_max = 0.25;
  s.divergence.energy_ratio_max = 0.875;
  s.divergence.scene_size_m = 0.291;
  s.divergence.speed_limit_mps = 24.5;
  s.bus_frames_dropped = 15;
  s.bus_frames_corrupted = 16;
  s.bus = "can:vcan0";
  s.bus_frames_recorded = 17;
  s.bus_record_dropped = 18;
  s.bus_record_written = 19;
  s.bus_record_io_errors = 20;
  s.bus_record_format_errors = 21;
  s.view_streamed = true;
  s.view_recorded = true;
  s.view_frames_published = 60;
  s.view_frames_decimated = 940;
  s.view_frames_dropped = 2;
  s.view_frames_delivered = 58;
  s.view_bytes = 33060;
  s.view_sink_errors = 1;
  s.view_record_frames = 57;
  s.view_record_io_errors = 1;
  s.realtime_overruns = 22;
  s.realtime_missed_periods = 23;
  s.overrun_limit = 4;
  s.wakeup_latency_us = {5.5, 6.5, 7.5, 8.5, 5.75};
  s.realtime_setup = {"SCHED_FIFO 80: ok", "mlockall: ok"};
  s.managed = true;
  s.startup = "operational";
  s.periods_to_operational = 24;
  s.periods_to_active = 25;
  s.periods_to_torque = 26;
  s.lifecycle = "active";
  s.faults = 27;
  s.fault_records = 28;
  s.first_fault = "encoder timeout";
  s.first_fault_id = 2;
  s.first_fault_value = 0.5;
  s.first_fault_time_s = 0.25;
  s.first_fault_period = 29;
  s.emcys = 30;
  s.emcy_faults = 31;
  s.configured_nodes = 71;
  s.sdo_reads = 72;
  s.sdo_read_errors = 73;
  s.heartbeat_losses = 32;
  s.zero_torque_periods = 33;
  s.drive_states = {"yaw: operation enabled", "pitch: switch on disabled"};
  s.emcy_messages = {"node 2 at 0.250 s: 0x4310 temperature: excess temperature device (register 0x09)"};
  s.real_bus = true;
  s.port.frames_rx = 34;
  s.port.frames_tx = 35;
  s.port.dropped = 36;
  s.port.errors = 37;
  s.port.tx_would_block = 38;
  s.transport = "socketcan: rx overflows 0";
  s.bus_state = "ok";
  s.bus_error_periods = 39;
  s.read_errors = 40;
  s.sync_write_failures = 41;
  s.command_failures = 42;
  s.frames_rejected = 43;
  s.encoder_frames_fd = 20;
  s.encoder_frames_remote = 3;
  s.encoder_frames_wrong_length = 2;
  s.frames_unknown_id = 44;
  s.error_frames = 45;
  s.values_out_of_range = 46;
  s.values_jump = 47;
  s.loop.period_ns = 1'000'000;
  s.loop.overrun_budget_ns = 900'000;
  s.loop.periods = 48;
  s.loop.invalid_periods = 49;
  s.loop.overruns = 50;
  s.loop.longest_overrun_streak = 51;
  s.loop.skipped_periods = 52;
  s.loop.safe_stops = 1;
  s.loop.safe_stop = true;
  s.loop.wakeup = {48, 1'100, 2'200, 3'300, 4'400, 5'500, 2'000.0};
  s.loop.step = {48, 10'100, 20'200, 30'300, 40'400, 50'500, 20'000.0};
  s.loop.bus_io = {48, 600, 700, 800, 900, 1'000, 700.0};
  s.loop.end_to_end = {48, 100'100, 200'200, 300'300, 400'400, 500'500, 200'000.0};
  s.last_device_frame_period = 53;
  s.last_torque_stop_period = 54;
  s.trace_pushed = 55;
  s.trace_dropped = 56;
  s.trace_written = 57;
  s.trace_io_errors = 58;
  s.stopped = true;
  s.stop_signal = 15;
  s.rearm_requests = 2;
  s.rearms_accepted = 1;
  s.rearm_first_period = 59;
  s.shutdown_periods = 60;
  s.drives_disabled = true;
  s.warnings = {"first warning", "second warning"};
  s.multirate.enabled = true;
  s.multirate.scene_dt_s = 0.01;
  s.multirate.ratio = 10;
  s.multirate.margin_mm = 12.5;
  s.multirate.scene_steps = 81;
  s.multirate.planes_max = 82;
  s.multirate.planes_dropped = 83;
  s.multirate.stale_models = 84;
  s.multirate.switches = 85;
  s.multirate.scene_thread = true;
  s.multirate.scene_overruns = 86;
  s.multirate.scene_step_us = {87.5, 88.5, 89.5, 90.5, 91.5};
  s.multirate.model_force_jump_max_n = 0.25;
  s.multirate.other_force_jump_max_n = 0.125;
  s.multirate.reset_energy_j = 0.375;
  s.multirate.reset_energy_max_j = 0.125;
  s.multirate.folded_scene_steps = 92;
  s.exit_status = 3;
  s.exit_reasons = {"first reason", "second reason"};
  return s;
}

/// An admittance run (minimal protocol): the admittance figures and the parts printed only
/// without the managed stack.
inline sim::RunSummary admittance_summary() {
  sim::RunSummary s = full_managed_summary();
  s.managed = false;
  s.real_bus = false;
  s.bus = "log:recorded.log";
  s.bus_frames_replayed = 61;
  s.bus_log_records = 62;
  s.bus_log_lost_frames = 63;
  s.bus_log_out_of_order = 64;
  s.nan_detected = false;
  s.overrun_limit = 0;
  s.admittance.enabled = true;
  s.admittance.measured_force_max_n = 5.25;
  s.admittance.measured_torque_max_nm = 0.125;
  s.admittance.device_error_max_mm = 0.5;
  s.admittance.device_error_rms_mm = 0.25;
  s.admittance.hand_separation_max_mm = 30.5;
  s.admittance.final_measured_force_n = 4.75;
  s.admittance.final_hand_separation_mm = 24.75;
  s.admittance.k_hand = 200.0;
  s.admittance.sensor_frames = 65;
  s.admittance.sensor_rejected_periods = 66;
  s.admittance.csp_rpdos = 67;
  s.admittance.setpoints_clamped = 68;
  s.admittance.setpoints_rate_limited = 69;
  s.admittance.hold_periods = 70;
  return s;
}

/// A run on --bus igtl (the OpenIGTLink tracker) with every igtl_* figure set.
inline sim::RunSummary igtl_summary() {
  sim::RunSummary s = full_managed_summary();
  s.managed = false;
  s.real_bus = false;
  s.bus = "igtl:127.0.0.1:18944";
  s.igtl = "127.0.0.1:18944 'StylusToTracker'";
  s.igtl_messages = 1203;
  s.igtl_poses = 1000;
  s.igtl_poses_taken = 990;
  s.igtl_other_devices = 200;
  s.igtl_ignored = 1;
  s.igtl_faults = 2;
  s.igtl_dropped = 10;
  s.igtl_connects = 1;
  s.igtl_connect_failures = 3;
  s.igtl_disconnects = 1;
  s.igtl_wait_timeouts = 0;
  s.igtl_syncs_without_pose = 4;
  s.igtl_stamps_backwards = 6;
  s.igtl_stamps_ahead = 7;
  s.igtl_stamps_unstamped = 8;
  s.igtl_stamp_resyncs = 1;
  s.igtl_silence_rebases = 1;
  s.igtl_follows = true;
  s.igtl_periods_after_end = 5;
  s.igtl_fault_records = {
      "CRC mismatch: TRANSFORM 'StylusToTracker', message 12 at stream byte 1272, field at byte "
      "50 (2 such)"};
  s.igtl_names_seen = {"PointerToTracker"};
  s.igtl_latency_us = {320.0, 610.0, 900.0, 5700.0, 340.0};
  return s;
}

}  // namespace numen::test
