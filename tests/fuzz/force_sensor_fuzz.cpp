/// @file force_sensor_fuzz.cpp
/// libFuzzer harness of the force/torque sensor driver (hal/device/force_sensor.hpp): its force and
/// torque TPDOs (node 32: 0x1A0, 0x2A0), the other CANopen objects of nodes 1–8 and others
/// through ForceSensor::on_frame(), with sample() between them. A valid sample must be finite
/// and within the configured ranges.

#include <cstdint>

#include "fuzz_input.hpp"
#include "numen/hal/device/force_sensor.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  FuzzedDataProvider in(data, size);
  const numen::hal::ForceSensorConfig config;
  numen::hal::ForceSensor sensor(config);
  static const std::vector<std::uint32_t> ids = numen::fuzz::canopen_cob_ids(
      8, {config.effective_force_cob_id(), config.effective_torque_cob_id(),
          config.effective_force_cob_id(), config.effective_torque_cob_id()});
  numen::fuzz::run_events(
      in, ids, [&](const numen::hal::CanFrame& f) { (void)sensor.on_frame(f); },
      [&](std::int64_t now_ns) {
        const numen::hal::ForceSample s = sensor.sample(now_ns);
        if (s.valid && !(s.wrench.force.allFinite() && s.wrench.torque.allFinite() &&
                         s.wrench.force.norm() <= config.max_force &&
                         s.wrench.torque.norm() <= config.max_torque)) {
          numen::fuzz::finding("force_sensor: a valid sample out of range or not finite");
        }
      });
  return 0;
}
