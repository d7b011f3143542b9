/// @file bus_recorder.cpp
/// Non-blocking bus recording: a lock-free SPSC queue from the control loop to a writer
/// thread that formats candump log lines into a stdio-buffered file.

#include "numen/hal/bus_recorder.hpp"

#include <algorithm>
#include <boost/lockfree/spsc_queue.hpp>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <stdexcept>
#include <type_traits>

namespace numen::hal {
namespace {

struct Entry {
  CanFrame frame;
  CandumpIface iface;
  CandumpDirection direction = CandumpDirection::kUnmarked;
};
static_assert(std::is_trivially_copyable_v<Entry>, "queue entries are copied, never built");
static_assert(std::atomic<std::uint64_t>::is_always_lock_free,
              "the producer's counters must not take a lock");

}  // namespace

struct CandumpWriter::Queue {
  explicit Queue(std::size_t capacity) : ring(capacity) {}
  boost::lockfree::spsc_queue<Entry> ring;  // runtime capacity: one allocation, here
};

CandumpWriter::CandumpWriter(const std::string& path, const CandumpWriterSettings& settings)
    : path_(path), settings_(settings) {
  if (settings.queue_capacity == 0) {
    throw std::invalid_argument("CandumpWriterSettings.queue_capacity must be >= 1 (got 0)");
  }
  if (settings.poll_period_ns <= 0) {
    throw std::invalid_argument("CandumpWriterSettings.poll_period_ns must be > 0 (got " +
                                std::to_string(settings.poll_period_ns) + ")");
  }
  queue_ = std::make_unique<Queue>(settings.queue_capacity);
  file_ = std::fopen(path.c_str(), "w");
  if (file_ == nullptr) {
    const int err = errno;
    throw std::runtime_error(path + ": cannot open for writing: " + std::strerror(err));
  }
}

CandumpWriter::~CandumpWriter() {
  stop();
  if (file_ != nullptr) {
    drain();
    if (std::fclose(file_) != 0) io_errors_.fetch_add(1, std::memory_order_relaxed);
  }
}

void CandumpWriter::start() {
  if (thread_.joinable()) throw std::logic_error("CandumpWriter " + path_ + ": already running");
  {
    std::lock_guard<std::mutex> lock(wake_mutex_);
    stop_requested_.store(false);
  }
  draining_.store(true);
  try {
    thread_ = std::thread([this] { run(); });
  } catch (...) {
    draining_.store(false);
    throw;
  }
}

void CandumpWriter::stop() {
  if (!thread_.joinable()) return;
  {
    std::lock_guard<std::mutex> lock(wake_mutex_);
    stop_requested_.store(true);
  }
  wake_.notify_one();
  thread_.join();
  draining_.store(false);
  // The thread drained the queue before it ended; this picks up what arrived meanwhile.
  drain();
  if (std::fflush(file_) != 0) io_errors_.fetch_add(1, std::memory_order_relaxed);
}

bool CandumpWriter::push(const CanFrame& frame, const CandumpIface& iface,
                         CandumpDirection direction) noexcept {
  Entry entry;
  entry.frame = frame;
  entry.iface = iface;
  entry.direction = direction;
  if (!queue_->ring.push(entry)) {
    bool queued = false;
    if (settings_.full_queue == FullQueuePolicy::kWait && draining_.load()) {
      waits_.fetch_add(1, std::memory_order_relaxed);
      const auto step =
          std::chrono::nanoseconds(std::max<std::int64_t>(settings_.poll_period_ns / 8, 1));
      // The thread drains until stop() joins it; draining_ turns false only after that. The
      // writer may be in its poll sleep: wake it rather than wait out poll_period_ns.
      while (!(queued = queue_->ring.push(entry)) && draining_.load()) {
        room_wanted_.store(true);
        wake_.notify_one();
        std::this_thread::sleep_for(step);
      }
    }
    if (!queued) {
      dropped_.fetch_add(1, std::memory_order_relaxed);
      return false;
    }
  }
  queued_.fetch_add(1, std::memory_order_relaxed);
  return true;
}

CandumpWriterCounters CandumpWriter::counters() const noexcept {
  CandumpWriterCounters c;
  c.queued = queued_.load(std::memory_order_relaxed);
  c.dropped = dropped_.load(std::memory_order_relaxed);
  c.waits = waits_.load(std::memory_order_relaxed);
  c.written = written_.load(std::memory_order_relaxed);
  c.format_errors = format_errors_.load(std::memory_order_relaxed);
  c.io_errors = io_errors_.load(std::memory_order_relaxed);
  return c;
}

std::size_t CandumpWriter::drain() noexcept {
  char line[kCandumpLineBufferSize];
  std::size_t count = 0;
  Entry entry;
  while (queue_->ring.pop(entry)) {
    ++count;
    const CandumpDirection direction =
        settings_.mark_direction ? entry.direction : CandumpDirection::kUnmarked;
    std::int64_t t_ns = 0;
    const bool overflow =
        __builtin_add_overflow(entry.frame.timestamp_ns, settings_.time_offset_ns, &t_ns);
    const CandumpFormatResult r =
        overflow ? CandumpFormatResult{CandumpFormatError::kNegativeTimestamp, 0}
                 : format_candump_line(t_ns, entry.iface, entry.frame, direction, line);
    if (!r.ok()) {
      format_errors_.fetch_add(1, std::memory_order_relaxed);
      continue;
    }
    line[r.length] = '\n';
    if (std::fwrite(line, 1, r.length + 1, file_) != r.length + 1) {
      io_errors_.fetch_add(1, std::memory_order_relaxed);
      continue;
    }
    written_.fetch_add(1, std::memory_order_relaxed);
  }
  return count;
}

void CandumpWriter::run() noexcept {
  const auto period = std::chrono::nanoseconds(settings_.poll_period_ns);
  while (!stop_requested_.load()) {
    room_wanted_.store(false);
    if (drain() > 0) continue;  // keep up while frames arrive
    if (std::fflush(file_) != 0) io_errors_.fetch_add(1, std::memory_order_relaxed);
    std::unique_lock<std::mutex> lock(wake_mutex_);
    wake_.wait_for(lock, period, [this] { return stop_requested_.load() || room_wanted_.load(); });
  }
  drain();
}

RecordingBus::RecordingBus(Bus& inner, CandumpWriter& writer, std::string_view iface)
    : inner_(&inner), writer_(&writer), iface_(make_candump_iface(iface, "RecordingBus iface")) {}

void RecordingBus::record(const CanFrame& frame, CandumpDirection direction) noexcept {
  if (writer_->push(frame, iface_, direction)) {
    ++counters_.recorded;
  } else {
    ++counters_.dropped;
  }
}

IoStatus RecordingBus::read(CanFrame& frame) noexcept {
  const IoStatus status = inner_->read(frame);
  if (status == IoStatus::kOk) record(frame, CandumpDirection::kReceived);
  return status;
}

IoStatus RecordingBus::write(const CanFrame& frame) noexcept {
  const IoStatus status = inner_->write(frame);
  if (status == IoStatus::kOk) record(frame, CandumpDirection::kTransmitted);
  return status;
}

}  // namespace numen::hal
