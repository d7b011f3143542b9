// TraceWriter: CSV that reads back bit-exactly, exact drop counts on a full queue, no
// allocation on push, and no drop at 10 kHz with a real periodic timer and a real file.
#include "numen/platform/trace_queue.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <sched.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "alloc_counter.hpp"
#include "numen/platform/monotonic_clock.hpp"
#include "numen/platform/periodic_timer.hpp"
#include "temp_dir.hpp"
#include "csv_lines.hpp"

using numen::platform::kTraceMaxColumns;
using numen::platform::RealtimeStepStatus;
using numen::platform::TraceRecord;
using numen::platform::TraceWriter;
using numen::platform::TraceWriterSettings;

namespace {

using numen::test::read_lines;

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> fields;
  std::stringstream ss(line);
  std::string f;
  while (std::getline(ss, f, ',')) fields.push_back(f);
  return fields;
}

TraceRecord record(std::uint64_t k) {
  TraceRecord r;
  r.period = k;
  r.time_ns = static_cast<std::int64_t>(k) * 100'000;
  r.flags = static_cast<std::uint32_t>(k & 3);
  for (std::size_t i = 0; i < kTraceMaxColumns; ++i)
    r.values[i] = static_cast<double>(k) / 1000.0 + static_cast<double>(i);
  return r;
}

}  // namespace

TEST(TraceWriter, WritesAHeaderAndLinesThatReadBackExactly) {
  numen::test::TempDir dir;
  const std::string path = (dir / "trace.csv").string();
  const std::vector<double> values = {
      0.1, 1.0 / 3.0, -1e-300, 6.02214076e23, -0.0, std::numeric_limits<double>::infinity(), 42.0};
  {
    TraceWriter writer(path, {"target_x", "god_x", "tiny", "big", "neg_zero", "inf", "contacts"});
    EXPECT_EQ(writer.num_columns(), 7u);
    TraceRecord r;
    r.period = 18'446'744'073'709'551'615ULL;  // UINT64_MAX
    r.time_ns = -5;
    r.flags = 0xFFFFFFFFu;
    for (std::size_t i = 0; i < values.size(); ++i) r.values[i] = values[i];
    r.values[values.size()] = 99.0;  // beyond the columns: not written
    ASSERT_TRUE(writer.push(r));
    writer.start();
    writer.stop();
    EXPECT_EQ(writer.counters().written, 1u);
  }
  const auto lines = read_lines(path);
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_EQ(lines[0], "period,time_ns,flags,target_x,god_x,tiny,big,neg_zero,inf,contacts");
  const auto f = split(lines[1]);
  ASSERT_EQ(f.size(), 10u) << lines[1];
  EXPECT_EQ(f[0], "18446744073709551615");
  EXPECT_EQ(f[1], "-5");
  EXPECT_EQ(f[2], "4294967295");
  for (std::size_t i = 0; i < values.size(); ++i) {
    const double back = std::strtod(f[3 + i].c_str(), nullptr);
    EXPECT_EQ(std::memcmp(&back, &values[i], sizeof(double)), 0) << f[3 + i];
  }
  EXPECT_EQ(f[3], "0.1");  // shortest form, not 0.10000000000000001
  EXPECT_EQ(f[9], "42");
}

TEST(TraceWriter, FullQueueDropsExactlyTheExcessAndCountsIt) {
  numen::test::TempDir dir;
  const std::string path = (dir / "small.csv").string();
  {
    TraceWriterSettings settings;
    settings.queue_capacity = 16;
    TraceWriter writer(path, {"a"}, settings);
    for (std::uint64_t k = 0; k < 20; ++k) EXPECT_EQ(writer.push(record(k)), k < 16) << k;
    auto c = writer.counters();
    EXPECT_EQ(c.queued, 16u);
    EXPECT_EQ(c.dropped, 4u);
    EXPECT_EQ(c.written, 0u);
    writer.start();
    writer.stop();
    c = writer.counters();
    EXPECT_EQ(c.written, 16u);
    EXPECT_FALSE(std::filesystem::exists(path));  // written to a temporary file until closed
    // Stopped again: three more fit, and the destructor writes them.
    for (std::uint64_t k = 100; k < 103; ++k) EXPECT_TRUE(writer.push(record(k)));
    EXPECT_EQ(writer.counters().dropped, 4u);
  }
  const auto lines = read_lines(path);
  ASSERT_EQ(lines.size(), 1u + 16u + 3u);
  for (std::size_t k = 0; k < 16; ++k) EXPECT_EQ(split(lines[1 + k])[0], std::to_string(k));
  EXPECT_EQ(split(lines[17])[0], "100");
  EXPECT_EQ(split(lines[19])[0], "102");
  EXPECT_EQ(split(lines[19])[3], "0.102");
}

TEST(TraceWriter, PushDoesNotAllocateWhetherAcceptedOrDropped) {
  numen::test::TempDir dir;
  TraceWriterSettings settings;
  settings.queue_capacity = 1000;
  TraceWriter writer((dir / "t.csv").string(), {"a", "b"}, settings);
  const TraceRecord r = record(1);
  int accepted = 0;
  numen::test::AllocationGuard guard;
  for (int i = 0; i < 1200; ++i) accepted += writer.push(r) ? 1 : 0;
  EXPECT_EQ(guard.count(), 0);
  EXPECT_EQ(accepted, 1000);
  EXPECT_EQ(writer.counters().dropped, 200u);
}

// 10,000 records paced by a real PeriodicTimer at 10 kHz (1 s) into a real file, with the
// default settings: nothing may be dropped, every record must be on disk in order.
TEST(TraceWriter, NoDropAt10kHzIntoARealFile) {
  numen::test::TempDir dir;
  const std::string path = (dir / "paced.csv").string();
  std::vector<std::string> columns;
  for (int i = 0; i < 16; ++i) {
    std::string name = "c";  // not "c" + to_string(i): GCC 12 -Wrestrict false positive
    name += std::to_string(i);
    columns.push_back(name);
  }
  constexpr int kRecords = 10'000;
  {
    TraceWriter writer(path, columns);
    writer.start();
    numen::platform::PeriodicTimer timer(100'000, numen::platform::monotonic_now_ns());
    std::int64_t pushes_failed = 0;
    numen::test::AllocationGuard guard;
    for (int k = 0; k < kRecords; ++k) {
      const numen::platform::Wakeup w = timer.wait_next();
      TraceRecord r = record(static_cast<std::uint64_t>(k));
      r.time_ns = w.woke_ns;
      pushes_failed += writer.push(r) ? 0 : 1;
    }
    EXPECT_EQ(guard.count(), 0);
    writer.stop();
    const auto c = writer.counters();
    EXPECT_EQ(pushes_failed, 0);
    EXPECT_EQ(c.dropped, 0u);
    EXPECT_EQ(c.queued, static_cast<std::uint64_t>(kRecords));
    EXPECT_EQ(c.written, static_cast<std::uint64_t>(kRecords));
    EXPECT_EQ(c.io_errors, 0u);
  }
  const auto lines = read_lines(path);
  ASSERT_EQ(lines.size(), 1u + kRecords);
  std::int64_t last_time = 0;
  for (int k = 0; k < kRecords; ++k) {
    const auto f = split(lines[1 + static_cast<std::size_t>(k)]);
    ASSERT_EQ(f.size(), 3u + 16u);
    ASSERT_EQ(f[0], std::to_string(k));
    const std::int64_t t = std::stoll(f[1]);
    ASSERT_GT(t, last_time);  // in order, one line per period
    last_time = t;
  }
}

TEST(TraceWriter, WriterThreadAffinityIsReported) {
  numen::test::TempDir dir;
  TraceWriter writer((dir / "a.csv").string(), {"a"});
  EXPECT_EQ(writer.start().status, RealtimeStepStatus::kNotRequested);
  EXPECT_THROW(writer.start(), std::logic_error);
  writer.stop();
  EXPECT_FALSE(writer.running());
  cpu_set_t mine;
  sched_getaffinity(0, sizeof(mine), &mine);
  int first = 0;
  while (!CPU_ISSET(first, &mine)) ++first;
  const auto applied = writer.start({first});
  EXPECT_EQ(applied.status, RealtimeStepStatus::kApplied) << applied.message;
  writer.stop();
  const auto refused = writer.start({-3});
  EXPECT_EQ(refused.status, RealtimeStepStatus::kFailed);
  EXPECT_NE(refused.message.find("CPU -3 is not a valid CPU index"), std::string::npos);
  EXPECT_TRUE(writer.running());  // it writes anyway
  EXPECT_TRUE(writer.push(record(0)));
  writer.stop();
  EXPECT_EQ(writer.counters().written, 1u);
}

TEST(TraceWriter, SetupErrorsNameTheColumnOrPath) {
  numen::test::TempDir dir;
  const std::string path = (dir / "e.csv").string();
  auto message = [&](std::vector<std::string> columns, TraceWriterSettings s = {}) {
    try {
      TraceWriter w(path, std::move(columns), s);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no exception");
  };
  EXPECT_EQ(message({}), "TraceWriter: 1..32 columns required (got 0)");
  EXPECT_EQ(message(std::vector<std::string>(33, "x")),
            "TraceWriter: 1..32 columns required (got 33)");
  EXPECT_EQ(message({"a", ""}), "TraceWriter column 1: empty name");
  EXPECT_EQ(message({"force,x"}),
            "TraceWriter column 0 'force,x': a name must not contain a comma, quote, CR or LF");
  EXPECT_EQ(message({"a", "flags"}),
            "TraceWriter column 1 'flags': reserved for the fixed columns");
  EXPECT_EQ(message({"a", "b", "a"}), "TraceWriter column 2 'a': duplicate name");
  TraceWriterSettings zero;
  zero.queue_capacity = 0;
  EXPECT_EQ(message({"a"}, zero), "TraceWriterSettings.queue_capacity must be >= 1 (got 0)");
  const std::string missing = (dir / "no/such/dir/t.csv").string();
  try {
    TraceWriter w(missing, {"a"});
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()),
              missing + ": cannot open for writing: No such file or directory");
  }
}
