// Tests of numen/hal/transport/bus_share.hpp: each port gets its own copy of the frames its
// filters pass, in order; writes reach the shared bus; a full port drops its oldest frame;
// a read error reaches every port once; no allocation in a port's read or write.
#include "numen/hal/transport/bus_share.hpp"

#include <gtest/gtest.h>

#include <stdexcept>
#include <vector>

#include "alloc_counter.hpp"
#include "numen/hal/transport/sim_bus.hpp"

namespace bus_share_test {  // named: the unity build shares a TU with other test files

namespace hal = numen::hal;

hal::CanFrame frame_with_id(std::uint32_t id, std::uint8_t first_byte) {
  hal::CanFrame f;
  f.id = id;
  f.len = 1;
  f.data[0] = first_byte;
  return f;
}

/// The ids `port` has pending now, oldest first.
std::vector<std::uint32_t> drain_ids(hal::Bus& port) {
  std::vector<std::uint32_t> ids;
  hal::CanFrame f;
  while (port.read(f) == hal::IoStatus::kOk) ids.push_back(f.id);
  return ids;
}

TEST(BusShare, EachPortReadsItsOwnCopyOfTheFramesItsFiltersPass) {
  hal::SimBus bus{hal::SimBusSettings{}};
  hal::BusShare share(bus.controller());
  hal::Bus& a = share.add_port({hal::exact_standard_filter(0x181), hal::exact_standard_filter(0x701)});
  hal::Bus& b = share.add_port({hal::exact_standard_filter(0x18B)});
  hal::Bus& all = share.add_port({});
  for (std::uint32_t id : {0x181u, 0x18Bu, 0x701u, 0x555u, 0x18Bu})
    ASSERT_EQ(bus.device().write(frame_with_id(id, 1)), hal::IoStatus::kOk);
  // Port a reads first: it takes its own frames, and the others keep theirs.
  EXPECT_EQ(drain_ids(a), (std::vector<std::uint32_t>{0x181, 0x701}));
  EXPECT_EQ(drain_ids(b), (std::vector<std::uint32_t>{0x18B, 0x18B}));
  EXPECT_EQ(drain_ids(all), (std::vector<std::uint32_t>{0x181, 0x18B, 0x701, 0x555, 0x18B}));
  EXPECT_EQ(a.counters().frames_rx, 2u);
  EXPECT_EQ(b.counters().frames_rx, 2u);
  EXPECT_EQ(share.num_ports(), 3u);
}

TEST(BusShare, WritesGoToTheSharedBus) {
  hal::SimBus bus{hal::SimBusSettings{}};
  hal::BusShare share(bus.controller());
  hal::Bus& a = share.add_port({});
  hal::Bus& b = share.add_port({});
  ASSERT_EQ(a.write(frame_with_id(0x80, 0)), hal::IoStatus::kOk);
  ASSERT_EQ(b.write(frame_with_id(0x20B, 7)), hal::IoStatus::kOk);
  EXPECT_EQ(drain_ids(bus.device()), (std::vector<std::uint32_t>{0x80, 0x20B}));
  EXPECT_EQ(a.counters().frames_tx, 1u);
  EXPECT_EQ(b.counters().frames_tx, 1u);
  EXPECT_TRUE(drain_ids(a).empty());  // a CAN controller does not read its own frames back
}

TEST(BusShare, AFullPortDropsItsOldestFrameAndCountsIt) {
  hal::SimBus bus{hal::SimBusSettings{}};
  hal::BusShare share(bus.controller(), 2);
  hal::Bus& slow = share.add_port({});
  hal::Bus& fast = share.add_port({});
  std::vector<std::uint32_t> fast_ids;
  for (std::uint32_t id : {0x101u, 0x102u, 0x103u}) {
    ASSERT_EQ(bus.device().write(frame_with_id(id, 0)), hal::IoStatus::kOk);
    for (std::uint32_t got : drain_ids(fast)) fast_ids.push_back(got);
  }
  EXPECT_EQ(fast_ids, (std::vector<std::uint32_t>{0x101, 0x102, 0x103}));
  EXPECT_EQ(drain_ids(slow), (std::vector<std::uint32_t>{0x102, 0x103}));
  EXPECT_EQ(slow.counters().dropped, 1u);
  EXPECT_EQ(fast.counters().dropped, 0u);
  EXPECT_THROW(hal::BusShare(bus.controller(), 0), std::invalid_argument);
}

TEST(BusShare, AReadErrorReachesEveryPortOnceAfterItsFrames) {
  hal::SimBus bus{hal::SimBusSettings{}};
  hal::BusShare share(bus.controller());
  hal::Bus& a = share.add_port({});
  hal::Bus& b = share.add_port({});
  ASSERT_EQ(bus.device().write(frame_with_id(0x181, 0)), hal::IoStatus::kOk);
  hal::CanFrame f;
  ASSERT_EQ(a.read(f), hal::IoStatus::kOk);  // the pump took the frame for both ports
  bus.set_state(hal::BusState::kBusOff);
  EXPECT_EQ(a.read(f), hal::IoStatus::kError);
  EXPECT_EQ(b.read(f), hal::IoStatus::kOk);  // b's frame first
  EXPECT_EQ(b.read(f), hal::IoStatus::kError);
  EXPECT_EQ(a.state(), hal::BusState::kBusOff);
  EXPECT_EQ(a.counters().errors, 1u);
  bus.set_state(hal::BusState::kOk);
  // b's reads met the error twice more while a was not reading: a hears of it once, then
  // reads on.
  EXPECT_EQ(a.read(f), hal::IoStatus::kError);
  EXPECT_EQ(a.read(f), hal::IoStatus::kWouldBlock);
  EXPECT_EQ(b.read(f), hal::IoStatus::kWouldBlock);
}

TEST(BusShare, PortsNeitherAllocateNorThrow) {
  hal::SimBus bus{hal::SimBusSettings{}};
  hal::BusShare share(bus.controller(), 8);
  hal::Bus& a = share.add_port({hal::exact_standard_filter(0x181)});
  hal::Bus& b = share.add_port({});
  numen::test::AllocationGuard guard;
  hal::CanFrame f;
  for (int k = 0; k < 100; ++k) {
    (void)bus.device().write(frame_with_id(0x181, static_cast<std::uint8_t>(k)));
    (void)bus.device().write(frame_with_id(0x281, 0));
    (void)a.read(f);
    (void)b.read(f);
    (void)b.read(f);
    (void)a.write(f);
  }
  EXPECT_EQ(guard.count(), 0);
}

}  // namespace bus_share_test
