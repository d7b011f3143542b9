#pragma once
/// @file admittance_emulator.hpp
/// Device side of an admittance device (the sibling of DeviceEmulator for impedance devices):
/// position-controlled axes (CiA 402 csp drives, an ideal or first-order-lag tracker of the
/// commanded target position) and a 6-axis force/torque sensor on the handle that measures the
/// wrench of a simulated user's hand — a spring–damper pulling the handle toward where the
/// hand wants to be (the scene trajectory):
///   F = k_hand (x_hand − x_dev) + c_hand (v_hand − v_dev)
///   T = k_hand_rot log(q_hand q_dev⁻¹) + c_hand_rot (ω_hand − ω_dev)
/// at the controlled frame's origin (world), reported in the sensor frame (docs/protocol.md
/// §18, docs/dynamics.md "Admittance devices").
/// Per period, on SYNC (bus time t): the axes advance from the previous SYNC to t, the hand
/// wrench is evaluated at the new device state and the two sensor TPDOs are sent stamped t.
/// A csp RPDO (controlword + target position) sets its axis's target when the controlword
/// commands enable operation (CiA 402-2 command coding, decode_controlword()); any other
/// command disables the axis's drive, and a disabled axis holds still (numen's emulated
/// arm has brakes: documented simplification).
/// Construction may allocate and throws std::invalid_argument; the rest is noexcept and
/// allocation free.

#include <array>
#include <cstdint>
#include <memory>

#include "numen/core/types.hpp"
#include "numen/hal/device/admittance_device.hpp"
#include "numen/hal/transport/bus.hpp"
#include "numen/hal/device/kinematics.hpp"

namespace numen::hal {

/// The simulated user's hand and the drives' tracking (scene `[device.hand]`, `[device.drive]`).
struct AdmittanceEmulatorSettings {
  double k_hand = 200.0;     ///< N/m, >= 0.
  double c_hand = 5.0;       ///< N·s/m, >= 0.
  double k_hand_rot = 0.5;   ///< N·m/rad, >= 0.
  double c_hand_rot = 0.01;  ///< N·m·s/rad, >= 0.
  /// Time constant of each axis's tracking of its target, s, >= 0: per SYNC interval Δt the
  /// axis moves by (1 − exp(−Δt/τ)) of its remaining error; 0 = ideal (reaches it at once).
  double lag_s = 0.002;
};

/// Counters since construction.
struct AdmittanceEmulatorCounters {
  std::uint64_t syncs = 0;           ///< SYNCs answered.
  std::uint64_t rpdos = 0;           ///< csp RPDOs decoded.
  std::uint64_t rpdos_rejected = 0;  ///< ... with a wrong length / not a data frame.
  std::uint64_t tx_failed = 0;       ///< Sensor TPDOs the bus did not take.
};

/// The emulated admittance device on the device port of a bus.
class AdmittanceEmulator {
 public:
  /// Validates (validate(DeviceConfig), validate(DeviceConfig, AdmittanceConfig), settings
  /// finite and >= 0) and builds the kinematics. Axes start at 0, disabled. Throws
  /// std::invalid_argument.
  AdmittanceEmulator(DeviceConfig device, AdmittanceConfig admittance,
                     const AdmittanceEmulatorSettings& settings);

  /// Puts the axes at `q` (m / rad), at rest, their targets too (setup, tests).
  void set_axis_values(const AxisVector& q) noexcept;
  /// Where the hand is and how it moves (world; the controlled frame's target), for the next SYNC.
  void set_hand(const core::Pose& pose, const core::Twist& twist) noexcept;

  /// Handles one frame from the controller: SYNC (advance, measure, send the two sensor
  /// TPDOs) or a csp RPDO of an axis; anything else is ignored.
  void on_frame(const CanFrame& frame, Bus& device_port) noexcept;
  /// Reads and handles up to `max_frames` frames; returns the number handled.
  int poll(Bus& device_port, int max_frames = 256) noexcept;

  /// Axis values (m / rad).
  const AxisVector& q() const noexcept { return q_; }
  /// Axis rates over the last SYNC interval.
  const AxisVector& qdot() const noexcept { return qdot_; }
  /// Pose of the controlled frame (forward kinematics of q()).
  core::Pose pose() const noexcept { return kinematics_->forward(q_); }
  /// The hand's wrench at the last SYNC (world; N at, N·m about, the controlled frame's origin).
  const core::Wrench& hand_wrench() const noexcept { return hand_wrench_; }
  /// True when axis `i`'s drive was last commanded enable operation.
  bool enabled(int i) const noexcept { return enabled_[static_cast<std::size_t>(i)] != 0; }
  /// Silences the sensor (fault injection: no TPDOs on SYNC).
  void set_sensor_silent(bool silent) noexcept { silent_ = silent; }
  const AdmittanceEmulatorCounters& counters() const noexcept { return counters_; }

 private:
  void on_sync(const CanFrame& frame, Bus& port) noexcept;

  DeviceConfig device_;
  AdmittanceConfig admittance_;
  AdmittanceEmulatorSettings settings_;
  std::unique_ptr<Kinematics> kinematics_;
  PdoMapping rpdo_map_;
  AxisVector q_;
  AxisVector qdot_;
  AxisVector target_;
  std::array<std::uint8_t, kMaxAxes> enabled_{};
  core::Pose hand_pose_;
  core::Twist hand_twist_;
  core::Wrench hand_wrench_;
  std::int64_t last_sync_ns_ = 0;
  bool had_sync_ = false;
  bool silent_ = false;
  AdmittanceEmulatorCounters counters_;
};

}  // namespace numen::hal
