/// @file run.cpp
/// The fixed-step run of a scene on a simulated bus.

#include "numen/sim/run.hpp"

#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <span>
#include <sstream>
#include <stdexcept>

#include "numen/core/collision.hpp"
#include "numen/core/data.hpp"
#include "numen/core/features.hpp"
#include "numen/core/net_collision.hpp"
#include "numen/core/step.hpp"
#include "numen/hal/device/instrument_device.hpp"
#include "numen/hal/canopen/emcy.hpp"
#include "numen/hal/canopen/heartbeat.hpp"
#include "numen/hal/transport/sim_bus.hpp"
#include "numen/platform/control_loop.hpp"
#include "numen/platform/monotonic_clock.hpp"
#include "numen/platform/periodic_timer.hpp"
#include "numen/sim/admittance_run.hpp"
#include "numen/sim/simulated_instrument.hpp"
#include "numen/sim/input_error.hpp"
#include "numen/sim/run_verdict.hpp"
#include "numen/sim/trace.hpp"
#include "numen/sim/trace_columns.hpp"
#include "numen/sim/view_output.hpp"

namespace numen::sim {
namespace {

/// Deepest contact (m) involving `body` among data's contacts; 0 if none.
/// `count` receives their number, `deepest_index` the index of the deepest (unchanged if none).
double deepest_contact_of(const core::Data& data, int body, int* count = nullptr,
                          int* deepest_index = nullptr) {
  double deepest = 0.0;
  int n = 0;
  for (int i = 0; i < data.num_contacts; ++i) {
    const core::Contact& c = data.contacts[static_cast<std::size_t>(i)];
    if (c.body_a == body || c.body_b == body) {
      if (c.depth > deepest && deepest_index) *deepest_index = i;
      deepest = std::max(deepest, c.depth);
      ++n;
    }
  }
  if (count) *count = n;
  return deepest;
}

/// Deepest node contact (m) of the nets whose rigid component belongs to
/// articulation `tree`; 0 if none. `count` receives their number.
double deepest_node_contact_of_tree(const core::Model& model, const core::Data& data, int tree,
                                    int* count) {
  double deepest = 0.0;
  int n = 0;
  for (int i = 0; i < data.num_node_contacts; ++i) {
    const core::NodeContact& c = data.node_contacts[static_cast<std::size_t>(i)];
    const int net = model.node_net[static_cast<std::size_t>(c.node)];
    const int body = model.nets[static_cast<std::size_t>(net)].body;
    if (model.articulation.body_tree[static_cast<std::size_t>(body)] != tree) continue;
    deepest = std::max(deepest, c.depth);
    ++n;
  }
  if (count) *count = n;
  return deepest;
}

/// Puts the nodes of the nets whose rigid component belongs to articulation
/// `tree` at their rest positions on that body's pose in `ghost` (the
/// undeformed tool where the hand is).
void place_tool_nets_at_rest(const core::Model& model, core::Data& ghost, int tree) {
  for (const core::NetModel& net : model.nets) {
    if (model.articulation.body_tree[static_cast<std::size_t>(net.body)] != tree) continue;
    const core::BodyState& b = ghost.bodies[static_cast<std::size_t>(net.body)];
    for (int i = net.node_begin; i < net.node_begin + net.node_count; ++i) {
      const auto n = static_cast<std::size_t>(i);
      ghost.nodes[n].position = b.position + b.orientation * model.node_rest[n];
      ghost.nodes[n].velocity.setZero();
    }
  }
}

}  // namespace

DurationSummary summarize_ns(const platform::LatencyHistogram& h) {
  DurationSummary d;
  d.median = static_cast<double>(h.quantile(0.5)) * 1e-3;
  d.p99 = static_cast<double>(h.quantile(0.99)) * 1e-3;
  d.p999 = static_cast<double>(h.quantile(0.999)) * 1e-3;
  d.max = static_cast<double>(h.max()) * 1e-3;
  d.mean = h.mean() * 1e-3;
  return d;
}

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
  if (v.net >= 0)
    d.subject = "net \"" + model.nets[static_cast<std::size_t>(v.net)].name + "\"";
  else if (v.body >= 0)
    d.subject = "body \"" + model.bodies[static_cast<std::size_t>(v.body)].name + "\"";
  d.value = v.value;
  d.limit = v.limit;
  d.time_s = v.time_s;
  d.period = v.period;
}

std::vector<std::string> apply_run_realtime(const platform::RealtimeSettings& rt) {
  if (!platform::any_step_requested(rt)) return {};
  return platform::describe(platform::apply_realtime(rt));  // throws only if strict
}

namespace {

/// The LogBus of a "log:FILE" spec, or nullptr for any other bus; `stats` gets what the loader
/// counted. The log is streamed from disk (memory does not grow with it); a paced run
/// (`realtime`) never waits for the reader thread, an offline run does. A log that the loader
/// refuses (located error) or whose records hold no frame the controller reads (another
/// device's ids) is input rejected: InputError naming the file.
std::unique_ptr<hal::LogBus> make_log_bus(const Scene& scene, const BusSpec& spec, bool realtime,
                                          hal::CandumpLoadStats& stats) {
  if (spec.kind != BusKind::kLog) return nullptr;
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

}  // namespace

platform::ControlLoopSettings control_loop_settings(bool paced, std::uint32_t overrun_limit) noexcept {
  platform::ControlLoopSettings s;
  s.supervise_overruns = paced && overrun_limit > 0;
  if (overrun_limit > 0) s.overrun_limit = overrun_limit;
  return s;
}

hal::CandumpWriterSettings recorder_settings(bool paced) noexcept {
  hal::CandumpWriterSettings s;
  s.full_queue = paced ? hal::FullQueuePolicy::kDrop : hal::FullQueuePolicy::kWait;
  return s;
}

SceneRunner::SceneRunner(const Scene& scene, std::size_t trace_capacity, const BusChoice& bus,
                         bool realtime, std::uint32_t overrun_limit)
    : scene_(&scene),
      spec_(parse_bus_spec(bus.spec)),
      bus_(scene.bus),
      real_bus_(spec_.real() ? open_real_bus(spec_, controller_filters(scene.device)) : nullptr),
      log_bus_(make_log_bus(scene, spec_, realtime, log_stats_)),
      writer_(bus.record_path.empty()
                  ? nullptr
                  : std::make_unique<hal::CandumpWriter>(
                        bus.record_path, recorder_settings(realtime || spec_.real()))),
      recorder_(writer_ ? std::make_unique<hal::RecordingBus>(
                              real_bus_  ? *real_bus_
                              : log_bus_ ? static_cast<hal::Bus&>(*log_bus_)
                                         : bus_.controller(),
                              *writer_, spec_.kind == BusKind::kCan ? spec_.target : "sim0")
                        : nullptr),
      port_(recorder_   ? static_cast<hal::Bus*>(recorder_.get())
            : real_bus_ ? real_bus_.get()
            : log_bus_  ? static_cast<hal::Bus*>(log_bus_.get())
                        : static_cast<hal::Bus*>(&bus_.controller())),
      instrument_(scene.device, scene.trajectory),
      device_(scene.device),
      data_(core::make_data(scene.model)),
      ghost_(core::make_data(scene.model)),
      loop_(scene.model, data_, *port_, device_, scene.binding,
            control_loop_settings(realtime || spec_.real(), overrun_limit)),
      multirate_(scene),
      period_ns_(static_cast<std::int64_t>(std::llround(scene.model.dt * 1e9))),
      phase_ns_(static_cast<std::int64_t>(std::llround(scene.compute_phase_s * 1e9))),
      startup_settle_periods_(
          std::max<std::int64_t>(1, std::llround(kStartupSettle / scene.model.dt))),
      divergence_(scene.model, data_) {
  if (multirate_.enabled()) loop_.set_step_function(&SceneRunner::step_multirate, this);
  trace_.reserve(trace_capacity);
  if (writer_) writer_->start();
  acc_.bus = bus.spec;
  describe_scene(scene, acc_);
  acc_.managed = loop_.managed();
  acc_.real_bus = spec_.real();
}

void SceneRunner::stream_trace(const std::string& path) {
  std::vector<std::string> axis_names;
  for (const hal::AxisConfig& a : scene_->device.axes) axis_names.push_back(a.name);
  trace_writer_ = std::make_unique<platform::TraceWriter>(
      path, trace_column_names(trace_stream_columns(), std::span(axis_names)));
  trace_writer_->start();
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

void SceneRunner::stream_view(const std::string& record_path,
                              std::vector<platform::StateFrameSink*> sinks, double rate_hz,
                              bool wait) {
  view_ = std::make_unique<ViewOutput>(*scene_, record_path, std::move(sinks), rate_hz, wait);
}

void SceneRunner::period(std::int64_t deadline_mono_ns, std::int64_t woke_mono_ns) noexcept {
  const std::int64_t t = k_ * period_ns_;
  apply_due_events(t);
  const platform::PeriodReport& report = exchange(t, deadline_mono_ns, woke_mono_ns);
  ++k_;
  // ---- measurements (outside the timed step) ----
  multirate_.view(data_);  // a multirate run: both loops as one single-rate Data
  count_period(report);
  const PeriodContacts contacts = measure_contacts();
  track_free_space(contacts);
  track_startup(contacts);
  accumulate_step_figures(report, contacts);
  record(report, contacts);
  if (divergence_.observe(scene_->model, data_, k_ - 1, static_cast<double>(t) * 1e-9))
    loop_.shutdown();  // zero torque from the next write on; the run stops after this period
  if (view_)
    view_->publish(data_, report,
                          std::span<const double>(loop_.impedance().sent_torques().torque.data(),
                                                  static_cast<std::size_t>(loop_.impedance().sent_torques().torque.size())),
                          {static_cast<std::uint64_t>(k_ - 1), contacts.tool_pen, contacts.target_pen});
}

void SceneRunner::step_multirate(void* runner) noexcept {
  SceneRunner& r = *static_cast<SceneRunner*>(runner);
  r.multirate_.step(r.data_);
}

void SceneRunner::start_scene_thread(const platform::SceneThreadSettings& settings) {
  multirate_.start_scene_thread(settings);
}

void SceneRunner::apply_due_events(std::int64_t t_ns) noexcept {
  while (next_event_ < scene_->events.size() &&
         scene_->events[next_event_].time_s * 1e9 <= static_cast<double>(t_ns) + 0.5) {
    core::set_attached_body(scene_->model, data_, scene_->events[next_event_].body);
    ++next_event_;
  }
}

const platform::PeriodReport& SceneRunner::exchange(std::int64_t t, std::int64_t deadline_mono_ns,
                                                    std::int64_t woke_mono_ns) noexcept {
  if (real_bus_) {  // bus time = CLOCK_MONOTONIC; the device answers in another process
    const std::int64_t now = platform::monotonic_now_ns();
    loop_.begin_period(now, deadline_mono_ns, woke_mono_ns);
    const std::int64_t read_at = (deadline_mono_ns >= 0 ? deadline_mono_ns : now) + phase_ns_;
    const timespec ts{static_cast<time_t>(read_at / 1'000'000'000),
                      static_cast<long>(read_at % 1'000'000'000)};
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
    }
    return loop_.end_period(platform::monotonic_now_ns());
  }
  if (log_bus_) {  // the recorded instrument's frames arrive at their logged times
    log_bus_->set_time_ns(t);
    loop_.begin_period(t, deadline_mono_ns, woke_mono_ns);
    log_bus_->set_time_ns(t + phase_ns_);
    return loop_.end_period(t + phase_ns_);
  }
  bus_.set_time_ns(t);
  loop_.begin_period(t, deadline_mono_ns, woke_mono_ns);
  bus_.set_time_ns(t + scene_->bus.latency_ns);
  instrument_.poll(bus_.device(), t + scene_->bus.latency_ns);  // encoders latch at SYNC and answer
  bus_.set_time_ns(t + phase_ns_);
  return loop_.end_period(t + phase_ns_);
}

void SceneRunner::count_period(const platform::PeriodReport& report) noexcept {
  RunSummary& s = acc_;
  if (report.frames_read > 0) s.last_device_frame_period = k_ - 1;
  if (last_torque_ && !report.torque_commanded) s.last_torque_stop_period = k_ - 1;
  last_torque_ = report.torque_commanded;
  if (port_->state() != hal::BusState::kOk || report.command_status == hal::IoStatus::kError)
    ++s.bus_error_periods;
  if (!report.sample_valid) ++s.invalid_periods;
  if (!report.torque_commanded) ++s.zero_torque_periods;
  if (report.entered_safe_stop && !has_first_fault_ && loop_.supervisor() != nullptr &&
      loop_.supervisor()->first_fault() != nullptr) {
    first_fault_ = *loop_.supervisor()->first_fault();
    has_first_fault_ = true;
  }
}

SceneRunner::PeriodContacts SceneRunner::measure_contacts() noexcept {
  const core::Model& model = scene_->model;
  PeriodContacts c;
  const int held = data_.attached_body;
  if (held < 0) return c;
  c.held = true;
  const auto h = static_cast<std::size_t>(held);
  // The tool: every body of the held body's articulation (the held body
  // alone for a rigid tool). The target: the same bodies placed where the
  // device puts them (held body at data.target, the others at their own
  // targets, Eq. 6).
  const int tree = model.articulation.body_tree[h];
  ghost_.bodies = data_.bodies;  // same size: no allocation
  ghost_.bodies[h].position = data_.target.position;
  ghost_.bodies[h].orientation = data_.target.orientation;
  for (std::size_t b = 0; b < data_.bodies.size(); ++b) {
    const core::BodyTarget& bt = data_.body_targets[b];
    if (b == h || !bt.enabled) continue;
    ghost_.bodies[b].position = bt.pose.position;
    ghost_.bodies[b].orientation = bt.pose.orientation;
  }
  core::detect_contacts(model, ghost_);
  for (int b = 0; b < model.num_bodies(); ++b) {
    if (model.articulation.body_tree[static_cast<std::size_t>(b)] != tree) continue;
    int n = 0, m = 0, deepest = -1;
    const double pen = deepest_contact_of(data_, b, &n, &deepest);
    if (pen > c.tool_pen) {
      c.deepest_tool_contact = deepest;
      c.deepest_tool_body = b;
    }
    c.tool_pen = std::max(c.tool_pen, pen);
    c.tool_contacts += n;
    c.target_pen = std::max(c.target_pen, deepest_contact_of(ghost_, b, &m));
    c.target_contacts += m;
  }
  if (model.num_nets() > 0) {
    // The tool's nets: as deformed (god-object), in their rest shape on the
    // target poses (the hand).
    ghost_.nodes = data_.nodes;  // same size: no allocation
    place_tool_nets_at_rest(model, ghost_, tree);
    if constexpr (core::kWithDeformable) core::detect_node_contacts(model, ghost_);
    int n = 0;
    c.tool_pen = std::max(c.tool_pen, deepest_node_contact_of_tree(model, data_, tree, &n));
    c.tool_contacts += n;
    int m = 0;
    c.target_pen = std::max(c.target_pen, deepest_node_contact_of_tree(model, ghost_, tree, &m));
    c.target_contacts += m;
  }
  return c;
}

void SceneRunner::track_free_space(const PeriodContacts& c) noexcept {
  // Free space: neither the tool nor the hand touches anything. A step where the tool has
  // come off a surface while the hand is still inside the obstacle is not free-space
  // tracking: the error there is the god-object's constraint, not its lag.
  if (!c.held || c.tool_contacts != 0 || c.target_contacts != 0) return;
  const double e =
      (data_.bodies[static_cast<std::size_t>(data_.attached_body)].position - data_.target.position)
          .norm();
  free_sq_ += e * e;
  acc_.tracking_error_free_max_mm = std::max(acc_.tracking_error_free_max_mm, e * 1e3);
  ++acc_.free_steps;
}

void SceneRunner::track_startup(const PeriodContacts& c) noexcept {
  RunSummary& s = acc_;
  // Start-up (RunSummary): the tool was spawned where the hand is, inside an obstacle, and the
  // contact forces push it out. It runs from the first period through the last period that
  // lowers the tool's penetration to a new minimum before kStartupSettle without one (or a
  // period without contact); the periods after that minimum count as the god-object's again.
  if (k_ == 1 && c.tool_contacts > 0) {
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
      s.startup_steps = k_;
    } else {
      startup_window_max_ = std::max(startup_window_max_, c.tool_pen);
      if (c.tool_contacts == 0 || k_ - s.startup_steps >= startup_settle_periods_) {
        in_startup_ = false;
        s.tool_penetration_max_mm = std::max(s.tool_penetration_max_mm, startup_window_max_ * 1e3);
      }
    }
  }
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
  const hal::AxisVector& tau = loop_.impedance().sent_torques().torque;
  if (tau.size() > 0) s.axis_torque_max = std::max(s.axis_torque_max, tau.cwiseAbs().maxCoeff());
  const int held = data_.attached_body;
  const int held_tree = held >= 0 ? model.articulation.body_tree[static_cast<std::size_t>(held)] : -1;
  for (int b = 0; b < model.num_bodies(); ++b)
    if (model.articulation.body_tree[static_cast<std::size_t>(b)] != held_tree)
      s.free_body_speed_max_mps = std::max(
          s.free_body_speed_max_mps, data_.bodies[static_cast<std::size_t>(b)].linear_velocity.norm());
  s.contacts_max = std::max(s.contacts_max, data_.num_contacts);
  s.solver_iterations_max = std::max(s.solver_iterations_max, data_.solver_iterations);
  solver_iterations_sum_ += data_.solver_iterations;
  // A NaN residual (a rejected solve) is kept, not dropped by std::max.
  if (std::isnan(data_.solver_residual) || data_.solver_residual > s.solver_residual_max)
    if (!std::isnan(s.solver_residual_max)) s.solver_residual_max = data_.solver_residual;
  if (data_.status & core::kSolverNotConverged) ++s.solver_not_converged_steps;
  s.node_contacts_max = std::max(s.node_contacts_max, data_.num_node_contacts);
  for (const core::NetOutput& net : data_.nets) {
    s.net_penetration_max_mm = std::max(s.net_penetration_max_mm, net.max_penetration * 1e3);
    s.net_tie_stretch_max_mm = std::max(s.net_tie_stretch_max_mm, net.max_tie_stretch * 1e3);
    s.net_strain_max = std::max(s.net_strain_max, net.max_strain);
    s.net_node_speed_max_mps = std::max(s.net_node_speed_max_mps, net.max_node_speed);
  }
}

void SceneRunner::record(const platform::PeriodReport& report, const PeriodContacts& c) noexcept {
  TraceRecord rec = make_trace_record(data_, data_.attached_body, c.tool_contacts, c.tool_pen,
                                      c.target_pen, report, loop_.impedance().sent_torques().torque);
  if (const hal::CanopenMaster* m = loop_.canopen()) {
    const std::uint64_t received = m->emcy_log().counters().received;
    if (received > emcys_traced_) {
      rec.emcys = static_cast<int>(std::min<std::uint64_t>(received - emcys_traced_, 1'000'000));
      if (const hal::EmcyRecord* e = m->emcy_log().newest()) {
        rec.emcy_node = e->message.node_id;
        rec.emcy_code = e->message.error_code;
      }
      emcys_traced_ = received;
    }
  }
  if (trace_writer_) {
    platform::TraceRecord r;
    r.period = static_cast<std::uint64_t>(k_ - 1);
    r.time_ns = report.deadline_ns;
    r.flags = (report.sample_valid ? 1u : 0u) | (report.torque_commanded ? 2u : 0u) |
              (report.overrun ? 4u : 0u);
    trace_column_values(trace_stream_columns(), StreamedPeriod{rec, report},
                        static_cast<int>(scene_->device.axes.size()), std::span(r.values));
    trace_writer_->push(r);
  }
  trace_.push(rec);
}

RunSummary SceneRunner::summary() const {
  RunSummary s = acc_;
  s.steps = k_;
  s.sim_time_s = static_cast<double>(k_) * scene_->model.dt;
  s.step_time_us = summarize_ns(loop_.step_time());
  s.solver_iterations_mean =
      k_ > 0 ? static_cast<double>(solver_iterations_sum_) / static_cast<double>(k_) : 0.0;
  s.tracking_error_free_rms_mm = s.free_steps ? std::sqrt(free_sq_ / static_cast<double>(s.free_steps)) * 1e3 : 0.0;
  s.soft_start_s = scene_->device.soft_start_s;
  s.soft_start_ramps = static_cast<std::int64_t>(loop_.impedance().torque_counters().soft_starts);
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
  s.rejected_samples = static_cast<std::int64_t>(device_.counters().values_rejected);
  s.contact_overflow = data_.contact_overflow_steps;
  s.contact_clamped_steps = data_.contact_clamped_steps;
  s.nonfinite_steps = data_.nonfinite_steps;
  multirate_.summarize(s);
  s.nan_detected = data_.nonfinite_steps > 0;
  for (const auto& b : data_.bodies)
    s.nan_detected = s.nan_detected || !b.position.allFinite() || !b.orientation.coeffs().allFinite();
  for (const auto& n : data_.nodes)
    s.nan_detected = s.nan_detected || !n.position.allFinite() || !n.velocity.allFinite();
  for (auto dir : {hal::SimBus::Direction::kControllerToDevice, hal::SimBus::Direction::kDeviceToController}) {
    s.bus_frames_dropped += static_cast<std::int64_t>(bus_.link_counters(dir).dropped);
    s.bus_frames_corrupted += static_cast<std::int64_t>(bus_.link_counters(dir).corrupted());
  }
  if (real_bus_) {
    s.port = port_->counters();
    s.transport = describe_transport_counters(*real_bus_);
    s.bus_state = hal::to_string(port_->state());
    s.loop = loop_.statistics().summary();
  }
  s.read_errors = static_cast<std::int64_t>(loop_.counters().read_errors);
  s.sync_write_failures = static_cast<std::int64_t>(loop_.counters().sync_write_failures);
  s.command_failures = static_cast<std::int64_t>(loop_.counters().command_failures);
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
    if (const hal::CanopenMaster* m = loop_.canopen())
      s.frames_rejected += static_cast<std::int64_t>(m->counters().drive_tpdos_malformed);
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
  if (const hal::CanopenMaster* m = loop_.canopen()) {
    const hal::SafetySupervisor& sup = *loop_.supervisor();
    const hal::StartupReport& st = m->startup();
    s.startup = hal::to_string(st.phase);
    if (st.phase == hal::StartupPhase::kFailed)
      s.startup += " (node " + std::to_string(st.missing_node) + ")";
    if (st.configuration_failed) s.startup += ": " + m->configuration_error();
    if (st.phase == hal::StartupPhase::kOperational || st.attempts > 1)
      s.periods_to_operational = static_cast<std::int64_t>(st.done_period);
    s.periods_to_active = loop_.first_active_period();
    s.periods_to_torque = loop_.first_torque_period();
    s.lifecycle = hal::to_string(sup.state());
    s.faults = static_cast<std::int64_t>(sup.counters().latches);
    s.fault_records = static_cast<std::int64_t>(sup.counters().records);
    if (has_first_fault_) {
      s.first_fault = hal::to_string(first_fault_.cause);
      s.first_fault_id = first_fault_.id;
      s.first_fault_value = first_fault_.value;
      s.first_fault_time_s = static_cast<double>(first_fault_.time_ns) * 1e-9;
      s.first_fault_period = static_cast<std::int64_t>(first_fault_.period);
    }
    s.emcys = static_cast<std::int64_t>(m->emcy_log().counters().received);
    s.emcy_faults = static_cast<std::int64_t>(m->emcy_log().counters().faults);
    s.configured_nodes = static_cast<std::int64_t>(m->counters().configurations);
    if (const hal::SdoPoller* p = m->sdo_poller()) {
      s.sdo_reads = static_cast<std::int64_t>(p->counters().completed);
      s.sdo_read_errors = static_cast<std::int64_t>(p->counters().aborted + p->counters().timeouts);
    }
    for (std::size_t i = 0; i < m->emcy_log().size(); ++i) {
      const hal::EmcyRecord& r = *m->emcy_log().at(i);
      // A drive node's codes by the CiA 402 table (its device profile), others by CiA 301's.
      std::uint16_t profile = 301;
      for (std::size_t d = 0; d < m->num_drives(); ++d) {
        const auto axis = static_cast<std::size_t>(m->drive_axis(d));
        if (scene_->device.canopen.axes[axis].node_id == r.message.node_id) profile = 402;
      }
      char line[200];
      std::snprintf(line, sizeof line, "node %d at %.3f s: 0x%04X %s (register 0x%02X)",
                    r.message.node_id, static_cast<double>(r.timestamp_ns) * 1e-9,
                    r.message.error_code, hal::describe_emcy_code(r.message.error_code, profile),
                    r.message.error_register);
      s.emcy_messages.push_back(line);
    }
    for (const hal::HeartbeatConsumer& c : m->heartbeats())
      s.heartbeat_losses += static_cast<std::int64_t>(c.counters().losses);
    for (std::size_t i = 0; i < m->num_drives(); ++i) {
      const int axis = m->drive_axis(i);
      s.drive_states.push_back(scene_->device.axes[static_cast<std::size_t>(axis)].name + ": " +
                               hal::to_string(m->drive_outputs()[i].state));
    }
  }
  return s;
}

void SceneRunner::finish() {
  multirate_.stop();
  if (writer_) writer_->close();              // the log and the trace appear under their
  if (trace_writer_) trace_writer_->close();  // paths, a failed close counted in the summary
  if (view_) view_->finish();
}

std::size_t in_memory_trace_capacity(std::int64_t periods) {
  // One record per period kept until the run ends: a long --duration with --trace.
  const double bytes = static_cast<double>(periods) * static_cast<double>(sizeof(TraceRecord));
  if (bytes > static_cast<double>(kMaxInMemoryTraceBytes))
    throw InputError("", 0, 0, "--trace",
                     "a simulated run keeps one trace record (" +
                         std::to_string(sizeof(TraceRecord)) + " bytes) per period until it "
                         "ends: " + std::to_string(periods) + " periods need " +
                         std::to_string(static_cast<long long>(bytes / (1 << 20))) +
                         " MiB, more than the " + std::to_string(kMaxInMemoryTraceBytes >> 20) +
                         " MiB a trace may take; shorten --duration");
  return static_cast<std::size_t>(std::max<std::int64_t>(periods, 0));
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

/// Refuses options that this run would not apply (InputError naming the option): nothing a
/// user asks for is dropped without a word.
void check_run_options(const Scene& scene, const RunOptions& options) {
  const double duration = options.duration_s >= 0.0 ? options.duration_s : scene.duration_s;
  if (std::llround(duration / scene.model.dt) < 1)
    throw InputError("", 0, 0, "--duration",
                     format_input_number(duration) + " s is less than half a period (dt = " +
                         format_input_number(scene.model.dt) + " s): the run would have none");
  // An admittance scene's real bus is refused by its runner (run_admittance_scene).
  const bool paced =
      options.realtime || (!scene.admittance && parse_bus_spec(options.bus.spec).real());
  if (options.view_speed > 0.0 && paced)
    throw InputError("", 0, 0, "--speed",
                     "paces an offline run; this run is paced at real time already (--realtime "
                     "or a real bus)");
  compute_phase_override_ns(scene, options);  // --phase at or above dt
  // A simulated run's trace is kept in memory until it ends (a real bus streams it).
  if (!options.trace_path.empty() && (scene.admittance || !parse_bus_spec(options.bus.spec).real()))
    in_memory_trace_capacity(std::llround(duration / scene.model.dt));
  const platform::SceneThreadSettings& st = options.scene_thread;
  if (st.fifo_priority == 0 && st.cpu_affinity.empty()) return;
  const std::string key = st.fifo_priority != 0 ? "--scene-rt-priority" : "--scene-cpu";
  if (!scene.multirate)
    throw InputError("", 0, 0, key,
                     "scene \"" + scene.name + "\" has no [multirate]: there is no scene thread");
  if (!paced)
    throw InputError("", 0, 0, key,
                     "an offline run steps both loops on one thread: the scene thread runs in "
                     "paced runs only (--realtime or a real bus)");
  if (st.fifo_priority != 0 && st.fifo_priority >= options.rt.fifo_priority)
    throw InputError("", 0, 0, "--scene-rt-priority",
                     std::to_string(st.fifo_priority) + " must be below the loop thread's " +
                         (options.rt.fifo_priority == 0
                              ? std::string("(--rt-priority not given: not real-time)")
                              : "--rt-priority " + std::to_string(options.rt.fifo_priority)) +
                         ": the scene thread would pre-empt the device loop");
}

/// Refuses an output path (--trace, --record, --record-view) that cannot be written before the
/// run (InputError, key `key`), so that a long run does not end without its file, and the
/// error names the option. Touches nothing: an existing file keeps its bytes (the writers
/// replace it only when the run closes it, hal::LineFile), a missing one is not created.
void check_output_path(const std::string& path, const std::string& key) {
  auto refuse = [&](const std::string& why) {
    throw InputError("", 0, 0, key, path + ": cannot be opened for writing (" + why + ")");
  };
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0) {
    if (S_ISDIR(st.st_mode)) refuse(std::strerror(EISDIR));
    if (::access(path.c_str(), W_OK) != 0) refuse(std::strerror(errno));
    return;
  }
  if (errno != ENOENT) refuse(std::strerror(errno));
  const std::filesystem::path parent = std::filesystem::path(path).parent_path();
  const std::string dir = parent.empty() ? "." : parent.string();
  if (::stat(dir.c_str(), &st) != 0) refuse(std::strerror(errno));
  if (!S_ISDIR(st.st_mode)) refuse(dir + " is not a directory");
  if (::access(dir.c_str(), W_OK | X_OK) != 0) refuse(dir + ": " + std::strerror(errno));
}

}  // namespace

std::int64_t compute_phase_override_ns(const Scene& scene, const RunOptions& options) {
  if (options.compute_phase_s < 0.0) return -1;
  if (!(options.compute_phase_s < scene.model.dt))
    throw InputError("", 0, 0, "--phase",
                     format_input_number(options.compute_phase_s) +
                         " s must be below the period dt = " + format_input_number(scene.model.dt) +
                         " s");
  return static_cast<std::int64_t>(std::llround(options.compute_phase_s * 1e9));
}

namespace {

RunSummary run_impedance_scene(const Scene& scene, const RunOptions& options) {
  const double duration = options.duration_s >= 0.0 ? options.duration_s : scene.duration_s;
  const auto steps = static_cast<std::int64_t>(std::llround(duration / scene.model.dt));
  const bool real = parse_bus_spec(options.bus.spec).real();
  // A real bus streams its trace through the TraceWriter; the in-memory trace is for sim runs,
  // refused before anything is allocated when it would not fit the budget.
  const std::size_t trace_capacity =
      options.trace_path.empty() || real ? 0 : in_memory_trace_capacity(steps);
  SceneRunner runner(scene, trace_capacity, options.bus, options.realtime, options.overrun_limit);
  if (const std::int64_t phase = compute_phase_override_ns(scene, options); phase >= 0)
    runner.set_compute_phase_ns(phase);
  // The writer threads and a multirate scene's scene thread are started before the real-time
  // setup pins and promotes this thread.
  if (real && !options.trace_path.empty()) runner.stream_trace(options.trace_path);
  if (options.realtime || real) runner.start_scene_thread(options.scene_thread);
  if (!options.record_view_path.empty() || !options.view_sinks.empty())
    runner.stream_view(options.record_view_path, options.view_sinks, options.view_rate_hz,
                       !(options.realtime || real));
  std::vector<std::string> rt_lines = apply_run_realtime(options.rt);
  const bool paced = options.realtime || real;
  RunLoopTally tally;
  const std::int64_t wall0 = platform::monotonic_now_ns();
  platform::PeriodicTimer timer(static_cast<std::int64_t>(std::llround(scene.model.dt * 1e9)), wall0);
  auto stop_requested = [&] {
    return options.stop != nullptr && options.stop->load(std::memory_order_relaxed);
  };
  // A live viewer of an unpaced run: one period every dt / view_speed of wall time.
  ViewPacer view_pacer(scene.model.dt, paced ? 0.0 : options.view_speed, wall0, options.stop);
  auto one_period = [&] {
    view_pacer.wait();
    if (paced) {
      const platform::Wakeup w = timer.wait_next();
      tally.woke(w);
      runner.period(w.deadline_ns, w.woke_ns);
    } else {
      runner.period();
    }
  };
  bool stopped = false;
  for (std::int64_t k = 0; k < steps && !runner.diverged(); ++k) {
    if (stop_requested()) {
      stopped = true;
      break;
    }
    if (tally.take_rearm(options.rearm, k) &&
        runner.loop().rearm() == platform::RearmResult::kAccepted)
      tally.rearm_accepted();
    one_period();
  }
  // Orderly end on a real bus: zero torque, drives disabled, a few periods for the
  // controlwords to go out (the device keeps answering SYNCs meanwhile).
  std::int64_t shutdown = 0;
  if (real) {
    runner.loop().shutdown();
    for (; shutdown < options.shutdown_periods; ++shutdown) {
      one_period();
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
  // Only the managed stack's supervisor latches on overruns (MinimalDevice::supervise ignores
  // them), and only in a paced run (an offline run has no deadlines): any other run reports
  // the policy it has, count only.
  s.overrun_limit = s.managed && paced ? options.overrun_limit : 0;
  s.realtime_setup = std::move(rt_lines);
  // The scene thread's own scheduling and CPUs (--scene-rt-priority, --scene-cpu), if asked.
  runner.multirate().describe_scene_thread(options.scene_thread, s.realtime_setup);
  s.stopped = stopped;
  s.shutdown_periods = shutdown;
  s.drives_disabled = runner.loop().drives_disabled();
  if (!options.trace_path.empty() && !real)
    write_in_memory_trace(runner.trace(), options.trace_path, s);
  return s;
}

}  // namespace

RunSummary run_scene(const Scene& scene, const RunOptions& options) {
  if (!(options.view_rate_hz > 0.0))
    throw InputError("", 0, 0, "--view-rate", "must be > 0 frames per second (got " +
                                                  format_input_number(options.view_rate_hz) + ")");
  if (!(options.view_speed >= 0.0) || !std::isfinite(options.view_speed))
    throw InputError("", 0, 0, "--speed", "must be a finite factor >= 0 (got " +
                                              format_input_number(options.view_speed) + ")");
  // Every refusal comes before any output is opened, and the output checks touch nothing: a
  // refused run leaves every file as it was (docs/inputs.md, "Outputs").
  check_run_options(scene, options);
  if (!options.trace_path.empty()) check_output_path(options.trace_path, "--trace");
  // (an admittance run refuses --record: run_admittance_scene)
  if (!options.bus.record_path.empty() && !scene.admittance)
    check_output_path(options.bus.record_path, "--record");
  if (!options.record_view_path.empty())
    check_output_path(options.record_view_path, "--record-view");
  RunSummary s = scene.admittance ? run_admittance_scene(scene, options)  // admittance_run.cpp
                                  : run_impedance_scene(scene, options);
  if (s.stopped && options.stop_signal != nullptr) s.stop_signal = options.stop_signal->load();
  RunVerdict verdict = run_verdict(s);
  s.exit_status = verdict.exit_status;
  s.exit_reasons = std::move(verdict.reasons);
  return s;
}

}  // namespace numen::sim
