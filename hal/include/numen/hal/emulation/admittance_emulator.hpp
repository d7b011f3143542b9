#pragma once
/// @file admittance_emulator.hpp
/// Device side of an admittance device (the sibling of DeviceEmulator for impedance devices,
/// both EmulatedDevice): position-controlled axes (CiA 402 csp drives) and a 6-axis
/// force/torque sensor on the handle (docs/protocol.md "Admittance devices"). A csp RPDO
/// (controlword + target position) sets its axis's target when the controlword commands enable
/// operation (CiA 402-2 command coding, decode_controlword()); any other command disables the
/// axis's drive. On SYNC (bus time t) the motion (set_motion(): the drives' tracking of their
/// targets and the hand on the handle, sim's AdmittanceHand) gives the axes and the hand's
/// wrench at t under those commands; the sensor reports that wrench, in its frame, in two
/// TPDOs stamped t. Without a motion the axes hold still and the sensor reads 0.
/// Construction may allocate and throws std::invalid_argument; the rest is noexcept and
/// allocation free.

#include <array>
#include <cstdint>
#include <memory>

#include "numen/core/types.hpp"
#include "numen/hal/device/admittance_device.hpp"
#include "numen/hal/device/kinematics.hpp"
#include "numen/hal/emulation/emulated_device.hpp"
#include "numen/hal/transport/bus.hpp"

namespace numen::hal {

/// Counters since construction.
struct AdmittanceEmulatorCounters {
  std::uint64_t syncs = 0;           ///< SYNCs answered.
  std::uint64_t rpdos = 0;           ///< csp RPDOs decoded.
  std::uint64_t rpdos_rejected = 0;  ///< ... with a wrong length / not a data frame.
  std::uint64_t tx_failed = 0;       ///< Sensor TPDOs the bus did not take.
};

/// The emulated admittance device on the device port of a bus.
class AdmittanceEmulator final : public EmulatedDevice {
 public:
  /// Validates (validate(DeviceConfig), validate(DeviceConfig, AdmittanceConfig)) and builds
  /// the kinematics. Axes start at 0, disabled. Throws std::invalid_argument.
  AdmittanceEmulator(DeviceConfig device, AdmittanceConfig admittance);
  /// Puts the axes at `q` (m / rad), at rest, their targets too (setup, tests; the motion
  /// must be put there as well).
  void set_axis_values(const AxisVector& q) noexcept;
  /// Handles one frame from the controller: SYNC (the motion's state, the two sensor TPDOs)
  /// or a csp RPDO of an axis; anything else is ignored.
  void on_frame(const CanFrame& frame, Bus& device_port) noexcept override;
  /// Axis values (m / rad) at the last SYNC.
  const AxisVector& q() const noexcept { return q_; }
  /// Axis rates at the last SYNC.
  const AxisVector& qdot() const noexcept { return qdot_; }
  /// Pose of the controlled frame (forward kinematics of q()).
  core::Pose pose() const noexcept { return kinematics_->forward(q_); }
  /// The hand's wrench at the last SYNC (world; N at, N·m about, the controlled frame's origin).
  const core::Wrench& hand_wrench() const noexcept { return hand_wrench_; }
  /// True when axis `i`'s drive was last commanded enable operation.
  bool enabled(int i) const noexcept { return commands_.enabled[static_cast<std::size_t>(i)] != 0; }
  /// The drives' commands as the motion is told them (targets, enable).
  const DriveCommands& commands() const noexcept { return commands_; }
  /// Silences the sensor (fault injection: no TPDOs on SYNC).
  void set_sensor_silent(bool silent) noexcept { silent_ = silent; }
  const AdmittanceEmulatorCounters& counters() const noexcept { return counters_; }
  const DeviceConfig& config() const noexcept { return device_; }
  const Kinematics& kinematics() const noexcept { return *kinematics_; }

 private:
  void on_sync(const CanFrame& frame, Bus& port) noexcept;

  DeviceConfig device_;
  AdmittanceConfig admittance_;
  std::unique_ptr<Kinematics> kinematics_;
  PdoMapping rpdo_map_;
  AxisVector q_;
  AxisVector qdot_;
  DriveCommands commands_;  // position_target, enabled
  core::Wrench hand_wrench_;
  bool silent_ = false;
  AdmittanceEmulatorCounters counters_;
};

}  // namespace numen::hal
