/// @file trace_queue.cpp
/// Non-blocking per-period traces: a lock-free SPSC queue from the loop to a writer thread
/// that formats CSV lines into a stdio-buffered file.

#include "numen/platform/trace_queue.hpp"

#include <pthread.h>
#include <sched.h>

#include <boost/lockfree/spsc_queue.hpp>
#include <cerrno>
#include <charconv>
#include <chrono>
#include <cstring>
#include <future>
#include <stdexcept>
#include <type_traits>
#include <unordered_set>

namespace numen::platform {
namespace {

static_assert(std::is_trivially_copyable_v<TraceRecord>, "records are copied, never built");
static_assert(std::atomic<std::uint64_t>::is_always_lock_free,
              "the producer's counters must not take a lock");

// Longest line: three integers (20 digits + sign) and kTraceMaxColumns doubles (to_chars
// shortest form: at most 24 characters), each with its separator, and the newline.
constexpr std::size_t kLineBufferSize = 3 * 22 + kTraceMaxColumns * 26 + 2;

/// Appends `sep` (unless '\0') and `v` at `p` (doubles in the shortest round-trip form);
/// false if it does not fit before `end`.
template <class T>
bool put(char*& p, char* end, T v, char sep) noexcept {
  if (sep != '\0') {
    if (p == end) return false;
    *p++ = sep;
  }
  const std::to_chars_result r = std::to_chars(p, end, v);
  if (r.ec != std::errc{}) return false;
  p = r.ptr;
  return true;
}

void check_column(const std::vector<std::string>& columns, std::size_t i) {
  const std::string& name = columns[i];
  const std::string where = "TraceWriter column " + std::to_string(i);
  if (name.empty()) throw std::invalid_argument(where + ": empty name");
  if (name.find_first_of(",\"\r\n") != std::string::npos)
    throw std::invalid_argument(where + " '" + name +
                                "': a name must not contain a comma, quote, CR or LF");
  if (name == "period" || name == "time_ns" || name == "flags")
    throw std::invalid_argument(where + " '" + name + "': reserved for the fixed columns");
}

}  // namespace

struct TraceWriter::Queue {
  explicit Queue(std::size_t capacity) : ring(capacity) {}
  boost::lockfree::spsc_queue<TraceRecord> ring;  // runtime capacity: one allocation, here
};

TraceWriter::TraceWriter(const std::string& path, std::vector<std::string> columns,
                         const TraceWriterSettings& settings)
    : path_(path), columns_(std::move(columns)), settings_(settings) {
  if (columns_.empty() || columns_.size() > kTraceMaxColumns)
    throw std::invalid_argument("TraceWriter: 1.." + std::to_string(kTraceMaxColumns) +
                                " columns required (got " + std::to_string(columns_.size()) + ")");
  std::unordered_set<std::string> seen;
  for (std::size_t i = 0; i < columns_.size(); ++i) {
    check_column(columns_, i);
    if (!seen.insert(columns_[i]).second)
      throw std::invalid_argument("TraceWriter column " + std::to_string(i) + " '" + columns_[i] +
                                  "': duplicate name");
  }
  if (settings.queue_capacity == 0)
    throw std::invalid_argument("TraceWriterSettings.queue_capacity must be >= 1 (got 0)");
  if (settings.poll_period_ns <= 0)
    throw std::invalid_argument("TraceWriterSettings.poll_period_ns must be > 0 (got " +
                                std::to_string(settings.poll_period_ns) + ")");
  queue_ = std::make_unique<Queue>(settings.queue_capacity);
  file_ = std::fopen(path.c_str(), "w");
  if (file_ == nullptr) {
    const int err = errno;
    throw std::runtime_error(path + ": cannot open for writing: " + std::strerror(err));
  }
  std::string header = "period,time_ns,flags";
  for (const std::string& c : columns_) header += ',' + c;
  header += '\n';
  if (std::fwrite(header.data(), 1, header.size(), file_) != header.size()) {
    const int err = errno;
    std::fclose(file_);
    file_ = nullptr;
    throw std::runtime_error(path + ": cannot write the header: " + std::strerror(err));
  }
}

TraceWriter::~TraceWriter() {
  stop();
  if (file_ != nullptr) {
    drain();
    if (std::fclose(file_) != 0) io_errors_.fetch_add(1, std::memory_order_relaxed);
  }
}

RealtimeStep TraceWriter::start(const std::vector<int>& writer_cpus) {
  if (thread_.joinable()) throw std::logic_error("TraceWriter " + path_ + ": already running");
  stop_requested_.store(false);
  std::promise<RealtimeStep> ready;
  std::future<RealtimeStep> step = ready.get_future();
  thread_ = std::thread([this, &ready, &writer_cpus] {
    // Never compete with the loop: drop an inherited real-time policy (always permitted).
    sched_param param{};
    param.sched_priority = 0;
    pthread_setschedparam(pthread_self(), SCHED_OTHER, &param);
    RealtimeStep affinity;
    try {
      if (!writer_cpus.empty()) {
        RealtimeSettings s;
        s.cpu_affinity = writer_cpus;
        affinity = apply_realtime(s).affinity;
      }
    } catch (const std::exception& e) {
      affinity = RealtimeStep{RealtimeStepStatus::kFailed, 0, e.what()};
    }
    ready.set_value(std::move(affinity));  // `ready` and `writer_cpus` are not used after this
    run();
  });
  return step.get();
}

void TraceWriter::stop() {
  if (!thread_.joinable()) return;
  {
    std::lock_guard<std::mutex> lock(wake_mutex_);
    stop_requested_.store(true);
  }
  wake_.notify_one();
  thread_.join();
  // The thread drained the queue before it ended; this picks up what arrived meanwhile.
  drain();
  if (std::fflush(file_) != 0) io_errors_.fetch_add(1, std::memory_order_relaxed);
}

bool TraceWriter::push(const TraceRecord& record) noexcept {
  if (!queue_->ring.push(record)) {
    dropped_.fetch_add(1, std::memory_order_relaxed);
    return false;
  }
  pushed_.fetch_add(1, std::memory_order_relaxed);
  return true;
}

TraceWriterCounters TraceWriter::counters() const noexcept {
  TraceWriterCounters c;
  c.pushed = pushed_.load(std::memory_order_relaxed);
  c.dropped = dropped_.load(std::memory_order_relaxed);
  c.written = written_.load(std::memory_order_relaxed);
  c.io_errors = io_errors_.load(std::memory_order_relaxed);
  return c;
}

std::size_t TraceWriter::drain() noexcept {
  char line[kLineBufferSize];
  char* const end = line + sizeof(line);
  const std::size_t n = columns_.size();
  std::size_t count = 0;
  TraceRecord r;
  while (queue_->ring.pop(r)) {
    ++count;
    char* p = line;
    bool ok =
        put(p, end, r.period, '\0') && put(p, end, r.time_ns, ',') && put(p, end, r.flags, ',');
    for (std::size_t i = 0; ok && i < n; ++i) ok = put(p, end, r.values[i], ',');
    if (!ok || p == end) {  // cannot happen with kLineBufferSize; never write a cut line
      io_errors_.fetch_add(1, std::memory_order_relaxed);
      continue;
    }
    *p++ = '\n';
    const auto len = static_cast<std::size_t>(p - line);
    if (std::fwrite(line, 1, len, file_) != len) {
      io_errors_.fetch_add(1, std::memory_order_relaxed);
      continue;
    }
    written_.fetch_add(1, std::memory_order_relaxed);
  }
  return count;
}

void TraceWriter::run() noexcept {
  const auto period = std::chrono::nanoseconds(settings_.poll_period_ns);
  while (!stop_requested_.load()) {
    if (drain() > 0) continue;  // keep up while records arrive
    if (std::fflush(file_) != 0) io_errors_.fetch_add(1, std::memory_order_relaxed);
    std::unique_lock<std::mutex> lock(wake_mutex_);
    wake_.wait_for(lock, period, [this] { return stop_requested_.load(); });
  }
  drain();
}

}  // namespace numen::platform
