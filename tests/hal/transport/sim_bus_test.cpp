// Tests of numen/hal/transport/sim_bus.hpp: latency, order, capacity, loss, corruption, determinism.
#include "numen/hal/transport/sim_bus.hpp"

#include <gtest/gtest.h>

#include <stdexcept>
#include <vector>

#include "alloc_counter.hpp"

namespace {

using numen::hal::BusState;
using numen::hal::CanFrame;
using numen::hal::IoStatus;
using numen::hal::SimBus;
using numen::hal::SimBusSettings;
using Dir = SimBus::Direction;

CanFrame frame(std::uint32_t id, std::uint8_t len, std::uint8_t fill) {
  CanFrame f;
  f.id = id;
  f.len = len;
  for (int i = 0; i < len; ++i)
    f.data[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(fill + i);
  return f;
}

TEST(SimBus, FrameArrivesOnTheOtherPortAfterTheLatency) {
  SimBusSettings s;
  s.latency_ns = 1000;
  SimBus bus(s);
  bus.set_time_ns(5000);
  ASSERT_EQ(bus.controller().write(frame(0x80, 0, 0)), IoStatus::kOk);
  CanFrame got;
  EXPECT_EQ(bus.controller().read(got), IoStatus::kWouldBlock);  // not looped back
  EXPECT_EQ(bus.device().read(got), IoStatus::kWouldBlock);      // still in flight
  bus.set_time_ns(5999);
  EXPECT_EQ(bus.device().read(got), IoStatus::kWouldBlock);
  bus.set_time_ns(6000);
  ASSERT_EQ(bus.device().read(got), IoStatus::kOk);
  EXPECT_EQ(got.id, 0x80u);
  EXPECT_EQ(got.timestamp_ns, 6000);  // delivery time
  EXPECT_EQ(bus.device().read(got), IoStatus::kWouldBlock);
  EXPECT_EQ(bus.controller().counters().frames_tx, 1u);
  EXPECT_EQ(bus.device().counters().frames_rx, 1u);
}

TEST(SimBus, BothDirectionsAreFifo) {
  SimBus bus(SimBusSettings{});
  for (std::uint8_t i = 0; i < 5; ++i) {
    ASSERT_EQ(bus.device().write(frame(0x181 + i, 4, i)), IoStatus::kOk);
    ASSERT_EQ(bus.controller().write(frame(0x201 + i, 2, i)), IoStatus::kOk);
  }
  CanFrame got;
  for (std::uint32_t i = 0; i < 5; ++i) {
    ASSERT_EQ(bus.controller().read(got), IoStatus::kOk);
    EXPECT_EQ(got.id, 0x181 + i);
    ASSERT_EQ(bus.device().read(got), IoStatus::kOk);
    EXPECT_EQ(got.id, 0x201 + i);
    EXPECT_EQ(got.len, 2);
    EXPECT_EQ(got.data[0], i);
  }
}

TEST(SimBus, FullRingRefusesWritesAndCounts) {
  SimBusSettings s;
  s.capacity = 3;
  SimBus bus(s);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(bus.controller().write(frame(0x100, 1, 0)), IoStatus::kOk);
  EXPECT_EQ(bus.controller().write(frame(0x100, 1, 0)), IoStatus::kWouldBlock);
  EXPECT_EQ(bus.controller().counters().tx_would_block, 1u);
  EXPECT_EQ(bus.link_counters(Dir::kControllerToDevice).full, 1u);
  EXPECT_EQ(bus.pending(Dir::kControllerToDevice), 3u);
  CanFrame got;
  ASSERT_EQ(bus.device().read(got), IoStatus::kOk);
  EXPECT_EQ(bus.controller().write(frame(0x100, 1, 0)), IoStatus::kOk);  // room again
}

TEST(SimBus, MalformedFramesAndBusOffAreErrors) {
  SimBus bus(SimBusSettings{});
  CanFrame bad = frame(0x900, 1, 0);  // 12-bit id on a standard frame
  EXPECT_EQ(bus.controller().write(bad), IoStatus::kError);
  EXPECT_EQ(bus.controller().counters().errors, 1u);
  bus.set_state(BusState::kBusOff);
  EXPECT_EQ(bus.controller().state(), BusState::kBusOff);
  EXPECT_EQ(bus.controller().write(frame(0x100, 1, 0)), IoStatus::kError);
  CanFrame got;
  EXPECT_EQ(bus.device().read(got), IoStatus::kError);
  bus.set_state(BusState::kOk);
  EXPECT_EQ(bus.controller().write(frame(0x100, 1, 0)), IoStatus::kOk);
}

TEST(SimBus, DropProbabilityOneLosesEverything) {
  SimBusSettings s;
  s.drop_probability = 1.0;
  SimBus bus(s);
  for (int i = 0; i < 10; ++i) EXPECT_EQ(bus.controller().write(frame(0x100, 1, 0)), IoStatus::kOk);
  CanFrame got;
  EXPECT_EQ(bus.device().read(got), IoStatus::kWouldBlock);
  EXPECT_EQ(bus.link_counters(Dir::kControllerToDevice).dropped, 10u);
  EXPECT_EQ(bus.device().counters().dropped, 10u);
}

TEST(SimBus, DropRateMatchesTheProbability) {
  SimBusSettings s;
  s.drop_probability = 0.2;
  s.seed = 7;
  SimBus bus(s);
  CanFrame got;
  for (int i = 0; i < 20000; ++i) {
    ASSERT_EQ(bus.controller().write(frame(0x100, 1, 0)), IoStatus::kOk);
    while (bus.device().read(got) == IoStatus::kOk) {
    }
  }
  const double rate =
      static_cast<double>(bus.link_counters(Dir::kControllerToDevice).dropped) / 20000.0;
  EXPECT_NEAR(rate, 0.2, 0.015);
}

TEST(SimBus, CorruptionFlipsOneBitOrChangesTheLength) {
  SimBusSettings s;
  s.corruption_probability = 1.0;
  s.seed = 3;
  s.capacity = 1;
  SimBus bus(s);
  const CanFrame sent = frame(0x181, 4, 0x10);
  int bit_flips = 0;
  int length_changes = 0;
  for (int i = 0; i < 400; ++i) {
    ASSERT_EQ(bus.device().write(sent), IoStatus::kOk);
    CanFrame got;
    ASSERT_EQ(bus.controller().read(got), IoStatus::kOk);
    EXPECT_EQ(got.id, sent.id);
    if (got.len != sent.len) {
      ++length_changes;
      EXPECT_LE(got.len, 8);
    } else {
      int differing_bits = 0;
      for (int b = 0; b < 4; ++b)
        differing_bits += __builtin_popcount(got.data[static_cast<std::size_t>(b)] ^
                                             sent.data[static_cast<std::size_t>(b)]);
      EXPECT_EQ(differing_bits, 1);
      ++bit_flips;
    }
  }
  const auto& c = bus.link_counters(Dir::kDeviceToController);
  EXPECT_EQ(c.corrupted_bit, static_cast<std::uint64_t>(bit_flips));
  EXPECT_EQ(c.corrupted_length, static_cast<std::uint64_t>(length_changes));
  EXPECT_GT(bit_flips, 150);
  EXPECT_GT(length_changes, 150);
}

TEST(SimBus, CorruptedFdFramesKeepAValidFdLength) {
  SimBusSettings s;
  s.corruption_probability = 1.0;
  SimBus bus(s);
  CanFrame f = frame(0x123, 0, 0);
  f.flags = numen::hal::CanFlag::kFd;
  f.len = 64;
  for (int i = 0; i < 200; ++i) {
    ASSERT_EQ(bus.controller().write(f), IoStatus::kOk);
    CanFrame got;
    ASSERT_EQ(bus.device().read(got), IoStatus::kOk);
    EXPECT_TRUE(numen::hal::is_valid_fd_length(got.len));
  }
}

std::vector<std::uint8_t> run_trace(std::uint64_t seed) {
  SimBusSettings s;
  s.latency_ns = 100;
  s.drop_probability = 0.1;
  s.corruption_probability = 0.1;
  s.seed = seed;
  SimBus bus(s);
  std::vector<std::uint8_t> trace;
  for (int i = 0; i < 2000; ++i) {
    bus.set_time_ns(i * 50);
    bus.controller().write(frame(0x200, 2, static_cast<std::uint8_t>(i)));
    bus.device().write(frame(0x180, 4, static_cast<std::uint8_t>(i)));
    CanFrame got;
    while (bus.device().read(got) == IoStatus::kOk) {
      trace.push_back(got.len);
      trace.insert(trace.end(), got.data.begin(), got.data.begin() + got.len);
    }
    while (bus.controller().read(got) == IoStatus::kOk) {
      trace.push_back(got.len);
      trace.insert(trace.end(), got.data.begin(), got.data.begin() + got.len);
    }
  }
  return trace;
}

TEST(SimBus, SameSeedSameRunDifferentSeedDifferentRun) {
  EXPECT_EQ(run_trace(42), run_trace(42));
  EXPECT_NE(run_trace(42), run_trace(43));
}

TEST(SimBus, ReadAndWriteDoNotAllocate) {
  SimBusSettings s;
  s.latency_ns = 10;
  s.drop_probability = 0.1;
  s.corruption_probability = 0.1;
  SimBus bus(s);
  numen::test::AllocationGuard guard;
  CanFrame got;
  for (int i = 0; i < 10000; ++i) {
    bus.set_time_ns(i * 10);
    bus.controller().write(frame(0x200, 2, 1));
    while (bus.device().read(got) == IoStatus::kOk) {
    }
  }
  EXPECT_EQ(guard.count(), 0);
}

TEST(SimBus, InvalidSettingsThrowNamingTheField) {
  auto expect_throw = [](SimBusSettings s, const char* field) {
    try {
      SimBus bus(s);
      ADD_FAILURE() << "no throw for " << field;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  };
  SimBusSettings s;
  s.latency_ns = -1;
  expect_throw(s, "latency_ns");
  s = {};
  s.drop_probability = 1.5;
  expect_throw(s, "drop_probability");
  s = {};
  s.corruption_probability = -0.1;
  expect_throw(s, "corruption_probability");
  s = {};
  s.capacity = 0;
  expect_throw(s, "capacity");
}

}  // namespace
