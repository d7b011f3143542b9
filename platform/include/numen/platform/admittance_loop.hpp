#pragma once
/// @file admittance_loop.hpp
/// One control period of an admittance device (paper Fig. 2 note; docs/dynamics.md
/// "Admittance devices", docs/protocol.md):
///   begin_period: SYNC on the bus;
///   end_period:   read every pending frame → force sensor TPDOs → check (fresh, in range)
///                 → DeviceLifecycle (a force reading missing or rejected for
///                 force_timeout_periods, out of range, or overrun_limit consecutive
///                 overrun periods latch the safe state)
///                 → data.device_wrench = the measured wrench in the world, about the held
///                 body's COM (sensor frame → world through the forward kinematics of the
///                 set-points) → core::step (CouplingMode::kAdmittance), or the step
///                 function set_step_function() installed (the multirate device period)
///                 → the held body's pose → inverse kinematics → csp RPDOs (controlword
///                 enable operation + target position) on the bus.
/// Outside kActive the drives get controlword shutdown (0x0006, CiA 402: operation disabled)
/// with the set-points held, and the god-object is braked to rest (no measured force drives
/// it). Construction may allocate and throws; begin_period / end_period / rearm never
/// allocate, throw, lock or block.

#include <cstdint>

#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/hal/device/admittance_device.hpp"
#include "numen/hal/transport/bus.hpp"
#include "numen/hal/canopen/device_lifecycle.hpp"

namespace numen::platform {

/// Creation settings of an AdmittanceLoop.
struct AdmittanceLoopSettings {
  /// Consecutive periods without a valid force reading that latch the safe state, >= 1 (the
  /// last accepted reading drives the god-object meanwhile).
  std::uint32_t force_timeout_periods = 3;
  /// LifecycleSettings::safe_stop_timeout_periods, >= 1.
  std::uint32_t safe_stop_timeout_periods = 100;
  /// Activate on its own in the first period with a valid reading (else call activate()).
  bool auto_activate = true;
  /// Consecutive overrun periods (end_period's `overran`) that latch the safe state, as the
  /// impedance loop's hal::DeviceSettings::overrun_limit; 0: overruns are counted, never
  /// latched (offline runs, where there is no deadline to miss).
  std::uint32_t overrun_limit = 0;
};

/// What latched an admittance loop's safe state (docs/safety.md).
enum class AdmittanceFaultCause : std::uint8_t {
  kNone,             ///< Nothing latched.
  kForceOutOfRange,  ///< A force/torque reading outside the sensor's range (SampleFault).
  kForceTimeout,     ///< No valid force reading for force_timeout_periods.
  kOverruns,         ///< overrun_limit consecutive control periods overran.
};

/// Short English name of an AdmittanceFaultCause (static string), e.g. "force reading timeout".
const char* to_string(AdmittanceFaultCause cause) noexcept;

/// What one period did.
struct AdmittanceReport {
  int frames_read = 0;            ///< Frames taken from the bus.
  bool sample_valid = false;      ///< The force reading was fresh and in range this period.
  hal::FaultMask faults = 0;      ///< The reading's SampleFault bits.
  core::Wrench measured;          ///< The wrench given to the god-object (world, about its COM).
  bool driven = false;            ///< The measured wrench drove the held body this period.
  std::uint16_t controlword = 0;  ///< Sent with the set-points.
  hal::IoStatus command_status = hal::IoStatus::kOk;  ///< Result of the RPDO writes.
  std::int64_t step_ns = 0;  ///< Wall time of core::step (CLOCK_MONOTONIC ns).
  hal::LifecycleState lifecycle = hal::LifecycleState::kUnconfigured;  ///< After this period.
  bool entered_safe_stop = false;  ///< The safe state latched in this period.
  /// What latched it (kNone unless entered_safe_stop); several at once: the first of
  /// out of range, timeout, overruns.
  AdmittanceFaultCause cause = AdmittanceFaultCause::kNone;
  bool overran = false;            ///< end_period() was told this period overran.
  bool activated = false;          ///< kInactive → kActive in this period.
};

/// Counters since construction.
struct AdmittanceLoopCounters {
  std::uint64_t periods = 0;              ///< end_period() calls.
  std::uint64_t sync_write_failures = 0;  ///< SYNC writes not accepted.
  std::uint64_t read_errors = 0;          ///< Bus reads that returned kError.
  std::uint64_t ignored_frames = 0;       ///< Frames that were not the sensor's.
  std::uint64_t invalid_periods = 0;      ///< Periods without a valid reading.
  std::uint64_t command_failures = 0;     ///< Periods whose RPDO writes did not all succeed.
  std::uint64_t hold_periods = 0;         ///< Periods not in kActive (drives disabled, braked).
  std::uint64_t overruns = 0;             ///< Periods end_period() was told overran.
};

/// The control loop of one admittance device driving one core::Data.
/// Not thread safe: one real-time thread owns it.
class AdmittanceLoop {
 public:
  /// Keeps references (all must outlive the loop). Throws std::invalid_argument if the model's
  /// coupling mode is not kAdmittance or a setting is 0. Configures the lifecycle
  /// (kUnconfigured → kInactive). The device's set-points are not touched.
  AdmittanceLoop(const core::Model& model, core::Data& data, hal::Bus& bus,
                 hal::AdmittanceDevice& device, const AdmittanceLoopSettings& settings = {});

  /// Starts a period: SYNC (COB-ID 0x080, counter 1..240) stamped `now_ns` (bus clock).
  void begin_period(std::int64_t now_ns) noexcept;
  /// Ends the period at bus time `now_ns` (see the file comment). `overran`: the previous
  /// period ran past this one's deadline (platform::Wakeup::overrun of a paced loop, as the
  /// impedance loop supervises its last period's overrun); overrun_limit of them in a row latch
  /// the safe state, a period without one resets the streak.
  const AdmittanceReport& end_period(std::int64_t now_ns, bool overran = false) noexcept;

  /// kInactive → kActive now (refused while the reading is invalid).
  hal::LifecycleResult activate() noexcept { return lifecycle_.activate(); }
  /// kFault → kInactive once the reading is valid again; auto_activate then follows.
  hal::LifecycleResult rearm() noexcept { return lifecycle_.rearm(); }

  /// A function of a context pointer that advances the loop's Data by one control period.
  using StepFunction = void (*)(void* context) noexcept;
  /// What end_period() calls instead of core::step(model, data): `step(context)`, which
  /// advances the loop's Data by one control period as core::step() would — reads
  /// data.device_wrench (the measured wrench or the brake), leaves the held body's state in
  /// data.bodies — e.g. the multirate god-object's device period (core::MultirateGodObject::
  /// take_targets(), step(), write_feedback(); docs/multirate.md). Null restores core::step.
  /// Must not allocate, throw, lock or block: it runs in the real-time period. Not while
  /// end_period() runs. (ControlLoop::set_step_function is the impedance loop's.)
  void set_step_function(StepFunction step, void* context) noexcept {
    step_function_ = step;
    step_context_ = context;
  }

  const hal::DeviceLifecycle& lifecycle() const noexcept { return lifecycle_; }
  const AdmittanceLoopCounters& counters() const noexcept { return counters_; }
  const AdmittanceReport& last_report() const noexcept { return report_; }

 private:
  void brake_held_body() noexcept;

  const core::Model* model_;
  core::Data* data_;
  hal::Bus* bus_;
  hal::AdmittanceDevice* device_;
  AdmittanceLoopSettings settings_;
  hal::DeviceLifecycle lifecycle_;
  bool disable_sent_ = false;  // controlword shutdown sent since the last kActive period
  std::uint8_t sync_counter_ = 0;
  std::uint32_t overrun_streak_ = 0;  // consecutive periods told they overran
  AdmittanceReport report_;
  AdmittanceLoopCounters counters_;
  StepFunction step_function_ = nullptr;  // null: core::step
  void* step_context_ = nullptr;
};

}  // namespace numen::platform
