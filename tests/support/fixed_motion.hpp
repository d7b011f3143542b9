#pragma once
// A hal::DeviceMotion for tests of the emulators and loops: the device is where the test puts
// it (state), and the motion records what it was last asked (the SYNC time and the drives'
// commands).

#include <cstdint>

#include "numen/hal/emulation/device_motion.hpp"

namespace numen::test {

struct FixedMotion final : hal::DeviceMotion {
  explicit FixedMotion(int axes) {
    state.q = hal::AxisVector::Zero(axes);
    state.qdot = hal::AxisVector::Zero(axes);
  }
  const hal::DeviceMotionState& at_sync(std::int64_t t_ns,
                                        const hal::DriveCommands& commands) noexcept override {
    last_t_ns = t_ns;
    last = commands;
    ++syncs;
    return state;
  }
  hal::DeviceMotionState state;  ///< What the device reports.
  hal::DriveCommands last;       ///< The commands of the last SYNC.
  std::int64_t last_t_ns = -1;
  int syncs = 0;
};

}  // namespace numen::test
