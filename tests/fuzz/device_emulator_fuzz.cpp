/// @file device_emulator_fuzz.cpp
/// libFuzzer harness of the device side (hal/emulation/device_emulator.hpp, the devices' CANopen
/// stack: NMT, SYNC, the controller's heartbeat, CiA 402 drive RPDOs with controlword and
/// target torque, the minimal torque RPDOs): frames of nodes 1–8 and the controller (127) and
/// others through DeviceEmulator::on_frame(), with tick() between them, for the trocar,
/// pose-tracker and phantom devices, managed or minimal protocol.

#include <cstdint>

#include "fuzz_input.hpp"
#include "numen/hal/emulation/device_emulator.hpp"
#include "numen/hal/transport/sim_bus.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  FuzzedDataProvider in(data, size);
  numen::hal::DeviceEmulator emulator(
      numen::fuzz::device_config(in.ConsumeIntegral<std::uint8_t>()));
  numen::hal::SimBus bus{numen::hal::SimBusSettings{}};
  static const std::vector<std::uint32_t> ids = numen::fuzz::canopen_cob_ids(8, {0x77F});
  numen::fuzz::run_events(
      in, ids, [&](const numen::hal::CanFrame& f) { emulator.on_frame(f, bus.device()); },
      [&](std::int64_t now_ns) {
        bus.set_time_ns(now_ns);
        emulator.tick(now_ns, bus.device());
        numen::fuzz::drain(bus.controller());
      });
  return 0;
}
