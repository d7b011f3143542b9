#pragma once
/// @file run_harness.hpp
/// sim::RunHarness: what run_scene()'s one period loop (run.cpp) drives, for both kinds of
/// device — a scene wired for a run over a platform::DeviceRig and the platform::ControlLoop
/// that runs it (SceneRunner: impedance instruments, run.hpp; AdmittanceRunner: an admittance
/// device, admittance_run.hpp). The loop paces the periods (or runs them as fast as possible),
/// hears the stop and re-arm requests, starts the scene thread and the state stream, and
/// writes the summary and the trace the same way for either. Setup members allocate and may
/// throw; period() never allocates, throws or locks.

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "numen/platform/control_loop.hpp"
#include "numen/platform/multirate_threads.hpp"
#include "numen/platform/state_stream.hpp"
#include "numen/sim/run/multirate_run.hpp"
#include "numen/sim/run/run_summary.hpp"
#include "numen/sim/run/trace.hpp"

namespace numen::sim {

/// A scene wired for a run, seen by run_scene()'s period loop (see the file comment). Not
/// copied; one thread runs the periods.
class RunHarness {
 public:
  virtual ~RunHarness() = default;
  RunHarness(const RunHarness&) = delete;
  RunHarness& operator=(const RunHarness&) = delete;

  /// Runs the next control period (bus time k·dt) and its measurements. `deadline_mono_ns` /
  /// `woke_mono_ns`: a paced run's platform::Wakeup (CLOCK_MONOTONIC); < 0: not paced.
  virtual void period(std::int64_t deadline_mono_ns = -1,
                      std::int64_t woke_mono_ns = -1) noexcept = 0;
  /// The divergence monitor latched: the run stops after this period.
  virtual bool diverged() const noexcept = 0;
  /// The control loop over the harness's rig (re-arm, shutdown, the drives' state).
  virtual platform::ControlLoop& loop() noexcept = 0;
  /// Overrides the scene's compute phase (ns after the SYNC, >= 0; `numen run --phase`).
  virtual void set_compute_phase_ns(std::int64_t ns) noexcept = 0;
  /// A multirate scene in a paced run: steps the scene loop on its own thread from now on
  /// until finish(); nothing for a single-rate scene. Allocates; throws std::system_error if
  /// the thread cannot start.
  virtual void start_scene_thread(const platform::SceneThreadSettings& settings) = 0;
  /// Publishes the state stream (docs/viewer.md) to a view recording at `record_path` (empty:
  /// none) and to `sinks` (not owned) at `rate_hz` frames per simulated second; `wait`: the
  /// loop waits for the consumers, else drops. Throws InputError at --record-view when the
  /// file cannot be created.
  virtual void stream_view(const std::string& record_path,
                           std::vector<platform::StateFrameSink*> sinks, double rate_hz,
                           bool wait) = 0;
  /// Ends the run's threads and streams (idempotent; after the last period).
  virtual void finish() = 0;
  /// The summary of the periods run so far (wall time and the loop's tallies are the caller's).
  virtual RunSummary summary() const = 0;
  /// The in-memory trace (empty without a capacity).
  virtual const Trace& trace() const noexcept = 0;
  /// The multirate god-object (enabled() false in a single-rate run) and its scene thread.
  virtual const MultirateRun& multirate() const noexcept = 0;

 protected:
  RunHarness() = default;
};

}  // namespace numen::sim
