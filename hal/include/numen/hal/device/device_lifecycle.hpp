#pragma once
/// @file device_lifecycle.hpp
/// DeviceLifecycle: the state machine of one hardware device, after ros2_control's hardware
/// component lifecycle (unconfigured → inactive, reading only → active, commands allowed;
/// REP-2007 / ros2_control "Hardware Components" lifecycle) with one difference: an error does
/// not lead back to unconfigured but latches a safe state that only an explicit rearm() leaves.
///
///   kUnconfigured ──configure()──▶ kInactive ──activate()──▶ kActive
///         ▲                          │  ▲                       │
///         └────────cleanup()─────────┘  └──────deactivate()─────┘
///   kInactive / kActive ──fault──▶ kSafeStop ──drives disabled / timeout──▶ kFault
///   kFault ──rearm() (no cause present)──▶ kInactive
///
/// kSafeStop: zero torque is commanded and the drives are asked to disable (CiA 402 disable
/// voltage); kFault: latched, drives disabled. Torque is allowed only in kActive; every other
/// state commands exactly zero (never "the last command").
///
/// The lifecycle decides nothing about faults itself: once per control period update() takes
/// the verdict of a supervisor (SafetySupervisor): a new latching fault this period, whether a
/// fault condition is present now (activate() and rearm() refuse while it is), and whether
/// every drive reports a disabled state. Pure logic, no clock, no I/O: every member except the
/// constructor is noexcept and allocation free.

#include <cstdint>

#include "numen/hal/canopen/cia402.hpp"

#include "numen/hal/device/device_status.hpp"

namespace numen::hal {


/// The supervisor's verdict for one period (input of DeviceLifecycle::update()).
struct LifecycleInputs {
  /// A latching fault was detected this period (an event: true in one period is enough).
  bool fault = false;
  /// A fault condition is present now (e.g. an encoder still silent, a drive still in
  /// fault): activate() and rearm() refuse until a period without one.
  bool cause_present = false;
  /// Every drive reports a disabled state (CiA 402 not ready to switch on, switch on
  /// disabled or fault). True for a device without drives.
  bool drives_disabled = false;
};

/// What one DeviceLifecycle::update() (or trip()) did.
struct LifecycleUpdate {
  LifecycleState state = LifecycleState::kUnconfigured;  ///< State after the call.
  bool entered_safe_stop = false;  ///< The call moved kInactive/kActive to kSafeStop.
  bool entered_fault = false;      ///< The call moved kSafeStop to kFault.
  bool timed_out = false;          ///< ... because safe_stop_timeout_periods passed with a
                                   ///< drive still not disabled.
};

/// Event counters of a DeviceLifecycle since construction.
struct LifecycleCounters {
  std::uint64_t updates = 0;             ///< update() calls.
  std::uint64_t transitions = 0;         ///< State changes (requested and automatic).
  std::uint64_t refused = 0;             ///< Transition requests refused.
  std::uint64_t safe_stops = 0;          ///< Entries into kSafeStop.
  std::uint64_t safe_stop_timeouts = 0;  ///< kSafeStop → kFault by timeout.
  std::uint64_t rearms = 0;              ///< Successful rearm() calls.
};

/// The lifecycle state machine of one device (see the file comment). Not thread safe: one
/// control loop owns it; transition requests are made from that loop between two updates.
class DeviceLifecycle {
 public:
  /// Default settings, kUnconfigured.
  DeviceLifecycle() noexcept = default;
  /// Throws std::invalid_argument naming the field if safe_stop_timeout_periods is 0.
  explicit DeviceLifecycle(const LifecycleSettings& settings);

  /// kUnconfigured → kInactive.
  LifecycleResult configure() noexcept;
  /// kInactive → kActive, refused (kCausePresent) if the last update() reported a fault
  /// condition present.
  LifecycleResult activate() noexcept;
  /// kActive → kInactive (zero torque, drives disabled; not a fault).
  LifecycleResult deactivate() noexcept;
  /// kInactive → kUnconfigured.
  LifecycleResult cleanup() noexcept;
  /// kFault → kInactive, refused (kCausePresent) if the last update() reported a fault
  /// condition present. A fresh activation then needs activate() again.
  LifecycleResult rearm() noexcept;

  /// One control period at `now_ns` (any monotonic clock, ns; only stored) with the
  /// supervisor's verdict. In kInactive / kActive a fault moves to kSafeStop at once (torque is
  /// forbidden from this period on). In kSafeStop, from the next update on: every drive
  /// disabled → kFault; else after safe_stop_timeout_periods updates → kFault with `timed_out`.
  /// kUnconfigured ignores faults (nothing is supervised).
  LifecycleUpdate update(std::int64_t now_ns, const LifecycleInputs& inputs) noexcept;

  /// A latching fault found between two updates (e.g. a NaN torque while saturating):
  /// kInactive / kActive → kSafeStop at once, stamped with the last update's time. No effect
  /// in the other states.
  LifecycleUpdate trip() noexcept;

  /// The current state.
  LifecycleState state() const noexcept { return state_; }
  /// True only in kActive: torque commands may be sent. False means exactly zero torque.
  bool torque_allowed() const noexcept { return state_ == LifecycleState::kActive; }
  /// The CiA 402 target the drives must be given (Cia402Master::request): kEnabled in
  /// kActive, kDisabled in every other state.
  Cia402Target drive_target() const noexcept {
    return state_ == LifecycleState::kActive ? Cia402Target::kEnabled : Cia402Target::kDisabled;
  }
  /// True in kSafeStop and kFault.
  bool latched() const noexcept {
    return state_ == LifecycleState::kSafeStop || state_ == LifecycleState::kFault;
  }
  /// Updates spent in kSafeStop so far (0 in the period it was entered).
  std::uint32_t safe_stop_periods() const noexcept { return safe_stop_periods_; }
  /// Time of the update at (or after) which kSafeStop was last entered, ns.
  std::int64_t safe_stop_since_ns() const noexcept { return safe_stop_since_ns_; }
  /// Time of the update at which kFault was last entered, ns.
  std::int64_t fault_since_ns() const noexcept { return fault_since_ns_; }
  /// True if the last kSafeStop → kFault was by timeout (a drive never reported disabled).
  bool safe_stop_timed_out() const noexcept { return timed_out_; }
  /// The supervisor's last verdict that a fault condition is present.
  bool cause_present() const noexcept { return cause_present_; }
  /// Counters.
  const LifecycleCounters& counters() const noexcept { return counters_; }
  /// The settings.
  const LifecycleSettings& settings() const noexcept { return settings_; }

 private:
  LifecycleResult refuse(LifecycleResult reason) noexcept;
  void enter(LifecycleState next) noexcept;
  LifecycleUpdate enter_safe_stop() noexcept;

  LifecycleSettings settings_;
  LifecycleCounters counters_;
  LifecycleState state_ = LifecycleState::kUnconfigured;
  bool cause_present_ = false;
  bool timed_out_ = false;
  std::uint32_t safe_stop_periods_ = 0;
  std::int64_t now_ns_ = 0;
  std::int64_t safe_stop_since_ns_ = 0;
  std::int64_t fault_since_ns_ = 0;
};

}  // namespace numen::hal
