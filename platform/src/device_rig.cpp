/// @file device_rig.cpp
/// The loop's devices assembled (device_rig.hpp): the impedance devices with their shared
/// buses and NMT masters, or the one admittance device.

#include "numen/platform/device_rig.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

#include "numen/hal/device/admittance_device.hpp"
#include "numen/hal/device/bus_filters.hpp"
#include "numen/hal/device/nmt_master.hpp"

namespace numen::platform {

namespace {

std::int64_t control_period_ns(const hal::DeviceConfig& config) {
  return static_cast<std::int64_t>(std::llround(config.control_period_s * 1e9));
}

// The devices of the impedance constructor, checked (count, pointers, one control period).
std::span<const LoopDevice> checked_devices(std::span<const LoopDevice> devices) {
  if (devices.empty() || devices.size() > static_cast<std::size_t>(kMaxLoopDevices))
    throw std::invalid_argument("control loop: " + std::to_string(devices.size()) +
                                " devices (1 to " + std::to_string(kMaxLoopDevices) + ")");
  for (std::size_t i = 0; i < devices.size(); ++i) {
    const LoopDevice& d = devices[i];
    if (d.bus == nullptr || d.instrument == nullptr)
      throw std::invalid_argument("control loop: device " + std::to_string(i) +
                                  " has no bus or no instrument");
    if (control_period_ns(d.instrument->config()) !=
        control_period_ns(devices[0].instrument->config()))
      throw std::invalid_argument("control loop: device " + std::to_string(i) + " ('" +
                                  d.instrument->config().name +
                                  "') has another control period than device 0");
  }
  return devices;
}

}  // namespace

DeviceRig::DeviceRig(std::span<const LoopDevice> devices)
    : kind_(DeviceKind::kImpedance),
      size_(checked_devices(devices).size()),
      period_ns_(control_period_ns(devices[0].instrument->config())) {
  // The buses several devices share: one BusShare each, a port per device with its filters;
  // the first device on a bus sends the SYNC; its managed devices share one NMT master, which
  // knows its minimal devices too (it then addresses every command).
  static_assert(static_cast<std::size_t>(kMaxLoopDevices) <= hal::kMaxNmtDevices);
  std::array<hal::Bus*, kMaxLoopDevices> port{};
  std::array<hal::NmtMaster*, kMaxLoopDevices> network{};
  std::array<bool, kMaxLoopDevices> sync_producer{};
  for (std::size_t i = 0; i < devices.size(); ++i) {
    std::size_t first = i;
    std::size_t users = 0;
    for (std::size_t j = 0; j < devices.size(); ++j) {
      if (devices[j].bus != devices[i].bus) continue;
      if (j < first) first = j;
      ++users;
    }
    sync_producer[i] = first == i;
    if (users == 1) {
      port[i] = devices[i].bus;
      continue;
    }
    if (first == i) {
      shares_.push_back(std::make_unique<hal::BusShare>(*devices[i].bus));
      networks_.push_back(std::make_unique<hal::NmtMaster>());
    }
    std::size_t s = 0;
    while (&shares_[s]->bus() != devices[i].bus) ++s;
    port[i] = &shares_[s]->add_port(hal::controller_filters(devices[i].instrument->config()));
    network[i] = networks_[s].get();
    // A minimal device's self-starting nodes share the network: no NMT broadcast may reach
    // them (its managed peers' commands go to their own nodes, addressed).
    const hal::DeviceConfig& config = devices[i].instrument->config();
    if (!config.canopen.managed) networks_[s]->add_bystander(config);
  }
  for (std::size_t i = 0; i < devices.size(); ++i) {
    const LoopDevice& d = devices[i];
    owned_[i] = hal::make_device(*d.instrument, *port[i], period_ns_, d.settings, network[i]);
    owned_[i]->set_sync_producer(sync_producer[i]);
    devices_[i] = owned_[i].get();
    instruments_[i] = d.instrument;
    bindings_[i] = d.binding;
  }
}

DeviceRig::DeviceRig(const hal::DeviceConfig& device, const hal::AdmittanceConfig& admittance,
                     hal::Bus& bus, const hal::AxisVector& q0,
                     const hal::AdmittanceSettings& settings)
    : kind_(DeviceKind::kAdmittance), size_(1), period_ns_(control_period_ns(device)) {
  auto built = std::make_unique<hal::AdmittanceDevice>(device, admittance, bus, q0, settings);
  admittance_ = built.get();
  devices_[0] = built.get();
  owned_[0] = std::move(built);
}

DeviceRig::DeviceRig(hal::AdmittanceDevice& device)
    : kind_(DeviceKind::kAdmittance),
      size_(1),
      period_ns_(control_period_ns(device.config())),
      admittance_(&device) {
  devices_[0] = &device;
}

DeviceRig::~DeviceRig() = default;

}  // namespace numen::platform
