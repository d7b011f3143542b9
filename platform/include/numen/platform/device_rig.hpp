#pragma once
/// @file device_rig.hpp
/// platform::DeviceRig: the control loop's devices assembled in one place, in the manner of
/// ros2_control's resource manager (which owns the hardware behind read() / write()): the
/// hal::Device of each instrument — of either kind, impedance (hal::ImpedanceDevice, built by
/// hal::make_device() for its protocol) or admittance (hal::AdmittanceDevice) — the bus ports
/// of devices that share a bus (one hal::BusShare and one NMT master per shared bus, the SYNC
/// from the first device on a bus), and each instrument's binding to the bodies it drives.
/// ControlLoop (control_loop.hpp) runs its period's stages over the rig's devices through the
/// device face only (hal::Device::read(), write(), supervise(); device.hpp); a run harness reads
/// them through the same face (the state, the output, the report, the conditioning).
/// Construction allocates and may throw; every accessor is noexcept and allocation free.

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "numen/hal/device/device.hpp"
#include "numen/hal/device/device_config.hpp"
#include "numen/hal/device/impedance_device.hpp"
#include "numen/hal/device/instrument_device.hpp"
#include "numen/hal/device/kinematics.hpp"
#include "numen/hal/transport/bus.hpp"
#include "numen/hal/transport/bus_share.hpp"
#include "numen/platform/device_binding.hpp"
#include "numen/platform/period_stages.hpp"

namespace numen::hal {
class AdmittanceDevice;   // admittance_device.hpp: the loop's second kind of device
struct AdmittanceConfig;  // its force sensor and set-point limits
struct AdmittanceSettings;  // its supervision
class NmtMaster;          // the NMT master the managed devices on one bus share (built with them)
}  // namespace numen::hal

namespace numen::platform {

/// One impedance device of a rig (DeviceRig's impedance constructor): an instrument on a bus,
/// the bodies it drives and its supervision.
struct LoopDevice {
  /// Its bus (must outlive the rig). Devices that name the same Bus share it: the rig reads
  /// it through one hal::BusShare port per device, filtered to that device's frames
  /// (hal::controller_filters()), the first of them sends the period's SYNC, and the managed
  /// ones share one NMT master and controller heartbeat (hal::make_device()'s `network`), so
  /// that one device's NMT commands (its start-up, a re-arm's) reach its own nodes only.
  hal::Bus* bus = nullptr;
  /// The instrument (configuration, kinematics, decoding; must outlive the rig); its
  /// DeviceConfig::canopen.managed picks the protocol (hal::make_device()).
  hal::InstrumentDevice* instrument = nullptr;
  /// Which bodies its links drive and which prescribed joints its axes impose (an empty link
  /// list: the rigid binding, link 0 → the held body).
  DeviceBinding binding = DeviceBinding::rigid();
  /// Its supervision (encoder timeout, overrun limit, safe-stop timeout, auto-activation,
  /// drive settings).
  hal::ImpedanceSettings settings;
};

/// The kind of a rig's devices (one kind a rig: the control loop's stage list follows it).
enum class DeviceKind : std::uint8_t {
  kImpedance,   ///< Encoders in, axis torques out (hal::ImpedanceDevice), 1 to kMaxLoopDevices.
  kAdmittance,  ///< A force sensor in, position set-points out (hal::AdmittanceDevice), one.
};

/// The loop's devices, assembled and owned in one place (see the file comment). Not copied or
/// moved: the devices keep pointers to the rig's bus ports and NMT masters. Not thread safe: one
/// real-time thread drives the devices.
class DeviceRig {
 public:
  /// The impedance devices of `devices` (1 to kMaxLoopDevices, device i = devices[i]), each
  /// built for its protocol (hal::make_device(): managed — CanopenMaster, SafetySupervisor,
  /// lifecycle configured to kInactive — or minimal) with its period (DeviceConfig::
  /// control_period_s) and its LoopDevice::settings. Devices naming the same Bus share it
  /// (LoopDevice::bus). Keeps the buses and instruments by reference and the bindings by value.
  /// Throws std::invalid_argument naming the device for no device / more than kMaxLoopDevices,
  /// a null bus or instrument, a control period other than device 0's, bad settings, or managed
  /// devices on one bus whose CANopen nodes overlap or whose controller node id or heartbeat
  /// period differ (one NMT master per bus).
  explicit DeviceRig(std::span<const LoopDevice> devices);
  /// One admittance device built here on `bus` (hal::AdmittanceDevice's constructor with
  /// `device`, `admittance`, the set-points' start `q0` and `settings`; throws as it does).
  /// Keeps a reference: `bus` must outlive the rig.
  DeviceRig(const hal::DeviceConfig& device, const hal::AdmittanceConfig& admittance,
            hal::Bus& bus, const hal::AxisVector& q0, const hal::AdmittanceSettings& settings);
  /// One admittance device built by the caller (kept by reference: it must outlive the rig).
  explicit DeviceRig(hal::AdmittanceDevice& device);
  /// Out of line: the header declares the admittance device and the NMT master only.
  ~DeviceRig();
  DeviceRig(const DeviceRig&) = delete;
  DeviceRig& operator=(const DeviceRig&) = delete;

  /// The kind of the rig's devices.
  DeviceKind kind() const noexcept { return kind_; }
  /// The number of devices, in [1, kMaxLoopDevices] (1 for an admittance rig).
  std::size_t size() const noexcept { return size_; }
  /// Device `i` (< size()) through the device face.
  hal::Device& device(std::size_t i = 0) noexcept { return *devices_[i]; }
  /// Same, read only.
  const hal::Device& device(std::size_t i = 0) const noexcept { return *devices_[i]; }
  /// Device `i`'s instrument (configuration, kinematics, decoding); null for an admittance rig.
  const hal::InstrumentDevice* instrument(std::size_t i = 0) const noexcept {
    return instruments_[i];
  }
  /// Device `i`'s binding as given (an empty one: the rigid binding); the rigid binding for an
  /// admittance rig, whose device drives the held body by its measured wrench.
  const DeviceBinding& binding(std::size_t i = 0) const noexcept { return bindings_[i]; }
  /// The admittance device (null for an impedance rig): its set-points, kinematics and
  /// counters, for the admittance run's emulation and summary.
  const hal::AdmittanceDevice* admittance() const noexcept { return admittance_; }
  /// The devices' control period, ns (DeviceConfig::control_period_s, rounded; the same for
  /// every device).
  std::int64_t period_ns() const noexcept { return period_ns_; }

 private:
  DeviceKind kind_ = DeviceKind::kImpedance;
  std::size_t size_ = 0;
  std::int64_t period_ns_ = 0;
  std::vector<std::unique_ptr<hal::BusShare>> shares_;     // one per bus several devices share
  std::vector<std::unique_ptr<hal::NmtMaster>> networks_;  // same order: their NMT master
  std::array<std::unique_ptr<hal::Device>, kMaxLoopDevices> owned_;  // the devices built here
  std::array<hal::Device*, kMaxLoopDevices> devices_{};              // owned_ or the caller's
  std::array<const hal::InstrumentDevice*, kMaxLoopDevices> instruments_{};
  std::array<DeviceBinding, kMaxLoopDevices> bindings_;
  const hal::AdmittanceDevice* admittance_ = nullptr;
};

}  // namespace numen::platform
