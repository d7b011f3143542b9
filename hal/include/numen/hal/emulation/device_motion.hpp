#pragma once
/// @file device_motion.hpp
/// The motion source of an emulated device: everything physical about it (the hand that holds
/// it, its drives' response, its mechanics), kept out of the HAL. The emulators here
/// (EmulatedDevice: DeviceEmulator for an impedance device, AdmittanceEmulator for an
/// admittance device) speak the device side of the protocol; at each SYNC they ask their
/// DeviceMotion where the device is, given what its drives were commanded, and report that.
/// The implementations live in sim, beside the rest of the simulated world (docs/architecture.md,
/// "The emulated device").

#include <array>
#include <cstdint>

#include "numen/core/types.hpp"
#include "numen/hal/device/kinematics.hpp"

namespace numen::hal {

/// What the drives of an emulated device hold at a SYNC: the commands the device side decoded
/// from the controller's RPDOs since the previous SYNC (n = the device's axes).
struct DriveCommands {
  /// Impedance device: the torque each axis's drive applies, N·m or N (0 on an axis without a
  /// drive or whose drive is disabled).
  AxisVector torque;
  /// Admittance device (CiA 402 csp): each axis's target position, m or rad.
  AxisVector position_target;
  /// Admittance device: 1 where the axis's drive was last commanded enable operation.
  std::array<std::uint8_t, kMaxAxes> enabled{};
};

/// The emulated device's physical state at a SYNC: what its encoders latch and its force
/// sensor measures.
struct DeviceMotionState {
  AxisVector q;     ///< Axis values, m or rad (n entries).
  AxisVector qdot;  ///< Axis rates, m/s or rad/s (n entries).
  /// The wrench the hand applies to the handle, world frame, N at and N·m about the controlled
  /// frame's origin (an admittance device's sensor reports it; 0 where nothing measures it).
  core::Wrench handle_wrench;
};

/// The motion source of one emulated device. One object per device; not thread safe (the
/// emulator's thread calls it).
class DeviceMotion {
 public:
  virtual ~DeviceMotion() = default;
  /// The device's state at SYNC bus time `t_ns` (ns), its drives having held `commands` since
  /// the previous SYNC. The reference stays valid until the next call. Never allocates,
  /// throws, locks or blocks.
  virtual const DeviceMotionState& at_sync(std::int64_t t_ns,
                                           const DriveCommands& commands) noexcept = 0;
};

}  // namespace numen::hal
