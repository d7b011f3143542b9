#pragma once
/// @file bus_recorder.hpp
/// Recording a run's bus traffic in can-utils' candump log format (candump_log.hpp) without
/// blocking the control loop:
///  - RecordingBus wraps any Bus; every frame read from or written to it with kOk is pushed,
///    with its timestamp, into the lock-free single-producer/single-consumer queue of a
///    CandumpWriter (boost::lockfree::spsc_queue, capacity fixed at construction);
///  - the CandumpWriter's own thread pops the records, formats them and writes the lines to
///    the log file through its own buffer with write(2) (CountedLineFile), so that a line
///    counts as written only once the kernel accepted its bytes.
/// A full queue drops the record and counts it, so a paced control loop never waits for the
/// disk (FullQueuePolicy::kDrop). An offline run, which has no deadline, may instead wait for
/// the writer to make room (kWait), so that a starved writer thread loses nothing.
///
/// Time base: a line's timestamp is the frame's timestamp_ns, i.e. the bus clock — receive
/// time for frames read, the caller's intended send time for frames written (CanFrame) —
/// plus CandumpWriterSettings::time_offset_ns (0 by default). For
/// SimBus that is simulated time from 0; for a transport on the loop's clock it is
/// CLOCK_MONOTONIC (time since boot). candump writes wall-clock time instead (SO_TIMESTAMP);
/// canplayer and log2asc only use the differences between lines (canplayer waits
/// line[i] − line[i−1]), so a log on the bus clock replays with the same timing. Only the
/// absolute date log2asc prints in its header is meaningless.
///
/// Direction: lines carry candump -x's marker, " R" for frames read and " T" for frames
/// written (CandumpWriterSettings::mark_direction), which canplayer ignores and LogBus can
/// filter on (LogBusSettings::received_only).

#include <cstdint>
#include <string>
#include <string_view>

#include "numen/hal/transport/async_record_writer.hpp"
#include "numen/hal/transport/bus.hpp"
#include "numen/hal/transport/can_frame.hpp"
#include "numen/hal/transport/candump_log.hpp"
#include "numen/hal/transport/line_file.hpp"

namespace numen::hal {

/// Creation settings of a CandumpWriter. Checked by its constructor.
struct CandumpWriterSettings : RecordWriterSettings {
  /// The queue's settings (RecordWriterSettings: queue_capacity, poll_period_ns, full_queue,
  /// checked by the constructor). queue_capacity defaults to 8192 records here (104 bytes
  /// each): size it for the frames of one poll_period_ns and the disk's worst stall; at 5
  /// frames per 1 ms period, 8192 records cover 1.6 s. full_queue: drop for paced runs (the
  /// default), wait for the writer in offline runs.
  CandumpWriterSettings() { queue_capacity = 8192; }
  /// Append " R" (read) / " T" (written) to each line (candump -x).
  bool mark_direction = true;
  /// Added to every frame's timestamp_ns on its line, ns. 0 writes the bus clock as it is.
  /// (CLOCK_REALTIME − bus clock), taken once at setup, writes wall-clock time like candump.
  /// Give runs whose bus clock starts at 0 (SimBus) an offset >= 1 s: log2asc (can-utils
  /// 2020.11) takes a start second of 0 for "no start yet" and restarts its output on every
  /// line. A line whose time would be negative or overflow is not written (format_errors).
  std::int64_t time_offset_ns = 0;
};

/// Counters of a CandumpWriter (queued, dropped, waits, lines whose bytes write(2) accepted,
/// records refused by format_candump_line(), failed write(2)/close(2) calls, lines lost to
/// them). `--record /dev/full` writes 0 lines.
using CandumpWriterCounters = RecordWriterCounters;

/// Owner of a candump log file and of the AsyncRecordWriter that fills it from the loop.
/// push() is the producer side: one thread at a time (the control loop), noexcept, no
/// allocation, no lock; it never blocks under FullQueuePolicy::kDrop. start()/stop() and the
/// destructor belong to the setup thread, which must not stop() while push() runs on another
/// thread. Not copyable or movable.
class CandumpWriter final : private RecordSink<CandumpRecord> {
 public:
  /// Opens `path` (CountedLineFile on an OutputFile: a temporary file renamed over it by
  /// close()) and allocates the queue; the thread is not started. Throws std::runtime_error
  /// "path: cannot open for writing: <errno text>", or
  /// std::invalid_argument naming the setting (queue_capacity 0, poll_period_ns <= 0).
  explicit CandumpWriter(const std::string& path, const CandumpWriterSettings& settings = {});
  /// close().
  ~CandumpWriter() override;
  CandumpWriter(const CandumpWriter&) = delete;
  CandumpWriter& operator=(const CandumpWriter&) = delete;
  CandumpWriter(CandumpWriter&&) = delete;
  CandumpWriter& operator=(CandumpWriter&&) = delete;

  /// Starts the writer thread. Throws std::logic_error if it is running; may throw
  /// std::system_error if the thread cannot be created.
  void start() { writer_.start(); }
  /// Stops the writer thread (wakes it, joins it), writes the records still queued and
  /// flushes the file. Idempotent. Records pushed afterwards wait in the queue for the next
  /// start() or the destructor.
  void stop() { writer_.stop(); }
  /// stop(), then writes what is still queued and closes the file: the log appears under its
  /// path (CountedLineFile::close(); a failure is counted in io_errors). Idempotent; the
  /// destructor calls it.
  void close();
  /// True between start() and stop().
  bool running() const noexcept { return writer_.running(); }

  /// Queues one record: `frame` (its timestamp_ns is the line's time) seen on `iface` in
  /// `direction`. False if the queue is full and the record is dropped and counted: always
  /// under kDrop; under kWait only while the writer thread is not running (kWait sleeps
  /// until there is room instead).
  bool push(const CanFrame& frame, const CandumpIface& iface, CandumpDirection direction) noexcept {
    return writer_.push(CandumpRecord{frame.timestamp_ns, iface, frame, direction});
  }

  /// Counters (see CandumpWriterCounters).
  CandumpWriterCounters counters() const noexcept { return writer_.counters(); }
  /// Path of the log file.
  const std::string& path() const noexcept { return file_.path(); }
  /// The settings the writer was built with.
  const CandumpWriterSettings& settings() const noexcept { return settings_; }

 private:
  SinkResult write(const CandumpRecord& record) noexcept override;
  bool flush() noexcept override { return file_.flush(); }
  SinkSettled take_settled() noexcept override;

  CandumpWriterSettings settings_;
  AsyncRecordWriter<CandumpRecord> writer_;  // first: bad settings throw before the file opens
  CountedLineFile file_;
};

/// Counters of one RecordingBus since construction.
struct RecordingCounters {
  std::uint64_t recorded = 0;  ///< Frames queued for the log.
  std::uint64_t dropped = 0;   ///< Frames not recorded: the writer's queue was full.
};

/// A Bus decorator that records the traffic of `inner` into a CandumpWriter. read() and
/// write() forward to `inner` and, on kOk, push the frame (read: kReceived, written:
/// kTransmitted) under interface name `iface`; kWouldBlock / kError results are not
/// recorded. state() and counters() are the inner bus's. Several RecordingBus may share one
/// writer (one log file, told apart by iface) if they are all driven from one thread.
/// read/write never allocate, throw or lock, and never block with a FullQueuePolicy::kDrop
/// writer (given that `inner`'s do not); a kWait writer may make them wait for room.
class RecordingBus final : public Bus {
 public:
  /// Wraps `inner` (not owned; must outlive this). Throws std::invalid_argument if `iface`
  /// is not a valid interface name (CandumpIface).
  RecordingBus(Bus& inner, CandumpWriter& writer, std::string_view iface = "can0");

  /// inner.read(); on kOk the frame is recorded as received.
  IoStatus read(CanFrame& frame) noexcept override;
  /// inner.write(); on kOk the frame is recorded as transmitted.
  IoStatus write(const CanFrame& frame) noexcept override;
  /// inner.state().
  BusState state() const noexcept override { return inner_->state(); }
  /// inner.counters() (recording losses are in recording_counters(), not in `dropped`).
  BusCounters counters() const noexcept override { return inner_->counters(); }

  /// Frames recorded and dropped by this bus.
  const RecordingCounters& recording_counters() const noexcept { return counters_; }
  /// The interface name written on this bus's lines.
  const CandumpIface& iface() const noexcept { return iface_; }

 private:
  void record(const CanFrame& frame, CandumpDirection direction) noexcept;

  Bus* inner_;
  CandumpWriter* writer_;
  CandumpIface iface_;
  RecordingCounters counters_{};
};

}  // namespace numen::hal
