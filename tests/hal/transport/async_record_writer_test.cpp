// Tests of numen/hal/transport/async_record_writer.hpp, the one queue-and-thread mechanism of the bus
// recorder and the trace writer: every pushed record ends written, refused by the sink's
// format or counted as an I/O error; a full queue drops exactly the excess under kDrop and
// nothing under kWait; push() never allocates; setup errors name the owner's settings.
#include "numen/hal/transport/async_record_writer.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "alloc_counter.hpp"

namespace {

using numen::hal::AsyncRecordWriter;
using numen::hal::FullQueuePolicy;
using numen::hal::RecordSink;
using numen::hal::RecordWriterSettings;
using numen::hal::SinkResult;

struct Sample {
  std::uint64_t k = 0;
};

/// Keeps what it is given; refuses records whose k % 7 == 3 (format) and % 11 == 5 (I/O);
/// optionally sleeps per record (a slow disk) and fails its flushes.
class MemorySink final : public RecordSink<Sample> {
 public:
  SinkResult write(const Sample& s) noexcept override {
    if (slow_us > 0) std::this_thread::sleep_for(std::chrono::microseconds(slow_us));
    if (s.k % 7 == 3) return SinkResult::kFormatError;
    if (s.k % 11 == 5) return SinkResult::kIoError;
    written.push_back(s.k);  // consumer thread only; reserved by the test
    return SinkResult::kWritten;
  }
  bool flush() noexcept override {
    ++flushes;
    return !fail_flush;
  }
  std::vector<std::uint64_t> written;
  std::atomic<int> flushes{0};
  int slow_us = 0;
  bool fail_flush = false;
};

}  // namespace

TEST(AsyncRecordWriter, EveryRecordEndsWrittenRefusedOrCountedInOrder) {
  MemorySink sink;
  sink.written.reserve(1000);
  RecordWriterSettings s;
  s.queue_capacity = 1000;
  AsyncRecordWriter<Sample> writer(sink, s, "TestSettings");
  writer.start();
  for (std::uint64_t k = 0; k < 1000; ++k) ASSERT_TRUE(writer.push(Sample{k}));
  writer.stop();
  const auto c = writer.counters();
  std::uint64_t format = 0, io = 0;
  std::vector<std::uint64_t> expected;
  for (std::uint64_t k = 0; k < 1000; ++k) {
    if (k % 7 == 3) ++format;
    else if (k % 11 == 5) ++io;
    else expected.push_back(k);
  }
  EXPECT_EQ(c.queued, 1000u);
  EXPECT_EQ(c.dropped, 0u);
  EXPECT_EQ(c.format_errors, format);
  EXPECT_EQ(c.io_errors, io);
  EXPECT_EQ(c.written, expected.size());
  EXPECT_EQ(sink.written, expected);  // in push order
  EXPECT_GE(sink.flushes.load(), 1);  // stop() flushes
}

TEST(AsyncRecordWriter, DropPolicyDropsExactlyTheExcessWithoutBlockingOrAllocating) {
  MemorySink sink;
  sink.written.reserve(8);
  RecordWriterSettings s;
  s.queue_capacity = 8;
  AsyncRecordWriter<Sample> writer(sink, s, "TestSettings");  // not started: nobody pops
  {
    numen::test::AllocationGuard guard;
    for (std::uint64_t k = 0; k < 20; ++k) writer.push(Sample{k * 77 + 1});  // none refused
    EXPECT_EQ(guard.count(), 0);
  }
  EXPECT_EQ(writer.counters().queued, 8u);
  EXPECT_EQ(writer.counters().dropped, 12u);
  EXPECT_EQ(writer.drain(), 8u);  // the owner drains on its own thread
  EXPECT_EQ(writer.counters().written, 8u);
}

TEST(AsyncRecordWriter, WaitPolicyLosesNothingBehindASlowSinkAndDropsWhenNotRunning) {
  MemorySink sink;
  sink.written.reserve(400);
  sink.slow_us = 200;  // 400 records at 200 µs: the 16-record queue is full most of the time
  RecordWriterSettings s;
  s.queue_capacity = 16;
  s.full_queue = FullQueuePolicy::kWait;
  AsyncRecordWriter<Sample> writer(sink, s, "TestSettings");
  writer.start();
  for (std::uint64_t k = 0; k < 400; ++k) ASSERT_TRUE(writer.push(Sample{k * 77 + 1}));
  writer.stop();
  EXPECT_EQ(writer.counters().queued, 400u);
  EXPECT_EQ(writer.counters().dropped, 0u);
  EXPECT_GT(writer.counters().waits, 0u);
  EXPECT_EQ(sink.written.size(), 400u);
  // Stopped: a full queue drops even under kWait (nobody would ever make room).
  for (std::uint64_t k = 0; k < 20; ++k) writer.push(Sample{1});
  EXPECT_EQ(writer.counters().dropped, 4u);
}

TEST(AsyncRecordWriter, FailedFlushesAreIoErrors) {
  MemorySink sink;
  sink.fail_flush = true;
  AsyncRecordWriter<Sample> writer(sink, RecordWriterSettings{}, "TestSettings");
  writer.start();
  writer.stop();
  EXPECT_GE(writer.counters().io_errors, 1u);
  writer.count_io_error();
  EXPECT_GE(writer.counters().io_errors, 2u);
}

TEST(AsyncRecordWriter, SetupErrorsNameTheSettings) {
  MemorySink sink;
  RecordWriterSettings zero;
  zero.queue_capacity = 0;
  try {
    AsyncRecordWriter<Sample> w(sink, zero, "TestSettings");
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "TestSettings.queue_capacity must be >= 1 (got 0)");
  }
  RecordWriterSettings poll;
  poll.poll_period_ns = -1;
  try {
    AsyncRecordWriter<Sample> w(sink, poll, "TestSettings");
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "TestSettings.poll_period_ns must be > 0 (got -1)");
  }
  AsyncRecordWriter<Sample> w(sink, RecordWriterSettings{}, "TestSettings");
  w.start();
  EXPECT_THROW(w.start(), std::logic_error);
  EXPECT_TRUE(w.running());
  w.stop();
  w.stop();  // idempotent
  EXPECT_FALSE(w.running());
}
