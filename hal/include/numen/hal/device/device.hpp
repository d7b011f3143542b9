#pragma once
/// @file device.hpp
/// hal::Device: the one interface between a control loop and a device on a bus, for both kinds
/// of device (impedance: encoders in, torques out, ImpedanceDevice; admittance: a force sensor
/// in, position set-points out, AdmittanceDevice), in the manner of a ros2_control hardware
/// interface (read(time) → the controller → write(time), with a lifecycle). One control period
/// of a device is, in this order:
///
///   begin_period(now)  SYNC (CiA 301, COB-ID 0x080) and the protocol's own period-start frames
///   read(now)          every pending frame → the protocol (take_frame) or the kind's input
///                      (encoder or force TPDOs) → the kind's checked sample
///   supervise(now, …)  watchdogs and lifecycle: whether the device may be driven this period
///   … the caller steps the dynamics …
///   write …            the kind's output (ImpedanceDevice::write(τ), AdmittanceDevice::
///                      write_pose(pose)), gated by the lifecycle there, once
///
/// This base holds what both kinds share: the period's SYNC counter, the frame-read loop, the
/// I/O-error flag the supervision reads, shutdown, and the lifecycle interface (activate,
/// rearm, the state, the first latched fault). Construction allocates and may throw; every
/// other member is noexcept, allocation free, lock free and never blocks.

#include <cstdint>

#include "numen/hal/device/device_state.hpp"
#include "numen/hal/device/device_status.hpp"
#include "numen/hal/transport/bus.hpp"

namespace numen::hal {

/// What Device::supervise() decided this period (minimal protocol: the defaults).
struct DeviceSupervision {
  /// Lifecycle state after this period (kUnconfigured in the minimal protocol: no lifecycle).
  LifecycleState lifecycle = LifecycleState::kUnconfigured;
  /// NMT start-up phase after this period (kResetCommunication without an NMT start-up).
  StartupPhase startup = StartupPhase::kResetCommunication;
  bool entered_safe_stop = false;  ///< The safe state latched in this period.
  bool activated = false;          ///< The lifecycle entered kActive in this period.
};

/// Result of Device::rearm().
enum class RearmResult : std::uint8_t {
  kAccepted,         ///< Fault resets requested (and the start-up rerun if a node needs it):
                     ///< the device re-arms the lifecycle as soon as no cause is present.
  kNotLatched,       ///< Nothing to re-arm: no safe state latched and the start-up did not fail.
  kMinimalProtocol,  ///< The device runs the minimal protocol: no lifecycle.
};

/// Short English name of a RearmResult (static string).
const char* to_string(RearmResult result) noexcept;

/// One device on one bus, seen by the control loop (see the file comment). Not thread safe:
/// one real-time thread owns it.
class Device {
 public:
  virtual ~Device() = default;
  Device(const Device&) = delete;
  Device& operator=(const Device&) = delete;

  /// Starts period k at bus time `now_ns`: a SYNC (COB-ID 0x080, counter 1..240) if this
  /// device produces it (set_sync_producer()), then the protocol's period-start frames
  /// (managed: the NMT command due, the controller heartbeat). Returns the SYNC write's status
  /// (kOk without one); a kError (of any of these writes) is an I/O error for the supervision.
  IoStatus begin_period(std::int64_t now_ns) noexcept;

  /// Whether begin_period() writes the SYNC (default true). One SYNC producer per bus
  /// (CiA 301 §7.2.5): of several devices on one bus, the control loop leaves it to the first.
  /// Construction time.
  void set_sync_producer(bool produce) noexcept { sync_producer_ = produce; }

  /// Reads every pending frame (at most 1024), gives each to the protocol (take_frame: managed,
  /// drive TPDOs, heartbeats, EMCY) or else to the kind's input (on_input_frame: encoder or
  /// force TPDOs), then checks the kind's input at `now_ns` (end_read): the period's
  /// DeviceState (device_state.hpp), valid until the next read().
  const DeviceState& read(std::int64_t now_ns) noexcept;
  /// Frames the kind's input took since construction (encoder or force TPDOs: the sum of
  /// DeviceState::input_frames over the reads).
  std::uint64_t input_frames() const noexcept { return input_frames_; }

  /// Sends the period's command at `now_ns`, gated here (the one gate of the device's output):
  /// an impedance device the axis torques (DeviceCommand::torques: gate, passivity controller,
  /// clamp, soft start, then the torque frames; ImpedanceDevice::write()), an admittance device
  /// the held body's pose (DeviceCommand::pose: inverse kinematics and csp set-points in
  /// kActive, held with controlword shutdown otherwise; AdmittanceDevice::write_pose()).
  /// Returns what was sent, valid until the next write().
  virtual const DeviceOutput& write(const DeviceCommand& command, std::int64_t now_ns) noexcept = 0;
  /// What the last write() sent (the same record write() returned; the defaults before the
  /// first write): the device face's view of the output — an impedance device's sent torques
  /// (DeviceOutput::torque), gate and soft start, an admittance device's controlword.
  const DeviceOutput& output() const noexcept { return output_; }
  /// What the writes' conditioning did since construction (OutputConditioning: the torque
  /// counters and the passivity controller of an impedance device; none by default). Never
  /// allocates.
  virtual OutputConditioning conditioning() const noexcept { return {}; }

  /// Watchdogs and lifecycle at `now_ns` after read(): whether the device may be driven this
  /// period (a fault latches the safe state in this very period). `overrun`: the previous
  /// period overran (counts only where overruns are supervised).
  virtual DeviceSupervision supervise(std::int64_t now_ns, bool overrun) noexcept = 0;

  // ---- lifecycle (ros2_control: activate, deactivate, error recovery) ----
  /// kInactive → kActive now; kNotInactive without a lifecycle (the minimal protocol).
  virtual LifecycleResult activate() noexcept { return LifecycleResult::kNotInactive; }
  /// Re-arms after a latched fault (or a failed start-up): the lifecycle kFault → kInactive in
  /// the first period in which no cause is present. Never blocks.
  virtual RearmResult rearm() noexcept { return RearmResult::kMinimalProtocol; }
  /// A re-arm was accepted and has not happened yet.
  virtual bool rearm_pending() const noexcept { return false; }
  /// Orderly stop: the output is gated from now on; no automatic activation or pending re-arm,
  /// and the lifecycle leaves kActive for kInactive (the drives are disabled). Never blocks.
  void shutdown() noexcept;
  /// shutdown() was called.
  bool shutting_down() const noexcept { return shutting_down_; }
  /// The lifecycle state now (kUnconfigured without a lifecycle).
  virtual LifecycleState lifecycle() const noexcept { return LifecycleState::kUnconfigured; }
  /// Every drive reports (or was commanded) a disabled state; true without a lifecycle.
  virtual bool drives_disabled() const noexcept { return true; }
  /// The first fault that latched the safe state since construction or the last re-arm
  /// (nullptr: none, or no supervision).
  virtual const FaultRecord* first_fault() const noexcept { return nullptr; }

  // ---- several devices in one loop (docs/safety.md "Several devices") ----
  /// Latches the safe state now for a cause found outside the device (the control loop's
  /// FaultCause::kPeerFault, `id` = the peer's index in the loop): zero torque from this
  /// period's write on, until rearm(). Without a lifecycle (the minimal protocol) nothing
  /// latches.
  virtual void latch_safe_state(FaultCause cause, std::uint8_t id) noexcept {
    (void)cause;
    (void)id;
  }
  /// While held, supervise() makes no automatic activation (the lifecycle stays out of
  /// kActive): the control loop holds a device while another of its devices is in its safe
  /// state, so that the devices return to kActive together. Default: not held.
  void hold_activation(bool held) noexcept { activation_held_ = held; }
  /// hold_activation(true) is in force.
  bool activation_held() const noexcept { return activation_held_; }

  /// The feedback is ramped in again from zero (the soft start, DeviceConfig::soft_start_s)
  /// from the next write whose gate is open: the control loop asks for it when a device's
  /// samples come back after going stale (platform::ControlLoopSettings::rejoin_after_stale:
  /// the instrument moved while nothing was known of it). No effect without a soft start, or for
  /// a device that sends no torque.
  virtual void ramp_feedback_again() noexcept {}

  /// The bus.
  const Bus& bus() const noexcept { return *bus_; }
  /// The protocol's and the supervision's figures now (device_status.hpp): the face through
  /// which the code above hal reads them, without naming the protocol (the minimal protocol:
  /// `managed` false and the defaults). Never allocates.
  virtual DeviceReport report() const noexcept { return {}; }
  /// The same in words for a summary (EMCY messages, drive states, a configuration error).
  /// Allocates: never in a period.
  virtual DeviceNotes notes() const { return {}; }

 protected:
  /// Keeps a reference: `bus` must outlive the device.
  explicit Device(Bus& bus) : bus_(&bus) {}

  /// Protocol frames read before the kind's input: true if taken (managed: CanopenMaster).
  virtual bool take_frame(const CanFrame& frame) noexcept {
    (void)frame;
    return false;
  }
  /// The kind's input frame (encoder TPDOs, force TPDOs): true if it was one.
  virtual bool on_input_frame(const CanFrame& frame) noexcept = 0;
  /// After the frames: the kind's checked input at `now_ns` into `state` (its bus fields and
  /// time_ns are set).
  virtual void end_read(std::int64_t now_ns, DeviceState& state) noexcept = 0;
  /// Protocol frames at the start of a period, after the SYNC (managed: NMT, heartbeat).
  virtual IoStatus begin_protocol(std::int64_t now_ns) noexcept {
    (void)now_ns;
    return IoStatus::kOk;
  }
  /// After shutdown() (managed: deactivate the lifecycle).
  virtual void on_shutdown() noexcept {}
  /// A Bus read or write returned kError since the last take_io_error() (then cleared).
  bool take_io_error() noexcept {
    const bool e = io_error_;
    io_error_ = false;
    return e;
  }
  /// Records a write's status (kError → I/O error for the supervision).
  void note(IoStatus s) noexcept {
    if (s == IoStatus::kError) io_error_ = true;
  }

  Bus* bus_;
  /// What the last write() sent (output()): the kind's write() fills it and returns it.
  DeviceOutput output_;

 private:
  DeviceState state_;
  std::uint64_t input_frames_ = 0;
  std::uint8_t sync_counter_ = 0;
  bool sync_producer_ = true;
  bool activation_held_ = false;
  bool io_error_ = false;
  bool shutting_down_ = false;
};

}  // namespace numen::hal
