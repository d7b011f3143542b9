#pragma once
// Helpers of the hal tests of an admittance device (controller and device side): the pose
// tracker at 1 kHz, its zero axis values, and draining a bus port.

#include <array>
#include <cstddef>

#include "numen/hal/device/device_config.hpp"
#include "numen/hal/device/kinematics.hpp"
#include "numen/hal/transport/bus.hpp"

namespace numen::test {

/// The default pose tracker (six axes) with a 1 ms control period.
inline hal::DeviceConfig admittance_tracker() {
  hal::DeviceConfig c = hal::make_default_pose_tracker_config(1);
  c.control_period_s = 1e-3;
  return c;
}

/// Its six axis values at 0.
inline hal::AxisVector tracker_zeros() { return hal::AxisVector::Zero(6); }

/// Reads every frame pending on `port` into `out` (at most 16); returns the count.
inline int drain(hal::Bus& port, std::array<hal::CanFrame, 16>& out) {
  int n = 0;
  hal::CanFrame f;
  while (n < 16 && port.read(f) == hal::IoStatus::kOk) out[static_cast<std::size_t>(n++)] = f;
  return n;
}

}  // namespace numen::test
