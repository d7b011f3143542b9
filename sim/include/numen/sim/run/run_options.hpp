#pragma once
/// @file run_options.hpp
/// How to run a scene (`numen run`'s options): the controller's bus, pacing, trace, real-time
/// setup, state stream, stop and re-arm requests; and the checks that refuse options a run
/// would not apply.

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "numen/platform/multirate_threads.hpp"
#include "numen/platform/realtime_setup.hpp"

namespace numen::platform {
class StateFrameSink;
}  // namespace numen::platform

namespace numen::sim {

struct Scene;

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
/// whose trace would take more, before allocating it. 1 GiB: ~2.5 million periods, 41 min at 1 kHz.
inline constexpr std::size_t kMaxInMemoryTraceBytes = std::size_t{1} << 30;

/// The capacity (records) of the in-memory trace of a simulated run of `periods` periods, for
/// run_scene() (either kind of device). Throws InputError (key "--trace", the periods and
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
  /// A multirate scene's scene thread in a paced run (scheduling, CPUs, spin; docs/multirate.md):
  /// paced runs step the scene loop on it, offline runs interleave both loops on one thread.
  platform::SceneThreadSettings scene_thread;
  /// Timer slack (ns) that a paced run gives its loop thread and its scene thread
  /// (prctl(PR_SET_TIMERSLACK), `--timer-slack`), whatever their scheduling policy: the
  /// kernel's default of 50 µs lets a SCHED_OTHER thread's timer fire up to that late
  /// (docs/realtime.md "Timer slack"). 1 (the minimum) by default; 0 leaves the kernel's.
  /// Offline runs leave it.
  std::int64_t timer_slack_ns = 1;
  /// PM QoS CPU latency (µs) that a paced run requests for as long as it runs
  /// (platform::CpuLatencyRequest on /dev/cpu_dma_latency, `--cpu-dma-latency`), as cyclictest
  /// does: 0 (the default) keeps idle CPUs polling instead of halting, so that the loop's timer
  /// does not wait for a halted CPU to come back (on an idle virtual machine it halved the
  /// wake-up latency: docs/realtime.md "CPU latency"). < 0 (`--no-cpu-dma-latency`) leaves the
  /// host's. Offline runs leave it. Without the privilege the step is reported as failed (fatal
  /// with rt.strict).
  std::int32_t cpu_dma_latency_us = 0;
  /// Paced run: the loop thread's period wait ends in a busy-wait of this long before each
  /// deadline (ns, `--spin`; platform::PeriodicTimer::set_spin_ns); 0 (default): it sleeps to
  /// the deadline. For a loop thread on a CPU of its own (rt.cpu_affinity, `--cpu`) on a
  /// kernel without PREEMPT_RT: check_run_options() refuses it otherwise, and at or above dt.
  std::int64_t spin_ns = 0;
  /// Set (e.g. by a SIGINT / SIGTERM / SIGHUP handler) to end the run early and cleanly: the loop
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

/// Refuses options that a run of `scene` would not apply or whose outputs it could not write,
/// before anything is opened (InputError naming the option): --view-rate not > 0, --speed
/// negative or not finite or with a paced run or pacing the run past kMaxRunDuration of wall
/// time, --rt-priority in an offline run, --timer-slack above dt in a paced run, a --duration
/// shorter than half a period,
/// --phase not below dt, an in-memory --trace over kMaxInMemoryTraceBytes, a --spin in an
/// offline run, without --cpu or not below dt, a --timer-slack in an offline run, a scene thread
/// (--scene-rt-priority, --scene-cpu, --scene-spin) that the run would not start or that would
/// pre-empt the device loop, a --scene-spin without --scene-cpu or not below scene_dt, an output path (--trace, --record, --record-view) that cannot be opened for
/// writing, and an output on the regular file of another output, of the scene file or of the
/// `--bus log:` log (it would replace it). Touches no file: a refused run leaves every file as
/// it was (docs/inputs.md, "Outputs").
void check_run_options(const Scene& scene, const RunOptions& options);

}  // namespace numen::sim
