/// @file device.cpp
/// hal::Device: the period's SYNC and frame-read loop, shared by both kinds of device.

#include "numen/hal/device/device.hpp"

#include "numen/hal/canopen/canopen.hpp"

namespace numen::hal {

const char* to_string(RearmResult result) noexcept {
  switch (result) {
    case RearmResult::kAccepted:
      return "accepted";
    case RearmResult::kNotLatched:
      return "nothing to re-arm";
    case RearmResult::kMinimalProtocol:
      return "minimal protocol: no lifecycle";
  }
  return "unknown";
}

IoStatus Device::begin_period(std::int64_t now_ns) noexcept {
  // CiA 301 SYNC counter runs 1..240 when used.
  IoStatus s = IoStatus::kOk;
  if (sync_producer_) {
    sync_counter_ = static_cast<std::uint8_t>(sync_counter_ >= 240 ? 1 : sync_counter_ + 1);
    s = bus_->write(make_sync(now_ns, sync_counter_));
    note(s);
  }
  note(begin_protocol(now_ns));
  return s;
}

const DeviceState& Device::read(std::int64_t now_ns) noexcept {
  state_.frames_read = 0;
  state_.read_error = false;
  state_.input_frames = 0;
  state_.time_ns = now_ns;
  CanFrame frame;
  for (int i = 0; i < 1024; ++i) {
    const IoStatus s = bus_->read(frame);
    if (s == IoStatus::kError) {
      state_.read_error = true;
      io_error_ = true;
    }
    if (s != IoStatus::kOk) break;
    ++state_.frames_read;
    if (!take_frame(frame) && on_input_frame(frame)) ++state_.input_frames;
  }
  input_frames_ += static_cast<std::uint64_t>(state_.input_frames);
  end_read(now_ns, state_);
  return state_;
}

void Device::shutdown() noexcept {
  shutting_down_ = true;
  on_shutdown();
}

}  // namespace numen::hal
