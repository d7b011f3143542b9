/// @file device_emulator.cpp
/// Device-side emulation of an instrument's encoder nodes and drives.

#include "numen/hal/device_emulator.hpp"

#include <utility>

#include "numen/hal/canopen.hpp"

namespace numen::hal {

DeviceEmulator::DeviceEmulator(DeviceConfig config) : config_(std::move(config)) {
  validate(config_);
  n_ = static_cast<int>(config_.axes.size());
  last_torques_ = AxisVector::Zero(n_);
  for (int i = 0; i < n_; ++i) {
    counts_[static_cast<std::size_t>(i)] =
        value_to_counts(config_.axes[static_cast<std::size_t>(i)], 0.0);
  }
}

void DeviceEmulator::set_axis_values(const double* q) noexcept {
  for (int i = 0; i < n_; ++i) {
    const auto k = static_cast<std::size_t>(i);
    counts_[k] = value_to_counts(config_.axes[k], q[i]);
  }
}

void DeviceEmulator::set_axis_counts(const std::int32_t* counts) noexcept {
  for (int i = 0; i < n_; ++i) counts_[static_cast<std::size_t>(i)] = counts[i];
}

void DeviceEmulator::on_frame(const CanFrame& frame, Bus& device_port) noexcept {
  if (frame.id == kSyncCobId) {
    if (!is_sync(frame)) {
      ++counters_.frames_malformed;
      return;
    }
    ++counters_.syncs;
    if (!responding_) {
      ++counters_.syncs_ignored;
      return;
    }
    for (int i = 0; i < n_; ++i) {
      const auto k = static_cast<std::size_t>(i);
      const IoStatus s = device_port.write(
          encode_position_pdo(config_.axes[k].encoder_cob_id, counts_[k], frame.timestamp_ns));
      if (s == IoStatus::kOk) ++counters_.tpdos_sent;
      if (s == IoStatus::kWouldBlock) ++counters_.tx_would_block;
      if (s == IoStatus::kError) ++counters_.tx_errors;
    }
    return;
  }
  for (int i = 0; i < n_; ++i) {
    const auto k = static_cast<std::size_t>(i);
    const AxisConfig& a = config_.axes[k];
    if (!a.has_drive() || frame.id != a.drive_cob_id) continue;
    std::int16_t pm = 0;
    if (decode_torque_pdo(frame, a.drive_cob_id, pm) == DecodeStatus::kOk) {
      ++counters_.rpdos;
      last_per_mille_[k] = pm;
      last_torques_[i] = per_mille_to_torque(a, pm);
    } else {
      ++counters_.frames_malformed;
    }
    return;
  }
  ++counters_.frames_ignored;
}

int DeviceEmulator::poll(Bus& device_port, int max_frames) noexcept {
  CanFrame frame;
  int read = 0;
  while (read < max_frames && device_port.read(frame) == IoStatus::kOk) {
    on_frame(frame, device_port);
    ++read;
  }
  return read;
}

}  // namespace numen::hal
