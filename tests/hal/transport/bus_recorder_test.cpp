// Tests of numen/hal/transport/bus_recorder.hpp: a RecordingBus over a SimBus writes a candump log that
// load_candump_log reads back identical; no allocation on the loop side; a full queue drops
// and counts without blocking, or waits for room when asked to (offline runs); writer
// lifecycle and errors; recording a LogBus replay.
#include "numen/hal/transport/bus_recorder.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <fstream>
#include <limits>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "alloc_counter.hpp"
#include "numen/hal/canopen/canopen.hpp"
#include "numen/hal/transport/log_bus.hpp"
#include "numen/hal/transport/sim_bus.hpp"
#include "temp_dir.hpp"
#include "csv_lines.hpp"

namespace {

using numen::hal::CandumpDirection;
using numen::hal::CandumpRecord;
using numen::hal::CandumpWriter;
using numen::hal::CandumpWriterSettings;
using numen::hal::CanFlag;
using numen::hal::CanFrame;
using numen::hal::IoStatus;
using numen::hal::RecordingBus;
using numen::hal::SimBus;
using numen::hal::SimBusSettings;

struct Expected {
  CanFrame frame;
  std::string iface;
  CandumpDirection direction;
};

using numen::test::read_lines;

void expect_matches(const std::vector<CandumpRecord>& log, const std::vector<Expected>& want) {
  ASSERT_EQ(log.size(), want.size());
  for (std::size_t i = 0; i < log.size(); ++i) {
    const CanFrame& a = log[i].frame;
    const CanFrame& b = want[i].frame;
    EXPECT_EQ(log[i].timestamp_ns, b.timestamp_ns) << "record " << i;
    EXPECT_EQ(a.timestamp_ns, b.timestamp_ns) << "record " << i;
    EXPECT_EQ(log[i].iface.view(), want[i].iface) << "record " << i;
    EXPECT_EQ(log[i].direction, want[i].direction) << "record " << i;
    EXPECT_EQ(a.id, b.id) << "record " << i;
    EXPECT_EQ(a.flags, b.flags) << "record " << i;
    ASSERT_EQ(a.len, b.len) << "record " << i;
    if (!a.remote()) {
      for (std::size_t k = 0; k < a.len; ++k) EXPECT_EQ(a.data[k], b.data[k]) << i << "/" << k;
    }
  }
}

CanFrame fd_frame(std::int64_t t_ns) {
  CanFrame f;
  f.id = 0x1ABCDE0;
  f.flags = CanFlag::kExtendedId | CanFlag::kFd | CanFlag::kBitRateSwitch;
  f.len = 12;
  for (std::uint8_t i = 0; i < f.len; ++i) f.data[i] = static_cast<std::uint8_t>(0xF0 + i);
  f.timestamp_ns = t_ns;
  return f;
}

// One controller period on a SimBus with 100 µs latency, both ports recorded into one log
// (controller as can0, device as can1). Appends what each RecordingBus passed with kOk.
void run_period(SimBus& bus, RecordingBus& controller, RecordingBus& device, int k,
                std::vector<Expected>* expected) {
  auto note = [&](const CanFrame& f, const char* iface, CandumpDirection d) {
    if (expected != nullptr) expected->push_back({f, iface, d});
  };
  const std::int64_t t = 1'000'000LL * k;
  CanFrame got;
  bus.set_time_ns(t);
  const CanFrame sync = numen::hal::make_sync(t, static_cast<std::uint8_t>(k % 240 + 1));
  ASSERT_EQ(controller.write(sync), IoStatus::kOk);
  note(sync, "can0", CandumpDirection::kTransmitted);

  bus.set_time_ns(t + 100'000);
  ASSERT_EQ(device.read(got), IoStatus::kOk);  // the SYNC, stamped with its delivery
  note(got, "can1", CandumpDirection::kReceived);
  const CanFrame tpdo = numen::hal::encode_position_pdo(0x181, 1000 * k - 7, t + 100'000);
  ASSERT_EQ(device.write(tpdo), IoStatus::kOk);
  note(tpdo, "can1", CandumpDirection::kTransmitted);

  bus.set_time_ns(t + 200'000);
  ASSERT_EQ(controller.read(got), IoStatus::kOk);  // the TPDO
  note(got, "can0", CandumpDirection::kReceived);
  EXPECT_EQ(controller.read(got), IoStatus::kWouldBlock);  // not recorded
  const CanFrame rpdo =
      numen::hal::encode_torque_pdo(0x201, static_cast<std::int16_t>(-k), t + 200'000);
  ASSERT_EQ(controller.write(rpdo), IoStatus::kOk);
  note(rpdo, "can0", CandumpDirection::kTransmitted);
  bus.set_time_ns(t + 300'000);
  ASSERT_EQ(device.read(got), IoStatus::kOk);  // the RPDO
  note(got, "can1", CandumpDirection::kReceived);
}

TEST(BusRecorder, LogOfASimBusRunReadsBackIdentical) {
  numen::test::TempDir dir;
  const std::string path = (dir / "run.log").string();
  SimBusSettings s;
  s.latency_ns = 100'000;
  SimBus bus(s);
  std::vector<Expected> expected;
  {
    CandumpWriter writer(path);
    RecordingBus controller(bus.controller(), writer, "can0");
    RecordingBus device(bus.device(), writer, "can1");
    writer.start();
    for (int k = 0; k < 200; ++k) run_period(bus, controller, device, k, &expected);

    // Frames of the other kinds, written by the controller and read by the device.
    bus.set_time_ns(300'000'000);
    CanFrame rtr;
    rtr.id = 0x701;
    rtr.flags = CanFlag::kRemote;
    rtr.len = 1;
    rtr.timestamp_ns = 300'000'000;
    CanFrame err;
    err.id = 0x004;  // CAN_ERR_CRTL
    err.flags = CanFlag::kErrorFrame;
    err.len = 8;
    err.data[1] = 0x04;
    err.timestamp_ns = 300'000'001;  // sub-µs part: the log keeps µs (checked below)
    for (const CanFrame& f : {fd_frame(300'000'000), rtr, err}) {
      ASSERT_EQ(controller.write(f), IoStatus::kOk);
      expected.push_back({f, "can0", CandumpDirection::kTransmitted});
    }
    expected.back().frame.timestamp_ns = 300'000'000;
    bus.set_time_ns(300'100'000);
    CanFrame got;
    while (device.read(got) == IoStatus::kOk)
      expected.push_back({got, "can1", CandumpDirection::kReceived});
    writer.stop();
    EXPECT_FALSE(writer.running());
    EXPECT_EQ(controller.recording_counters().dropped, 0u);
    EXPECT_EQ(device.recording_counters().dropped, 0u);
    EXPECT_EQ(controller.recording_counters().recorded + device.recording_counters().recorded,
              expected.size());
    const auto c = writer.counters();
    EXPECT_EQ(c.queued, expected.size());
    EXPECT_EQ(c.written, expected.size());
    EXPECT_EQ(c.dropped + c.format_errors + c.io_errors, 0u);
    // The recording bus reports the inner bus's own counters.
    EXPECT_EQ(controller.counters().frames_tx, bus.controller().counters().frames_tx);
  }
  ASSERT_EQ(expected.size(), 200u * 6u + 6u);
  const std::vector<std::string> lines = read_lines(path);
  ASSERT_FALSE(lines.empty());
  EXPECT_EQ(lines[0], "(0000000000.000000) can0 080#01 T");
  EXPECT_EQ(lines[1], "(0000000000.000100) can1 080#01 R");
  EXPECT_EQ(lines[2], "(0000000000.000100) can1 181#F9FFFFFF T");  // -7 counts, LE int32
  expect_matches(numen::hal::load_candump_log(path), expected);
}

TEST(BusRecorder, RecordingBusDoesNotAllocate) {
  numen::test::TempDir dir;
  SimBusSettings s;
  s.latency_ns = 100'000;
  SimBus bus(s);
  CandumpWriter writer((dir / "run.log").string());
  RecordingBus controller(bus.controller(), writer, "can0");
  RecordingBus device(bus.device(), writer, "can1");
  writer.start();
  run_period(bus, controller, device, 0, nullptr);  // warm-up outside the guard
  {
    numen::test::AllocationGuard guard;
    for (int k = 1; k < 500; ++k) run_period(bus, controller, device, k, nullptr);
    EXPECT_EQ(guard.count(), 0);
  }
  writer.stop();
  EXPECT_EQ(writer.counters().written, 500u * 6u);
}

TEST(BusRecorder, FullQueueDropsAndCountsWithoutBlocking) {
  numen::test::TempDir dir;
  const std::string path = (dir / "run.log").string();
  SimBus bus(SimBusSettings{});
  CandumpWriterSettings ws;
  ws.queue_capacity = 4;
  CandumpWriter writer(path, ws);  // not started: nothing drains the queue
  RecordingBus rec(bus.controller(), writer, "can0");
  for (int k = 0; k < 10; ++k) {
    // A blocking push would hang here forever: no thread pops.
    EXPECT_EQ(rec.write(numen::hal::make_sync(1000LL * k)), IoStatus::kOk)
        << "the bus write must not depend on the recording";
  }
  EXPECT_EQ(rec.recording_counters().recorded, 4u);
  EXPECT_EQ(rec.recording_counters().dropped, 6u);
  EXPECT_EQ(writer.counters().queued, 4u);
  EXPECT_EQ(writer.counters().dropped, 6u);
  EXPECT_EQ(bus.controller().counters().frames_tx, 10u);
  writer.start();
  writer.close();  // the log appears under its path
  const std::vector<std::string> lines = read_lines(path);
  ASSERT_EQ(lines.size(), 4u);  // the first four, in order
  EXPECT_EQ(lines[0], "(0000000000.000000) can0 080# T");
  EXPECT_EQ(lines[3], "(0000000000.000003) can0 080# T");
}

TEST(BusRecorder, EveryRecordIsWrittenOrCountedUnderLoad) {
  // Producer in bursts of 32 frames every >= 20 µs, writer polling every 1 ms with room for
  // 64: the writer drains while the producer pushes, some bursts overflow the queue. Every
  // record is either written, whole and in order, or counted as dropped.
  numen::test::TempDir dir;
  const std::string path = (dir / "run.log").string();
  CandumpWriterSettings ws;
  ws.queue_capacity = 64;
  ws.poll_period_ns = 1'000'000;
  const numen::hal::CandumpIface can0 = numen::hal::make_candump_iface("can0");
  constexpr int kFrames = 50'000;
  std::uint64_t dropped = 0;
  {
    CandumpWriter writer(path, ws);
    writer.start();
    for (int k = 0; k < kFrames; ++k) {
      const CanFrame f = numen::hal::encode_position_pdo(0x181, k, 1000LL * k);
      if (!writer.push(f, can0, CandumpDirection::kReceived)) ++dropped;
      if (k % 32 == 31) std::this_thread::sleep_for(std::chrono::microseconds(20));
    }
    writer.stop();
    const auto c = writer.counters();
    EXPECT_EQ(c.dropped, dropped);
    EXPECT_EQ(c.queued + c.dropped, static_cast<std::uint64_t>(kFrames));
    EXPECT_EQ(c.written, c.queued);
    EXPECT_GT(c.written, ws.queue_capacity);  // drained concurrently, not only at stop()
  }
  const std::vector<CandumpRecord> log = numen::hal::load_candump_log(path);
  EXPECT_EQ(log.size() + dropped, static_cast<std::size_t>(kFrames));
  std::int64_t previous = -1;
  for (const CandumpRecord& r : log) {
    std::int32_t counts = 0;
    ASSERT_EQ(numen::hal::decode_position_pdo(r.frame, 0x181, counts),
              numen::hal::DecodeStatus::kOk);
    EXPECT_EQ(r.timestamp_ns, 1000LL * counts);  // payload and time from the same push
    EXPECT_GT(counts, previous);
    previous = counts;
  }
}

TEST(BusRecorder, WaitPolicyLosesNothingWhenTheWriterFallsBehind) {
  // An offline run's recorder (FullQueuePolicy::kWait): room for 64 records, a writer that
  // polls every 5 ms, a producer pushing 20 000 records back to back — far faster than the
  // writer drains. Nothing is dropped: the producer waits for room, and every record is
  // written whole and in order.
  numen::test::TempDir dir;
  const std::string path = (dir / "run.log").string();
  CandumpWriterSettings ws;
  ws.queue_capacity = 64;
  ws.poll_period_ns = 5'000'000;
  ws.full_queue = numen::hal::FullQueuePolicy::kWait;
  const numen::hal::CandumpIface can0 = numen::hal::make_candump_iface("can0");
  constexpr int kFrames = 20'000;
  {
    CandumpWriter writer(path, ws);
    writer.start();
    for (int k = 0; k < kFrames; ++k) {
      const CanFrame f = numen::hal::encode_position_pdo(0x181, k, 1000LL * k);
      ASSERT_TRUE(writer.push(f, can0, CandumpDirection::kReceived)) << "record " << k;
    }
    writer.stop();
    const auto c = writer.counters();
    EXPECT_EQ(c.dropped, 0u);
    EXPECT_EQ(c.queued, static_cast<std::uint64_t>(kFrames));
    EXPECT_EQ(c.written, c.queued);
    EXPECT_GT(c.waits, 0u);  // the queue did fill: the policy was exercised
  }
  const std::vector<CandumpRecord> log = numen::hal::load_candump_log(path);
  ASSERT_EQ(log.size(), static_cast<std::size_t>(kFrames));
  for (int k = 0; k < kFrames; ++k) {
    std::int32_t counts = -1;
    ASSERT_EQ(
        numen::hal::decode_position_pdo(log[static_cast<std::size_t>(k)].frame, 0x181, counts),
        numen::hal::DecodeStatus::kOk);
    ASSERT_EQ(counts, k);
  }
}

TEST(BusRecorder, WaitPolicyDropsWhileTheWriterIsNotRunning) {
  // kWait must not hang a producer that nobody drains: before start() and after stop() a
  // full queue drops and counts, as under kDrop.
  numen::test::TempDir dir;
  CandumpWriterSettings ws;
  ws.queue_capacity = 2;
  ws.full_queue = numen::hal::FullQueuePolicy::kWait;
  CandumpWriter writer((dir / "run.log").string(), ws);
  const numen::hal::CandumpIface can0 = numen::hal::make_candump_iface("can0");
  for (int k = 0; k < 5; ++k)
    writer.push(numen::hal::make_sync(k), can0, CandumpDirection::kTransmitted);
  EXPECT_EQ(writer.counters().queued, 2u);
  EXPECT_EQ(writer.counters().dropped, 3u);
  writer.start();
  writer.stop();  // writes the two
  for (int k = 0; k < 5; ++k)
    writer.push(numen::hal::make_sync(k), can0, CandumpDirection::kTransmitted);
  EXPECT_EQ(writer.counters().queued, 4u);
  EXPECT_EQ(writer.counters().dropped, 6u);
  EXPECT_EQ(writer.counters().waits, 0u);
  EXPECT_EQ(writer.counters().written, 2u);
}

// A frame is written once write(2) accepted its line: on a full device none is, whether the
// records arrived while the writer thread ran (it flushes as the queue empties: a paced run)
// or were queued before it started (one 64 KiB buffer fills and is written out), and every
// queued record ends in `lost`. stdio's buffer counted thousands as written.
TEST(BusRecorder, FramesAreWrittenOnlyWhenTheKernelAcceptsThem) {
  const numen::hal::CandumpIface can0 = numen::hal::make_candump_iface("can0");
  for (const bool thread : {false, true}) {
    CandumpWriterSettings ws;
    ws.queue_capacity = 4096;
    CandumpWriter writer("/dev/full", ws);
    if (thread) writer.start();
    for (int k = 0; k < 3000; ++k)
      ASSERT_TRUE(writer.push(numen::hal::make_sync(k), can0, CandumpDirection::kTransmitted));
    if (!thread) writer.start();
    writer.stop();
    const numen::hal::CandumpWriterCounters c = writer.counters();
    EXPECT_EQ(c.queued, 3000u) << "thread " << thread;
    EXPECT_EQ(c.written, 0u) << "thread " << thread;
    EXPECT_EQ(c.lost, 3000u) << "thread " << thread;
    EXPECT_GT(c.io_errors, 0u) << "thread " << thread;
  }
  // The same records to a file: every one written, none lost.
  numen::test::TempDir dir;
  CandumpWriter writer((dir / "run.log").string());
  writer.start();
  for (int k = 0; k < 3000; ++k)
    ASSERT_TRUE(writer.push(numen::hal::make_sync(k), can0, CandumpDirection::kTransmitted));
  writer.close();  // the log appears under its path
  EXPECT_EQ(writer.counters().written, 3000u);
  EXPECT_EQ(writer.counters().lost + writer.counters().io_errors, 0u);
  EXPECT_EQ(read_lines((dir / "run.log").string()).size(), 3000u);
}

TEST(BusRecorder, UnformattableRecordsAreCountedNotWritten) {
  numen::test::TempDir dir;
  const std::string path = (dir / "run.log").string();
  SimBus bus(SimBusSettings{});
  {
    CandumpWriter writer(path);
    RecordingBus rec(bus.controller(), writer);
    ASSERT_EQ(rec.write(numen::hal::make_sync(-5)), IoStatus::kOk);  // before the epoch
    ASSERT_EQ(rec.write(numen::hal::make_sync(5000)), IoStatus::kOk);
    writer.start();
    writer.stop();
    EXPECT_EQ(writer.counters().format_errors, 1u);
    EXPECT_EQ(writer.counters().written, 1u);
  }
  EXPECT_EQ(read_lines(path), std::vector<std::string>{"(0000000000.000005) can0 080# T"});
}

TEST(BusRecorder, TimeOffsetShiftsEveryLine) {
  numen::test::TempDir dir;
  const std::string path = (dir / "run.log").string();
  CandumpWriterSettings ws;
  ws.time_offset_ns = 1'436'509'052'000'000'000;  // SimBus time 0 -> a candump-like date
  {
    CandumpWriter writer(path, ws);
    const auto iface = numen::hal::make_candump_iface("can0");
    writer.push(numen::hal::make_sync(0), iface, CandumpDirection::kTransmitted);
    writer.push(numen::hal::make_sync(249'713'000), iface, CandumpDirection::kTransmitted);
    writer.push(numen::hal::make_sync(std::numeric_limits<std::int64_t>::max()), iface,
                CandumpDirection::kTransmitted);  // overflows with the offset: not written
    writer.start();
    writer.stop();
    EXPECT_EQ(writer.counters().format_errors, 1u);
  }
  EXPECT_EQ(read_lines(path), (std::vector<std::string>{"(1436509052.000000) can0 080# T",
                                                        "(1436509052.249713) can0 080# T"}));
}

TEST(BusRecorder, DestructorWritesWhatIsStillQueued) {
  numen::test::TempDir dir;
  const std::string path = (dir / "run.log").string();
  CandumpWriterSettings ws;
  ws.mark_direction = false;  // plain candump -l lines
  {
    CandumpWriter writer(path, ws);
    const auto iface = numen::hal::make_candump_iface("vcan0");
    for (int k = 0; k < 3; ++k) {
      writer.push(numen::hal::make_sync(1'000'000LL * k), iface, CandumpDirection::kReceived);
    }
  }
  EXPECT_EQ(read_lines(path), (std::vector<std::string>{"(0000000000.000000) vcan0 080#",
                                                        "(0000000000.001000) vcan0 080#",
                                                        "(0000000000.002000) vcan0 080#"}));
}

TEST(BusRecorder, WriterLifecycleAndSetupErrors) {
  numen::test::TempDir dir;
  CandumpWriter writer((dir / "run.log").string());
  writer.start();
  EXPECT_TRUE(writer.running());
  EXPECT_THROW(writer.start(), std::logic_error);
  writer.stop();
  writer.stop();   // idempotent
  writer.start();  // restartable
  writer.stop();

  EXPECT_THROW(
      {
        try {
          CandumpWriter bad((dir / "no_such_dir" / "run.log").string());
        } catch (const std::runtime_error& e) {
          EXPECT_NE(std::string(e.what()).find("run.log: cannot open for writing: "),
                    std::string::npos)
              << e.what();
          throw;
        }
      },
      std::runtime_error);
  CandumpWriterSettings zero;
  zero.queue_capacity = 0;
  EXPECT_THROW(CandumpWriter((dir / "a.log").string(), zero), std::invalid_argument);
  CandumpWriterSettings poll;
  poll.poll_period_ns = 0;
  EXPECT_THROW(CandumpWriter((dir / "b.log").string(), poll), std::invalid_argument);
  SimBus bus(SimBusSettings{});
  EXPECT_THROW(RecordingBus(bus.controller(), writer, "can 0"), std::invalid_argument);
}

TEST(BusRecorder, RecordingAReplayKeepsReplayedAndWrittenFrames) {
  // A desk run: the field log replayed through LogBus, recorded again with what the
  // controller sends in response.
  numen::test::TempDir dir;
  const std::string field = dir.write("field.log",
                                      "(1436509052.000000) can0 080# T\n"
                                      "(1436509052.000150) can0 181#10000000 R\n"
                                      "(1436509052.001000) can0 080# T\n"
                                      "(1436509052.001150) can0 181#20000000 R\n");
  numen::hal::LogBusSettings ls;
  ls.received_only = true;
  numen::hal::LogBus replay(numen::hal::load_candump_log(field), ls);
  const std::string desk = (dir / "desk.log").string();
  {
    CandumpWriter writer(desk);
    RecordingBus bus(replay, writer, "can0");
    writer.start();
    CanFrame got;
    for (std::int64_t t = 0; t < 2'000'000; t += 1'000'000) {
      replay.set_time_ns(t);
      ASSERT_EQ(bus.write(numen::hal::make_sync(t)), IoStatus::kOk);
      replay.set_time_ns(t + 200'000);
      ASSERT_EQ(bus.read(got), IoStatus::kOk);
    }
    writer.stop();
  }
  EXPECT_EQ(read_lines(desk), (std::vector<std::string>{
                                  "(0000000000.000000) can0 080# T",
                                  "(0000000000.000150) can0 181#10000000 R",
                                  "(0000000000.001000) can0 080# T",
                                  "(0000000000.001150) can0 181#20000000 R",
                              }));
}

}  // namespace
