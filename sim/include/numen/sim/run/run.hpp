#pragma once
/// @file run.hpp
/// `numen run`: run_scene()'s one period loop (as fast as possible, or paced to wall-clock
/// time) over the run harness (RunHarness, run_harness.hpp), and SceneRunner, the harness
/// wired for impedance instruments: the SimulatedInstruments on the simulated bus's device
/// side (or a real bus, a log replay, a tracker), their InstrumentDevices in the harness's
/// DeviceRig, the measurements of the summary and the trace. The options of a run are in
/// run_options.hpp, what it measured in run_summary.hpp.

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "numen/core/data.hpp"
#include "numen/hal/device/instrument_device.hpp"
#include "numen/sim/device/hand_servo.hpp"
#include "numen/hal/transport/bus_recorder.hpp"
#include "numen/hal/transport/bus_share.hpp"
#include "numen/hal/transport/log_bus.hpp"
#include "numen/hal/transport/sim_bus.hpp"
#include "numen/platform/control_loop.hpp"
#include "numen/platform/device_rig.hpp"
#include "numen/platform/latency_histogram.hpp"
#include "numen/platform/multirate_threads.hpp"
#include "numen/platform/periodic_timer.hpp"
#include "numen/platform/realtime_setup.hpp"
#include "numen/platform/state_stream.hpp"
#include "numen/platform/trace_queue.hpp"
#include "numen/sim/device/simulated_instrument.hpp"
#include "numen/sim/input/bus_spec.hpp"
#include "numen/sim/run/divergence.hpp"
#include "numen/sim/run/igtl_run.hpp"
#include "numen/sim/run/multirate_run.hpp"
#include "numen/sim/run/run_harness.hpp"
#include "numen/sim/run/run_options.hpp"
#include "numen/sim/run/run_summary.hpp"
#include "numen/sim/run/target_measurement.hpp"
#include "numen/sim/run/trace.hpp"
#include "numen/sim/scene/scene.hpp"
#include "numen/sim/view/view_output.hpp"

namespace numen::sim {

/// Start-up of a run whose tool starts inside an obstacle (RunSummary): it ends when the
/// tool's penetration has set no new minimum for this long (s).
inline constexpr double kStartupSettle = 0.02;

/// What a run's period loop counts around its harness (run_scene()'s one loop, for both kinds
/// of device): a paced loop's wake-ups and the operator's re-arm
/// requests (RunOptions::rearm, SIGUSR1). Not used inside the real-time period.
class RunLoopTally {
 public:
  /// A paced period's wake-up (platform::PeriodicTimer::wait_next): its overrun, the periods
  /// it skipped and its latency.
  void woke(const platform::Wakeup& w) noexcept;
  /// Takes the re-arm request pending before period `k` (clears `request`); true if there was
  /// one: the caller re-arms its loop and calls rearm_accepted() if that was accepted.
  bool take_rearm(std::atomic<bool>* request, std::int64_t k) noexcept;
  void rearm_accepted() noexcept { ++rearms_accepted_; }
  /// Writes RunSummary::realtime_overruns, realtime_missed_periods, wakeup_latency_us and the
  /// rearm_* figures.
  void write(RunSummary& s) const;

 private:
  std::int64_t overruns_ = 0, missed_ = 0;
  platform::LatencyHistogram wakeup_;
  std::int64_t rearm_requests_ = 0, rearms_accepted_ = 0, rearm_first_ = -1;
};

/// A run's real-time setup (apply_run_realtime()): what its loop thread got, and what the run
/// holds for as long as this lives (keep it until the last period).
struct RunRealtime {
  /// The PM QoS CPU latency request of a paced run (RunOptions::cpu_dma_latency_us); not held
  /// in an offline run or when the run asks none. Released with this object.
  platform::CpuLatencyRequest cpu_latency;
  /// The setup's lines (RunSummary::realtime_setup): apply_realtime()'s, then the CPU latency
  /// request's ("cpu latency: ..."); empty when nothing was asked.
  std::vector<std::string> lines;
};

/// The real-time setup of a run's loop thread: apply_realtime() of options.rt described line by
/// line, or nothing if it asks for no step. A `paced` run also sets the thread's timer slack to
/// options.timer_slack_ns whatever its scheduling (docs/realtime.md "Timer slack") and holds
/// the CPU latency request of options.cpu_dma_latency_us (docs/realtime.md "CPU latency"); an
/// offline run leaves both. Throws as apply_realtime() (a failed step only if strict; with
/// strict, a failed CPU latency request too).
RunRealtime apply_run_realtime(const RunOptions& options, bool paced);

/// The scene thread's settings of a paced run: options.scene_thread with the timer slack of
/// options.timer_slack_ns.
platform::SceneThreadSettings paced_scene_thread(const RunOptions& options);

/// The period timer of a paced run of period `dt_s` starting at `start_ns`, with the spin of
/// options.spin_ns (platform::PeriodicTimer::set_spin_ns).
platform::PeriodicTimer run_timer(const RunOptions& options, double dt_s, std::int64_t start_ns);

/// Writes what `monitor` saw into s.divergence (the breach's body or net named from `model`).
/// Setup thread (allocates the names), after the run.
void summarize_divergence(const DivergenceMonitor& monitor, const core::Model& model,
                          RunSummary& s);

/// The ControlLoop settings of a run: `paced` (real bus, or RunOptions::realtime) periods have
/// deadlines, so consecutive overruns are supervised and `overrun_limit` of them latch the safe
/// state; `overrun_limit` 0 or an unpaced run: overruns are only counted (LoopStatistics). The
/// other settings are ControlLoopSettings' defaults (encoder timeout 3 periods, docs/safety.md).
platform::ControlLoopSettings control_loop_settings(bool paced, std::uint32_t overrun_limit) noexcept;

/// The bus recorder's (BusChoice::record_path) writer settings of a run: a `paced` run drops
/// records its writer thread has no room for (hal::FullQueuePolicy::kDrop, counted in
/// RunSummary::bus_record_dropped; the loop never waits for the disk); an offline run has no
/// deadline and waits for room (kWait), so its log is complete however starved the writer
/// thread is. The other settings are CandumpWriterSettings' defaults.
hal::CandumpWriterSettings recorder_settings(bool paced) noexcept;

/// Writes the in-memory trace of a simulated run to `path` after the run and accounts for it in
/// `s` (trace_pushed, trace_dropped, trace_written, trace_io_errors): a file that cannot be
/// written is not thrown but counted (1 I/O error, 0 written) with the error as a warning, so
/// the run keeps its summary and its verdict reports the lost records (exit status 5).
void write_in_memory_trace(const Trace& trace, const std::string& path, RunSummary& s);

/// The run harness (RunHarness: data, simulated bus, rig and loop, multirate, trace, view,
/// divergence) wired for impedance instruments: the simulated instrument on the bus's device
/// port (or the real bus, log or tracker of --bus), its InstrumentDevice (and those of a scene
/// of several devices) in the harness's DeviceRig, the bus recorder and streamed trace, and
/// the impedance measurements (target, free space, start-up, per device). The constructor
/// allocates everything; period() never allocates, throws or locks (tested), so the same loop
/// can be driven by a test, a benchmark or `numen run`.
class SceneRunner final : public RunHarness {
 public:
  /// `scene` must outlive the runner; each of its devices (Scene::extra_devices beside the
  /// first) is emulated on the simulated bus and driven by the one ControlLoop (a LoopDevice
  /// each); a scene of several devices runs on the simulated bus only (InputError at --bus
  /// otherwise). `trace_capacity` records are reserved.
  /// `bus` chooses the controller's bus; a log is loaded and a recording
  /// opened (its writer thread started) here. Throws std::invalid_argument
  /// for an unknown bus spec, InputError for a scene without [trajectory] or [device]
  /// (require_runnable()), std::runtime_error ("file:line:column: what")
  /// for a log that cannot be read or a recording that cannot be written.
  /// `realtime`: the periods are paced to CLOCK_MONOTONIC (run_scene with
  /// RunOptions::realtime), so overruns are supervised (control_loop_settings()) with
  /// `overrun_limit` (RunOptions::overrun_limit; 0: counted, never latched).
  explicit SceneRunner(const Scene& scene, std::size_t trace_capacity = 0,
                       const BusChoice& bus = {}, bool realtime = false,
                       std::uint32_t overrun_limit = 3);
  /// Ends the loop and its rig before the devices and buses they refer to.
  ~SceneRunner() override;

  /// Runs control period k (bus time k·dt), in named parts: apply_due_events() (tool
  /// switching), exchange() (SYNC and the managed stack's NMT / heartbeat, the instrument's
  /// answer, the controller's read–check–supervise–step–write in platform::ControlLoop), then
  /// the measurements outside the timed step — count_period(), measure_contacts(),
  /// track_free_space(), track_startup(), accumulate_step_figures() — and record() (one trace
  /// record). `deadline_mono_ns` / `woke_mono_ns`: the paced
  /// timer's wake-up (CLOCK_MONOTONIC), -1 when not paced.
  ///
  /// Real bus (can:, serial:): bus time is CLOCK_MONOTONIC. The SYNC goes out at once
  /// (stamped now), then the thread sleeps until deadline + compute phase (clock_nanosleep,
  /// TIMER_ABSTIME; `deadline_mono_ns` < 0: from now) while the device answers, then
  /// end_period reads, checks, steps and writes the torques at that time. This sleep is the
  /// only blocking call; nothing allocates, throws or locks.
  void period(std::int64_t deadline_mono_ns = -1,
              std::int64_t woke_mono_ns = -1) noexcept override;
  /// True when the controller's port is a real bus (can:, serial:).
  bool real_bus() const noexcept { return spec_.real(); }
  /// The controller's port (the real bus, the log replay, the recorder, or the SimBus port).
  const hal::Bus& port() const noexcept { return *port_; }
  /// Streams one record per period into a CSV through platform::TraceWriter (lock-free queue,
  /// writer thread started here; setup only). Columns: the streamed ones of trace_columns()
  /// (TraceKind::kStream: frames_read, sample_valid, torque_commanded, lifecycle,
  /// target_{x,y,z}, tool_{x,y,z}, feedback_f{x,y,z}, axis_torque_<axis name> per axis,
  /// step_time_us, end_to_end_us, wakeup_latency_us, emcys, emcy_node, emcy_code); flags
  /// bit 0 sample valid, bit 1 torque commanded, bit 2 overrun. Throws like TraceWriter's
  /// constructor.
  void stream_trace(const std::string& path);
  /// The streaming trace writer (nullptr unless stream_trace() was called).
  platform::TraceWriter* trace_writer() noexcept { return trace_writer_.get(); }
  /// A paced run: measures the target (the summary's "penetration max: target", the hand's
  /// depth) on a thread of its own from now on (TargetMeasurementThread), kept off
  /// `avoid_cpus` (the loop's and the scene thread's), the loop handing over its inputs and
  /// reading the newest result, until finish(). Allocates (call before the first period).
  /// Throws std::system_error if the thread cannot start.
  void start_target_thread(const std::vector<int>& avoid_cpus);
  /// The target thread's line for the summary's real-time setup ("target measurement: …"),
  /// appended to `lines` after finish(); nothing when the target was measured inline.
  void describe_target_thread(std::vector<std::string>& lines) const;

  /// Ends the run's streams: stops the bus recorder's and the trace's writer threads, which
  /// write what is still queued and close the files (they appear under their paths), so that
  /// summary() reports what reached them.
  /// Idempotent; call it after the last period() (setup thread).
  void finish() override;

  /// The summary of the periods run so far (wall time and realtime overruns
  /// are the caller's, see run_scene).
  RunSummary summary() const override;

  const hal::InstrumentDevice& device() const noexcept { return device_; }
  const SimulatedInstrument& instrument() const noexcept { return instrument_; }
  /// The simulated instrument, for fault injection in tests.
  SimulatedInstrument& instrument() noexcept { return instrument_; }
  /// The emulated instrument of device `i` (< num_devices(*scene); 0: instrument()).
  const SimulatedInstrument& instrument(std::size_t i) const noexcept {
    return i == 0 ? instrument_ : *extra_instruments_[i - 1];
  }

 private:
  /// What measure_contacts() found after a period's step (penetrations in m).
  struct PeriodContacts {
    bool held = false;              ///< A body is held (else everything below is zero).
    double tool_pen = 0.0;          ///< Deepest contact of the tool (bodies and nets).
    double target_pen = 0.0;        ///< Deepest contact of the target (where the encoders are).
    double hand_pen = 0.0;          ///< Closed loop: of the held body at the hand's intent.
    int tool_contacts = 0;          ///< Contacts of the tool.
    int target_contacts = 0;        ///< Contacts of the target.
    int deepest_tool_contact = -1;  ///< Index of the tool's deepest rigid contact (-1: none).
    int deepest_tool_body = -1;     ///< Its tool body.
  };
  /// Holds the bodies of the tool-switching events due at bus time `t_ns`.
  void apply_due_events(std::int64_t t_ns) noexcept;
  /// The bus side of the period at bus time `t` (ns): the simulated bus and instrument, the
  /// log replay or the real bus around ControlLoop::begin_period / end_period.
  const platform::PeriodReport& exchange(std::int64_t t, std::int64_t deadline_mono_ns,
                                         std::int64_t woke_mono_ns) noexcept;
  /// Counts of the period's report: frames, torque stops, bus errors, invalid and zero-torque
  /// periods, the first latched fault.
  void count_period(const platform::PeriodReport& report) noexcept;
  /// One zero-torque period into s.zero_torque_periods and its cause's count
  /// (RunSummary::zero_torque_safe_state and the others, in their order).
  void count_zero_torque(const platform::PeriodReport& report, RunSummary& s) const noexcept;
  /// The tool's contacts (as the step found them) and the target's (measure_target(), in its
  /// periods; held between them).
  PeriodContacts measure_contacts() noexcept;
  /// The inputs of the target's measurement (target_measurement.hpp) at this period: the tool
  /// of articulation `tree` at the target and, closed loop, at the hand's intent. Never
  /// allocates (`in` sized by make_target_inputs()).
  void fill_target_inputs(int tree, TargetInputs& in) const noexcept;
  /// The free-space tracking error (RunSummary::tracking_error_free_rms_mm).
  void track_free_space(const PeriodContacts& c) noexcept;
  /// The start-up push-out and the god-object's penetration after it (RunSummary).
  void track_startup(const PeriodContacts& c) noexcept;
  /// Running maxima and sums of the step: penetrations, feedback, joints, solver, nets.
  void accumulate_step_figures(const platform::PeriodReport& report, const PeriodContacts& c) noexcept;
  /// The period's trace record: in memory (trace_) and streamed (trace_writer_).
  void record(const platform::PeriodReport& report, const PeriodContacts& c) noexcept;
  /// The state frame's figures of this period (k_ − 1): penetrations, and the closed loop's
  /// hand penetration, handle force and port energy (the target's penetration and zeros in
  /// replay, as the trace's columns).
  platform::StateFrameFigures view_figures(const PeriodContacts& c) const noexcept;
  /// The period's state frame to the view (view_): device 0's report and torques, the loop's
  /// other devices' (platform::FrameDeviceInput), the figures. Never allocates.
  void publish_view(const platform::PeriodReport& report, const PeriodContacts& c) noexcept;

  BusSpec spec_;
  std::unique_ptr<hal::Bus> real_bus_;            // --bus can:IFACE / serial:PATH
  hal::CandumpLoadStats log_stats_;               // --bus log:FILE, what the loader counted
  std::unique_ptr<hal::LogBus> log_bus_;          // --bus log:FILE
  std::unique_ptr<IgtlRun> igtl_;                 // --bus igtl: the OpenIGTLink tracker
  std::unique_ptr<hal::CandumpWriter> writer_;    // --record FILE
  std::unique_ptr<hal::RecordingBus> recorder_;   // --record FILE, around the controller port
  hal::Bus* port_;                                // what the control loop reads and writes
  SimulatedInstrument instrument_;
  std::vector<std::uint8_t> explicit_bound_;  // per body: 1 if a binding names it
  hal::InstrumentDevice device_;
  TargetMeasurement target_measurement_;  // offline: the target measured inline
  TargetInputs target_inputs_;            // its inputs
  std::unique_ptr<TargetMeasurementThread> target_thread_;  // paced: on its own thread
  bool target_thread_pinned_ = false;  // kept off the loop's and the scene thread's CPUs
  /// The target is measured every ghost_every_ periods: 1, but in a multirate run at most at
  /// 1 kHz (round(1 ms / dt) periods), so that a 10 kHz device loop's thread does not detect the
  /// whole scene again every period (docs/outputs.md).
  std::int64_t ghost_every_ = 1;
  int ghost_held_ = -1;      // the held body when the target was last measured
  TargetContacts target_{};  // the target's contacts, last measured (or taken from the thread)
  // Devices 1 .. N−1 of a scene of several ([[device]]; docs/scenes.md "Several devices"),
  // simulated bus only: each its emulated instrument (its own trajectory, plant and hand) and
  // its InstrumentDevice; with several devices each emulated instrument reads the simulated
  // bus's device side through its own port of device_share_ (its frames only), port i for
  // device i.
  std::vector<std::unique_ptr<SimulatedInstrument>> extra_instruments_;
  std::vector<std::unique_ptr<hal::InstrumentDevice>> extra_devices_;
  // Per device: its hand's sight (hand_servo.hpp; null: none), observing each period's step and
  // moving its emulated instrument's hand from the next SYNC on.
  std::vector<std::unique_ptr<HandServo>> servos_;
  // The servos' figures into s (RunSummary::servo_lines and the rest; a saturated one warned).
  void summarize_servos(RunSummary& s) const;
  std::unique_ptr<hal::BusShare> device_share_;
  // Per device of a scene of several: its period figures (DeviceRunSummary), kept by
  // tally_devices().
  struct DeviceTally {
    double force_max = 0.0, torque_max = 0.0;
    std::int64_t torque_periods = 0, invalid_periods = 0;
  };
  std::array<DeviceTally, platform::kMaxLoopDevices> device_tally_{};
  // Devices 1 .. N−1: the body whose target and pose the trace's per-device columns carry
  // (extra_device_body(); -1: none).
  std::array<int, kMaxTraceExtraDevices> extra_trace_body_{-1, -1, -1};
  // A scene of several devices: each device's report of the period into device_tally_.
  void tally_devices() noexcept;
  // A scene of several devices: each device's figures into s.devices and s.device_lines.
  void summarize_devices(RunSummary& s) const;
  std::size_t next_event_ = 0;
  double free_sq_ = 0.0;
  std::unique_ptr<platform::TraceWriter> trace_writer_;  // real-bus --trace
  bool last_torque_ = false;
  std::int64_t startup_settle_periods_;  // kStartupSettle in periods (>= 1)
  bool in_startup_ = false;       // the spawned tool is being pushed out (RunSummary::startup_steps)
  double startup_min_ = 0.0;      // lowest tool penetration of the start-up so far (m)
  double startup_window_max_ = 0.0;  // deepest tool penetration since that minimum (m)
  int startup_obstacle_ = -1;     // obstacle of the deepest start-up contact (-1: none)
  int first_inversion_net_ = -1;  // the net that first turned a tetrahedron inside out (-1: none)
  int startup_other_body_ = -1;   // ... or the other body
  // The period (k_) whose contacts open the start-up: 1, or the period after a live input's
  // first sample brought the tool there (ControlLoop::placed_period()).
  std::int64_t startup_from_ = 1;
  // A live input's first sample, where it put the held body's target: its distance (mm; -1:
  // no such start) and angle (°) from the body's scene start (note_live_start()).
  double live_start_mm_ = -1.0;
  double live_start_deg_ = 0.0;
  // The loop brought the tool to a live input's first sample in this period.
  void note_live_start() noexcept;
  // Device 0's stale stretches (RunSummary::stale_*): the one under way (its first period and
  // length; 0: none) and the longest so far.
  std::int64_t stale_from_ = 0;
  std::int64_t stale_run_ = 0;
  std::int64_t stale_longest_ = 0;
  std::int64_t stale_longest_from_ = 0;
  // A period's sample stale or not (count_period()).
  void tally_stale(bool stale) noexcept;
  // Devices 1 .. N−1 (index i for device i + 1): the start-up push-out of each one's tool (the
  // articulation of extra_trace_body_[i], when it is not the held body's), as device 0's above.
  struct DeviceStartup {
    bool in = false;         // its tool is being pushed out
    double min = 0.0;        // lowest penetration of the start-up so far (m)
    double first_mm = 0.0;   // penetration in the start-up's first period (mm)
    std::int64_t steps = 0;  // periods of the start-up (0: started free)
    int obstacle = -1;       // obstacle of the deepest first contact (-1: none)
    int other_body = -1;     // ... or the other body
  };
  std::array<DeviceStartup, kMaxTraceExtraDevices> device_startup_{};
  // The other devices' start-ups of this period (track_startup()); true when one ended.
  bool track_device_startups() noexcept;
  // A device's tool is still being pushed out (the divergence bounds keep the push-out's).
  bool any_startup() const noexcept;
  hal::FaultRecord first_fault_;  // the first latched fault of the run (kept across re-arms)
  bool has_first_fault_ = false;
  std::uint64_t emcys_traced_ = 0;  // EMCY messages received up to the last trace record
  core::Vec3 last_feedback_force_ = core::Vec3::Zero();  // sent the period before (N)
};

/// The body device `i` + 1 of `scene` (extra_devices[i]) drives that the trace's per-device
/// columns follow: the one its `tool` link (link 0) drives, else the first body with spheres its
/// links drive; -1 when none (docs/outputs.md, "Trace columns").
int extra_device_body(const Scene& scene, std::size_t i) noexcept;

/// Runs `scene` for options.duration_s (or the scene's duration) and judges it
/// (RunSummary::exit_status, run_verdict()): one period loop (as fast as possible, paced with
/// options.realtime or on a real bus, or at options.view_speed × real time for a live viewer)
/// over the scene's harness (RunHarness): an AdmittanceRunner for an admittance scene
/// (Scene::admittance), else a SceneRunner. options.rearm re-arms the loop after a latched safe
/// state (ControlLoop::rearm()); a paced run reports its overruns, missed periods and wake-up
/// latency, and latches the safe state after options.overrun_limit consecutive overruns where
/// a supervisor latches on them (the managed stack, the admittance device; 0: counted only; an
/// offline run has no deadline and never latches on them; docs/safety.md). A run on a real bus
/// ends with the shutdown periods (zero torque, drives disabled). The in-memory trace of a
/// simulated run is written to options.trace_path after the run; a real bus streams it.
/// Throws InputError for a scene without [trajectory] or [device] (require_runnable()), for an
/// admittance scene on a bus other than "sim" or with a bus recording (key "--bus" or
/// "--record": its emulated device lives on the scene's SimBus), for a trace over the
/// in-memory budget (key "--trace"), std::runtime_error if the trace cannot be written.
RunSummary run_scene(const Scene& scene, const RunOptions& options);

}  // namespace numen::sim
