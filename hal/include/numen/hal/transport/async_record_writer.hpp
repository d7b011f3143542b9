#pragma once
/// @file async_record_writer.hpp
/// The one way records leave the real-time loop: the loop (single producer) pushes fixed-size,
/// trivially copyable records into a lock-free single-producer/single-consumer queue
/// (boost::lockfree::spsc_queue, capacity fixed at construction); a consumer thread pops them
/// and hands each to a RecordSink (a file writer, a network stream). The loop never waits for
/// the sink: a full queue drops the record and counts it (FullQueuePolicy::kDrop). A run
/// without a deadline may instead wait for room (kWait), so that a starved consumer loses
/// nothing.
///
/// Users: the bus recorder (CandumpWriter, bus_recorder.hpp: candump log lines) and the
/// per-period trace (platform::TraceWriter, trace_queue.hpp: CSV lines). Each is a sink plus
/// this writer; the queue, the thread, the wake-up, the drop/wait policy and the counters are
/// kept here once.
///
/// Threads: push() belongs to one producer thread at a time; start(), stop() and the
/// destructor to the setup thread, which must not stop() while push() runs on another thread.
/// The sink's members run on the consumer thread while it runs, and on the setup thread in
/// stop() and drain() (never both at once).

#include <algorithm>
#include <atomic>
#include <boost/lockfree/spsc_queue.hpp>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <type_traits>
#include <utility>

namespace numen::hal {

/// What AsyncRecordWriter::push() does when the queue is full.
enum class FullQueuePolicy {
  /// Drop the record and count it (RecordWriterCounters::dropped); push() never blocks.
  /// For paced runs: the control loop never waits for the disk.
  kDrop,
  /// Wake the consumer thread and sleep in steps of poll_period_ns / 8 until it has made room,
  /// so nothing is lost however far the consumer falls behind. push() then blocks: for offline
  /// (unpaced) runs only, which have no deadline. While the thread is not running (before
  /// start(), after stop()) a full queue drops as with kDrop.
  kWait,
};

/// Creation settings of an AsyncRecordWriter. Checked by its constructor.
struct RecordWriterSettings {
  /// Records the queue holds, >= 1; allocated once at construction.
  std::size_t queue_capacity = 4096;
  /// How long the consumer thread sleeps when the queue is empty (after flushing the sink), ns,
  /// > 0. Also bounds how stale the sink's output can be.
  std::int64_t poll_period_ns = 2'000'000;
  /// A full queue drops (paced runs, the default) or waits for the consumer (offline runs).
  FullQueuePolicy full_queue = FullQueuePolicy::kDrop;
};

/// Counters of an AsyncRecordWriter since construction. Read with relaxed atomics: consistent
/// each, not with each other while the consumer runs. Every pushed record ends in exactly one
/// of written, format_errors, io_errors (a sink that writes each record itself) or lost (a
/// sink that buffers them, SinkResult::kBuffered) once the writer is stopped (queued = written
/// + format_errors + record io_errors + lost); io_errors also counts failed flushes, closes
/// and, for a buffering sink, failed writes of its buffer.
struct RecordWriterCounters {
  std::uint64_t queued = 0;         ///< Records accepted by push().
  std::uint64_t dropped = 0;        ///< Records refused by push(): queue full.
  std::uint64_t waits = 0;          ///< kWait: pushes that found the queue full and waited.
  /// Records the sink wrote; for a buffering sink, records whose bytes the file accepted.
  std::uint64_t written = 0;
  std::uint64_t format_errors = 0;  ///< Records the sink refused to format (not written).
  std::uint64_t io_errors = 0;      ///< Failed sink writes, flushes and closes.
  std::uint64_t lost = 0;           ///< Buffered records whose bytes the file did not accept.
};

/// Outcome of RecordSink::write() for one record.
enum class SinkResult : std::uint8_t {
  kWritten,      ///< The record was written.
  kFormatError,  ///< The record cannot be represented (e.g. a negative log timestamp).
  kIoError,      ///< The write failed (disk full, I/O error, peer gone).
  /// The record is in the sink's own buffer: neither written nor lost yet. It is counted when
  /// the sink settles it (RecordSink::take_settled(), after a later write() or flush()).
  kBuffered,
};

/// Buffered records (SinkResult::kBuffered) a sink settled since its last take_settled().
struct SinkSettled {
  std::uint64_t written = 0;    ///< Their bytes were accepted by the file.
  std::uint64_t lost = 0;       ///< They were not (an I/O error).
  /// Failed writes of the sink's buffer inside write() (a failed flush() is returned by it).
  std::uint64_t io_errors = 0;
};

/// Consumer side of an AsyncRecordWriter: called on the consumer thread, never on the loop.
template <class Record>
class RecordSink {
 public:
  virtual ~RecordSink() = default;
  /// Writes one record (buffered output is fine: flush() follows when the queue runs empty).
  virtual SinkResult write(const Record& record) noexcept = 0;
  /// Pushes buffered output out; false on failure (counted as an io error).
  virtual bool flush() noexcept = 0;
  /// The kBuffered records settled since the last call (called after every write() and
  /// flush()). A sink that never returns kBuffered keeps this default: none.
  virtual SinkSettled take_settled() noexcept { return {}; }
};

/// Owner of the record queue and of the consumer thread that feeds `sink`. push() is the
/// producer side: noexcept, no allocation, no lock; it never blocks under kDrop.
template <class Record>
class AsyncRecordWriter {
  static_assert(std::is_trivially_copyable_v<Record>, "records are copied, never built");
  static_assert(std::atomic<std::uint64_t>::is_always_lock_free,
                "the producer's counters must not take a lock");

 public:
  /// Allocates the queue; the thread is not started. Throws std::invalid_argument
  /// "<settings_name>.queue_capacity must be >= 1 (got 0)" or "<settings_name>.poll_period_ns
  /// must be > 0 (got N)"; `settings_name` names the owner's settings struct. `sink` is not owned and
  /// must outlive this writer.
  AsyncRecordWriter(RecordSink<Record>& sink, const RecordWriterSettings& settings,
                    const std::string& settings_name)
      : sink_(&sink),
        settings_(checked(settings, settings_name)),
        ring_(settings.queue_capacity),
        name_(settings_name) {}
  /// stop(); records still queued stay queued (the owner calls drain() before closing its sink).
  ~AsyncRecordWriter() { stop(); }
  AsyncRecordWriter(const AsyncRecordWriter&) = delete;
  AsyncRecordWriter& operator=(const AsyncRecordWriter&) = delete;
  AsyncRecordWriter(AsyncRecordWriter&&) = delete;
  AsyncRecordWriter& operator=(AsyncRecordWriter&&) = delete;

  /// Starts the consumer thread; it first runs `on_thread_start` (e.g. leave the real-time
  /// policy, set an affinity), then consumes until stop(). Throws std::logic_error if it is
  /// running; may throw std::system_error if the thread cannot be created.
  void start(std::function<void()> on_thread_start = {}) {
    if (thread_.joinable()) throw std::logic_error("record writer of " + name_ + ": already running");
    {
      std::lock_guard<std::mutex> lock(wake_mutex_);
      stop_requested_.store(false);
    }
    draining_.store(true);
    try {
      thread_ = std::thread([this, init = std::move(on_thread_start)] {
        if (init) init();
        run();
      });
    } catch (...) {
      draining_.store(false);
      throw;
    }
  }

  /// Stops the consumer thread (wakes it, joins it), consumes the records still queued and
  /// flushes the sink. Idempotent. Records pushed afterwards wait for the next start() or drain().
  void stop() {
    if (!thread_.joinable()) return;
    {
      std::lock_guard<std::mutex> lock(wake_mutex_);
      stop_requested_.store(true);
    }
    wake_.notify_one();
    thread_.join();
    draining_.store(false);
    drain();  // the thread drained before it ended; this picks up what arrived meanwhile
    flush_sink();
  }

  /// True between start() and stop().
  bool running() const noexcept { return thread_.joinable(); }

  /// Queues one record. False if the queue is full and the record is dropped and counted:
  /// always under kDrop; under kWait only while the consumer is not running (kWait sleeps
  /// until there is room instead).
  bool push(const Record& record) noexcept {
    if (!ring_.push(record) && !wait_for_room([&] { return ring_.push(record); })) {
      dropped_.fetch_add(1, std::memory_order_relaxed);
      return false;
    }
    queued_.fetch_add(1, std::memory_order_relaxed);
    return true;
  }

  /// kWait's wait, for the producer, once `try_once()` has failed: under kWait and while the
  /// consumer thread runs, counts one wait (RecordWriterCounters::waits), then wakes the
  /// consumer and sleeps in steps of poll_period_ns / 8 until `try_once()` returns true (a
  /// push into this queue, or a pop from a free list the consumer refills: StateStream) or
  /// the thread stops. Returns false at once under kDrop or while the thread is not running,
  /// without calling `try_once`. Blocks: offline runs only. `try_once` must be noexcept.
  template <class TryOnce>
  bool wait_for_room(TryOnce&& try_once) noexcept {
    if (settings_.full_queue != FullQueuePolicy::kWait || !draining_.load()) return false;
    waits_.fetch_add(1, std::memory_order_relaxed);
    const auto step = std::chrono::nanoseconds(std::max<std::int64_t>(settings_.poll_period_ns / 8, 1));
    // The thread drains until stop() joins it; draining_ turns false only after that. The
    // consumer may be in its poll sleep: wake it rather than wait out poll_period_ns.
    bool done = false;
    while (!(done = try_once()) && draining_.load()) {
      room_wanted_.store(true);
      wake_.notify_one();
      std::this_thread::sleep_for(step);
    }
    return done;
  }

  /// Hands every queued record to the sink, on the calling thread; returns how many. For the
  /// owner while the consumer is not running (after stop(), before closing the sink).
  std::size_t drain() noexcept {
    std::size_t count = 0;
    Record r;
    while (ring_.pop(r)) {
      ++count;
      switch (sink_->write(r)) {
        case SinkResult::kWritten: written_.fetch_add(1, std::memory_order_relaxed); break;
        case SinkResult::kFormatError: format_errors_.fetch_add(1, std::memory_order_relaxed); break;
        case SinkResult::kIoError: io_errors_.fetch_add(1, std::memory_order_relaxed); break;
        case SinkResult::kBuffered: break;
      }
      settle();
    }
    return count;
  }

  /// Flushes the sink (counting a failure as an io error) and counts what it settled. For the
  /// owner while the consumer is not running (e.g. before reading the counters of a stopped
  /// writer whose sink holds records drain() added).
  void flush_sink() noexcept {
    if (!sink_->flush()) io_errors_.fetch_add(1, std::memory_order_relaxed);
    settle();
  }

  /// Counts one io error outside drain() (e.g. the owner's failed close).
  void count_io_error() noexcept { io_errors_.fetch_add(1, std::memory_order_relaxed); }

  /// Counters (see RecordWriterCounters).
  RecordWriterCounters counters() const noexcept {
    RecordWriterCounters c;
    c.queued = queued_.load(std::memory_order_relaxed);
    c.dropped = dropped_.load(std::memory_order_relaxed);
    c.waits = waits_.load(std::memory_order_relaxed);
    c.written = written_.load(std::memory_order_relaxed);
    c.format_errors = format_errors_.load(std::memory_order_relaxed);
    c.io_errors = io_errors_.load(std::memory_order_relaxed);
    c.lost = lost_.load(std::memory_order_relaxed);
    return c;
  }

  /// The settings the writer was built with.
  const RecordWriterSettings& settings() const noexcept { return settings_; }

 private:
  static const RecordWriterSettings& checked(const RecordWriterSettings& s, const std::string& name) {
    if (s.queue_capacity == 0)
      throw std::invalid_argument(name + ".queue_capacity must be >= 1 (got 0)");
    if (s.poll_period_ns <= 0)
      throw std::invalid_argument(name + ".poll_period_ns must be > 0 (got " +
                                  std::to_string(s.poll_period_ns) + ")");
    return s;
  }

  // Counts the buffered records the sink settled (SinkSettled).
  void settle() noexcept {
    const SinkSettled d = sink_->take_settled();
    if (d.written != 0) written_.fetch_add(d.written, std::memory_order_relaxed);
    if (d.lost != 0) lost_.fetch_add(d.lost, std::memory_order_relaxed);
    if (d.io_errors != 0) io_errors_.fetch_add(d.io_errors, std::memory_order_relaxed);
  }

  void run() noexcept {
    const auto period = std::chrono::nanoseconds(settings_.poll_period_ns);
    while (!stop_requested_.load()) {
      room_wanted_.store(false);
      if (drain() > 0) continue;  // keep up while records arrive
      flush_sink();
      std::unique_lock<std::mutex> lock(wake_mutex_);
      wake_.wait_for(lock, period,
                     [this] { return stop_requested_.load() || room_wanted_.load(); });
    }
    drain();
  }

  RecordSink<Record>* sink_;
  RecordWriterSettings settings_;
  boost::lockfree::spsc_queue<Record> ring_;  // runtime capacity: one allocation, here
  std::string name_;  // the owner's settings struct, for messages
  std::thread thread_;
  std::mutex wake_mutex_;  // stop request only; push() never takes it (kWait notifies wake_)
  std::condition_variable wake_;
  std::atomic<bool> stop_requested_{false};  // set under wake_mutex_
  std::atomic<bool> draining_{false};        // the thread runs and drains: kWait may wait
  std::atomic<bool> room_wanted_{false};     // kWait: a push found the queue full
  std::atomic<std::uint64_t> queued_{0};
  std::atomic<std::uint64_t> dropped_{0};
  std::atomic<std::uint64_t> waits_{0};
  std::atomic<std::uint64_t> written_{0};
  std::atomic<std::uint64_t> format_errors_{0};
  std::atomic<std::uint64_t> io_errors_{0};
  std::atomic<std::uint64_t> lost_{0};
};

}  // namespace numen::hal
