#pragma once
/// @file control_loop.hpp
/// One control period of numen (docs/encoder-path.md; docs/protocol.md), the same for every
/// protocol and both kinds of device, through hal::Device. An impedance device (hal::ImpedanceDevice):
///   begin_period: Device::begin_period — SYNC (+ the managed stack's NMT command due and
///                 controller heartbeat);
///   end_period:   Device::read (frames → decode → check → forward kinematics)
///                 → Device::supervise (managed: watchdogs, lifecycle; a fault latches zero
///                 torque now) → bound bodies' targets into core::Data → core::step
///                 → map: the bound bodies' Eq. 8 wrenches carried to their links (Eq. 9),
///                 τ = Σ_l J_lᵀ w_l → ImpedanceDevice::write (gate and clamp, once; the torque frames).
/// The period is a fixed list of free-function stages over one PeriodData (period_stages.hpp,
/// period_data.hpp), and the device is seen through one face: Device::read() returns a
/// hal::DeviceState, Device::write() takes a hal::DeviceCommand (device_state.hpp).
/// An admittance device (hal::AdmittanceDevice; paper Fig. 2 note; docs/dynamics.md
/// "Admittance devices", docs/protocol.md "Admittance devices"):
///   begin_period: Device::begin_period — SYNC;
///   end_period:   Device::read (force sensor TPDOs → the checked reading) → Device::supervise
///                 (force timeout, out of range, overruns latch the safe state)
///                 → data.device_wrench = the measured wrench in the world, about the held
///                 body's COM (in kActive), else a brake that halves the held body's twist
///                 each step → core::step (CouplingMode::kAdmittance) → the held body's pose
///                 → AdmittanceDevice::write → write_pose (inverse kinematics, csp RPDOs; the
///                 set-points held with controlword shutdown outside kActive).
/// The devices are assembled in one place, a platform::DeviceRig (device_rig.hpp: the devices,
/// their shared buses and NMT masters, their bindings), the caller's or one the loop builds; the
/// kind and protocol (DeviceConfig::canopen.managed) are chosen once, at construction
/// (hal::make_device(); the stage list, DeviceRig::kind()); no period branches on them. A loop may run several
/// impedance devices (at most kMaxLoopDevices; LoopDevice), on one bus or on several, each with
/// its binding to the bodies it drives, its own supervision and its own safe state; each stage
/// runs over every device, the step once (period_stages.hpp), and one device's safe state
/// latches the others' (docs/safety.md "Several devices"). The same object runs against SimBus in
/// simulation and SocketCAN on hardware. Construction may allocate; begin_period / end_period /
/// rearm never allocate, throw, lock or block.

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/hal/transport/bus.hpp"
#include "numen/hal/transport/bus_share.hpp"
#include "numen/hal/device/device.hpp"
#include "numen/hal/device/device_status.hpp"
#include "numen/hal/device/impedance_device.hpp"
#include "numen/hal/device/instrument_device.hpp"
#include "numen/platform/device_binding.hpp"
#include "numen/platform/device_rig.hpp"
#include "numen/platform/latency_histogram.hpp"
#include "numen/platform/loop_statistics.hpp"
#include "numen/platform/period_data.hpp"
#include "numen/platform/period_stages.hpp"
#include "numen/platform/stepper.hpp"

namespace numen::platform {

/// Creation settings of a ControlLoop (the managed stack's supervision; the minimal protocol
/// uses none of them but the statistics).
/// The device's supervision settings (hal::ImpedanceSettings: encoder timeout, overrun limit,
/// safe-stop timeout, auto-activation, drive settings; kept there once and handed to
/// hal::make_device() as they are) and the loop's own.
struct ControlLoopSettings : hal::ImpedanceSettings {
  /// Feed LoopStatistics' overrun verdict to the supervisor. Only meaningful when periods are
  /// paced to a clock (a simulation run as fast as possible has no deadlines).
  bool supervise_overruns = false;
  /// Bring each device's bound bodies to their targets at its first ready sample: each bound
  /// body's pose is set to its link's target and its twist to the target's (the held body's too),
  /// before that period's step. A live input (an OpenIGTLink tracker, a real device) starts
  /// wherever the instrument lies, not where the scene's recording starts: without this its
  /// springs would pull the god-object across the gap in one swing (a tracker turned 90° and
  /// 100 mm away: 14 m/s). ControlLoop::placed_period() says when. Off: the bodies start where
  /// the scene put them. Not for a multirate stepper (its god-object is its own copy).
  bool place_at_first_sample = false;
  /// When a device's samples come back after going stale (a tracker that stalled, encoders
  /// silent for longer than max_sample_age: the instrument moved while nothing was known of it),
  /// bring each of its bound bodies' targets from where it was held to the resumed sample's over
  /// the device's soft start (DeviceConfig::soft_start_s; 0: at once) on a smoothstep
  /// r = 3s² − 2s³ (position lerped, orientation slerped, the twist the glide's plus r times the
  /// sample's; its prescribed joints likewise), and ramp its feedback in again from zero over
  /// the same time (hal::Device::ramp_feedback_again()). Off: the target steps to the resumed
  /// pose in one period and the feedback comes back at once. ControlLoop::rejoins() counts them.
  bool rejoin_after_stale = false;
};

/// Result of ControlLoop::rearm() (hal::Device::rearm()).
using RearmResult = hal::RearmResult;
/// Short English name of a RearmResult (hal::to_string()).
inline const char* to_string(RearmResult result) noexcept { return hal::to_string(result); }

/// The control loop of one instrument (or several: LoopDevice) driving one core::Data.
/// Not thread safe: one real-time thread owns it. Accessors that take a device index `i`
/// (in [0, num_devices()); default 0) read that device's part.
class ControlLoop {
 public:
  /// Keeps references: `model`, `data`, `bus` and `device` must outlive the loop.
  /// `binding` says which bodies the device's links drive and which prescribed
  /// joints its axes impose (copied; the default drives the held body by
  /// link 0). Throws std::invalid_argument if a link, body, joint or axis index
  /// of the binding is out of range, a body is bound to two links, or a
  /// prescription names a joint that is not prescribed. The held body
  /// follows its own binding if it has one, else the binding with body = -1.
  /// Allocates (construction only).
  /// Builds the hal::Device of `device`'s protocol around `device` and `bus` in a rig of its
  /// own (DeviceRig: hal::make_device(): managed — CanopenMaster, SafetySupervisor, lifecycle
  /// configured to kInactive; or minimal); throws std::invalid_argument for bad settings or a device whose
  /// control_period_s is not model.dt (one period steps the model once). The LoopStatistics
  /// period is that control period.
  ControlLoop(const core::Model& model, core::Data& data, hal::Bus& bus,
              hal::InstrumentDevice& device, DeviceBinding binding = DeviceBinding::rigid(),
              const ControlLoopSettings& settings = {});
  /// The loop of `devices` (1 to kMaxLoopDevices impedance instruments, device i = devices[i])
  /// driving one `data`: each device's binding and supervision as for one device (above),
  /// plus: a body is bound by at most one device, and at most one device drives the held
  /// body through the rigid binding (LinkBinding::body = −1); every device's control period
  /// is model.dt. Devices naming the same Bus share it (LoopDevice::bus). `settings`:
  /// supervise_overruns only (each device's supervision is its LoopDevice::settings). Throws
  /// std::invalid_argument naming the device for any of these, a null bus or instrument,
  /// no device / more than kMaxLoopDevices, or managed devices on one bus whose CANopen
  /// nodes overlap or whose controller node id or heartbeat period differ (one NMT master
  /// per bus). The devices are assembled in a rig the loop owns (DeviceRig). Allocates
  /// (construction only).
  ControlLoop(const core::Model& model, core::Data& data, std::span<const LoopDevice> devices,
              const ControlLoopSettings& settings = {});
  /// The loop of an admittance device (built by the caller on its bus, with its supervision
  /// settings: hal::AdmittanceSettings); keeps references to `model`, `data` and `device`.
  /// Throws std::invalid_argument if the model's coupling mode is not kAdmittance or the
  /// device's control_period_s is not model.dt. `settings`: supervise_overruns only (the
  /// device's own settings supervise). The LoopStatistics period is that control period.
  ControlLoop(const core::Model& model, core::Data& data, hal::AdmittanceDevice& device,
              const ControlLoopSettings& settings = {});
  /// The loop of the devices `rig` assembled (device_rig.hpp; kept by reference: it must
  /// outlive the loop), of either kind: an impedance rig's devices each with the binding the
  /// rig holds and checked as for the LoopDevice constructor, an admittance rig's device as
  /// for the admittance constructor (the model's coupling mode kAdmittance). The stage list
  /// follows DeviceRig::kind(). Throws std::invalid_argument as those constructors do.
  /// Allocates (construction only).
  ControlLoop(const core::Model& model, core::Data& data, DeviceRig& rig,
              const ControlLoopSettings& settings = {});

  /// Out of line: the loop may own its rig (the constructors above that take no DeviceRig).
  ~ControlLoop();
  /// Not copied or moved: the devices' contexts point at the loop's own records.
  ControlLoop(const ControlLoop&) = delete;
  ControlLoop& operator=(const ControlLoop&) = delete;

  /// Starts period k: writes a SYNC (CANopen COB-ID 0x080) stamped `now_ns` (bus clock), one
  /// per bus; managed stack: then the NMT commands due and the controller's heartbeat when due,
  /// one NMT master per bus (its devices' commands go out after the last of them began).
  /// `deadline_mono_ns` / `woke_mono_ns` (CLOCK_MONOTONIC, from PeriodicTimer::wait_next()) stamp
  /// the period for LoopStatistics; < 0: the time of this call.
  void begin_period(std::int64_t now_ns, std::int64_t deadline_mono_ns = -1,
                    std::int64_t woke_mono_ns = -1) noexcept;

  /// Ends the period at bus time `now_ns` (after the encoders answered), in this order:
  ///  1. read: Device::read() — every pending frame, the period's hal::DeviceState;
  ///  2. supervise: Device::supervise() (managed: CanopenMaster::update(), SafetySupervisor,
  ///     re-arm, automatic activation, the drives' CiA 402 target; a fault latches the safe
  ///     state in this very period);
  ///  3. targets: when the device is ready (a rejected sample keeps the last good target),
  ///     the bound bodies' targets — body pose = link pose · body_in_link, twist carried to the
  ///     body's origin; the held body's into data.target, the others into
  ///     data.body_targets (paper Eq. 6) — and the prescribed joints' values;
  ///  4. step: one Stepper::step() (core::step unless set_stepper());
  ///  5. map: w_l = the bound bodies' Eq. 8 feedback (data.body_feedback) carried to their
  ///     link's origin (Eq. 9), τ = Σ_l J_lᵀ w_l with the state's Jacobians (computed as it
  ///     is, NaN included; 0 for a link without a driven body);
  ///  6. send: the fault policy between devices (another device in its safe state latches
  ///     this one's: docs/safety.md "Several devices"), then Device::write(DeviceCommand) →
  ///     ImpedanceDevice::write(τ) — gated (zero unless this period's sample is valid, no
  ///     shutdown, and — managed — the lifecycle active and the drive's master allowing
  ///     torque), clamped to ±max_torque and scaled by the soft start's r there, once; then
  ///     the torque frames; the report's feedback from what it applied;
  ///  7. finish: Stepper::finish() completes the Data the measurements read (a multirate run's
  ///     single-rate view), outside the timed step.
  /// The steps are the stage list fixed at construction (period_stages.hpp) over each device's
  /// PeriodData (period_data(i)), stage by stage over the devices, the step once;
  /// `observer`, if not null, sees each device's record after each stage (tests, tracing).
  /// Returns device 0's report.
  const PeriodReport& end_period(std::int64_t now_ns, PeriodObserver* observer = nullptr) noexcept;

  /// Re-arms after a latched fault or a failed start-up (for the CLI and tests), every device:
  /// asks every drive's master for a fault reset, reruns the NMT start-up if a node is not
  /// operational (or the start-up failed; on a shared bus its NMT commands go to its own nodes
  /// only, so a device that runs on is not reset), and re-arms the lifecycle (kFault →
  /// kInactive) in the first period in which no cause is present; the automatic activation
  /// then follows (with several devices, once none is in its safe state). Never blocks.
  /// kAccepted if any device accepted, else device 0's result.
  RearmResult rearm() noexcept;
  /// A re-arm was accepted and has not happened yet (on any device).
  bool rearm_pending() const noexcept;
  /// Managed stack: kInactive → kActive now (SafetySupervisor::activate()), every device;
  /// kNotInactive in the minimal protocol. The first result that is not kOk, else kOk.
  hal::LifecycleResult activate() noexcept;

  /// Orderly stop (Ctrl-C / SIGTERM, the end of a run on a real bus), every device: from now on
  /// no automatic activation or pending re-arm, and the lifecycle leaves kActive for kInactive
  /// (managed: SafetySupervisor::deactivate()), so every following period sends zero torque and
  /// the drives' masters are asked for kDisabled (disable voltage, CiA 402 §6.3). The caller then
  /// runs periods until drives_disabled() (or a bound) so the controlwords go out. The minimal
  /// protocol has no lifecycle: its periods send zero torque from now on. Never blocks.
  void shutdown() noexcept;
  /// shutdown() was called.
  bool shutting_down() const noexcept { return contexts_[0].device->shutting_down(); }
  /// Managed: every drive's master of every device reports a disabled state (not energised:
  /// switch on disabled, ready to switch on, not ready, fault); minimal protocol: true.
  bool drives_disabled() const noexcept;
  /// True for the managed stack (device 0's protocol; hal::DeviceReport::managed).
  bool managed() const noexcept { return contexts_[0].device->report().managed; }
  /// The number of devices, in [1, kMaxLoopDevices].
  std::size_t num_devices() const noexcept { return num_devices_; }
  /// Device `i` (protocol, supervision), of either kind.
  const hal::Device& device(std::size_t i = 0) const noexcept { return *contexts_[i].device; }
  /// Same, mutable (tests: e.g. to reach a managed device's CANopen master). Not while
  /// end_period() runs.
  hal::Device& device(std::size_t i = 0) noexcept { return *contexts_[i].device; }
  /// Impedance device `i` (the torques sent); precondition: the loop was built for impedance
  /// devices (admittance() is null). For tests of the kind: code above the loop reads a device
  /// through the face (device(), hal::Device::output(), conditioning()).
  const hal::ImpedanceDevice& impedance(std::size_t i = 0) const noexcept {
    return static_cast<const hal::ImpedanceDevice&>(*contexts_[i].device);
  }
  /// The admittance device (nullptr for an impedance device; DeviceRig::admittance()).
  const hal::AdmittanceDevice* admittance() const noexcept { return rig_->admittance(); }
  /// The devices the loop runs (device_rig.hpp): their kind, instruments and bindings.
  const DeviceRig& rig() const noexcept { return *rig_; }
  /// Timing statistics of the periods (wake-up, step, bus I/O, end-to-end, overruns; with
  /// several devices from the first device's read to the last one's writes).
  const LoopStatistics& statistics() const noexcept { return *stats_; }
  /// Period index (0-based end_period() count) at which device i's lifecycle first became
  /// active; -1 if never.
  std::int64_t first_active_period(std::size_t i = 0) const noexcept {
    return contexts_[i].first_active_period;
  }
  /// Period index at which device i first commanded non-zero torque; -1 if never.
  std::int64_t first_torque_period(std::size_t i = 0) const noexcept {
    return contexts_[i].first_torque_period;
  }
  /// Period index at which device i's bodies were brought to its first ready sample
  /// (ControlLoopSettings::place_at_first_sample); -1 if not (yet, or the setting is off).
  std::int64_t placed_period(std::size_t i = 0) const noexcept {
    return contexts_[i].placed_period;
  }
  /// Device i's returns from stale samples (ControlLoopSettings::rejoin_after_stale).
  const RejoinTally& rejoins(std::size_t i = 0) const noexcept { return contexts_[i].rejoin; }

  /// The step stage's dynamics (step 4 of end_period()): `stepper`'s step() over the loop's
  /// Model and Data, and its finish() after the commands were sent (outside the timed step),
  /// e.g. the multirate god-object's device period and its single-rate view
  /// (sim::MultirateRun). Null restores core::step (CoreStepper). Keeps a pointer: `stepper`
  /// must outlive the loop or be replaced first. Not while end_period() runs.
  void set_stepper(Stepper* stepper) noexcept;

  /// Wall time of core::step per period (ns).
  const LatencyHistogram& step_time() const noexcept { return contexts_[0].step_time; }
  /// Device i's counters since construction.
  const ControlLoopCounters& counters(std::size_t i = 0) const noexcept {
    return contexts_[i].counters;
  }
  /// What the last end_period() did (device i's report).
  const PeriodReport& last_report(std::size_t i = 0) const noexcept { return periods_[i].report; }
  /// Device i's period record (what the last period's stages wrote).
  const PeriodData& period_data(std::size_t i = 0) const noexcept { return periods_[i]; }
  /// The stage list end_period() runs (fixed at construction by the kind of device).
  std::span<const PeriodStageEntry> stages() const noexcept { return stages_; }

 private:
  // The loop over a rig it owns (the constructors that take none): `owned` is kept.
  ControlLoop(const core::Model& model, core::Data& data, std::unique_ptr<DeviceRig> owned,
              const ControlLoopSettings& settings);
  // The impedance devices' bodies (bound at most once over the loop, the held body by one rigid
  // binding at most), each device's context and binding, the feedback groups and points.
  void bind_all(const core::Model& model, core::Data& data, const ControlLoopSettings& settings);
  // Device i's context: its fixed part (construction).
  void init_context(std::size_t i, const core::Model& model, core::Data& data,
                    hal::Device& device, const ControlLoopSettings& settings);
  // Device i's binding: checked against the model and the device, kept, and the bodies and
  // prescribed joints it drives set to hold where they start.
  void bind(std::size_t i, const core::Model& model, core::Data& data,
            const hal::InstrumentDevice& instrument, DeviceBinding binding);

  std::unique_ptr<DeviceRig> owned_rig_;  // the rig built by the loop (null: the caller's)
  DeviceRig* rig_ = nullptr;               // the devices: owned_rig_ or the caller's
  CoreStepper core_stepper_;
  std::unique_ptr<LoopStatistics> stats_;
  std::size_t num_devices_ = 1;
  // Per device: the device (owned_ or the caller's), binding, tallies; and its record.
  std::array<PeriodContext, kMaxLoopDevices> contexts_;
  std::array<PeriodData, kMaxLoopDevices> periods_;
  std::span<const PeriodStageEntry> stages_;
};

}  // namespace numen::platform
