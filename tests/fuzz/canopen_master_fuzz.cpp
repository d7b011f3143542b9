/// @file canopen_master_fuzz.cpp
/// libFuzzer harness of the controller's CANopen master (hal/device/canopen_master.hpp): frames of
/// every CANopen object of nodes 1–8 (boot-ups and heartbeats, EMCY, CiA 402 drive TPDOs with
/// statusword and torque, NMT, SYNC, SDO) and others through CanopenMaster::on_frame(), with
/// update(), begin_period() and the drive RPDOs between them, for the managed trocar,
/// pose-tracker and phantom devices.

#include <array>
#include <cstdint>

#include "fuzz_input.hpp"
#include "numen/hal/device/canopen_master.hpp"
#include "numen/hal/transport/sim_bus.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  FuzzedDataProvider in(data, size);
  // The master needs the managed stack: even choices of device_config() (0, 1, 2 mod 6).
  const std::uint8_t kind = in.ConsumeIntegralInRange<std::uint8_t>(0, 2);
  numen::hal::CanopenMaster master(numen::fuzz::device_config(kind), 1'000'000);
  numen::hal::SimBus bus{numen::hal::SimBusSettings{}};
  static const std::vector<std::uint32_t> ids = numen::fuzz::canopen_cob_ids(8);
  std::array<std::int16_t, 8> torque{100, -200, 300, 0, 0, 0, 0, 0};
  numen::fuzz::run_events(
      in, ids, [&](const numen::hal::CanFrame& f) { (void)master.on_frame(f); },
      [&](std::int64_t now_ns) {
        bus.set_time_ns(now_ns);
        master.update(now_ns);
        (void)master.begin_period(now_ns, bus.controller());
        (void)master.write_drive_rpdos(now_ns, torque, bus.controller());
        master.request_drives(
            static_cast<numen::hal::Cia402Target>(in.ConsumeIntegralInRange<int>(0, 2)));
        numen::fuzz::drain(bus.device());
      });
  return 0;
}
