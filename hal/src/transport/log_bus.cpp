/// @file log_bus.cpp
/// Replay of a candump log as bus input, relative timing, user-space acceptance filters; a log
/// in memory or streamed from disk by a reader thread through a bounded lock-free queue.

#include "numen/hal/transport/log_bus.hpp"

#include <algorithm>
#include <atomic>
#include <boost/lockfree/spsc_queue.hpp>
#include <chrono>
#include <limits>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>

namespace numen::hal {

/// The reader side of a streaming replay: a thread that reads the log again (once per pass)
/// and pushes every record into `queue`; read() pops them through `head`.
struct LogBus::Stream {
  Stream(const LogBusStream& s, std::size_t records_per_pass, bool loop)
      : path(s.path), limits(s.limits), count(records_per_pass), loop(loop),
        wait(s.wait_for_reader), queue(s.queue_records) {}

  // Reader thread body: one pass per loop, checking each pass holds `count` records.
  void run() noexcept {
    try {
      do {
        CandumpLogReader reader(path, limits);
        CandumpRecord r;
        std::size_t n = 0;
        while (!stop.load(std::memory_order_relaxed) && reader.next(r)) {
          if (++n > count) break;
          while (!queue.push(r)) {  // full: read() is ahead of its due records, wait
            if (stop.load(std::memory_order_relaxed)) break;
            std::this_thread::sleep_for(std::chrono::microseconds(100));
          }
        }
        if (stop.load(std::memory_order_relaxed)) break;
        if (n != count) {
          throw std::runtime_error(path + ": changed since it was checked: " +
                                   std::to_string(count) + " records then, " +
                                   (n > count ? "more" : std::to_string(n)) + " now");
        }
      } while (loop);
    } catch (const std::exception& e) {
      error = e.what();
    } catch (...) {
      error = path + ": reader failed";
    }
    done.store(true, std::memory_order_release);  // after the last push and `error`
  }

  const std::string path;
  const CandumpLoadLimits limits;
  const std::size_t count;  // records per pass, from the validating pass
  const bool loop;
  const bool wait;
  boost::lockfree::spsc_queue<CandumpRecord> queue;  // runtime capacity: one allocation, here
  std::atomic<bool> stop{false};  // set by the destructor
  std::atomic<bool> done{false};  // the reader pushes nothing more
  std::string error;              // written before done
  CandumpRecord head;             // popped, not yet taken (consumer side)
  bool has_head = false;
  std::thread thread;
};

LogBus::LogBus(std::vector<CandumpRecord> records, LogBusSettings settings)
    : records_(std::move(records)), settings_(std::move(settings)) {
  check_settings();
  count_ = records_.size();
  if (!records_.empty()) {
    first_ns_ = records_.front().timestamp_ns;
    for (const CandumpRecord& r : records_)
      span_ns_ = std::max(span_ns_, r.timestamp_ns - first_ns_);
  }
  check_span();
  for (const CandumpRecord& r : records_) {
    if (!accepts(r)) continue;
    ++matching_;
    if (r.frame.error_frame()) ++matching_errors_;
  }
}

LogBus::LogBus(const LogBusStream& stream, LogBusSettings settings, CandumpLoadStats* stats)
    : settings_(std::move(settings)) {
  check_settings();
  if (stream.queue_records == 0)
    throw std::invalid_argument("LogBusStream.queue_records must be >= 1 (got 0)");
  {  // Validating pass, constant memory.
    CandumpLogReader reader(stream.path, stream.limits);
    CandumpRecord r;
    while (reader.next(r)) {
      if (reader.stats().records == 1) first_ns_ = r.timestamp_ns;
      span_ns_ = std::max(span_ns_, r.timestamp_ns - first_ns_);
      if (!accepts(r)) continue;
      ++matching_;
      if (r.frame.error_frame()) ++matching_errors_;
    }
    const CandumpLoadStats& counts = reader.stats();
    if (counts.records == 0) {
      throw std::runtime_error(stream.path + ": no frame records (" +
                               std::to_string(counts.lines) +
                               " lines: blank, '#' comments or DROPCOUNT notes): nothing to "
                               "replay");
    }
    count_ = counts.records;
    if (stats != nullptr) *stats = counts;
  }
  check_span();
  stream_ = std::make_unique<Stream>(stream, count_, settings_.loop);
  Stream& s = *stream_;
  s.thread = std::thread([&s] { s.run(); });
  // Setup: wait until the queue is full (or the log read), so the first periods have their
  // records in hand.
  while (s.queue.write_available() > 0 && !s.done.load(std::memory_order_acquire))
    std::this_thread::sleep_for(std::chrono::microseconds(100));
}

LogBus::~LogBus() {
  if (stream_ && stream_->thread.joinable()) {
    stream_->stop.store(true, std::memory_order_relaxed);
    stream_->thread.join();
  }
}

void LogBus::check_settings() {
  if (!settings_.iface.empty())
    iface_ = make_candump_iface(settings_.iface, "LogBusSettings.iface");
  if (settings_.loop_gap_ns < 0) {
    throw std::invalid_argument("LogBusSettings.loop_gap_ns must be >= 0 (got " +
                                std::to_string(settings_.loop_gap_ns) + ")");
  }
}

void LogBus::check_span() {
  if (settings_.offset_ns > std::numeric_limits<std::int64_t>::max() - span_ns_) {
    throw std::invalid_argument("LogBusSettings.offset_ns " + std::to_string(settings_.offset_ns) +
                                " + log span " + std::to_string(span_ns_) + " ns overflows int64");
  }
  if (settings_.loop && count_ > 0 && span_ns_ + settings_.loop_gap_ns <= 0) {
    throw std::invalid_argument(
        "LogBusSettings.loop needs a pass period > 0: the log spans 0 ns, set loop_gap_ns > 0");
  }
  pass_base_ns_ = settings_.offset_ns;
  latest_due_ns_ = pass_base_ns_;
}

bool LogBus::waits_for_reader() const noexcept { return stream_ && stream_->wait; }

std::string LogBus::reader_error() const {
  if (!stream_ || !stream_->done.load(std::memory_order_acquire)) return {};
  return stream_->error;
}

const CandumpRecord* LogBus::peek() const noexcept {
  if (!stream_) return &records_[cursor_];
  Stream& s = *stream_;
  if (s.has_head) return &s.head;
  for (unsigned spins = 0;; ++spins) {
    if (s.queue.pop(s.head)) {
      s.has_head = true;
      return &s.head;
    }
    if (s.done.load(std::memory_order_acquire)) {  // its last push came before `done`
      if (!s.queue.pop(s.head)) return nullptr;
      s.has_head = true;
      return &s.head;
    }
    if (spins == 0) ++log_counters_.reader_behind;
    if (!s.wait) return nullptr;
    if (spins < 64)
      std::this_thread::yield();
    else
      std::this_thread::sleep_for(std::chrono::microseconds(50));
  }
}

void LogBus::take() noexcept {
  if (stream_) stream_->has_head = false;
  ++cursor_;
}

std::int64_t LogBus::next_due_ns() const noexcept {
  if (cursor_ >= count_) return latest_due_ns_;
  const CandumpRecord* record = peek();
  if (record == nullptr) return latest_due_ns_;
  const std::int64_t due = pass_base_ns_ + (record->timestamp_ns - first_ns_);
  return std::max(due, latest_due_ns_);
}

bool LogBus::accepts(const CandumpRecord& record) const noexcept {
  if (iface_.size != 0 && !(record.iface == iface_)) return false;
  if (settings_.received_only && record.direction == CandumpDirection::kTransmitted) return false;
  return passes(settings_.filters, record.frame);
}

IoStatus LogBus::read(CanFrame& frame) noexcept {
  for (;;) {
    if (cursor_ == count_) {
      if (!settings_.loop || count_ == 0) return IoStatus::kWouldBlock;
      // Next pass: its first record is due one period after this pass's first.
      const std::int64_t next_base = pass_base_ns_ + span_ns_ + settings_.loop_gap_ns;
      if (next_base > now_ns_) return IoStatus::kWouldBlock;
      pass_base_ns_ = next_base;
      latest_due_ns_ = next_base;
      cursor_ = 0;
    }
    const CandumpRecord* record = peek();
    if (record == nullptr) return IoStatus::kWouldBlock;  // streaming: reader behind or stopped
    const std::int64_t due = std::max(pass_base_ns_ + (record->timestamp_ns - first_ns_),
                                      latest_due_ns_);
    if (due > now_ns_) return IoStatus::kWouldBlock;
    latest_due_ns_ = due;
    const bool accepted = accepts(*record);
    if (accepted) frame = record->frame;
    take();
    if (cursor_ == count_) ++log_counters_.passes;
    if (!accepted) {
      ++log_counters_.filtered;
      continue;
    }
    frame.timestamp_ns = due;
    ++log_counters_.replayed;
    ++counters_.frames_rx;
    return IoStatus::kOk;
  }
}

IoStatus LogBus::write(const CanFrame& frame) noexcept {
  if (check_frame(frame) != FrameError::kNone) {
    ++counters_.errors;
    return IoStatus::kError;
  }
  ++counters_.frames_tx;
  return IoStatus::kOk;
}

}  // namespace numen::hal
