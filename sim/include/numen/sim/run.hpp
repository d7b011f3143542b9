#pragma once
/// @file run.hpp
/// The run harness behind `numen run`: a SimBus, a SimulatedInstrument on its
/// device port, the platform::ControlLoop on its controller port, the fixed-step
/// loop (as fast as possible, or paced to wall-clock time), the measurements of
/// the summary and an optional per-step trace.

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "numen/core/data.hpp"
#include "numen/core/multirate.hpp"
#include "numen/hal/transport/bus_recorder.hpp"
#include "numen/hal/device/instrument_device.hpp"
#include "numen/hal/transport/log_bus.hpp"
#include "numen/hal/transport/sim_bus.hpp"
#include "numen/platform/control_loop.hpp"
#include "numen/platform/latency_histogram.hpp"
#include "numen/platform/loop_statistics.hpp"
#include "numen/platform/multirate_threads.hpp"
#include "numen/platform/periodic_timer.hpp"
#include "numen/sim/multirate_run.hpp"
#include "numen/platform/realtime_setup.hpp"
#include "numen/platform/state_stream.hpp"
#include "numen/platform/trace_queue.hpp"
#include "numen/sim/view_output.hpp"
#include "numen/sim/bus_spec.hpp"
#include "numen/sim/divergence.hpp"
#include "numen/sim/scene.hpp"
#include "numen/sim/simulated_instrument.hpp"
#include "numen/sim/trace.hpp"

namespace numen::sim {

/// Start-up of a run whose tool starts inside an obstacle (RunSummary): it ends when the
/// tool's penetration has set no new minimum for this long (s).
inline constexpr double kStartupSettle = 0.02;

/// The bus the controller talks to in a run (`numen run --bus`, `--record`).
struct BusChoice {
  /// "sim" (default): the scene's SimBus with the simulated instrument on its
  /// device port. "log:FILE": a candump log (can-utils `candump -l` format,
  /// docs/transports.md) replayed as the controller's input — no simulated
  /// instrument; only the encoder TPDOs of the scene's axes are read (exact
  /// CanFilter per COB-ID) and records marked transmitted (" T") are skipped,
  /// so a log recorded with `record_path` replays the controller's input
  /// exactly; the first record of the log is due at bus time 0 and the others
  /// keep their relative times. "can:IFACE" (SocketCAN, kernel filters from
  /// controller_filters()) or "serial:PATH[@BAUD]" (SerialBus, user-space
  /// filters): a real bus with the instrument (`numen device`, hardware) at the
  /// other end — bus time is CLOCK_MONOTONIC and the run is paced (see
  /// SceneRunner::period()). Anything else: std::invalid_argument.
  std::string spec = "sim";
  /// Record the controller port (frames read: " R", written: " T") into this
  /// candump log through a lock-free queue and a writer thread; empty: none.
  /// Paced runs drop what the queue has no room for, offline runs wait (recorder_settings()).
  std::string record_path;
};

/// Largest in-memory trace of a simulated run (`--trace` without a real bus): one TraceRecord per
/// period is kept until the run ends, so run_scene() refuses (InputError, key "--trace") a run
/// whose trace would take more, before allocating it. 1 GiB: ~3 million periods, 50 min at 1 kHz.
inline constexpr std::size_t kMaxInMemoryTraceBytes = std::size_t{1} << 30;

/// The capacity (records) of the in-memory trace of a simulated run of `periods` periods, for
/// run_scene() and run_admittance_scene(). Throws InputError (key "--trace", the periods and
/// MiB asked for and the limit) if it would take more than kMaxInMemoryTraceBytes; 0 periods
/// or fewer need none (0).
std::size_t in_memory_trace_capacity(std::int64_t periods);

/// How to run a scene.
struct RunOptions {
  double duration_s = -1.0;  ///< Simulated time (s); < 0: the scene's duration.
  bool realtime = false;     ///< Pace each period to CLOCK_MONOTONIC (clock_nanosleep).
  std::string trace_path;    ///< Per-step CSV trace; empty: none.
  BusChoice bus;             ///< The controller's bus (default: the simulated bus).
  /// Real-time setup of the loop thread (SCHED_FIFO, mlockall, stack prefault, CPU
  /// affinity), applied by run_scene() on the calling thread before the first period when
  /// anything is requested; each step's outcome is in RunSummary::realtime_setup. Lack of
  /// privilege is reported, not fatal, unless rt.strict.
  platform::RealtimeSettings rt;
  /// A multirate scene's scene thread in a paced run (scheduling, CPUs; docs/multirate.md):
  /// paced runs step the scene loop on it, offline runs interleave both loops on one thread.
  platform::SceneThreadSettings scene_thread;
  /// Set (e.g. by a SIGINT / SIGTERM handler) to end the run early and cleanly: the loop
  /// shuts down (ControlLoop::shutdown(): zero torque, drives disabled) over at most
  /// shutdown_periods more periods and the summary is returned. nullptr: none.
  const std::atomic<bool>* stop = nullptr;
  /// The number of the signal that set `stop` (SIGINT 2, SIGTERM 15; 0 or nullptr: not known),
  /// read once the run has stopped: the summary's exit status is then 128 + it (shell
  /// convention) unless the run's verdict is worse, and its reasons name the signal.
  const std::atomic<int>* stop_signal = nullptr;
  /// Set (e.g. by a SIGUSR1 handler: `kill -USR1 PID`) to re-arm after a latched safe state:
  /// taken (exchanged to false) before the next period, which calls ControlLoop::rearm()
  /// (fault resets, start-up rerun if needed; the lifecycle re-arms once no cause is
  /// present). The operator's explicit re-arm of docs/safety.md. nullptr: none.
  std::atomic<bool>* rearm = nullptr;
  /// Periods run after the end (duration reached or stop) to send zero torque and disable
  /// the drives (stops early once every drive reports disabled). Real buses only.
  int shutdown_periods = 50;
  /// Compute phase override, s (< 0: the scene's [bus] compute_phase): how long after the
  /// SYNC a paced period on a real bus waits before reading the device's answers.
  double compute_phase_s = -1.0;
  /// Overrun policy of a paced run (platform::ControlLoopSettings::overrun_limit): this many
  /// consecutive overruns latch the safe state (docs/safety.md); 0: overruns are counted and
  /// reported in the summary but never latch (for a host that cannot hold the period, such as
  /// the HIL guest under qemu's TCG emulation, docs/hil.md).
  std::uint32_t overrun_limit = 3;
  /// The state stream (docs/viewer.md): write a view recording (.nmv) of the run here; empty:
  /// none. An offline run waits for the file (every due frame is written); a paced run drops
  /// and counts, and the verdict reports lost records.
  std::string record_view_path;
  /// Further consumers of the state stream (a viewer server), not owned; they must outlive
  /// the run. Frames they cannot take are theirs to drop.
  std::vector<platform::StateFrameSink*> view_sinks;
  /// Frames per second of simulated time the stream publishes, > 0.
  double view_rate_hz = 60.0;
  /// > 0: an unpaced run (simulated bus or log, no --realtime) is paced at view_speed × real
  /// time so that a live viewer sees it move (sleeps between periods; no real-time
  /// supervision). 0: as fast as it goes.
  double view_speed = 0.0;
};

/// The compute phase (ns after the SYNC) that RunOptions::compute_phase_s asks of a run of
/// `scene`, or -1 when it asks none (the scene's [bus] compute_phase then holds). Throws
/// InputError (key "--phase") unless it is below the scene's period dt.
std::int64_t compute_phase_override_ns(const Scene& scene, const RunOptions& options);

/// Percentiles of a duration distribution (µs).
struct DurationSummary {
  double median = 0.0;
  double p99 = 0.0;
  double p999 = 0.0;
  double max = 0.0;
  double mean = 0.0;
};

/// The percentiles of a histogram of durations in ns, converted to µs.
DurationSummary summarize_ns(const platform::LatencyHistogram& h);

struct RunSummary;

/// What a run's period loop counts around its runner (run_scene's impedance loop and
/// run_admittance_scene share it): a paced loop's wake-ups and the operator's re-arm
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

/// The real-time setup of a run's loop thread: apply_realtime(rt) described line by line, or
/// nothing if `rt` asks for no step. Throws as apply_realtime() (a failed step only if strict).
std::vector<std::string> apply_run_realtime(const platform::RealtimeSettings& rt);

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

/// What a run of an admittance device measured (AdmittanceRunner; docs/scenes.md). Positions
/// are the controlled frame's origin (world): "device" where the emulated device is, "hand"
/// where the simulated hand wants it (the scene trajectory), "god-object" the held body's COM.
/// The multirate god-object of a run (scene [multirate]; docs/multirate.md); all zero without.
struct MultirateSummary {
  bool enabled = false;          ///< The scene ran multirate.
  double scene_dt_s = 0.0;       ///< The scene loop's period (s).
  int ratio = 0;                 ///< Device periods per scene period.
  double margin_mm = 0.0;        ///< Proximity margin δ (mm).
  std::int64_t scene_steps = 0;  ///< Scene periods stepped.
  std::int64_t planes_max = 0;   ///< Most contact planes handed to the device loop at once.
  /// Contacts of the god-object the scene loop found beyond core::kMaxContactPlanes (summed
  /// over scene periods): surfaces the device loop did not see.
  std::int64_t planes_dropped = 0;
  /// Device periods that used planes older than one scene period (a late scene step); 0 in
  /// runs that interleave the loops on one thread.
  std::int64_t stale_models = 0;
  std::int64_t switches = 0;     ///< Tool switches the god-object followed.
  bool scene_thread = false;     ///< The scene loop ran on its own thread (a paced run).
  /// Scene periods on the scene thread that ended past the next deadline (a paced run).
  std::int64_t scene_overruns = 0;
  DurationSummary scene_step_us;  ///< Wall time of the scene steps on the scene thread (us).
  /// Largest change of the feedback force sent (N) into a period that took a new scene model
  /// (a scene-step boundary), and into any other period.
  double model_force_jump_max_n = 0.0;
  double other_force_jump_max_n = 0.0;
};

/// The divergence monitor of a run (divergence.hpp; docs/safety.md, "Divergence").
struct DivergenceSummary {
  bool latched = false;            ///< A breach latched: the run stopped (ExitStatus::kDiverged).
  std::string cause;               ///< "body speed", "node speed", "tie stretch" or "energy".
  std::string subject;             ///< The body, or the net, that breached.
  double value = 0.0;              ///< The quantity (m/s, m or J).
  double limit = 0.0;              ///< Its limit (same unit).
  double time_s = 0.0;             ///< Simulated time of the breach (s).
  std::int64_t period = -1;        ///< Its period (0-based).
  double speed_ratio_max = 0.0;    ///< Largest speed / its limit of a body or node (1: the limit).
  double stretch_ratio_max = 0.0;  ///< Largest tie stretch / its limit (0 without nets).
  /// Largest held energy / max(E₀ + W_in, floor) (0 where the coupling springs do not act).
  double energy_ratio_max = 0.0;
  double scene_size_m = 0.0;       ///< The scene's bounding-box diagonal at the start (m).
  double speed_limit_mps = 0.0;    ///< The speed limit at the end (10 × v_ref; m/s).
};

struct AdmittanceSummary {
  bool enabled = false;                  ///< The run was an admittance run.
  double measured_force_max_n = 0.0;     ///< Largest |measured force| that drove the god-object.
  double measured_torque_max_nm = 0.0;   ///< Largest |measured torque| (about the COM).
  double device_error_max_mm = 0.0;      ///< Largest |x_device − x_god-object|.
  double device_error_rms_mm = 0.0;      ///< Its RMS over the periods.
  double hand_separation_max_mm = 0.0;   ///< Largest |x_hand − x_device|.
  double final_measured_force_n = 0.0;   ///< |measured force| in the last period.
  double final_hand_separation_mm = 0.0; ///< |x_hand − x_device| in the last period.
  double k_hand = 0.0;                   ///< The hand's stiffness (N/m), for k_hand × separation.
  std::int64_t sensor_frames = 0;        ///< Force sensor TPDOs received.
  std::int64_t sensor_rejected_periods = 0;  ///< Periods whose reading was rejected.
  std::int64_t csp_rpdos = 0;            ///< csp RPDOs written.
  std::int64_t setpoints_clamped = 0;    ///< Set-points clamped to an axis range.
  std::int64_t setpoints_rate_limited = 0;  ///< Set-points limited to max_speed · dt.
  std::int64_t hold_periods = 0;         ///< Periods not active (drives disabled, god-object braked).
};

/// What a run measured. Penetrations are the deepest overlap (mm) of the
/// tool's spheres (the held body and the bodies jointed to it, and the node
/// spheres of the deformable nets whose rigid component is one of them) with
/// obstacles and other bodies; "target" is the same bodies placed at the
/// device's target poses (where the hand is) with their nets in their rest
/// shape, "tool" the god-object itself (its nets as deformed).
///
/// Start-up: the god-object starts where the hand is. When the hand starts
/// inside an obstacle, so does the tool, and the contact forces first push it
/// out. The start-up runs from the first period through the last period that
/// lowers the tool's penetration to a new minimum before kStartupSettle
/// passes without a new minimum (or before a period without contact): the
/// push-out, whose pauses last a few periods (the default instrument spawned
/// 21 mm into the tissue: 90 periods, pauses of up to 6). Its depth is
/// startup_tool_penetration_mm (with a warning naming the obstacle), and
/// tool_penetration_max_mm covers every period after it.
struct RunSummary {
  std::string scene;
  std::string coupling;
  std::string integrator;
  std::int64_t steps = 0;
  double dt_s = 0.0;
  double sim_time_s = 0.0;
  double wall_time_s = 0.0;
  DurationSummary step_time_us;            ///< Wall time of core::step per period.
  double target_penetration_max_mm = 0.0;
  double tool_penetration_max_mm = 0.0;    ///< God-object, after the start-up (see above).
  /// The god-object's penetration at the first period when it starts inside an obstacle (mm;
  /// the deepest of the start-up); 0 when it starts free.
  double startup_tool_penetration_mm = 0.0;
  std::int64_t startup_steps = 0;          ///< Periods of the start-up (0: the tool started free).
  double any_penetration_max_mm = 0.0;     ///< Deepest contact of any body this run.
  /// |x_tool − x_target| (held body's origin) RMS over the free-space steps: steps where
  /// neither the tool nor the target (the hand) touches anything.
  double tracking_error_free_rms_mm = 0.0;
  double tracking_error_free_max_mm = 0.0; ///< Largest of the same (mm).
  std::int64_t free_steps = 0;             ///< Steps counted in the free-space error.
  double feedback_force_max_n = 0.0;       ///< Largest |feedback force| sent (after saturation).
  /// Largest |F_k − F_{k−1}| of the feedback force sent between consecutive periods (N).
  double feedback_force_jump_max_n = 0.0;
  /// The device's soft start (hal::DeviceConfig::soft_start_s, s; 0: off): the feedback ramps
  /// in over this time at start-up and after every re-arm.
  double soft_start_s = 0.0;
  /// Soft-start ramps run (hal::TorqueCounters::soft_starts: the start-up's and one per
  /// activation after a re-arm that enabled torque again).
  std::int64_t soft_start_ramps = 0;
  double feedback_torque_max_nm = 0.0;
  double axis_torque_max = 0.0;            ///< Largest |axis torque| commanded (N·m or N).
  double free_body_speed_max_mps = 0.0;    ///< Fastest body not part of the held tool (m/s): blocks thrown about.
  int num_bodies = 0;
  int num_joints = 0;
  double joint_drift_max_mm = 0.0;         ///< Largest linear joint error |C| after a step (mm).
  double joint_angle_drift_max_mrad = 0.0; ///< Largest angular joint error |C| after a step (mrad).
  std::int64_t rejected_samples = 0;       ///< Axis samples rejected by the checks.
  std::int64_t invalid_periods = 0;        ///< Periods whose sample was not valid (target held).
  std::int64_t contact_overflow = 0;       ///< Steps that ran out of contact capacity.
  /// Steps with a contact whose stiffness the time-constant floor lowered
  /// (core::Data::contact_clamped_steps; core::SolverSettings::contact_max_omega_dt).
  std::int64_t contact_clamped_steps = 0;
  int contacts_max = 0;           ///< Rigid sphere contacts in one step (node contacts apart).
  int solver_iterations_max = 0;  ///< Iterations of the implicit solve in one step.
  double solver_iterations_mean = 0.0;  ///< Mean over the steps.
  double solver_residual_max = 0.0;  ///< Largest Data::solver_residual of a step.
  /// Steps whose implicit solve ended at max_iterations above the tolerance.
  std::int64_t solver_not_converged_steps = 0;
  // Deformable nets (paper §4.2); all zero without nets.
  int num_nets = 0;
  int num_nodes = 0;
  int node_contacts_max = 0;            ///< Node contacts in one step (all nets).
  double net_penetration_max_mm = 0.0;  ///< Deepest node contact of any net (mm).
  double net_tie_stretch_max_mm = 0.0;  ///< Largest |x − a| of a node from its rest position (mm).
  double net_strain_max = 0.0;  ///< Largest |l − L|/L of a structural spring (dimensionless).
  double net_node_speed_max_mps = 0.0;  ///< Fastest node (m/s).
  bool nan_detected = false;
  std::int64_t nonfinite_steps = 0;
  std::int64_t bus_frames_dropped = 0;
  std::int64_t bus_frames_corrupted = 0;
  std::string bus = "sim";                 ///< BusChoice::spec of the run.
  std::int64_t bus_frames_replayed = 0;    ///< log: records read by the controller.
  std::int64_t bus_log_records = 0;        ///< log: frame records in the file.
  std::int64_t bus_log_lost_frames = 0;    ///< log: frames the recording itself lost (DROPCOUNT notes).
  std::int64_t bus_log_out_of_order = 0;   ///< log: records earlier than a record before them
                                           ///< (another interface or direction).
  std::int64_t bus_frames_recorded = 0;    ///< --record: frames queued for the log.
  std::int64_t bus_record_dropped = 0;     ///< --record: lost to a full queue (paced runs).
  std::int64_t bus_record_written = 0;     ///< --record: lines the writer thread wrote.
  std::int64_t bus_record_io_errors = 0;   ///< --record: failed writes / flushes (disk full).
  std::int64_t bus_record_format_errors = 0;  ///< --record: records that could not be formatted.
  bool view_streamed = false;              ///< The state stream ran (--record-view, --view).
  bool view_recorded = false;              ///< ... into a view recording (--record-view).
  std::int64_t view_frames_published = 0;  ///< Frames queued by the loop.
  std::int64_t view_frames_decimated = 0;  ///< Periods left out by the display rate.
  std::int64_t view_frames_dropped = 0;    ///< Due frames lost: every buffer was in use.
  std::int64_t view_frames_delivered = 0;  ///< Frames handed to the consumers.
  std::int64_t view_bytes = 0;             ///< Bytes of the frames delivered.
  std::int64_t view_sink_errors = 0;       ///< Consumer refusals (write or flush failures).
  std::int64_t view_record_frames = 0;     ///< --record-view: frames in the file.
  std::int64_t view_record_io_errors = 0;  ///< --record-view: failed writes / flushes / close.
  std::int64_t realtime_overruns = 0;      ///< Paced periods (--realtime) that began after their deadline.
  std::int64_t realtime_missed_periods = 0;  ///< Whole periods skipped to re-phase after overruns.
  /// RunOptions::overrun_limit in effect: consecutive overruns that latch (0: counted only, as
  /// in an unpaced run or a minimal-protocol one, whose loop does not supervise overruns).
  std::uint32_t overrun_limit = 3;
  DurationSummary wakeup_latency_us;       ///< Paced runs: wake-up time − deadline (µs).
  /// RunOptions::rt outcome, one line per step plus the kernel and the limits
  /// (platform::describe()); empty when nothing was requested.
  std::vector<std::string> realtime_setup;
  // Device lifecycle and safety (managed CANopen stack; docs/safety.md). Minimal protocol:
  // managed = false and the rest at their defaults.
  bool managed = false;                    ///< The device ran the managed CANopen stack.
  std::string startup;                     ///< Start-up phase at the end ("operational",
                                           ///< "failed (node 3)", ...).
  std::int64_t periods_to_operational = -1;  ///< Period index at which every node was heard
                                             ///< operational (-1: never).
  std::int64_t periods_to_active = -1;     ///< Period index at which the lifecycle became active.
  std::int64_t periods_to_torque = -1;     ///< Period index of the first non-zero torque command.
  std::string lifecycle;                   ///< Lifecycle state at the end.
  std::int64_t faults = 0;                 ///< Safe states latched.
  std::int64_t fault_records = 0;          ///< Fault records written (latching or not).
  std::string first_fault;                 ///< Cause of the first latched fault ("" if none).
  int first_fault_id = 0;                  ///< Its axis / node / drive (FaultRecord::id).
  double first_fault_value = 0.0;          ///< Its value (FaultRecord::value).
  double first_fault_time_s = 0.0;         ///< Its bus time, s.
  std::int64_t first_fault_period = -1;    ///< Its period index.
  std::int64_t emcys = 0;                  ///< EMCY messages received.
  std::int64_t emcy_faults = 0;            ///< ... of which reported a fault.
  std::int64_t configured_nodes = 0;       ///< Node configurations from a DCF completed (read back
                                           ///< equal) at start-ups.
  std::int64_t sdo_reads = 0;              ///< In-loop SDO reads completed (canopen.sdo_poll_period).
  std::int64_t sdo_read_errors = 0;        ///< ... aborted by a node or timed out.
  std::int64_t heartbeat_losses = 0;       ///< Heartbeat losses over all nodes.
  std::int64_t zero_torque_periods = 0;    ///< Periods that commanded zero torque on every drive.
  std::vector<std::string> drive_states;   ///< "axis: CiA 402 state" per drive at the end.
  /// The EMCY messages the master still holds at the end (its log keeps the last 16), oldest
  /// first: "node 3 at 1.234 s: 0x4310 <CiA 301 name> (register 0x09)"; an error reset says
  /// "no error / reset".
  std::vector<std::string> emcy_messages;
  // Real buses (can:, serial:) — zeros / empty otherwise.
  bool real_bus = false;                   ///< The controller ran on a real bus, paced.
  hal::BusCounters port;                   ///< Counters of the controller's port (rx, tx,
                                           ///< dropped, errors, would-block).
  std::string transport;                   ///< describe_transport_counters() of the port.
  std::string bus_state;                   ///< Port state at the end (hal::to_string(BusState)).
  std::int64_t bus_error_periods = 0;      ///< Periods whose port state was not kOk or that
                                           ///< saw a read / write error (link down, bus off).
  std::int64_t read_errors = 0;            ///< ControlLoopCounters::read_errors.
  std::int64_t sync_write_failures = 0;    ///< ControlLoopCounters::sync_write_failures.
  std::int64_t command_failures = 0;       ///< ControlLoopCounters::command_failures.
  std::int64_t frames_rejected = 0;        ///< Encoder frames of a wrong length / kind, frames of
                                           ///< no known id, malformed drive TPDOs (InstrumentDevice
                                           ///< and CanopenMaster counters).
  std::int64_t frames_unknown_id = 0;      ///< ... of which of an id no axis has.
  /// Encoder frames rejected (on an encoder's 11-bit COB-ID, InstrumentDevice): CAN FD frames,
  /// remote requests, classic data frames of a wrong length. Part of frames_rejected; each
  /// rejects its axis's sample for the period (docs/inputs.md).
  std::int64_t encoder_frames_fd = 0;
  std::int64_t encoder_frames_remote = 0;
  std::int64_t encoder_frames_wrong_length = 0;
  std::int64_t error_frames = 0;           ///< Controller error reports the device ignored
                                           ///< (never decoded as PDOs; docs/protocol.md).
  std::int64_t values_out_of_range = 0;    ///< Axis values rejected as out of [min, max].
  std::int64_t values_jump = 0;            ///< Axis values rejected as implausible jumps.
  platform::LoopSummary loop;              ///< LoopStatistics of the periods (paced runs).
  std::int64_t last_device_frame_period = -1;  ///< Last period that read a frame (-1: none).
  std::int64_t last_torque_stop_period = -1;   ///< Last period whose torque was zero after a
                                               ///< period with torque (the last safe stop).
  /// The trace (--trace): a real bus streams it (TraceWriter: records queued, refused by a full
  /// queue, written, failed writes); a simulated run keeps it in memory and writes it after the
  /// run (write_in_memory_trace(): records taken, refused by a full store, written, 1 failure).
  std::int64_t trace_pushed = 0;           ///< Trace: records queued / taken.
  std::int64_t trace_dropped = 0;          ///< ... refused by a full queue (must be 0).
  std::int64_t trace_written = 0;          ///< ... lines written to the file.
  std::int64_t trace_io_errors = 0;        ///< ... failed writes / flushes (disk full).
  bool stopped = false;                    ///< Ended early by RunOptions::stop (signal).
  int stop_signal = 0;                     ///< ... by this signal (RunOptions::stop_signal; 0: unknown).
  std::int64_t rearm_requests = 0;         ///< RunOptions::rearm requests taken.
  std::int64_t rearms_accepted = 0;        ///< Of these, ControlLoop::rearm() kAccepted.
  std::int64_t rearm_first_period = -1;    ///< Period before which the first request was taken.
  std::int64_t shutdown_periods = 0;       ///< Periods run to shut down.
  bool drives_disabled = false;            ///< Every drive disabled at the end of the shutdown.
  std::vector<std::string> warnings;
  std::string trocar_note;
  /// Admittance device runs only (enabled = true); the impedance-only fields above stay 0.
  AdmittanceSummary admittance;
  MultirateSummary multirate;
  DivergenceSummary divergence;
  /// The run's exit status (run_verdict(): ExitStatus as int, 0 clean; 128 + stop_signal for
  /// a run a signal stopped that is otherwise clean) and every condition behind it, most
  /// severe first; set by run_scene(). The status the `numen run` process returns.
  int exit_status = 0;
  std::vector<std::string> exit_reasons;
};

/// Writes the in-memory trace of a simulated run to `path` after the run and accounts for it in
/// `s` (trace_pushed, trace_dropped, trace_written, trace_io_errors): a file that cannot be
/// written is not thrown but counted (1 I/O error, 0 written) with the error as a warning, so
/// the run keeps its summary and its verdict reports the lost records (exit status 5).
void write_in_memory_trace(const Trace& trace, const std::string& path, RunSummary& s);

/// A scene wired for a run: SimBus, simulated instrument on its device port,
/// InstrumentDevice and ControlLoop on its controller port, core Data, the
/// measurement state and the trace storage. The constructor allocates
/// everything; period() never allocates, throws or locks (tested), so the
/// same loop can be driven by a test, a benchmark or `numen run`.
class SceneRunner {
 public:
  /// `scene` must outlive the runner. `trace_capacity` records are reserved.
  /// `bus` chooses the controller's bus; a log is loaded and a recording
  /// opened (its writer thread started) here. Throws std::invalid_argument
  /// for an unknown bus spec, std::runtime_error ("file:line:column: what")
  /// for a log that cannot be read or a recording that cannot be written.
  /// `realtime`: the periods are paced to CLOCK_MONOTONIC (run_scene with
  /// RunOptions::realtime), so overruns are supervised (control_loop_settings()) with
  /// `overrun_limit` (RunOptions::overrun_limit; 0: counted, never latched).
  explicit SceneRunner(const Scene& scene, std::size_t trace_capacity = 0,
                       const BusChoice& bus = {}, bool realtime = false,
                       std::uint32_t overrun_limit = 3);

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
  void period(std::int64_t deadline_mono_ns = -1, std::int64_t woke_mono_ns = -1) noexcept;
  /// True when the controller's port is a real bus (can:, serial:).
  bool real_bus() const noexcept { return spec_.real(); }
  /// The controller's port (the real bus, the log replay, the recorder, or the SimBus port).
  const hal::Bus& port() const noexcept { return *port_; }
  /// Streams one record per period into a CSV through platform::TraceWriter (lock-free queue,
  /// writer thread started here; setup only). Columns: trace_stream_columns() (frames_read,
  /// sample_valid, torque_commanded, lifecycle, target_{x,y,z}, tool_{x,y,z}, force_{x,y,z},
  /// tau_<axis name> per axis, step_us, end_to_end_us, wakeup_us); flags bit 0 sample valid,
  /// bit 1 torque commanded, bit 2 overrun. Throws like TraceWriter's constructor.
  void stream_trace(const std::string& path);
  /// Publishes the run's state stream (docs/viewer.md) to a view recording at `record_path`
  /// (empty: none) and to `sinks`, at `rate_hz` frames per simulated second; `wait`: the loop
  /// waits for the consumers (offline runs), else drops. Starts the stream's thread. Throws
  /// InputError at --record-view when the file cannot be created.
  void stream_view(const std::string& record_path, std::vector<platform::StateFrameSink*> sinks,
                   double rate_hz, bool wait);
  /// The streaming trace writer (nullptr unless stream_trace() was called).
  platform::TraceWriter* trace_writer() noexcept { return trace_writer_.get(); }
  /// Overrides the scene's compute phase (ns, >= 0).
  void set_compute_phase_ns(std::int64_t ns) noexcept { phase_ns_ = ns; }
  /// Periods run so far.
  std::int64_t periods() const noexcept { return k_; }
  /// The divergence monitor latched (divergence.hpp): the period that breached it shut the
  /// device down (zero torque from the next write on); the run stops after it.
  bool diverged() const noexcept { return divergence_.divergence().cause != nullptr; }
  /// A multirate scene in a paced run: steps the scene loop on its own thread from now on
  /// (platform::MultirateThreads, `settings`) until finish(); nothing for a single-rate scene.
  /// Allocates (call before the first period). Throws std::system_error if the thread cannot
  /// start.
  void start_scene_thread(const platform::SceneThreadSettings& settings);
  /// The multirate god-object (MultirateRun::enabled() false in a single-rate run) and its
  /// scene thread; read the thread's realtime_report() after finish().
  const MultirateRun& multirate() const noexcept { return multirate_; }

  /// Ends the run's streams: stops the bus recorder's and the trace's writer threads, which
  /// write what is still queued and close the files (they appear under their paths), so that
  /// summary() reports what reached them.
  /// Idempotent; call it after the last period() (setup thread).
  void finish();

  /// The summary of the periods run so far (wall time and realtime overruns
  /// are the caller's, see run_scene).
  RunSummary summary() const;

  const core::Data& data() const noexcept { return data_; }
  const hal::InstrumentDevice& device() const noexcept { return device_; }
  const SimulatedInstrument& instrument() const noexcept { return instrument_; }
  /// The simulated instrument, for fault injection in tests.
  SimulatedInstrument& instrument() noexcept { return instrument_; }
  /// The control loop (lifecycle, supervisor, CANopen master, statistics, rearm()).
  const platform::ControlLoop& loop() const noexcept { return loop_; }
  platform::ControlLoop& loop() noexcept { return loop_; }
  hal::SimBus& bus() noexcept { return bus_; }
  const Trace& trace() const noexcept { return trace_; }
  /// What the control loop did in the last period (step wall time included).
  const platform::PeriodReport& last_report() const noexcept { return loop_.last_report(); }

 private:
  /// What measure_contacts() found after a period's step (penetrations in m).
  struct PeriodContacts {
    bool held = false;              ///< A body is held (else everything below is zero).
    double tool_pen = 0.0;          ///< Deepest contact of the tool (bodies and nets).
    double target_pen = 0.0;        ///< Deepest contact of the target (where the hand is).
    int tool_contacts = 0;          ///< Contacts of the tool.
    int target_contacts = 0;        ///< Contacts of the target.
    int deepest_tool_contact = -1;  ///< Index of the tool's deepest rigid contact (-1: none).
    int deepest_tool_body = -1;     ///< Its tool body.
  };
  /// Attaches the bodies of the tool-switching events due at bus time `t_ns`.
  void apply_due_events(std::int64_t t_ns) noexcept;
  /// The bus side of the period at bus time `t` (ns): the simulated bus and instrument, the
  /// log replay or the real bus around ControlLoop::begin_period / end_period.
  const platform::PeriodReport& exchange(std::int64_t t, std::int64_t deadline_mono_ns,
                                         std::int64_t woke_mono_ns) noexcept;
  /// Counts of the period's report: frames, torque stops, bus errors, invalid and zero-torque
  /// periods, the first latched fault.
  void count_period(const platform::PeriodReport& report) noexcept;
  /// The tool's and the target's contacts (the target detected on ghost_).
  PeriodContacts measure_contacts() noexcept;
  /// The free-space tracking error (RunSummary::tracking_error_free_rms_mm).
  void track_free_space(const PeriodContacts& c) noexcept;
  /// The start-up push-out and the god-object's penetration after it (RunSummary).
  void track_startup(const PeriodContacts& c) noexcept;
  /// Running maxima and sums of the step: penetrations, feedback, joints, solver, nets.
  void accumulate_step_figures(const platform::PeriodReport& report, const PeriodContacts& c) noexcept;
  /// The period's trace record: in memory (trace_) and streamed (trace_writer_).
  void record(const platform::PeriodReport& report, const PeriodContacts& c) noexcept;
  /// The loop's step in a multirate run: MultirateRun::step(data_); period() writes the rest
  /// of the single-rate view (MultirateRun::view()) after the timed step, before measuring.
  static void step_multirate(void* runner) noexcept;

  const Scene* scene_;
  BusSpec spec_;
  hal::SimBus bus_;
  std::unique_ptr<hal::Bus> real_bus_;            // --bus can:IFACE / serial:PATH
  hal::CandumpLoadStats log_stats_;               // --bus log:FILE, what the loader counted
  std::unique_ptr<hal::LogBus> log_bus_;          // --bus log:FILE
  std::unique_ptr<hal::CandumpWriter> writer_;    // --record FILE
  std::unique_ptr<hal::RecordingBus> recorder_;   // --record FILE, around the controller port
  hal::Bus* port_;                                // what the control loop reads and writes
  SimulatedInstrument instrument_;
  hal::InstrumentDevice device_;
  core::Data data_;
  core::Data ghost_;  // the held body placed at the target, for measurement
  platform::ControlLoop loop_;
  /// The multirate god-object (scene [multirate]), stepped in place of core::step by the
  /// loop (ControlLoop::set_step_function); not enabled in a single-rate run.
  MultirateRun multirate_;
  Trace trace_;
  std::int64_t k_ = 0;
  std::size_t next_event_ = 0;
  std::int64_t period_ns_;
  std::int64_t phase_ns_;
  RunSummary acc_;     // running maxima and counts
  double free_sq_ = 0.0;
  std::int64_t solver_iterations_sum_ = 0;
  std::unique_ptr<platform::TraceWriter> trace_writer_;  // real-bus --trace
  std::unique_ptr<ViewOutput> view_;                     // --record-view, --view
  bool last_torque_ = false;
  std::int64_t startup_settle_periods_;  // kStartupSettle in periods (>= 1)
  bool in_startup_ = false;       // the spawned tool is being pushed out (RunSummary::startup_steps)
  double startup_min_ = 0.0;      // lowest tool penetration of the start-up so far (m)
  double startup_window_max_ = 0.0;  // deepest tool penetration since that minimum (m)
  int startup_obstacle_ = -1;     // obstacle of the deepest start-up contact (-1: none)
  int startup_other_body_ = -1;   // ... or the other body
  hal::FaultRecord first_fault_;  // the first latched fault of the run (kept across re-arms)
  bool has_first_fault_ = false;
  std::uint64_t emcys_traced_ = 0;  // EMCY messages received up to the last trace record
  core::Vec3 last_feedback_force_ = core::Vec3::Zero();  // sent the period before (N)
  DivergenceMonitor divergence_;  // judged after each period's measurements
};

/// Fills what a run's summary says of its scene, whichever runner runs it: name, coupling,
/// integrator, dt, the scene's warnings and trocar note, the numbers of bodies, joints, nets
/// and net nodes.
void describe_scene(const Scene& scene, RunSummary& s);

/// Runs `scene` for options.duration_s (or the scene's duration) and judges it
/// (RunSummary::exit_status, run_verdict()).
/// Throws std::runtime_error if the trace cannot be written.
RunSummary run_scene(const Scene& scene, const RunOptions& options);

/// Readable multi-line summary: the layout of run_summary_text.hpp, whose placeholders are
/// figures of run_figures() (run_summary_text.cpp).
std::string format_summary(const RunSummary& s);
/// Exactly one JSON object (no trailing newline): every figure of run_figures() in the table's
/// order, dotted names as nested objects, non-finite numbers as null (run_summary_json.cpp).
std::string format_summary_json(const RunSummary& s);

}  // namespace numen::sim
