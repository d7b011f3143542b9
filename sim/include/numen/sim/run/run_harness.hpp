#pragma once
/// @file run_harness.hpp
/// sim::RunHarness: the one run harness behind run_scene() (run.cpp), for both kinds of device.
/// It owns what every run has — the scene's core::Data, the simulated bus, the loop's devices
/// assembled in a platform::DeviceRig and the platform::ControlLoop that runs them, the
/// multirate god-object as the loop's stepper, the trace, the state stream, the divergence
/// monitor, the period count and the summary's running figures — and what the period loop
/// asks of it. A device kind's wiring derives from it and adds what lies on the far side of
/// the bus and what only that kind measures: SceneRunner (impedance instruments: emulated
/// instruments, a real bus, a log replay or a tracker; run.hpp), AdmittanceRunner (an
/// admittance device: its emulator and the hand that pushes it; admittance_run.hpp). The
/// period loop (run_scene()) paces the periods (or runs them as fast as possible), hears the
/// stop and re-arm requests, starts the scene thread and the state stream, and writes the
/// summary and the trace the same way for either. Setup members allocate and may throw;
/// period() never allocates, throws or locks.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "numen/core/data.hpp"
#include "numen/hal/transport/sim_bus.hpp"
#include "numen/platform/control_loop.hpp"
#include "numen/platform/device_rig.hpp"
#include "numen/platform/multirate_threads.hpp"
#include "numen/platform/state_stream.hpp"
#include "numen/sim/run/divergence.hpp"
#include "numen/sim/run/multirate_run.hpp"
#include "numen/sim/run/run_summary.hpp"
#include "numen/sim/run/trace.hpp"
#include "numen/sim/scene/scene.hpp"
#include "numen/sim/view/view_output.hpp"

namespace numen::sim {

/// The run harness of a scene (see the file comment). Not copied; one thread runs the periods.
class RunHarness {
 public:
  virtual ~RunHarness();
  RunHarness(const RunHarness&) = delete;
  RunHarness& operator=(const RunHarness&) = delete;

  /// Runs the next control period (bus time k·dt) and its measurements. `deadline_mono_ns` /
  /// `woke_mono_ns`: a paced run's platform::Wakeup (CLOCK_MONOTONIC); < 0: not paced.
  virtual void period(std::int64_t deadline_mono_ns = -1,
                      std::int64_t woke_mono_ns = -1) noexcept = 0;
  /// Ends the run's threads and streams (idempotent; after the last period).
  virtual void finish() = 0;
  /// The summary of the periods run so far (wall time and the loop's tallies are the caller's).
  virtual RunSummary summary() const = 0;

  /// The divergence monitor latched (divergence.hpp): the run stops after this period.
  bool diverged() const noexcept { return divergence_.divergence().cause != nullptr; }
  /// The control loop over the harness's rig (lifecycle, supervisor, statistics, rearm(),
  /// shutdown()).
  platform::ControlLoop& loop() noexcept { return *loop_; }
  const platform::ControlLoop& loop() const noexcept { return *loop_; }
  /// What the control loop did in the last period (device 0; step wall time included).
  const platform::PeriodReport& last_report() const noexcept { return loop_->last_report(); }
  /// Overrides the scene's compute phase (ns after the SYNC, >= 0; `numen run --phase`): when
  /// the loop reads the device's answers and steps.
  void set_compute_phase_ns(std::int64_t ns) noexcept { phase_ns_ = ns; }
  /// A multirate scene in a paced run: steps the scene loop on its own thread
  /// (platform::MultirateThreads, `settings`) from now on until finish(); nothing for a
  /// single-rate scene. Allocates (call before the first period); throws std::system_error if
  /// the thread cannot start.
  void start_scene_thread(const platform::SceneThreadSettings& settings);
  /// Publishes the run's state stream (docs/viewer.md) to a view recording at `record_path`
  /// (empty: none) and to `sinks` (not owned) at `rate_hz` frames per simulated second; `wait`:
  /// the loop waits for the consumers (offline runs), else drops. Starts the stream's thread.
  /// Setup only; throws InputError at --record-view when the file cannot be created.
  void stream_view(const std::string& record_path, std::vector<platform::StateFrameSink*> sinks,
                   double rate_hz, bool wait);
  /// Periods run so far.
  std::int64_t periods() const noexcept { return k_; }
  /// The scene's state as the loop's last step left it.
  const core::Data& data() const noexcept { return data_; }
  /// The simulated bus (the controller's port and the emulated device's side).
  hal::SimBus& bus() noexcept { return bus_; }
  /// The in-memory trace (empty without a capacity).
  const Trace& trace() const noexcept { return trace_; }
  /// The multirate god-object (MultirateRun::enabled() false in a single-rate run) and its
  /// scene thread; read the thread's realtime_report() after finish().
  const MultirateRun& multirate() const noexcept { return multirate_; }

 protected:
  /// `scene` must outlive the harness; `trace_capacity` trace records are reserved (0: no
  /// trace). The rig and the loop come with assemble(), from the derived wiring's constructor.
  RunHarness(const Scene& scene, std::size_t trace_capacity);
  /// Assembles the loop's devices (`rig_args`: platform::DeviceRig's constructor arguments,
  /// impedance instruments or an admittance device) and the loop over them with `settings`;
  /// a multirate scene's god-object becomes the loop's stepper (ControlLoop::set_stepper()).
  /// Allocates; throws as those constructors do.
  template <class... RigArgs>
  void assemble(const platform::ControlLoopSettings& settings, RigArgs&&... rig_args) {
    rig_.emplace(std::forward<RigArgs>(rig_args)...);
    loop_.emplace(scene_->model, data_, *rig_, settings);
    if (multirate_.enabled()) loop_->set_stepper(&multirate_);
  }
  /// Ends the scene thread, the loop and the rig: first in a derived wiring's destructor, while
  /// the devices and buses the rig refers to still live.
  void disassemble() noexcept;
  /// Into `s`, what any run's summary takes from its periods and the scene's state: steps and
  /// simulated time, the loop's step time, the solver's mean iterations, the non-finite,
  /// invalid-target and contact-overflow steps, a non-finite state (nan_detected) and the
  /// simulated bus's dropped and corrupted frames. Adds no warning.
  void summarize_periods(RunSummary& s) const;

  const Scene* scene_;
  hal::SimBus bus_;
  core::Data data_;
  std::optional<platform::DeviceRig> rig_;    // the loop's devices (assemble())
  std::optional<platform::ControlLoop> loop_;  // the loop over rig_ (assemble())
  /// The multirate god-object (scene [multirate]), stepped in place of core::step by the loop
  /// (its platform::Stepper); not enabled in a single-rate run.
  MultirateRun multirate_;
  Trace trace_;                       // --trace (in memory)
  std::unique_ptr<ViewOutput> view_;  // --record-view, --view
  DivergenceMonitor divergence_;      // judged after each period's measurements
  RunSummary acc_;                    // running maxima and counts
  std::int64_t k_ = 0;                // periods run
  std::int64_t period_ns_;            // model.dt
  std::int64_t phase_ns_;             // when the loop reads and steps, after the SYNC
  std::int64_t solver_iterations_sum_ = 0;
};

}  // namespace numen::sim
