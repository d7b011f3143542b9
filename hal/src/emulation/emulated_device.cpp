/// @file emulated_device.cpp
/// hal::EmulatedDevice: the frame loop both emulators share.

#include "numen/hal/emulation/emulated_device.hpp"

namespace numen::hal {

int EmulatedDevice::poll(Bus& device_port, int max_frames) noexcept {
  CanFrame frame;
  int read = 0;
  while (read < max_frames && device_port.read(frame) == IoStatus::kOk) {
    ++read;
    on_frame(frame, device_port);
  }
  return read;
}

}  // namespace numen::hal
