/// @file run_summary.cpp
/// A run's summary built from what its runner measured: SceneRunner::summary() and the
/// summarize helpers both runners share (summarize_ns, summarize_divergence, describe_scene).

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iomanip>
#include <numbers>
#include <sstream>
#include <string>
#include <string_view>

#include "numen/hal/device/instrument_device.hpp"
#include "numen/hal/device/passivity_controller.hpp"
#include "numen/sim/run/grasp_summary.hpp"
#include "numen/sim/run/needle_summary.hpp"
#include "numen/sim/run/thread_summary.hpp"
#include "numen/sim/run/run.hpp"
#include "numen/sim/run/run_summary.hpp"
#include "numen/sim/run/task_summary.hpp"

namespace numen::sim {

DurationSummary summarize_ns(const platform::LatencyHistogram& h) {
  DurationSummary d;
  d.median = static_cast<double>(h.quantile(0.5)) * 1e-3;
  d.p99 = static_cast<double>(h.quantile(0.99)) * 1e-3;
  d.p999 = static_cast<double>(h.quantile(0.999)) * 1e-3;
  d.max = static_cast<double>(h.max()) * 1e-3;
  d.mean = h.mean() * 1e-3;
  return d;
}

void summarize_divergence(const DivergenceMonitor& monitor, const core::Model& model,
                          RunSummary& s) {
  DivergenceSummary& d = s.divergence;
  d.speed_ratio_max = monitor.speed_ratio_max();
  d.stretch_ratio_max = monitor.stretch_ratio_max();
  d.energy_ratio_max = monitor.energy_ratio_max();
  d.scene_size_m = monitor.scene_size_m();
  d.speed_limit_mps = monitor.speed_limit_mps();
  const Divergence& v = monitor.divergence();
  if (v.cause == nullptr) return;
  d.latched = true;
  d.cause = v.cause;
  if (std::string_view(v.cause) == "device plant")
    d.subject = "device axis " + std::to_string(v.body);
  else if (v.net >= 0)
    d.subject = "net \"" + model.nets[static_cast<std::size_t>(v.net)].name + "\"";
  else if (v.body >= 0)
    d.subject = "body \"" + model.bodies[static_cast<std::size_t>(v.body)].name + "\"";
  d.value = v.value;
  d.limit = v.limit;
  d.time_s = v.time_s;
  d.period = v.period;
}

void describe_scene(const Scene& scene, RunSummary& s) {
  s.scene = scene.name;
  s.coupling = to_string(scene.model.coupling_mode);
  s.integrator = to_string(scene.model.integrator);
  s.dt_s = scene.model.dt;
  s.warnings = scene.warnings;
  s.trocar_note = scene.trocar_note;
  s.num_bodies = scene.model.num_bodies();
  s.num_joints = scene.model.num_joints();
  s.num_nets = scene.model.num_nets();
  s.num_nodes = scene.model.num_nodes();
  if (scene.multirate) {
    s.multirate.enabled = true;
    s.multirate.scene_dt_s = scene.multirate->scene_dt_s;
    s.multirate.ratio = scene.multirate->ratio;
    s.multirate.margin_mm = scene.multirate->margin_m * 1e3;
  }
}

std::string rejection_causes(const hal::DeviceCounters& c) {
  std::string out;
  const auto add = [&out](std::uint64_t n, const char* what) {
    if (n == 0) return;
    if (!out.empty()) out += ", ";
    out += std::to_string(n) + " " + what;
  };
  add(c.rejected_stale, "stale (older than max_sample_age, or none came)");
  add(c.rejected_jump, "implausible jump");
  add(c.rejected_out_of_range, "out of range");
  add(c.rejected_malformed, "malformed");
  add(c.rejected_non_finite, "non-finite");
  return out;
}

std::string format_device_line(const DeviceRunSummary& d) {
  std::ostringstream os;
  os << std::fixed << std::setprecision(3) << d.name << ": feedback force max "
     << d.feedback_force_max_n << " N, torque max " << d.feedback_torque_max_nm << " N·m, torque sent in "
     << d.torque_periods << " periods";
  if (d.closed_loop)
    os << "; closed loop: force on the hand max " << d.handle_force_max_n
       << " N, hand–handle separation max " << d.hand_separation_max_mm << " mm, port energy "
       << d.device_port_energy_j << " J";
  os << "; invalid periods " << d.invalid_periods << ", rejected samples " << d.rejected_samples;
  if (!d.rejected_causes.empty()) os << " (" << d.rejected_causes << ")";
  if (!d.lifecycle.empty()) os << ", lifecycle " << d.lifecycle << ", safe states " << d.faults;
  return os.str();
}

void SceneRunner::summarize_servos(RunSummary& s) const {
  for (const std::unique_ptr<HandServo>& servo : servos_) {
    if (!servo) continue;
    s.servos = true;
    s.servo_offset_max_mm = std::max(s.servo_offset_max_mm, 1e3 * servo->offset_max_m());
    s.servo_error_max_mm = std::max(s.servo_error_max_mm, 1e3 * servo->error_max_m());
    s.servo_saturated_periods += servo->saturated_periods();
    const std::string& device = servo->device();
    std::ostringstream os;
    os << std::fixed << std::setprecision(3) << device << " watches " << servo->spec().body_name
       << ": offset max " << 1e3 * servo->offset_max_m() << " mm (at most "
       << 1e3 * servo->spec().settings.max_offset_m << "), error max " << 1e3 * servo->error_max_m()
       << " mm, saturated " << servo->saturated_periods() << " periods";
    s.servo_lines.push_back(os.str());
    if (servo->saturated_periods() > 0) {
      std::ostringstream w;
      w << std::fixed << std::setprecision(3) << "device '" << device << "': its hand's servo reached its max_offset ("
        << 1e3 * servo->spec().settings.max_offset_m << " mm) in " << servo->saturated_periods()
        << " periods, the first at " << servo->first_saturation_s()
        << " s: the hand could not bring " << servo->spec().body_name
        << " to its target (a larger max_offset, or a script nearer what happens; docs/suturing.md, \"The drivers' sight\")";
      s.warnings.push_back(w.str());
    }
  }
}

void SceneRunner::summarize_devices(RunSummary& s) const {
  if (extra_devices_.empty()) return;
  for (std::size_t i = 0; i < loop_->num_devices(); ++i) {
    DeviceRunSummary d;
    const hal::InstrumentDevice& dev = i == 0 ? device_ : *extra_devices_[i - 1];
    d.name = dev.config().name;
    d.feedback_force_max_n = device_tally_[i].force_max;
    d.feedback_torque_max_nm = device_tally_[i].torque_max;
    d.torque_periods = device_tally_[i].torque_periods;
    d.invalid_periods = device_tally_[i].invalid_periods;
    d.rejected_samples = static_cast<std::int64_t>(dev.counters().values_rejected);
    d.rejected_causes = rejection_causes(dev.counters());
    if (const hal::DeviceReport r = loop_->device(i).report(); r.managed) {
      d.lifecycle = hal::to_string(r.lifecycle);
      d.faults = static_cast<std::int64_t>(r.latches);
    }
    if (const PlantMotion* plant = instrument(i).plant()) {
      d.closed_loop = true;
      d.handle_force_max_n = plant->figures().handle_force_max_n;
      d.hand_separation_max_mm = plant->figures().hand_separation_max_mm;
      d.device_port_energy_j = plant->figures().port_energy_j;
    }
    s.device_lines.push_back(format_device_line(d));
    s.devices.push_back(std::move(d));
  }
}

RunSummary SceneRunner::summary() const {
  RunSummary s = acc_;
  summarize_periods(s);
  s.tracking_error_free_rms_mm = s.free_steps ? std::sqrt(free_sq_ / static_cast<double>(s.free_steps)) * 1e3 : 0.0;
  s.soft_start_s = scene_->device.soft_start_s;
  // On a real bus or a replayed log the device is not this process's: what moves it is unknown.
  if (real_bus_ || log_bus_ || igtl_) s.device_loop = "external";
  if (const PlantMotion* plant = instrument_.plant()) {
    const PlantFigures& f = plant->figures();
    s.device_loop = "closed";
    s.closed_loop = true;
    s.handle_force_max_n = f.handle_force_max_n;
    s.device_port_energy_j = f.port_energy_j;
    s.device_port_energy_min_j = f.port_energy_min_j;
    s.device_port_energy_min_time_s = f.port_energy_min_time_s;
    s.hand_separation_max_mm = f.hand_separation_max_mm;
    s.limit_cycle_detected = f.limit_cycle.detected();
    s.limit_cycle_amplitude_mm = f.limit_cycle.amplitude_m() * 1e3;
    s.limit_cycle_hz = f.limit_cycle.frequency_hz();
    s.limit_cycle_time_s = f.limit_cycle.time_s();
    if (s.limit_cycle_detected) {
      std::ostringstream os;
      os << std::setprecision(3) << "the device's handle went into a limit cycle at "
         << s.limit_cycle_time_s << " s (" << s.limit_cycle_amplitude_mm << " mm at "
         << s.limit_cycle_hz << " Hz): the haptic loop is not stable with this plant and "
         << "feedback (numen info: the passivity lint; docs/device_plant.md)";
      s.warnings.push_back(os.str());
    }
  }
  // The output's conditioning through the device face (hal::Device::conditioning()).
  const hal::OutputConditioning out = loop_->device().conditioning();
  if (out.torque != nullptr) s.soft_start_ramps = static_cast<std::int64_t>(out.torque->soft_starts);
  if (const hal::PassivityController* pc = out.passivity) {
    s.passivity_controller = pc->num_axes() > 0;
    s.passivity_acting_periods = static_cast<std::int64_t>(pc->counters().acting_periods);
    s.passivity_dissipated_j = pc->counters().dissipated_j;
  }
  // A run that ends inside the start-up: the periods after its last minimum are the god-object's.
  if (in_startup_)
    s.tool_penetration_max_mm = std::max(s.tool_penetration_max_mm, startup_window_max_ * 1e3);
  if (s.startup_steps > 0) {
    const core::Model& model = scene_->model;
    std::string what = "an obstacle";
    if (startup_obstacle_ >= 0)
      what = "obstacle '" + model.obstacles[static_cast<std::size_t>(startup_obstacle_)].name + "'";
    else if (startup_other_body_ >= 0)
      what = "body '" + model.bodies[static_cast<std::size_t>(startup_other_body_)].name + "'";
    std::ostringstream os;
    os << std::fixed << std::setprecision(1) << "the tool started inside " << what << ", "
       << s.startup_tool_penetration_mm << " mm deep (the god-object is spawned where the hand "
       << "is): the " << s.startup_steps << " start-up steps (" << std::setprecision(3)
       << static_cast<double>(s.startup_steps) * model.dt
       << " s) that pushed it out are reported apart, not in the god-object penetration max";
    s.warnings.push_back(os.str());
  }
  for (std::size_t i = 0; i < extra_devices_.size() && i < device_startup_.size(); ++i) {
    const DeviceStartup& u = device_startup_[i];
    if (u.steps == 0) continue;
    const core::Model& model = scene_->model;
    std::string what = "an obstacle";
    if (u.obstacle >= 0)
      what = "obstacle '" + model.obstacles[static_cast<std::size_t>(u.obstacle)].name + "'";
    else if (u.other_body >= 0)
      what = "body '" + model.bodies[static_cast<std::size_t>(u.other_body)].name + "'";
    std::ostringstream os;
    os << std::fixed << std::setprecision(1) << "device '" << extra_devices_[i]->config().name
       << "': the tool started inside " << what << ", " << u.first_mm
       << " mm deep (the god-object is spawned where the hand is): the " << u.steps
       << " start-up steps (" << std::setprecision(3) << static_cast<double>(u.steps) * model.dt
       << " s) pushed it out";
    s.warnings.push_back(os.str());
  }
  if (live_start_mm_ >= 0.0 && (live_start_mm_ > 1.0 || live_start_deg_ > 1.0)) {
    std::ostringstream os;
    os << std::fixed << std::setprecision(1) << "the live input's first sample (period "
       << startup_from_ - 1 << ") put the tool " << live_start_mm_ << " mm and " << live_start_deg_
       << " deg from the scene's start: it was brought there, the start-up "
       << "and the divergence bounds taken from there (docs/safety.md \"A live input's start\")";
    s.warnings.push_back(os.str());
  }
  s.stale_longest_s = static_cast<double>(stale_longest_) * scene_->model.dt;
  s.stale_longest_from_s = static_cast<double>(stale_longest_from_) * scene_->model.dt;
  const platform::RejoinTally& rejoin = loop_->rejoins(0);
  s.stale_rejoins = static_cast<std::int64_t>(rejoin.rejoins);
  s.stale_rejoin_gap_mm = rejoin.gap_max_m * 1e3;
  s.stale_rejoin_gap_deg = rejoin.gap_max_rad * 180.0 / std::numbers::pi;
  if (s.stale_stretches > 0) {
    std::ostringstream os;
    os << std::fixed << std::setprecision(3) << "the device's samples went stale "
       << s.stale_stretches << " time(s), " << s.stale_periods
       << " periods in all (the input stalled, or sent nothing for longer than max_sample_age): "
       << "the longest stretch " << s.stale_longest_s << " s (" << stale_longest_
       << " periods) from t = " << s.stale_longest_from_s << " s";
    if (s.stale_rejoins > 0)
      os << std::setprecision(1) << "; " << s.stale_rejoins
         << " time(s) they came back, the target was brought to the resumed pose over the soft "
            "start (the largest gap "
         << s.stale_rejoin_gap_mm << " mm and " << s.stale_rejoin_gap_deg
         << " deg) and the feedback ramped in again (docs/safety.md \"A stalled input\")";
    s.warnings.push_back(os.str());
  }
  s.rejected_samples = static_cast<std::int64_t>(device_.counters().values_rejected);
  s.rejected_causes = rejection_causes(device_.counters());
  s.contact_clamped_steps = data_.contact_clamped_steps;
  s.net_crossed_steps = data_.net_crossed_steps;
  if (first_inversion_net_ >= 0)
    s.net_first_inversion_net = scene_->model.nets[static_cast<std::size_t>(first_inversion_net_)].name;
  if (s.net_inverted_tetrahedra_max > 0) {
    std::ostringstream os;
    os << std::fixed << std::setprecision(3) << "organ '" << s.net_first_inversion_net
       << "': its net turned tetrahedra inside out, the first at " << s.net_first_inversion_s
       << " s, up to " << s.net_inverted_tetrahedra_max
       << " at once: its springs do not resist it, and the force there is no longer the tissue's "
          "(a finer net, a larger load_patch_radius or a lighter load; docs/tissue.md, \"Inversion\")";
    s.warnings.push_back(os.str());
  }
  s.crossed_contact_steps = data_.crossed_contact_steps;
  s.pass_throughs = data_.pass_throughs;
  if (s.pass_throughs > 0) {
    std::ostringstream os;
    os << std::fixed << std::setprecision(3) << s.pass_throughs
       << " sphere pair(s) of two bodies went through each other, the first at "
       << s.first_pass_through_s
       << " s: faster than the contacts can hold (docs/dynamics.md, \"Crossing\")";
    s.warnings.push_back(os.str());
  }
  summarize_grasps(scene_->model, data_, s);
  summarize_threads(scene_->model, data_, s);
  summarize_needles(s);
  summarize_devices(s);
  summarize_servos(s);
  summarize_task(*scene_, data_, s);
  multirate_.summarize(s);
  if (real_bus_) {
    s.port = port_->counters();
    s.transport = describe_transport_counters(*real_bus_);
    s.bus_state = hal::to_string(port_->state());
    s.loop = loop_->statistics().summary();
  }
  s.read_errors = static_cast<std::int64_t>(loop_->counters().read_errors);
  s.sync_write_failures = static_cast<std::int64_t>(loop_->counters().sync_write_failures);
  s.command_failures = static_cast<std::int64_t>(loop_->counters().command_failures);
  {
    const hal::DeviceCounters& d = device_.counters();
    s.frames_unknown_id = static_cast<std::int64_t>(d.frames_unknown_id);
    s.error_frames = static_cast<std::int64_t>(d.frames_error);
    s.frames_rejected = static_cast<std::int64_t>(d.frames_wrong_length + d.frames_not_data);
    s.encoder_frames_fd = static_cast<std::int64_t>(d.frames_fd);
    s.encoder_frames_remote = static_cast<std::int64_t>(d.frames_remote);
    s.encoder_frames_wrong_length = static_cast<std::int64_t>(d.frames_wrong_length);
    s.values_out_of_range = static_cast<std::int64_t>(d.rejected_out_of_range);
    s.values_jump = static_cast<std::int64_t>(d.rejected_jump);
    s.frames_rejected += static_cast<std::int64_t>(loop_->device().report().malformed_drive_frames);
  }
  if (trace_writer_) {
    const platform::TraceWriterCounters c = trace_writer_->counters();
    s.trace_pushed = static_cast<std::int64_t>(c.queued);
    s.trace_dropped = static_cast<std::int64_t>(c.dropped);
    s.trace_written = static_cast<std::int64_t>(c.written);
    s.trace_io_errors = static_cast<std::int64_t>(c.io_errors);
  }
  if (view_) view_->summarize(s);
  summarize_divergence(divergence_, scene_->model, s);
  if (igtl_) igtl_->summarize(s);
  if (log_bus_) {
    s.bus_frames_replayed = static_cast<std::int64_t>(log_bus_->log_counters().replayed);
    s.bus_log_records = static_cast<std::int64_t>(log_stats_.records);
    s.bus_log_lost_frames = static_cast<std::int64_t>(log_stats_.dropped_frames);
    s.bus_log_out_of_order = static_cast<std::int64_t>(log_stats_.out_of_order);
    if (log_stats_.dropped_frames > 0)
      s.warnings.push_back("the replayed log says its recording lost " +
                           std::to_string(log_stats_.dropped_frames) + " frames (" +
                           std::to_string(log_stats_.drop_notes) + " DROPCOUNT notes)");
    // An offline run waits for the reader (nothing to say); a paced one does not.
    const std::uint64_t behind = log_bus_->log_counters().reader_behind;
    if (!log_bus_->waits_for_reader() && behind > 0)
      s.warnings.push_back("the log's reader thread fell behind the paced replay " +
                           std::to_string(behind) + " times: frames due then came late");
    if (const std::string error = log_bus_->reader_error(); !error.empty())
      s.warnings.push_back("the replay ended early: " + error);
  }
  if (recorder_) {
    s.bus_frames_recorded = static_cast<std::int64_t>(recorder_->recording_counters().recorded);
    s.bus_record_dropped = static_cast<std::int64_t>(recorder_->recording_counters().dropped);
    const hal::CandumpWriterCounters w = writer_->counters();
    s.bus_record_written = static_cast<std::int64_t>(w.written);
    s.bus_record_io_errors = static_cast<std::int64_t>(w.io_errors);
    s.bus_record_format_errors = static_cast<std::int64_t>(w.format_errors);
  }
  if (const hal::DeviceReport d = loop_->device().report(); d.managed) {
    const hal::DeviceNotes notes = loop_->device().notes();
    const hal::StartupStatus& st = d.startup;
    s.startup = hal::to_string(st.phase);
    if (st.phase == hal::StartupPhase::kFailed)
      s.startup += " (node " + std::to_string(st.missing_node) + ")";
    if (st.configuration_failed) s.startup += ": " + notes.configuration_error;
    if (st.phase == hal::StartupPhase::kOperational || st.attempts > 1)
      s.periods_to_operational = static_cast<std::int64_t>(st.done_period);
    s.periods_to_active = loop_->first_active_period();
    s.periods_to_torque = loop_->first_torque_period();
    s.lifecycle = hal::to_string(d.lifecycle);
    s.faults = static_cast<std::int64_t>(d.latches);
    s.fault_records = static_cast<std::int64_t>(d.fault_records);
    if (has_first_fault_) {
      s.first_fault = hal::to_string(first_fault_.cause);
      s.first_fault_id = first_fault_.id;
      s.first_fault_value = first_fault_.value;
      s.first_fault_time_s = static_cast<double>(first_fault_.time_ns) * 1e-9;
      s.first_fault_period = static_cast<std::int64_t>(first_fault_.period);
    }
    s.emcys = static_cast<std::int64_t>(d.emcys);
    s.emcy_faults = static_cast<std::int64_t>(d.emcy_faults);
    s.configured_nodes = static_cast<std::int64_t>(d.configured_nodes);
    if (d.sdo_polled) {
      s.sdo_reads = static_cast<std::int64_t>(d.sdo_reads);
      s.sdo_read_errors = static_cast<std::int64_t>(d.sdo_read_errors);
    }
    s.emcy_messages = notes.emcy_messages;
    s.heartbeat_losses += static_cast<std::int64_t>(d.heartbeat_losses);
    s.drive_states = notes.drive_states;
  }
  return s;
}

}  // namespace numen::sim
