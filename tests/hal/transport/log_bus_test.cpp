// Tests of numen/hal/transport/log_bus.hpp: relative replay timing (nothing before its time), filters
// (ids, interface, direction), counters, out-of-order logs, looping, writes, no allocation.
#include "numen/hal/transport/log_bus.hpp"

#include <gtest/gtest.h>

#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "alloc_counter.hpp"
#include "numen/hal/transport/can_filter.hpp"
#include "numen/hal/canopen/canopen.hpp"

namespace {

using numen::hal::CandumpDirection;
using numen::hal::CandumpRecord;
using numen::hal::CanFilter;
using numen::hal::CanFlag;
using numen::hal::CanFrame;
using numen::hal::exact_standard_filter;
using numen::hal::IoStatus;
using numen::hal::LogBus;
using numen::hal::LogBusSettings;

// A record parsed from a candump line, so the tests read like the logs they replay.
CandumpRecord rec(const std::string& line) {
  CandumpRecord r;
  const auto result = numen::hal::parse_candump_line(line, r);
  EXPECT_TRUE(result.ok()) << line << ": " << to_string(result.error);
  return r;
}

// Controller-side recording of three 1 ms periods: SYNC and torque RPDO sent (T), encoder
// TPDO received (R), on a log clock around 1436509052 s.
std::vector<CandumpRecord> controller_log() {
  return {
      rec("(1436509052.000000) can0 080# T"),          // t = 0
      rec("(1436509052.000150) can0 181#10000000 R"),  // 150 µs
      rec("(1436509052.000200) can0 201#6400 T"),      // 200 µs
      rec("(1436509052.001000) can0 080# T"),          // 1 ms
      rec("(1436509052.001150) can0 181#20000000 R"), rec("(1436509052.001200) can0 201#C800 T"),
      rec("(1436509052.002000) can0 080# T"),  // 2 ms
      rec("(1436509052.002150) can0 181#30000000 R"), rec("(1436509052.002200) can0 201#2C01 T"),
  };
}

TEST(LogBus, NoFrameBeforeItsTimeAndEachAtItsFirstChance) {
  LogBusSettings s;
  s.offset_ns = 5000;
  const std::vector<CandumpRecord> log = controller_log();
  LogBus bus(log, s);
  EXPECT_EQ(bus.span_ns(), 2'200'000);
  CanFrame got;
  bus.set_time_ns(4999);
  EXPECT_EQ(bus.read(got), IoStatus::kWouldBlock);  // first record due at the offset
  // Step the clock in 50 µs steps; every frame comes out at the first step at or after its
  // due time (offset + log time − first log time), in log order.
  std::size_t next = 0;
  std::int64_t previous_now = 4999;
  for (std::int64_t now = 5000; now <= 5000 + 2'300'000; now += 50'000) {
    bus.set_time_ns(now);
    while (bus.read(got) == IoStatus::kOk) {
      ASSERT_LT(next, log.size());
      const std::int64_t due = 5000 + (log[next].timestamp_ns - log[0].timestamp_ns);
      EXPECT_EQ(got.timestamp_ns, due);
      EXPECT_LE(due, now) << "frame " << next << " returned before its time";
      EXPECT_GT(due, previous_now) << "frame " << next << " returned late";
      EXPECT_EQ(got.id, log[next].frame.id);
      EXPECT_EQ(got.len, log[next].frame.len);
      ++next;
    }
    previous_now = now;
  }
  EXPECT_EQ(next, log.size());
  EXPECT_TRUE(bus.finished());
  EXPECT_EQ(bus.remaining(), 0u);
  EXPECT_EQ(bus.log_counters().replayed, log.size());
  EXPECT_EQ(bus.log_counters().filtered, 0u);
  EXPECT_EQ(bus.log_counters().passes, 1u);
  EXPECT_EQ(bus.counters().frames_rx, log.size());
}

TEST(LogBus, ExactDueTimeIsInclusive) {
  LogBus bus(controller_log());
  CanFrame got;
  ASSERT_EQ(bus.read(got), IoStatus::kOk);  // record 0 due at 0 = now
  bus.set_time_ns(149'999);
  EXPECT_EQ(bus.read(got), IoStatus::kWouldBlock);
  EXPECT_EQ(bus.next_due_ns(), 150'000);
  bus.set_time_ns(150'000);
  ASSERT_EQ(bus.read(got), IoStatus::kOk);
  EXPECT_EQ(got.id, 0x181u);
  EXPECT_EQ(got.data[0], 0x10);
}

TEST(LogBus, FiltersPassOnlyWhatTheControllerWouldReceive) {
  LogBusSettings s;
  s.filters = {exact_standard_filter(numen::hal::encoder_tpdo_cob_id(1))};
  LogBus bus(controller_log(), s);
  bus.set_time_ns(1'500'000);  // six records due, two of them TPDOs
  CanFrame got;
  ASSERT_EQ(bus.read(got), IoStatus::kOk);
  EXPECT_EQ(got.id, 0x181u);
  EXPECT_EQ(got.timestamp_ns, 150'000);
  EXPECT_EQ(bus.log_counters().filtered, 1u);  // the SYNC before it
  ASSERT_EQ(bus.read(got), IoStatus::kOk);
  EXPECT_EQ(got.id, 0x181u);
  EXPECT_EQ(got.data[0], 0x20);
  EXPECT_EQ(bus.read(got), IoStatus::kWouldBlock);
  EXPECT_EQ(bus.log_counters().replayed, 2u);
  EXPECT_EQ(bus.log_counters().filtered, 4u);  // SYNC, RPDO, SYNC, RPDO
  EXPECT_EQ(bus.remaining(), 3u);
  EXPECT_FALSE(bus.finished());
  bus.set_time_ns(10'000'000);
  ASSERT_EQ(bus.read(got), IoStatus::kOk);
  EXPECT_EQ(got.data[0], 0x30);
  EXPECT_EQ(bus.read(got), IoStatus::kWouldBlock);
  EXPECT_TRUE(bus.finished());
  EXPECT_EQ(bus.log_counters().replayed, 3u);
  EXPECT_EQ(bus.log_counters().filtered, 6u);
}

TEST(LogBus, ReceivedOnlySkipsTheLoggersOwnTransmissions) {
  LogBusSettings s;
  s.received_only = true;
  LogBus bus(controller_log(), s);
  bus.set_time_ns(1'000'000'000);
  CanFrame got;
  std::vector<std::uint32_t> ids;
  while (bus.read(got) == IoStatus::kOk) ids.push_back(got.id);
  EXPECT_EQ(ids, (std::vector<std::uint32_t>{0x181, 0x181, 0x181}));
  EXPECT_EQ(bus.log_counters().filtered, 6u);
}

TEST(LogBus, InterfaceFilterAndExtendedFilter) {
  const std::vector<CandumpRecord> log = {
      rec("(10.000000) can0 181#01"),
      rec("(10.000100) can1 181#02"),
      rec("(10.000200) can1 00000181#03"),                // 29-bit, same number
      rec("(10.000300) can1 181#R4"),                     // remote request of the same id
      rec("(10.000400) can1 20000004#0004000000000000"),  // error report: passes filters
  };
  LogBusSettings s;
  s.iface = "can1";
  s.filters = {exact_standard_filter(0x181)};
  LogBus bus(log, s);
  bus.set_time_ns(1'000'000);
  CanFrame got;
  ASSERT_EQ(bus.read(got), IoStatus::kOk);
  EXPECT_EQ(got.data[0], 0x02);
  ASSERT_EQ(bus.read(got), IoStatus::kOk);
  EXPECT_TRUE(got.error_frame());
  EXPECT_EQ(bus.read(got), IoStatus::kWouldBlock);
  EXPECT_EQ(bus.log_counters().filtered, 3u);  // can0, 29-bit, remote
  EXPECT_EQ(bus.matching_records(), 2u);        // known before the replay
  EXPECT_EQ(bus.matching_error_reports(), 1u);

  LogBusSettings ext;
  ext.filters = {CanFilter{0x181 | numen::hal::kFilterExtendedBit,
                           0x1FFFFFFF | numen::hal::kFilterExtendedBit}};
  LogBus ext_bus(log, ext);
  ext_bus.set_time_ns(1'000'000);
  ASSERT_EQ(ext_bus.read(got), IoStatus::kOk);
  EXPECT_TRUE(got.extended());
  EXPECT_EQ(got.data[0], 0x03);
}

TEST(LogBus, RecordsOutOfTimeOrderFollowTheirPredecessor) {
  // A clock step backwards in the log: the record is due right after the one before it
  // (canplayer sends it at once), and due times never decrease.
  const std::vector<CandumpRecord> log = {
      rec("(100.000000) can0 181#01"),
      rec("(100.002000) can0 181#02"),
      rec("(99.000000) can0 181#03"),
      rec("(100.003000) can0 181#04"),
  };
  LogBus bus(log);
  CanFrame got;
  bus.set_time_ns(1'999'999);
  ASSERT_EQ(bus.read(got), IoStatus::kOk);
  EXPECT_EQ(bus.read(got), IoStatus::kWouldBlock);  // #02 not due, so neither is #03
  bus.set_time_ns(2'000'000);
  ASSERT_EQ(bus.read(got), IoStatus::kOk);
  EXPECT_EQ(got.data[0], 0x02);
  ASSERT_EQ(bus.read(got), IoStatus::kOk);
  EXPECT_EQ(got.data[0], 0x03);
  EXPECT_EQ(got.timestamp_ns, 2'000'000);
  EXPECT_EQ(bus.read(got), IoStatus::kWouldBlock);
  bus.set_time_ns(3'000'000);
  ASSERT_EQ(bus.read(got), IoStatus::kOk);
  EXPECT_EQ(got.data[0], 0x04);
}

TEST(LogBus, LoopReplaysFromTheStartOnePeriodLater) {
  const std::vector<CandumpRecord> log = {
      rec("(5.000000) can0 181#01"),
      rec("(5.001000) can0 181#02"),
  };
  LogBusSettings s;
  s.loop = true;
  s.loop_gap_ns = 500'000;  // pass period 1.5 ms
  LogBus bus(log, s);
  CanFrame got;
  std::vector<std::int64_t> stamps;
  for (std::int64_t now = 0; now <= 4'600'000; now += 100'000) {
    bus.set_time_ns(now);
    while (bus.read(got) == IoStatus::kOk) stamps.push_back(got.timestamp_ns);
  }
  EXPECT_EQ(stamps, (std::vector<std::int64_t>{0, 1'000'000, 1'500'000, 2'500'000, 3'000'000,
                                               4'000'000, 4'500'000}));
  EXPECT_EQ(bus.log_counters().passes, 3u);
  EXPECT_FALSE(bus.finished());
}

TEST(LogBus, SettingsAreChecked) {
  const std::vector<CandumpRecord> one = {rec("(5.000000) can0 181#01")};
  LogBusSettings loop;
  loop.loop = true;
  EXPECT_THROW((LogBus{one, loop}), std::invalid_argument);  // span 0, gap 0: infinite frames
  loop.loop_gap_ns = 1;
  EXPECT_NO_THROW((LogBus{one, loop}));
  LogBusSettings gap;
  gap.loop_gap_ns = -1;
  EXPECT_THROW((LogBus{one, gap}), std::invalid_argument);
  LogBusSettings iface;
  iface.iface = "can 0";
  EXPECT_THROW((LogBus{one, iface}), std::invalid_argument);
  LogBusSettings offset;
  offset.offset_ns = std::numeric_limits<std::int64_t>::max();
  EXPECT_NO_THROW((LogBus{one, offset}));  // span 0
  EXPECT_THROW((LogBus{controller_log(), offset}), std::invalid_argument);
}

// A log holding nothing for the controller's ids says so before the replay (the run harness
// turns matching_records() == 0 into an error).
TEST(LogBus, MatchingRecordsCountsWhatTheFiltersLeave) {
  LogBusSettings s;
  s.filters = {exact_standard_filter(numen::hal::encoder_tpdo_cob_id(5))};
  LogBus other(controller_log(), s);
  EXPECT_EQ(other.size(), 9u);
  EXPECT_EQ(other.matching_records(), 0u);
  LogBusSettings received;
  received.received_only = true;
  EXPECT_EQ(LogBus(controller_log(), received).matching_records(), 3u);
  EXPECT_EQ(LogBus(controller_log()).matching_records(), 9u);
}

TEST(LogBus, EmptyLogIsFinishedAtOnce) {
  LogBus bus(std::vector<CandumpRecord>{});
  CanFrame got;
  EXPECT_EQ(bus.matching_records(), 0u);
  EXPECT_TRUE(bus.finished());
  EXPECT_EQ(bus.read(got), IoStatus::kWouldBlock);
  LogBusSettings loop;
  loop.loop = true;
  LogBus looping(std::vector<CandumpRecord>{}, loop);
  looping.set_time_ns(1'000'000'000);
  EXPECT_EQ(looping.read(got), IoStatus::kWouldBlock);
}

TEST(LogBus, WritesAreAcceptedAndCounted) {
  LogBus bus(controller_log());
  EXPECT_EQ(bus.write(numen::hal::make_sync(0)), IoStatus::kOk);
  EXPECT_EQ(bus.write(numen::hal::encode_torque_pdo(0x201, 100, 0)), IoStatus::kOk);
  CanFrame bad;
  bad.id = 0x800;  // 12 bits without kExtendedId
  EXPECT_EQ(bus.write(bad), IoStatus::kError);
  EXPECT_EQ(bus.counters().frames_tx, 2u);
  EXPECT_EQ(bus.counters().errors, 1u);
  EXPECT_EQ(bus.log_counters().replayed, 0u);  // writes do not touch the replay
  EXPECT_EQ(bus.remaining(), controller_log().size());
}

TEST(LogBus, ReadAndWriteDoNotAllocate) {
  LogBusSettings s;
  s.filters = {exact_standard_filter(0x181), exact_standard_filter(0x182)};
  s.iface = "can0";
  s.received_only = true;
  s.loop = true;
  s.loop_gap_ns = 800'000;
  LogBus bus(controller_log(), s);
  CanFrame got;
  std::uint64_t frames = 0;
  numen::test::AllocationGuard guard;
  for (std::int64_t now = 0; now < 30'000'000; now += 1'000'000) {
    bus.set_time_ns(now);
    while (bus.read(got) == IoStatus::kOk) ++frames;
    bus.write(numen::hal::make_sync(now));
  }
  EXPECT_EQ(guard.count(), 0);
  EXPECT_GT(frames, 20u);
  EXPECT_EQ(frames, bus.log_counters().replayed);
}

}  // namespace
