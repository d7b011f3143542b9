#pragma once
/// @file trace_queue.hpp
/// Per-period traces leaving the real-time loop without blocking it: the loop pushes a
/// fixed-size POD TraceRecord into the lock-free single-producer/single-consumer queue of an
/// hal::AsyncRecordWriter (async_record_writer.hpp, the same mechanism as the bus recorder);
/// its thread pops the records and writes them as CSV through buffered stdio. A full queue
/// drops the record and counts it; the loop never waits for the disk.
///
/// The record is generic: period index, time, flags and up to kTraceMaxColumns doubles whose
/// meaning (target / god-object positions, feedback wrench, contact count, solver
/// iterations...) is given by the column names passed at setup — sim defines its columns.
///
/// CSV (RFC 4180, no quoting needed: names are checked): header
///   period,time_ns,flags,<column 0>,...,<column n-1>
/// then one line per record: integers in decimal, doubles in the shortest form that reads
/// back to the same value (std::to_chars), "nan"/"inf"/"-inf" for non-finite values.

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "numen/hal/transport/async_record_writer.hpp"
#include "numen/hal/transport/line_file.hpp"
#include "numen/platform/realtime_setup.hpp"

namespace numen::platform {

/// Doubles a TraceRecord carries (fixed: the record is a POD of fixed size, 280 bytes).
inline constexpr std::size_t kTraceMaxColumns = 32;

/// One period's trace. Trivially copyable; the loop fills it on its stack and pushes it.
/// Only the first TraceWriter::num_columns() values are written.
struct TraceRecord {
  std::uint64_t period = 0;  ///< Period index k.
  std::int64_t time_ns = 0;  ///< Period time (ns; the loop's clock, e.g. the deadline).
  std::uint32_t flags = 0;   ///< Bit set defined by the caller (e.g. sample valid, overrun).
  std::array<double, kTraceMaxColumns> values{};  ///< Column values, in the setup order.
};

/// Creation settings of a TraceWriter, checked by its constructor: queue_capacity records
/// (>= 1, sizeof(TraceRecord) each, allocated once; at 1 kHz the default 4096 covers a 4 s disk
/// stall), poll_period_ns (> 0) and the full-queue policy (drop, the default, for paced runs).
using TraceWriterSettings = hal::RecordWriterSettings;

/// Counters of a TraceWriter (records queued, dropped, lines written; format_errors: a line
/// that did not fit its buffer, which cannot happen; io_errors: failed fwrite/fflush/fclose).
using TraceWriterCounters = hal::RecordWriterCounters;

/// Owner of a CSV trace file, of the record queue and of the thread that writes it.
/// push() is the producer side: one thread (the loop), noexcept, no allocation, no lock,
/// never blocks. start()/stop() and the destructor belong to the setup thread.
///
/// The writer thread is made SCHED_OTHER when it starts, whatever it inherited: a thread
/// created after apply_realtime() would otherwise inherit SCHED_FIFO (and the CPU affinity)
/// of its creator and compete with the loop. Start the writer before pinning the loop
/// thread, or pass the CPUs it may use in `writer_cpus`.
class TraceWriter final : private hal::RecordSink<TraceRecord> {
 public:
  /// Checks the column names (1..kTraceMaxColumns of them, each non-empty, unique, no comma,
  /// quote, CR or LF, not "period"/"time_ns"/"flags"), opens (truncates) `path`, writes the
  /// header and allocates the queue; the thread is not started. Throws
  /// std::invalid_argument naming the column or setting, or std::runtime_error
  /// "path: cannot open for writing: <errno text>".
  TraceWriter(const std::string& path, std::vector<std::string> columns,
              const TraceWriterSettings& settings = {});
  /// stop(), then writes what is still queued and closes the file.
  ~TraceWriter() override;
  TraceWriter(const TraceWriter&) = delete;
  TraceWriter& operator=(const TraceWriter&) = delete;
  TraceWriter(TraceWriter&&) = delete;
  TraceWriter& operator=(TraceWriter&&) = delete;

  /// Starts the writer thread, which makes itself SCHED_OTHER and, if `writer_cpus` is not
  /// empty, sets its CPU affinity to them (apply_realtime()); returns that affinity step
  /// (kNotRequested for an empty list; on failure the thread keeps the affinity it
  /// inherited and writes anyway). Throws std::logic_error if it is running; may throw
  /// std::system_error if the thread cannot be created.
  RealtimeStep start(const std::vector<int>& writer_cpus = {});
  /// Stops the writer thread (wakes it, joins it), writes the records still queued and
  /// flushes the file. Idempotent. Records pushed afterwards wait for the next start() or
  /// the destructor.
  void stop() { writer_.stop(); }
  /// stop(), then writes what is still queued and closes the file: the trace appears under
  /// its path (hal::LineFile::close(); a failure is counted in io_errors). Idempotent; the
  /// destructor calls it.
  void close();
  /// True between start() and stop().
  bool running() const noexcept { return writer_.running(); }

  /// Queues one record. False if the queue is full: the record is dropped and counted.
  bool push(const TraceRecord& record) noexcept { return writer_.push(record); }

  /// Counters (see TraceWriterCounters).
  TraceWriterCounters counters() const noexcept { return writer_.counters(); }
  /// Number of value columns (the names given at construction).
  std::size_t num_columns() const noexcept { return columns_.size(); }
  /// The column names.
  const std::vector<std::string>& columns() const noexcept { return columns_; }
  /// Path of the CSV file.
  const std::string& path() const noexcept { return file_.path(); }

 private:
  hal::SinkResult write(const TraceRecord& record) noexcept override;
  bool flush() noexcept override { return file_.flush(); }

  std::vector<std::string> columns_;
  hal::AsyncRecordWriter<TraceRecord> writer_;  // before the file: bad settings throw first
  hal::LineFile file_;
};

}  // namespace numen::platform
