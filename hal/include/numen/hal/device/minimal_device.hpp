#pragma once
/// @file minimal_device.hpp
/// MinimalDevice: hal::ImpedanceDevice for the minimal protocol (DeviceConfig::canopen.managed = false;
/// docs/protocol.md): SYNC each period, one 4-byte position TPDO per axis from
/// self-starting encoders, one 2-byte torque RPDO (per mille of the rated torque) per axis
/// with a drive. No NMT, heartbeats, EMCY or lifecycle: torque is allowed on every driven axis
/// whenever the period's sample is valid (ImpedanceDevice::write() gates and clamps).

#include <cstdint>

#include "numen/hal/device/impedance_device.hpp"

namespace numen::hal {

/// The minimal protocol behind hal::ImpedanceDevice. Not thread safe.
class MinimalDevice final : public ImpedanceDevice {
 public:
  /// Keeps references: `instrument` and `bus` must outlive the device.
  MinimalDevice(InstrumentDevice& instrument, Bus& bus);

  /// Nothing to supervise: returns the defaults (no lifecycle, no start-up).
  DeviceSupervision supervise(std::int64_t now_ns, bool overrun) noexcept override;

 private:
  bool torque_allowed(int axis) const noexcept override;
  IoStatus send(const SentTorques& torques, std::int64_t now_ns) noexcept override;
};

}  // namespace numen::hal
