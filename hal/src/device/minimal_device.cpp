/// @file minimal_device.cpp
/// The minimal protocol behind hal::ImpedanceDevice: torque RPDOs per driven axis.

#include "numen/hal/device/minimal_device.hpp"

#include "numen/hal/canopen/canopen.hpp"

namespace numen::hal {

MinimalDevice::MinimalDevice(InstrumentDevice& instrument, Bus& bus)
    : ImpedanceDevice(instrument, bus) {}

DeviceSupervision MinimalDevice::supervise(std::int64_t now_ns, bool overrun) noexcept {
  (void)now_ns;
  (void)overrun;
  return DeviceSupervision{};
}

bool MinimalDevice::torque_allowed(int axis) const noexcept {
  (void)axis;
  return true;
}

IoStatus MinimalDevice::send(const SentTorques& torques, std::int64_t now_ns) noexcept {
  IoStatus status = IoStatus::kOk;
  const DeviceConfig& config = instrument_->config();
  for (std::size_t i = 0; i < config.axes.size(); ++i) {
    const AxisConfig& a = config.axes[i];
    if (!a.has_drive()) continue;
    status = worst(status, bus_->write(encode_torque_pdo(a.drive_cob_id, torques.per_mille[i], now_ns)));
  }
  return status;
}

}  // namespace numen::hal
