#pragma once
/// @file admittance_hand.hpp
/// The motion of an emulated admittance device (hal::DeviceMotion of hal::AdmittanceEmulator;
/// docs/dynamics.md "Admittance devices"): position-controlled axes that track their csp
/// targets with a first-order lag, and a simulated user's hand — a spring–damper pulling the
/// handle toward where the hand wants to be (the scene trajectory): the hand of hand.hpp
/// (hand_wrench(), scene `[device.hand]`), shared with the impedance devices' PlantMotion; its
/// mass is not felt by the position-controlled drives. Per SYNC interval Δt an enabled axis moves by
/// (1 − exp(−Δt/τ)) of its remaining error to its target (τ = lag_s; 0: at once); a disabled
/// axis holds still (the emulated arm has brakes: a documented simplification). The wrench is
/// then evaluated at the new state. Construction may allocate and throws
/// std::invalid_argument; the rest is noexcept and allocation free.

#include <cstdint>
#include <memory>

#include "numen/core/types.hpp"
#include "numen/hal/device/device_config.hpp"
#include "numen/hal/device/kinematics.hpp"
#include "numen/hal/emulation/device_motion.hpp"
#include "numen/sim/device/hand.hpp"

namespace numen::sim {

/// The admittance drives' tracking lag of a scene without `[device.admittance] drive_lag`, s.
inline constexpr double kDefaultDriveLagS = 0.002;

/// The hand on an admittance device's handle, and its drives (see the file comment).
class AdmittanceHand final : public hal::DeviceMotion {
 public:
  /// Builds the device's kinematics; throws std::invalid_argument naming the device if a hand
  /// setting (validate(HandSettings)) or `lag_s` (each axis's tracking time constant, s; 0:
  /// ideal) is negative or not finite. The axes start at 0, at rest.
  AdmittanceHand(const hal::DeviceConfig& device, const HandSettings& hand, double lag_s);
  /// Puts the axes at `q` (m / rad), at rest (setup; the emulator is put there too).
  void set_axis_values(const hal::AxisVector& q) noexcept;
  /// Where the hand is and how it moves (world; the controlled frame's target), for the next SYNC.
  void set_hand(const core::Pose& pose, const core::Twist& twist) noexcept;
  const hal::DeviceMotionState& at_sync(std::int64_t t_ns,
                                        const hal::DriveCommands& commands) noexcept override;
  /// The state of the last SYNC.
  const hal::DeviceMotionState& state() const noexcept { return state_; }
  const HandSettings& hand() const noexcept { return hand_settings_; }
  double lag_s() const noexcept { return lag_s_; }

 private:
  hal::DeviceConfig device_;
  HandSettings hand_settings_;
  double lag_s_;
  std::unique_ptr<hal::Kinematics> kinematics_;
  hal::DeviceMotionState state_;
  core::Pose hand_pose_;
  core::Twist hand_twist_;
  std::int64_t last_sync_ns_ = 0;
  bool had_sync_ = false;
};

}  // namespace numen::sim
