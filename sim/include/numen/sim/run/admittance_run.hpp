#pragma once
/// @file admittance_run.hpp
/// The run harness of a scene with an admittance device (`coupling = "admittance"`,
/// `[device.admittance]`; paper Fig. 2 note): a SimBus, a hal::AdmittanceEmulator on its
/// device port (the position-controlled device and its force sensor, pushed by a simulated
/// hand that follows the scene trajectory), a hal::AdmittanceDevice in a platform::DeviceRig
/// and the platform::ControlLoop that runs the rig on its controller port. run_scene() dispatches here.
/// One period (bus time t = k·dt):
///   t            controller: SYNC
///   t + latency  device: the drives advance to their targets, the hand's wrench is measured,
///                two sensor TPDOs
///   t + phase    controller: read, check, measured wrench → core::step → IK → csp RPDOs
///                (taken by the drives before the next SYNC)
/// With [multirate] (docs/multirate.md) the loop's core::step is the multirate god-object's
/// device period (MultirateRun), the scene loop interleaved every N periods or, in a paced
/// run, on its own thread (start_scene_thread()).
/// The constructor allocates; period() never allocates, throws or locks (tested).

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "numen/core/data.hpp"
#include "numen/hal/device/admittance_device.hpp"
#include "numen/hal/emulation/admittance_emulator.hpp"
#include "numen/sim/device/admittance_hand.hpp"
#include "numen/hal/transport/sim_bus.hpp"
#include "numen/platform/control_loop.hpp"
#include "numen/platform/device_rig.hpp"
#include "numen/platform/latency_histogram.hpp"
#include "numen/platform/multirate_threads.hpp"
#include "numen/sim/run/divergence.hpp"
#include "numen/sim/run/multirate_run.hpp"
#include "numen/sim/run/run_harness.hpp"
#include "numen/sim/run/run_options.hpp"
#include "numen/sim/run/run_summary.hpp"
#include "numen/sim/scene/scene.hpp"
#include "numen/sim/run/trace.hpp"
#include "numen/sim/view/view_output.hpp"

namespace numen::sim {

/// A scene with an admittance device wired for a run.
class AdmittanceRunner final : public RunHarness {
 public:
  /// `scene` (with Scene::admittance set) must outlive the runner. The device starts at the
  /// held body's initial pose (inverse kinematics), the hand at the trajectory's first sample.
  /// `trace_capacity` trace records are reserved (0: no trace; a full trace counts its drops).
  /// `overrun_limit`: consecutive overrun periods that latch the safe state
  /// (hal::AdmittanceSettings::overrun_limit; 0: counted only). Throws std::invalid_argument if
  /// the scene has no admittance device.
  explicit AdmittanceRunner(const Scene& scene, std::size_t trace_capacity = 0,
                            std::uint32_t overrun_limit = 0);

  /// Runs control period k (see the file comment) and its measurements, and publishes it to
  /// the state stream if stream_view() was called. `deadline_mono_ns` / `woke_mono_ns`: a paced
  /// run's platform::Wakeup (CLOCK_MONOTONIC), for the loop's statistics and overrun verdict
  /// (ControlLoop::begin_period); < 0: this call's time.
  void period(std::int64_t deadline_mono_ns = -1,
              std::int64_t woke_mono_ns = -1) noexcept override;
  /// Publishes the run's state stream (docs/viewer.md, "Admittance runs") to a view recording
  /// at `record_path` (empty: none) and to `sinks` (not owned), at `rate_hz` frames per
  /// simulated second; `wait`: the loop waits for the consumers, else drops. Setup only; throws
  /// InputError at --record-view when the file cannot be created.
  void stream_view(const std::string& record_path, std::vector<platform::StateFrameSink*> sinks,
                   double rate_hz, bool wait) override;
  /// A multirate scene in a paced run: steps the scene loop on its own thread from now on
  /// (MultirateRun::start_scene_thread()) until finish(); nothing for a single-rate scene.
  /// Allocates (call before the first period). Throws std::system_error if the thread cannot
  /// start.
  void start_scene_thread(const platform::SceneThreadSettings& settings) override;
  /// Stops the scene thread (if any), delivers and closes the state stream (if any). Idempotent.
  void finish() override;
  /// Overrides the scene's compute phase (ns after the SYNC, >= 0): when the loop reads the
  /// sensor's answers and steps (`numen run --phase`).
  void set_compute_phase_ns(std::int64_t ns) noexcept override { phase_ns_ = ns; }
  /// Periods run so far.
  std::int64_t periods() const noexcept { return k_; }
  /// The summary of the periods run so far (RunSummary::admittance filled in; wall time is the
  /// caller's).
  RunSummary summary() const override;

  const core::Data& data() const noexcept { return data_; }
  const hal::AdmittanceEmulator& emulator() const noexcept { return emulator_; }
  hal::AdmittanceEmulator& emulator() noexcept { return emulator_; }
  const platform::ControlLoop& loop() const noexcept { return loop_; }
  platform::ControlLoop& loop() noexcept override { return loop_; }
  /// The multirate god-object (enabled() false in a single-rate run) and its scene thread.
  const MultirateRun& multirate() const noexcept override { return multirate_; }
  /// Where the hand was at the last period (the controlled frame's target, world).
  const core::Pose& hand_pose() const noexcept { return hand_; }
  /// Deepest contact of the held body at the hand's pose in the last period (m).
  double hand_penetration() const noexcept { return hand_pen_; }
  /// Deepest contact of the held body (the god-object) in the last period (m).
  double tool_penetration() const noexcept { return tool_pen_; }
  /// One record per period (if a capacity was given): the target is the hand's pose, the
  /// feedback the measured wrench that drove the god-object, no axis columns (no torque is
  /// sent), step time that of the loop's step.
  const Trace& trace() const noexcept override { return trace_; }
  /// The divergence monitor latched (divergence.hpp): the run stops after this period (the
  /// emulated device lives on the simulated bus only; nothing is sent after the run).
  bool diverged() const noexcept override { return divergence_.divergence().cause != nullptr; }

 private:
  const Scene* scene_;
  hal::SimBus bus_;
  AdmittanceHand hand_motion_;  // the emulator's motion: drive lag and the hand's spring
  hal::AdmittanceEmulator emulator_;
  // The device's kinematics (the hand's pose from the trajectory's axes) and its axes at the
  // held body's initial pose: where the device's set-points, the emulator and the hand start.
  std::unique_ptr<const hal::Kinematics> kinematics_;
  hal::AxisVector start_axes_;
  platform::DeviceRig rig_;  // the admittance device, assembled in the rig the loop runs
  core::Data data_;
  core::Data ghost_;  // the held body placed at the hand, for measurement
  platform::ControlLoop loop_;
  /// Stepped in place of core::step by the loop (its platform::Stepper, ControlLoop::set_stepper()) with
  /// [multirate]; not enabled in a single-rate run.
  MultirateRun multirate_;
  platform::LatencyHistogram step_time_;
  std::int64_t k_ = 0;
  std::int64_t period_ns_;
  std::int64_t phase_ns_;
  core::Pose hand_;
  double hand_pen_ = 0.0;
  double tool_pen_ = 0.0;
  double error_sq_ = 0.0;
  double solver_iterations_sum_ = 0.0;
  RunSummary acc_;  // first_fault* set at the first latched safe state
  std::unique_ptr<ViewOutput> view_;      // --record-view, --view
  platform::PeriodReport view_report_;    // the frame's header and wrench (admittance meaning)
  std::vector<double> view_axis_values_;  // the frame's axis field: zeros (no torque is sent)
  Trace trace_;                           // --trace
  DivergenceMonitor divergence_;          // judged after each period's measurements
};

}  // namespace numen::sim
