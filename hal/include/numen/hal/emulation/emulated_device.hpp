#pragma once
/// @file emulated_device.hpp
/// The device side of an emulated device on a bus, either kind: DeviceEmulator (an impedance
/// device: encoders answer the SYNC, drives take torque RPDOs) or AdmittanceEmulator (an
/// admittance device: a force sensor answers the SYNC, csp drives take position RPDOs). Both
/// take the device's motion from a DeviceMotion (device_motion.hpp) at each SYNC, so what
/// moves the device (a replayed hand, a hand spring and drive lag, a plant under the
/// commanded torques) is written once, above the HAL.

#include <cstdint>

#include "numen/hal/emulation/device_motion.hpp"
#include "numen/hal/transport/bus.hpp"

namespace numen::hal {

/// The emulated device on the device port of a bus (see the file comment). Not thread safe.
class EmulatedDevice {
 public:
  virtual ~EmulatedDevice() = default;
  /// The motion source asked at each SYNC (not owned; it must outlive its use). nullptr: the
  /// device stays where it was put (set_axis_values()) and measures no wrench.
  void set_motion(DeviceMotion* motion) noexcept { motion_ = motion; }
  /// The motion source (nullptr: none).
  DeviceMotion* motion() const noexcept { return motion_; }
  /// Handles one frame read on the device port (a SYNC asks the motion, then answers).
  virtual void on_frame(const CanFrame& frame, Bus& device_port) noexcept = 0;
  /// Reads up to `max_frames` frames from `device_port` and handles each; returns how many.
  int poll(Bus& device_port, int max_frames = 256) noexcept;
  /// The time-driven part at bus time `now_ns`, after poll() (the managed stack's boot-ups,
  /// heartbeats, EMCYs); nothing by default.
  virtual void tick(std::int64_t now_ns, Bus& device_port) noexcept {
    (void)now_ns;
    (void)device_port;
  }

 protected:
  EmulatedDevice() = default;
  /// The motion's state at SYNC time `t_ns` under `commands`; nullptr without a motion.
  const DeviceMotionState* move(std::int64_t t_ns, const DriveCommands& commands) noexcept {
    return motion_ != nullptr ? &motion_->at_sync(t_ns, commands) : nullptr;
  }

 private:
  DeviceMotion* motion_ = nullptr;
};

}  // namespace numen::hal
