// Tests of numen/hal/transport/log_bus.hpp: relative replay timing (nothing before its time), filters
// (ids, interface, direction), counters, out-of-order logs, looping, writes, no allocation.
#include "numen/hal/transport/log_bus.hpp"

#include <gtest/gtest.h>

#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "alloc_counter.hpp"
#include "numen/hal/transport/can_filter.hpp"
#include "numen/hal/canopen/canopen.hpp"
#include "temp_dir.hpp"

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
using numen::hal::LogBusStream;

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

/// 30 periods of 1 ms on `bus` (every due frame read, a SYNC written) under the allocation
/// counter: none allocates, more than 20 frames come, each counted as replayed.
void expect_replay_without_allocating(LogBus& bus) {
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

TEST(LogBus, ReadAndWriteDoNotAllocate) {
  LogBusSettings s;
  s.filters = {exact_standard_filter(0x181), exact_standard_filter(0x182)};
  s.iface = "can0";
  s.received_only = true;
  s.loop = true;
  s.loop_gap_ns = 800'000;
  LogBus bus(controller_log(), s);
  expect_replay_without_allocating(bus);
}

// --- streaming replay (LogBus(const LogBusStream&)) ------------------------------------------

// A log with out-of-order records, other ids, both directions and an error report, as text.
const std::string kStreamLog =
    "# recorded on can0\n"
    "(1436509052.000000) can0 080# T\n"
    "(1436509052.000150) can0 181#10000000 R\n"
    "(1436509052.000200) can0 201#6400 T\n"
    "DROPCOUNT: dropped 3 CAN frames on 'can0' socket (total drops 3)\n"
    "(1436509052.000100) can1 182#01 R\n"
    "(1436509052.001000) can0 080# T\n"
    "(1436509052.001150) can0 181#20000000 R\n"
    "(1436509052.001160) can0 20000004#0004000000000000 R\n"
    "\n"
    "(1436509052.001200) can0 201#C800 T\n"
    "(1436509052.002150) can0 181#30000000 R\n";

// Everything read() returns while the clock steps by `step_ns` up to `end_ns`, as (time, id).
std::vector<std::pair<std::int64_t, std::uint32_t>> replay(LogBus& bus, std::int64_t step_ns,
                                                            std::int64_t end_ns) {
  std::vector<std::pair<std::int64_t, std::uint32_t>> out;
  CanFrame got;
  for (std::int64_t now = 0; now <= end_ns; now += step_ns) {
    bus.set_time_ns(now);
    while (bus.read(got) == IoStatus::kOk) out.emplace_back(got.timestamp_ns, got.id);
  }
  return out;
}

// A streamed log replays exactly as the same log loaded into memory: frames, due times,
// counters, figures, the loader's counts; with loop, filters and a queue of 1 or 3 records
// (the reader refilling it many times per pass).
TEST(LogBus, StreamedLogReplaysLikeTheLoadedLog) {
  numen::test::TempDir dir;
  const std::string path = dir.write("run.log", kStreamLog);
  for (const bool loop : {false, true}) {
    for (const std::size_t queue : {std::size_t{1}, std::size_t{3}, numen::hal::kLogBusQueueRecords}) {
      LogBusSettings s;
      s.offset_ns = 250'000;
      s.loop = loop;
      s.loop_gap_ns = 300'000;
      s.received_only = true;
      s.filters = {exact_standard_filter(0x181), exact_standard_filter(0x182)};
      numen::hal::CandumpLoadStats loaded_stats, streamed_stats;
      LogBus loaded(numen::hal::load_candump_log(path, &loaded_stats), s);
      LogBusStream stream;
      stream.path = path;
      stream.queue_records = queue;
      LogBus streamed(stream, s, &streamed_stats);
      EXPECT_TRUE(streamed.streaming());
      EXPECT_TRUE(streamed.waits_for_reader());
      EXPECT_FALSE(loaded.streaming());
      EXPECT_EQ(streamed.size(), loaded.size());
      EXPECT_EQ(streamed.span_ns(), loaded.span_ns());
      EXPECT_EQ(streamed.matching_records(), loaded.matching_records());
      EXPECT_EQ(streamed.matching_error_reports(), loaded.matching_error_reports());
      EXPECT_EQ(streamed_stats.records, loaded_stats.records);
      EXPECT_EQ(streamed_stats.lines, loaded_stats.lines);
      EXPECT_EQ(streamed_stats.dropped_frames, 3u);
      EXPECT_EQ(streamed_stats.out_of_order, loaded_stats.out_of_order);
      EXPECT_EQ(streamed.next_due_ns(), loaded.next_due_ns());
      const auto a = replay(loaded, 50'000, 12'000'000);
      const auto b = replay(streamed, 50'000, 12'000'000);
      EXPECT_GT(a.size(), loop ? 20u : 3u);
      EXPECT_EQ(a, b) << "loop " << loop << ", queue " << queue;
      EXPECT_EQ(streamed.log_counters().replayed, loaded.log_counters().replayed);
      EXPECT_EQ(streamed.log_counters().filtered, loaded.log_counters().filtered);
      EXPECT_EQ(streamed.log_counters().passes, loaded.log_counters().passes);
      EXPECT_EQ(streamed.remaining(), loaded.remaining());
      EXPECT_EQ(streamed.finished(), loaded.finished());
      EXPECT_EQ(streamed.reader_error(), "");
    }
  }
}

// The validating pass refuses what load_candump_log() refuses, with the same message, before
// any replay; the settings are checked as for a log in memory.
TEST(LogBus, StreamedLogIsCheckedAtConstruction) {
  numen::test::TempDir dir;
  const auto error = [](const std::string& path, const LogBusSettings& s = {}) -> std::string {
    LogBusStream stream;
    stream.path = path;
    try {
      LogBus bus(stream, s);
    } catch (const std::exception& e) {
      return e.what();
    }
    return "";
  };
  const std::string bad = dir.write("bad.log", "(1.000000) can0 181#01\n(1.001000) can0 18Z#01\n");
  EXPECT_EQ(error(bad).rfind(bad + ":2:", 0), 0u) << error(bad);
  const std::string empty = dir.write("empty.log", "# nothing\n");
  EXPECT_EQ(error(empty), empty +
                              ": no frame records (1 lines: blank, '#' comments or DROPCOUNT "
                              "notes): nothing to replay");
  EXPECT_NE(error(dir.path().string() + "/missing.log").find(": cannot open: "), std::string::npos);
  const std::string one = dir.write("one.log", "(1.000000) can0 181#01\n");
  LogBusSettings loop;
  loop.loop = true;
  EXPECT_NE(error(one, loop).find("pass period > 0"), std::string::npos);
  LogBusStream zero;
  zero.path = one;
  zero.queue_records = 0;
  EXPECT_THROW((LogBus{zero, LogBusSettings{}}), std::invalid_argument);
}

// A log changed on disk after the check (here: a record appended, seen when the looping
// reader opens the file for its second pass) ends the replay there, said by reader_error();
// the first pass, checked, is replayed whole.
TEST(LogBus, StreamedLogChangedOnDiskEndsTheReplay) {
  numen::test::TempDir dir;
  const std::string path = dir.write("run.log", "(5.000000) can0 181#01\n(5.001000) can0 181#02\n");
  LogBusSettings s;
  s.loop = true;
  s.loop_gap_ns = 500'000;
  LogBusStream stream;
  stream.path = path;
  stream.queue_records = 1;  // the reader holds the second record until read() takes the first
  LogBus bus(stream, s);
  dir.write("run.log", "(5.000000) can0 181#01\n(5.001000) can0 181#02\n(5.002000) can0 181#03\n");
  const auto got = replay(bus, 100'000, 10'000'000);
  ASSERT_GE(got.size(), 2u);
  EXPECT_LT(got.size(), 10u);  // not the 14 of an unchanged log
  EXPECT_NE(bus.reader_error().find(path + ": changed since it was checked: 2 records then, "),
            std::string::npos)
      << bus.reader_error();
  EXPECT_FALSE(bus.finished());  // looping, but nothing more comes
}

// The real-time side of a streaming replay does not allocate either (the reader thread does,
// on its own thread: the counter is per thread).
TEST(LogBus, StreamedReadDoesNotAllocate) {
  numen::test::TempDir dir;
  const std::string path = dir.write("run.log", kStreamLog);
  LogBusSettings s;
  s.filters = {exact_standard_filter(0x181), exact_standard_filter(0x182)};
  s.received_only = true;
  s.loop = true;
  s.loop_gap_ns = 800'000;
  LogBusStream stream;
  stream.path = path;
  stream.queue_records = 4;
  LogBus bus(stream, s);
  expect_replay_without_allocating(bus);
}

}  // namespace
