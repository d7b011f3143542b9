/// @file run.cpp
/// The fixed-step run of a scene (run.hpp): SceneRunner's wiring and period, the bus it talks
/// to, the period loop of run_scene(). The period's measurements are in run_measurements.cpp,
/// the summary in run_summary.cpp, the option checks in run_options.cpp.

#include "numen/sim/run/run.hpp"

#include <time.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <numbers>
#include <cstdio>
#include <filesystem>
#include <span>
#include <stdexcept>

#include "numen/core/step.hpp"
#include "numen/hal/device/bus_filters.hpp"
#include "numen/platform/monotonic_clock.hpp"
#include "numen/sim/input/input_error.hpp"
#include "numen/sim/run/needle_summary.hpp"
#include "numen/sim/run/admittance_run.hpp"
#include "numen/sim/run/run_verdict.hpp"
#include "numen/sim/run/trace_columns.hpp"

namespace numen::sim {

void RunLoopTally::woke(const platform::Wakeup& w) noexcept {
  overruns_ += w.overrun ? 1 : 0;
  missed_ += w.missed_periods;
  wakeup_.record(w.latency_ns());
}

bool RunLoopTally::take_rearm(std::atomic<bool>* request, std::int64_t k) noexcept {
  if (request == nullptr || !request->exchange(false, std::memory_order_relaxed)) return false;
  ++rearm_requests_;
  if (rearm_first_ < 0) rearm_first_ = k;
  return true;
}

void RunLoopTally::write(RunSummary& s) const {
  s.realtime_overruns = overruns_;
  s.realtime_missed_periods = missed_;
  s.wakeup_latency_us = summarize_ns(wakeup_);
  s.rearm_requests = rearm_requests_;
  s.rearms_accepted = rearms_accepted_;
  s.rearm_first_period = rearm_first_;
}

RunRealtime apply_run_realtime(const RunOptions& options, bool paced) {
  platform::RealtimeSettings rt = options.rt;
  if (paced) rt.timer_slack_ns = options.timer_slack_ns;
  RunRealtime out;
  if (platform::any_step_requested(rt))
    out.lines = platform::describe(platform::apply_realtime(rt));  // throws only if strict
  if (paced && options.cpu_dma_latency_us >= 0) {
    out.cpu_latency = platform::CpuLatencyRequest(options.cpu_dma_latency_us);
    out.lines.push_back(platform::describe_cpu_latency(out.cpu_latency));
    if (rt.strict && out.cpu_latency.step().failed())
      throw std::runtime_error("real-time setup failed (strict):\n  " + out.lines.back());
  }
  return out;
}

platform::SceneThreadSettings paced_scene_thread(const RunOptions& options) {
  platform::SceneThreadSettings st = options.scene_thread;
  st.timer_slack_ns = options.timer_slack_ns;
  return st;
}

platform::PeriodicTimer run_timer(const RunOptions& options, double dt_s, std::int64_t start_ns) {
  platform::PeriodicTimer timer(static_cast<std::int64_t>(std::llround(dt_s * 1e9)), start_ns);
  timer.set_spin_ns(options.spin_ns);
  return timer;
}

namespace {

/// The LogBus of a "log:FILE" spec, or nullptr for any other bus; `stats` gets what the loader
/// counted. The log is streamed from disk (memory does not grow with it); a paced run
/// (`realtime`) never waits for the reader thread, an offline run does. A log that the loader
/// refuses (located error), a directory, or a log whose records hold no frame the controller
/// reads (another device's ids) is input rejected: InputError naming the file.
std::unique_ptr<hal::LogBus> make_log_bus(const Scene& scene, const BusSpec& spec, bool realtime,
                                          hal::CandumpLoadStats& stats) {
  if (spec.kind != BusKind::kLog) return nullptr;
  std::error_code ec;  // (a directory opens, then fails its first read: "FILE:1: read error")
  if (std::filesystem::is_directory(spec.target, ec))
    throw InputError(spec.target, 0, 0, "", "is a directory, not a candump log");
  hal::LogBusSettings settings;
  settings.filters = controller_filters(scene.device);
  settings.received_only = true;
  hal::LogBusStream stream;
  stream.path = spec.target;
  stream.wait_for_reader = !realtime;
  std::unique_ptr<hal::LogBus> bus;
  try {
    bus = std::make_unique<hal::LogBus>(stream, settings, &stats);
  } catch (const std::runtime_error& e) {
    throw InputError("", 0, 0, "", e.what());  // the message is "file:line:column: what"
  }
  if (bus->matching_records() == 0) {
    std::string ids;
    for (const hal::AxisConfig& a : scene.device.axes) {
      char buf[16];
      std::snprintf(buf, sizeof buf, "%s0x%03X", ids.empty() ? "" : ", ", a.encoder_cob_id);
      ids += buf;
    }
    throw InputError(spec.target, 0, 0, "",
                     std::to_string(stats.records) + " records, none that the controller reads "
                     "(received frames of the scene's encoder COB-IDs " + ids + "): nothing to replay");
  }
  return bus;
}

/// The bus spec `text` of a run of `scene` (parse_bus_spec()); a scene of several devices runs
/// on the simulated bus only (its emulated instruments share it): InputError at --bus otherwise.
BusSpec bus_spec_for(const Scene& scene, const std::string& text) {
  BusSpec spec = parse_bus_spec(text);
  if (!scene.extra_devices.empty() && spec.kind != BusKind::kSim)
    throw InputError("", 0, 0, "--bus",
                     "scene \"" + scene.name + "\" has " + std::to_string(num_devices(scene)) +
                         " devices: it runs on the simulated bus only (--bus sim)");
  return spec;
}

/// Devices 1 .. N−1 of `scene`, each its InstrumentDevice.
std::vector<std::unique_ptr<hal::InstrumentDevice>> make_extra_devices(const Scene& scene) {
  std::vector<std::unique_ptr<hal::InstrumentDevice>> out;
  for (const SceneDevice& d : scene.extra_devices)
    out.push_back(std::make_unique<hal::InstrumentDevice>(d.device));
  return out;
}

/// Devices 1 .. N−1 of `scene` emulated: each on its trajectory, closed loop with its plant and
/// hand where it has a plant.
std::vector<std::unique_ptr<SimulatedInstrument>> make_extra_instruments(const Scene& scene) {
  std::vector<std::unique_ptr<SimulatedInstrument>> out;
  for (const SceneDevice& d : scene.extra_devices)
    out.push_back(std::make_unique<SimulatedInstrument>(d.device, d.trajectory,
                                                        d.plant ? &*d.plant : nullptr, d.hand));
  return out;
}

/// The simulated bus's device side shared by the emulated instruments of a scene of several
/// devices, a port each with its frames (hal::device_filters()); null for one device.
std::unique_ptr<hal::BusShare> make_device_share(const Scene& scene, hal::SimBus& bus,
                                                 bool several) {
  if (!several) return nullptr;
  auto share = std::make_unique<hal::BusShare>(bus.device(), scene.bus.capacity);
  share->add_port(hal::device_filters(scene.device));
  for (const SceneDevice& d : scene.extra_devices) share->add_port(hal::device_filters(d.device));
  return share;
}

/// The loop's devices: device 0 on `port`, the others on it too (the rig shares it).
std::vector<platform::LoopDevice> loop_devices(
    const Scene& scene, hal::Bus& port, hal::InstrumentDevice& first,
    const std::vector<std::unique_ptr<hal::InstrumentDevice>>& extra,
    const platform::ControlLoopSettings& settings) {
  std::vector<platform::LoopDevice> out;
  out.push_back(platform::LoopDevice{&port, &first, scene.binding, settings});
  for (std::size_t i = 0; i < extra.size(); ++i)
    out.push_back(platform::LoopDevice{&port, extra[i].get(), scene.extra_devices[i].binding, settings});
  return out;
}

}  // namespace

platform::ControlLoopSettings control_loop_settings(bool paced, std::uint32_t overrun_limit) noexcept {
  platform::ControlLoopSettings s;
  s.supervise_overruns = paced && overrun_limit > 0;
  if (overrun_limit > 0) s.overrun_limit = overrun_limit;
  return s;
}

// `s` for a run whose input is `live` (a real bus, an OpenIGTLink tracker: the instrument lies
// wherever it lies, not at the recording's start): its bodies are brought to the first sample
// (docs/safety.md "A live input's start"; not with a multirate god-object: its own copy), and
// after a stall (samples stale, then valid again) its targets glide to the resumed pose and its
// feedback ramps in again (docs/safety.md "A stalled input").
platform::ControlLoopSettings with_live_start(platform::ControlLoopSettings s, bool live,
                                              const Scene& scene) noexcept {
  s.place_at_first_sample = live && !scene.multirate;
  s.rejoin_after_stale = live;
  return s;
}

hal::CandumpWriterSettings recorder_settings(bool paced) noexcept {
  hal::CandumpWriterSettings s;
  s.full_queue = paced ? hal::FullQueuePolicy::kDrop : hal::FullQueuePolicy::kWait;
  return s;
}

SceneRunner::SceneRunner(const Scene& scene, std::size_t trace_capacity, const BusChoice& bus,
                         bool realtime, std::uint32_t overrun_limit)
    : RunHarness((require_runnable(scene), scene), trace_capacity),
      spec_(bus_spec_for(scene, bus.spec)),
      real_bus_(spec_.real() ? open_real_bus(spec_, controller_filters(scene.device)) : nullptr),
      log_bus_(make_log_bus(scene, spec_, realtime, log_stats_)),
      igtl_(make_igtl_run(scene, spec_, realtime)),
      writer_(bus.record_path.empty()
                  ? nullptr
                  : std::make_unique<hal::CandumpWriter>(
                        bus.record_path, recorder_settings(realtime || spec_.real()))),
      recorder_(writer_ ? std::make_unique<hal::RecordingBus>(
                              real_bus_  ? *real_bus_
                              : log_bus_ ? static_cast<hal::Bus&>(*log_bus_)
                              : igtl_    ? igtl_->bus()
                                         : bus_.controller(),
                              *writer_, spec_.kind == BusKind::kCan ? spec_.target : "sim0")
                        : nullptr),
      port_(recorder_   ? static_cast<hal::Bus*>(recorder_.get())
            : real_bus_ ? real_bus_.get()
            : log_bus_  ? static_cast<hal::Bus*>(log_bus_.get())
            : igtl_     ? &igtl_->bus()
                        : static_cast<hal::Bus*>(&bus_.controller())),
      // The emulated device runs on the simulated bus only (a log, a tracker or a real bus
      // brings its own).
      instrument_(scene.device, scene.trajectory,
                  scene.plant && !real_bus_ && !log_bus_ && !igtl_ ? &*scene.plant : nullptr,
                  scene.hand),
      device_(scene.device),
      target_measurement_(scene.model),
      target_inputs_(make_target_inputs(scene.model)),
      extra_instruments_(make_extra_instruments(scene)),
      extra_devices_(make_extra_devices(scene)),
      device_share_(make_device_share(scene, bus_, !extra_devices_.empty())),
      startup_settle_periods_(
          std::max<std::int64_t>(1, std::llround(kStartupSettle / scene.model.dt))) {
  // The hands' sight: on the simulated bus only, where the emulated instruments are the hands
  // (refused before the loop is assembled: a throw here leaves nothing to take apart).
  for (std::size_t i = 0; i < num_devices(scene); ++i) {
    const std::optional<HandServoSpec>& spec = i == 0 ? scene.servo : scene.extra_devices[i - 1].servo;
    servos_.push_back(nullptr);
    if (!spec) continue;
    const std::string& name = i == 0 ? scene.device.name : scene.extra_devices[i - 1].device.name;
    if (real_bus_ || log_bus_ || igtl_ || (i > 0 && i > extra_instruments_.size()))
      throw InputError("", 0, 0, "--bus",
                       "device \"" + name + "\"'s hand has a servo ([device.trajectory.servo]): it "
                       "moves the emulated instrument of the simulated bus, which --bus " + bus.spec +
                       " replaces (run it on the simulated bus)");
    servos_.back() = std::make_unique<HandServo>(*spec, scene.model.dt, name);
    (i == 0 ? instrument_ : *extra_instruments_[i - 1]).set_servo(servos_.back().get());
  }
  // The loop's devices (their buses' shares, NMT masters) in the harness's rig, the loop over it.
  const platform::ControlLoopSettings settings =
      with_live_start(control_loop_settings(realtime || spec_.real(), overrun_limit),
                      spec_.real() || igtl_ != nullptr, scene);
  assemble(settings, loop_devices(scene, *port_, device_, extra_devices_, settings));
  if (multirate_.enabled() && scene.multirate) {
    ghost_every_ = std::max<std::int64_t>(1, std::llround(1e-3 / scene.model.dt));
  }
  explicit_bound_ = platform::explicitly_bound_bodies(scene.binding, scene.model.num_bodies());
  std::vector<std::string> axis_names;
  for (const hal::AxisConfig& a : scene.device.axes) axis_names.push_back(a.name);
  trace_.set_axis_names(std::move(axis_names));
  std::vector<std::string> device_names;
  for (std::size_t i = 0; i < scene.extra_devices.size() && i < extra_trace_body_.size(); ++i) {
    device_names.push_back(scene.extra_devices[i].device.name);
    extra_trace_body_[i] = extra_device_body(scene, i);
  }
  trace_.set_device_names(std::move(device_names));
  if (writer_) writer_->start();
  acc_.bus = bus.spec;
  begin_needle_figures(scene, acc_);
  acc_.managed = loop_->managed();
  acc_.real_bus = spec_.real();
}

SceneRunner::~SceneRunner() { disassemble(); }

void SceneRunner::stream_trace(const std::string& path) {
  std::vector<std::string> axis_names;
  for (const hal::AxisConfig& a : scene_->device.axes) axis_names.push_back(a.name);
  trace_writer_ = std::make_unique<platform::TraceWriter>(
      path, trace_column_names(TraceKind::kStream, axis_names));
  trace_writer_->start();
}

void SceneRunner::period(std::int64_t deadline_mono_ns, std::int64_t woke_mono_ns) noexcept {
  const std::int64_t t = k_ * period_ns_;
  apply_due_events(t);
  const platform::PeriodReport& report = exchange(t, deadline_mono_ns, woke_mono_ns);
  ++k_;
  // ---- measurements (outside the timed step) ----
  if (loop_->placed_period(0) == k_ - 1) note_live_start();
  count_period(report);
  if (!extra_devices_.empty()) tally_devices();

  const PeriodContacts contacts = measure_contacts();
  track_free_space(contacts);
  track_startup(contacts);
  accumulate_step_figures(report, contacts);
  record(report, contacts);
  // A multirate run's organs change only at the scene samples (MultirateRun::finish()).
  bool diverged = divergence_.observe(scene_->model, data_, k_ - 1, static_cast<double>(t) * 1e-9,
                                      multirate_.enabled() && !multirate_.took_model());
  for (std::size_t i = 0; i <= extra_instruments_.size(); ++i)  // every device's plant
    if (const PlantMotion* plant = instrument(i).plant(); plant && plant->figures().diverged)
      diverged = divergence_.latch_external("device plant", plant->figures().diverged_axis,
                                            plant->figures().diverged_speed,
                                            plant->figures().diverged_speed_limit, k_ - 1,
                                            static_cast<double>(t) * 1e-9) ||
                 diverged;
  if (diverged)
    loop_->shutdown();  // zero torque from the next write on; the run stops after this period
  // The hands that look: what they see of this step moves them from the next SYNC on.
  for (const std::unique_ptr<HandServo>& servo : servos_)
    if (servo) servo->observe(static_cast<double>(t) * 1e-9, data_);
  if (view_) publish_view(report, contacts);
}

void SceneRunner::publish_view(const platform::PeriodReport& report,
                               const PeriodContacts& contacts) noexcept {
  const auto sent = [&](std::size_t i) { return loop_->device(i).output().torque; };
  // The loop's other devices: each its report and torques (one bus: device 0's state).
  std::array<platform::FrameDeviceInput, platform::kMaxLoopDevices> extra{};
  const std::size_t n = std::min(loop_->num_devices(), extra.size() + 1) - 1;
  const bool bus_down = port_->state() != hal::BusState::kOk;
  for (std::size_t i = 0; i < n; ++i)
    extra[i] = platform::FrameDeviceInput{&loop_->last_report(i + 1), sent(i + 1), bus_down};
  view_->publish(data_, report, sent(0), view_figures(contacts),
                 std::span<const platform::FrameDeviceInput>(extra.data(), n));
}

void SceneRunner::note_live_start() noexcept {
  // A live input's first sample brought the tool where the instrument lies (the loop's
  // place_at_first_sample, before this period's step): the start-up and the divergence bounds
  // begin here, as at a first period.
  startup_from_ = k_;
  in_startup_ = false;
  acc_.startup_steps = 0;
  divergence_.restart();
  const int held = data_.held_body;
  if (held < 0) return;
  const core::Pose& start = scene_->model.bodies[static_cast<std::size_t>(held)].initial_pose;
  live_start_mm_ = (data_.target.position - start.position).norm() * 1e3;
  live_start_deg_ =
      data_.target.orientation.angularDistance(start.orientation) * 180.0 / std::numbers::pi;
}

void SceneRunner::tally_devices() noexcept {
  for (std::size_t i = 0; i < loop_->num_devices(); ++i) {
    const platform::PeriodReport& r = loop_->last_report(i);
    DeviceTally& t = device_tally_[i];
    t.force_max = std::max(t.force_max, r.feedback.force.norm());
    t.torque_max = std::max(t.torque_max, r.feedback.torque.norm());
    t.torque_periods += r.torque_commanded ? 1 : 0;
    t.invalid_periods += r.sample_valid ? 0 : 1;
  }
}

void SceneRunner::start_target_thread(const std::vector<int>& avoid_cpus) {
  target_thread_ = std::make_unique<TargetMeasurementThread>(scene_->model);
  target_thread_pinned_ = target_thread_->start(avoid_cpus);
}

void SceneRunner::describe_target_thread(std::vector<std::string>& lines) const {
  if (!target_thread_) return;
  lines.push_back(std::string("target measurement: on its own thread") +
                  (target_thread_pinned_ ? " off the loop's and the scene thread's CPUs, " : ", ") +
                  std::to_string(target_thread_->measured()) + " of " +
                  std::to_string(target_thread_->submitted()) +
                  " submitted targets measured (the newest is measured; docs/outputs.md)");
}

void SceneRunner::apply_due_events(std::int64_t t_ns) noexcept {
  while (next_event_ < scene_->events.size() &&
         scene_->events[next_event_].time_s * 1e9 <= static_cast<double>(t_ns) + 0.5) {
    core::set_held_body(scene_->model, data_, scene_->events[next_event_].body);
    ++next_event_;
  }
}

const platform::PeriodReport& SceneRunner::exchange(std::int64_t t, std::int64_t deadline_mono_ns,
                                                    std::int64_t woke_mono_ns) noexcept {
  if (real_bus_) {  // bus time = CLOCK_MONOTONIC; the device answers in another process
    const std::int64_t now = platform::monotonic_now_ns();
    loop_->begin_period(now, deadline_mono_ns, woke_mono_ns);
    const std::int64_t read_at = (deadline_mono_ns >= 0 ? deadline_mono_ns : now) + phase_ns_;
    const timespec ts{static_cast<time_t>(read_at / 1'000'000'000),
                      static_cast<long>(read_at % 1'000'000'000)};
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
    }
    return loop_->end_period(platform::monotonic_now_ns());
  }
  if (log_bus_) {  // the recorded instrument's frames arrive at their logged times
    log_bus_->set_time_ns(t);
    loop_->begin_period(t, deadline_mono_ns, woke_mono_ns);
    log_bus_->set_time_ns(t + phase_ns_);
    return loop_->end_period(t + phase_ns_);
  }
  if (igtl_) {  // the tracker's poses: taken at the SYNC, stamped with their messages' times
    igtl_->set_time_ns(t);
    loop_->begin_period(t, deadline_mono_ns, woke_mono_ns);
    igtl_->set_time_ns(t + phase_ns_);
    return loop_->end_period(t + phase_ns_);
  }
  bus_.set_time_ns(t);
  loop_->begin_period(t, deadline_mono_ns, woke_mono_ns);
  bus_.set_time_ns(t + scene_->bus.latency_ns);
  // The encoders latch at SYNC and answer; several devices: each on its port of the device side.
  if (device_share_) {
    instrument_.poll(device_share_->port(0), t + scene_->bus.latency_ns);
    for (std::size_t i = 0; i < extra_instruments_.size(); ++i)
      extra_instruments_[i]->poll(device_share_->port(i + 1), t + scene_->bus.latency_ns);
  } else {
    instrument_.poll(bus_.device(), t + scene_->bus.latency_ns);
  }
  bus_.set_time_ns(t + phase_ns_);
  return loop_->end_period(t + phase_ns_);
}

void SceneRunner::count_zero_torque(const platform::PeriodReport& report,
                                    RunSummary& s) const noexcept {
  ++s.zero_torque_periods;
  const hal::Device& device = loop_->device();
  const hal::DeviceOutput& sent = device.output();
  if (report.fault_cause != hal::FaultCause::kNone)
    ++s.zero_torque_safe_state;
  else if (device.shutting_down())
    ++s.zero_torque_shutdown;
  else if (s.managed && report.lifecycle != hal::LifecycleState::kActive)
    ++s.zero_torque_startup;
  else if (sent.gated)
    ++s.zero_torque_gated;
  else if (sent.ramp < 1.0)
    ++s.zero_torque_soft_start;
  else
    ++s.zero_torque_below_resolution;
}

void SceneRunner::count_period(const platform::PeriodReport& report) noexcept {
  RunSummary& s = acc_;
  if (report.frames_read > 0) s.last_device_frame_period = k_ - 1;
  if (last_torque_ && !report.torque_commanded) s.last_torque_stop_period = k_ - 1;
  last_torque_ = report.torque_commanded;
  if (port_->state() != hal::BusState::kOk || report.command_status == hal::IoStatus::kError)
    ++s.bus_error_periods;
  if (!report.sample_valid) ++s.invalid_periods;
  tally_stale((report.sample_faults & hal::SampleFault::kStale) != 0);
  if (!report.torque_commanded) count_zero_torque(report, s);
  if (report.entered_safe_stop && !has_first_fault_ && loop_->managed() &&
      loop_->device().first_fault() != nullptr) {
    first_fault_ = *loop_->device().first_fault();
    has_first_fault_ = true;
  }
}

void SceneRunner::tally_stale(bool stale) noexcept {
  if (stale) {
    if (stale_run_++ == 0) {
      stale_from_ = k_ - 1;
      ++acc_.stale_stretches;
    }
    ++acc_.stale_periods;
    if (stale_run_ > stale_longest_) {
      stale_longest_ = stale_run_;
      stale_longest_from_ = stale_from_;
    }
    return;
  }
  stale_run_ = 0;
}

void SceneRunner::record(const platform::PeriodReport& report, const PeriodContacts& c) noexcept {
  TraceRecord rec = make_trace_record(data_, data_.held_body, c.tool_contacts, c.tool_pen,
                                      c.target_pen, report, loop_->device().output().torque);
  if (const PlantMotion* plant = instrument_.plant()) {
    rec.hand_penetration_mm = c.hand_pen * 1e3;
    rec.handle_force_n = plant->figures().handle_force_n;
    rec.device_port_energy_j = plant->figures().port_energy_j;
  }
  rec.num_extra_devices = static_cast<int>(std::min(extra_devices_.size(), extra_trace_body_.size()));
  for (int i = 0; i < rec.num_extra_devices; ++i) {
    const platform::PeriodReport& r = loop_->last_report(static_cast<std::size_t>(i) + 1);
    DeviceTraceRecord& t = rec.devices[static_cast<std::size_t>(i)];
    const auto single = [](const core::Vec3& v) {
      return std::array<float, 3>{static_cast<float>(v.x()), static_cast<float>(v.y()), static_cast<float>(v.z())};
    };
    t.sample_valid = r.sample_valid;
    t.feedback_force = single(r.feedback.force);
    if (const int b = extra_trace_body_[static_cast<std::size_t>(i)]; b >= 0) {
      t.target = single(data_.body_targets[static_cast<std::size_t>(b)].pose.position);
      t.tool = single(data_.bodies[static_cast<std::size_t>(b)].position);
    }
  }
  if (const hal::DeviceReport d = loop_->device().report(); d.managed) {
    if (d.emcys > emcys_traced_) {
      rec.emcys = static_cast<int>(std::min<std::uint64_t>(d.emcys - emcys_traced_, 1'000'000));
      if (d.has_emcy) {
        rec.emcy_node = d.newest_emcy_node;
        rec.emcy_code = d.newest_emcy_code;
      }
      emcys_traced_ = d.emcys;
    }
  }
  if (trace_writer_) {
    platform::TraceRecord r;
    r.period = static_cast<std::uint64_t>(k_ - 1);
    r.time_ns = report.deadline_ns;
    r.flags = (report.sample_valid ? 1u : 0u) | (report.torque_commanded ? 2u : 0u) |
              (report.overrun ? 4u : 0u);
    trace_column_values(TraceKind::kStream, rec,
                        static_cast<int>(scene_->device.axes.size()), std::span(r.values));
    trace_writer_->push(r);
  }
  trace_.push(rec);
}

platform::StateFrameFigures SceneRunner::view_figures(const PeriodContacts& c) const noexcept {
  platform::StateFrameFigures f{static_cast<std::uint64_t>(k_ - 1), c.tool_pen, c.target_pen,
                                c.hand_pen, 0.0, 0.0};
  f.bus_down = port_->state() != hal::BusState::kOk;  // a tracker's connection lost, a bus off
  if (const PlantMotion* plant = instrument_.plant()) {
    f.handle_force = plant->figures().handle_force_n;
    f.device_port_energy = plant->figures().port_energy_j;
  }
  return f;
}

void SceneRunner::finish() {
  multirate_.stop();
  if (target_thread_) target_thread_->stop();
  if (igtl_) igtl_->finish();
  if (writer_) writer_->close();              // the log and the trace appear under their
  if (trace_writer_) trace_writer_->close();  // paths, a failed close counted in the summary
  if (view_) view_->finish();
}

void write_in_memory_trace(const Trace& trace, const std::string& path, RunSummary& s) {
  const auto records = static_cast<std::int64_t>(trace.records().size());
  s.trace_pushed = records;
  s.trace_dropped = static_cast<std::int64_t>(trace.dropped());
  try {
    trace.write_csv(path);
    s.trace_written = records;
  } catch (const std::exception& e) {  // disk full, the file removed or made read-only meanwhile
    s.trace_written = 0;
    s.trace_io_errors = 1;
    s.warnings.push_back(std::string("--trace: ") + e.what());
  }
}

namespace {

/// The harness of `scene` for a run with `options` of `steps` periods: an AdmittanceRunner for an
/// admittance scene (refusing a bus other than the simulated one and a bus recording, before
/// anything is allocated: its emulated device lives on the scene's SimBus), else a SceneRunner.
/// `real`: the controller's port is a real bus (it streams its trace; the in-memory trace is
/// for sim runs, refused when it would not fit the budget).
std::unique_ptr<RunHarness> make_harness(const Scene& scene, const RunOptions& options,
                                         std::int64_t steps, bool real) {
  if (scene.admittance) {
    if (options.bus.spec != "sim")
      throw InputError("", 0, 0, "--bus",
                       "'" + options.bus.spec + "': the admittance scene '" + scene.name +
                           "' runs its emulated device on the simulated bus only (use --bus sim)");
    if (!options.bus.record_path.empty())
      throw InputError("", 0, 0, "--record",
                       "the admittance scene '" + scene.name +
                           "' does not record its simulated bus (use --trace or --record-view)");
  }
  const std::size_t trace_capacity =
      options.trace_path.empty() || real ? 0 : in_memory_trace_capacity(steps);
  // Overruns latch only where there is a deadline to miss (a paced run).
  if (scene.admittance)
    return std::make_unique<AdmittanceRunner>(scene, trace_capacity,
                                              options.realtime ? options.overrun_limit : 0);
  return std::make_unique<SceneRunner>(scene, trace_capacity, options.bus, options.realtime,
                                       options.overrun_limit);
}

/// The one period loop of a run of either kind of device (RunHarness).
RunSummary run_harness(const Scene& scene, const RunOptions& options) {
  const double duration = options.duration_s >= 0.0 ? options.duration_s : scene.duration_s;
  const auto steps = static_cast<std::int64_t>(std::llround(duration / scene.model.dt));
  const bool real = !scene.admittance && parse_bus_spec(options.bus.spec).real();
  const std::unique_ptr<RunHarness> harness = make_harness(scene, options, steps, real);
  RunHarness& runner = *harness;
  // The impedance instruments' harness: its streamed trace and target thread (none for an
  // admittance device, whose hand's depth is measured inline).
  auto* const scene_runner = dynamic_cast<SceneRunner*>(harness.get());
  if (const std::int64_t phase = compute_phase_override_ns(scene, options); phase >= 0)
    runner.set_compute_phase_ns(phase);
  // The writer threads and a multirate scene's scene thread are started before the real-time
  // setup pins and promotes this thread.
  if (real && !options.trace_path.empty()) scene_runner->stream_trace(options.trace_path);
  const bool paced = options.realtime || real;
  if (paced) {
    runner.start_scene_thread(paced_scene_thread(options));
    if (scene_runner != nullptr) {
      std::vector<int> busy = options.rt.cpu_affinity;  // the measurement keeps off these
      busy.insert(busy.end(), options.scene_thread.cpu_affinity.begin(),
                  options.scene_thread.cpu_affinity.end());
      scene_runner->start_target_thread(busy);
    }
  }
  if (!options.record_view_path.empty() || !options.view_sinks.empty())
    runner.stream_view(options.record_view_path, options.view_sinks, options.view_rate_hz,
                       !paced);
  RunRealtime rt_setup = apply_run_realtime(options, paced);  // held until the run ends
  RunLoopTally tally;
  const std::int64_t wall0 = platform::monotonic_now_ns();
  platform::PeriodicTimer timer = run_timer(options, scene.model.dt, wall0);
  auto stop_requested = [&] {
    return options.stop != nullptr && options.stop->load(std::memory_order_relaxed);
  };
  // A live viewer of an unpaced run: one period every dt / view_speed of wall time.
  ViewPacer view_pacer(scene.model.dt, paced ? 0.0 : options.view_speed, wall0, options.stop);
  // One period; false (and no period) when a stop request came while a paced run waited for
  // its deadline (`hear_stop`: heard within platform::kStopSliceNs whatever dt is).
  auto one_period = [&](bool hear_stop) {
    view_pacer.wait();
    if (paced) {
      const platform::Wakeup w = hear_stop
                                     ? timer.wait_next(options.stop, platform::kStopSliceNs)
                                     : timer.wait_next();
      if (w.stopped) return false;
      tally.woke(w);
      runner.period(w.deadline_ns, w.woke_ns);
    } else {
      runner.period();
    }
    return true;
  };
  bool stopped = false;
  for (std::int64_t k = 0; k < steps && !runner.diverged(); ++k) {
    if (stop_requested()) {
      stopped = true;  // SIGINT / SIGTERM / SIGHUP (docs/inputs.md, "Signals")
      break;
    }
    // SIGUSR1 (docs/safety.md, "How the control loop uses it")
    if (tally.take_rearm(options.rearm, k) &&
        runner.loop().rearm() == platform::RearmResult::kAccepted)
      tally.rearm_accepted();
    if (!one_period(true)) {
      stopped = true;
      break;
    }
  }
  // Orderly end on a real bus: zero torque, drives disabled, a few periods for the
  // controlwords to go out (the device keeps answering SYNCs meanwhile).
  std::int64_t shutdown = 0;
  if (real) {
    runner.loop().shutdown();
    for (; shutdown < options.shutdown_periods; ++shutdown) {
      one_period(false);  // the stop was heard: these periods are paced to the end
      if (runner.loop().drives_disabled() && shutdown >= 2) {
        ++shutdown;
        break;
      }
    }
  }
  runner.finish();
  RunSummary s = runner.summary();
  s.wall_time_s = static_cast<double>(platform::monotonic_now_ns() - wall0) * 1e-9;
  tally.write(s);
  // Only a managed stack's supervisor (and the admittance device's) latches on overruns
  // (MinimalDevice::supervise ignores them), and only in a paced run (an offline run has no
  // deadlines): any other run reports the policy it has, count only.
  s.overrun_limit = (scene.admittance || s.managed) && paced ? options.overrun_limit : 0;
  s.realtime_setup = std::move(rt_setup.lines);
  // The scene thread's own scheduling and CPUs (--scene-rt-priority, --scene-cpu), if asked.
  runner.multirate().describe_scene_thread(paced_scene_thread(options), s.realtime_setup);
  if (scene_runner != nullptr) scene_runner->describe_target_thread(s.realtime_setup);
  s.stopped = stopped;
  if (scene_runner != nullptr) {
    s.shutdown_periods = shutdown;
    s.drives_disabled = runner.loop().drives_disabled();
  }
  if (!options.trace_path.empty() && !real)
    write_in_memory_trace(runner.trace(), options.trace_path, s);
  return s;
}

}  // namespace

RunSummary run_scene(const Scene& scene, const RunOptions& options) {
  require_runnable(scene);  // a scene loaded to be stepped by its caller may lack both
  check_run_options(scene, options);  // every refusal before any output is opened
  RunSummary s = run_harness(scene, options);
  if (s.stopped && options.stop_signal != nullptr) s.stop_signal = options.stop_signal->load();
  judge_run(s);
  return s;
}

int extra_device_body(const Scene& scene, std::size_t i) noexcept {
  const SceneDevice& d = scene.extra_devices[i];
  for (const platform::LinkBinding& l : d.binding.links)
    if (l.link == 0 && l.body >= 0) return l.body;
  for (const platform::LinkBinding& l : d.binding.links)
    if (l.body >= 0 && scene.model.bodies[static_cast<std::size_t>(l.body)].sphere_count > 0) return l.body;
  return -1;
}

}  // namespace numen::sim
