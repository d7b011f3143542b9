#pragma once
/// @file admittance_run.hpp
/// The run harness (RunHarness) wired for a scene with an admittance device (`coupling =
/// "admittance"`, `[device.admittance]`; paper Fig. 2 note): a SimBus, a hal::AdmittanceEmulator on its
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
/// The harness (the data, the loop over the rig, multirate, trace, view, divergence) is
/// RunHarness's; this wiring adds the emulator, the hand and the admittance figures. The
/// constructor allocates; period() never allocates, throws or locks (tested).

#include <cstdint>
#include <memory>
#include <vector>

#include "numen/core/data.hpp"
#include "numen/hal/device/admittance_device.hpp"
#include "numen/hal/emulation/admittance_emulator.hpp"
#include "numen/sim/device/admittance_hand.hpp"
#include "numen/sim/run/run_harness.hpp"
#include "numen/sim/run/run_summary.hpp"
#include "numen/sim/scene/scene.hpp"

namespace numen::sim {

/// The run harness wired for a scene with an admittance device (see the file comment).
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
  /// Ends the loop and its rig before the emulator and the hand.
  ~AdmittanceRunner() override;

  /// Runs control period k (see the file comment) and its measurements, and publishes it to
  /// the state stream if stream_view() was called. `deadline_mono_ns` / `woke_mono_ns`: a paced
  /// run's platform::Wakeup (CLOCK_MONOTONIC), for the loop's statistics and overrun verdict
  /// (ControlLoop::begin_period); < 0: this call's time.
  void period(std::int64_t deadline_mono_ns = -1,
              std::int64_t woke_mono_ns = -1) noexcept override;
  /// Stops the scene thread (if any), delivers and closes the state stream (if any). Idempotent.
  void finish() override;
  /// The summary of the periods run so far (RunSummary::admittance filled in; wall time is the
  /// caller's).
  RunSummary summary() const override;

  const hal::AdmittanceEmulator& emulator() const noexcept { return emulator_; }
  hal::AdmittanceEmulator& emulator() noexcept { return emulator_; }
  /// Where the hand was at the last period (the controlled frame's target, world).
  const core::Pose& hand_pose() const noexcept { return hand_; }
  /// Deepest contact of the held body at the hand's pose in the last period (m).
  double hand_penetration() const noexcept { return hand_pen_; }
  /// Deepest contact of the held body (the god-object) in the last period (m).
  double tool_penetration() const noexcept { return tool_pen_; }
  // The trace (RunHarness::trace()) has one record per period (if a capacity was given): the
  // target is the hand's pose, the feedback the measured wrench that drove the god-object, no
  // axis columns (no torque is sent), step time that of the loop's step. The divergence
  // monitor's latch (diverged()) stops the run after its period: the emulated device lives on
  // the simulated bus only, nothing is sent after the run.

 private:
  AdmittanceHand hand_motion_;  // the emulator's motion: drive lag and the hand's spring
  hal::AdmittanceEmulator emulator_;
  // The device's kinematics (the hand's pose from the trajectory's axes) and its axes at the
  // held body's initial pose: where the device's set-points, the emulator and the hand start.
  std::unique_ptr<const hal::Kinematics> kinematics_;
  hal::AxisVector start_axes_;
  core::Data ghost_;  // the held body placed at the hand, for measurement
  core::Pose hand_;
  double hand_pen_ = 0.0;
  double tool_pen_ = 0.0;
  double error_sq_ = 0.0;
  platform::PeriodReport view_report_;    // the frame's header and wrench (admittance meaning)
  std::vector<double> view_axis_values_;  // the frame's axis field: zeros (no torque is sent)
};

}  // namespace numen::sim
