/// @file instrument_device_fuzz.cpp
/// libFuzzer harness of the controller-side device driver (hal/device/instrument_device.hpp): frames
/// of every CANopen object of nodes 1–8 (encoder TPDOs, drive TPDOs, NMT, SYNC, EMCY,
/// heartbeats, SDO) and others through InstrumentDevice::on_frame(), with sample(),
/// torques_for() and MinimalDevice::write() between them, for the trocar, pose-tracker and
/// phantom devices, managed or minimal protocol. A valid sample must be finite, and so must
/// the torques sent.

#include <cmath>
#include <cstdint>
#include <span>

#include "fuzz_input.hpp"
#include "numen/hal/device/instrument_device.hpp"
#include "numen/hal/device/minimal_device.hpp"
#include "numen/hal/transport/sim_bus.hpp"

namespace {
bool finite(const numen::core::Pose& p) {
  return p.position.allFinite() && p.orientation.coeffs().allFinite();
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  FuzzedDataProvider in(data, size);
  numen::hal::InstrumentDevice device(
      numen::fuzz::device_config(in.ConsumeIntegral<std::uint8_t>()));
  numen::hal::SimBus bus{numen::hal::SimBusSettings{}};
  numen::hal::MinimalDevice sender(device, bus.controller());
  static const std::vector<std::uint32_t> ids = numen::fuzz::canopen_cob_ids(8);
  numen::fuzz::run_events(
      in, ids, [&](const numen::hal::CanFrame& f) { (void)device.on_frame(f); },
      [&](std::int64_t now_ns) {
        bus.set_time_ns(now_ns);
        const numen::hal::DeviceSample s = device.sample(now_ns);
        if (!finite(s.pose)) numen::fuzz::finding("instrument_device: non-finite target pose");
        numen::core::Wrench w;
        w.force = numen::core::Vec3(1.0, -2.0, 0.5);
        numen::hal::AxisVector tau;
        device.torques_for(std::span<const numen::core::Wrench>(&w, 1), tau);
        (void)sender.write(std::span<const double>(tau.data(), static_cast<std::size_t>(tau.size())),
                           now_ns);
        if (!sender.sent_torques().torque.allFinite())
          numen::fuzz::finding("instrument_device: non-finite torque sent");
        numen::fuzz::drain(bus.device());
      });
  return 0;
}
