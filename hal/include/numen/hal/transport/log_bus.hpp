#pragma once
/// @file log_bus.hpp
/// LogBus: a Bus that replays a recorded candump log (candump_log.hpp) as bus input, on a
/// clock set by the caller like SimBus, so a field recording runs again on a desk. Replay
/// timing is relative, as canplayer's: the first record is due at `offset_ns`, every other
/// record at offset_ns + (its log time − the first record's log time).
///
/// Two sources: records in memory (LogBus(std::vector<CandumpRecord>), load_candump_log()),
/// or a log file streamed from disk (LogBus(const LogBusStream&)): a validating pass at
/// construction, then a reader thread that keeps a bounded lock-free queue filled, so that
/// memory does not grow with the log (docs/inputs.md, "Bus logs").

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "numen/hal/transport/bus.hpp"
#include "numen/hal/transport/can_filter.hpp"
#include "numen/hal/transport/can_frame.hpp"
#include "numen/hal/transport/candump_log.hpp"

namespace numen::hal {

/// Creation settings of a LogBus. Checked by the LogBus constructor.
struct LogBusSettings {
  /// Bus time, ns, at which the first record is due.
  std::int64_t offset_ns = 0;
  /// Acceptance filters (SocketCAN semantics, can_filter.hpp): only records passing one of
  /// them are returned; empty passes all. A controller replaying a log that also holds its
  /// own transmissions (SYNC, torque RPDOs) passes only what it would receive, e.g. the
  /// exact_standard_filter() of each encoder TPDO.
  std::vector<CanFilter> filters;
  /// Only records of this interface are returned; empty: any interface. Must be a valid
  /// interface name otherwise (CandumpIface).
  std::string iface;
  /// Skip records marked transmitted (" T", candump -x and numen's recorder): what the
  /// logging node sent itself.
  bool received_only = false;
  /// Start again from the first record after the last one (canplayer -l i).
  bool loop = false;
  /// With loop: time, ns >= 0, from the latest record of one pass to the first record of the
  /// next. The pass period (log span + gap) must be > 0.
  std::int64_t loop_gap_ns = 0;
};

/// Records the reader thread of a streaming LogBus keeps ahead of read() by default (the
/// queue's capacity): 4096 × sizeof(CandumpRecord) (~112 bytes) ≈ 460 KB. At 3 000 frames/s
/// (three axes at 1 kHz) that is more than a second of replay in hand.
inline constexpr std::size_t kLogBusQueueRecords = 4096;

/// A candump log replayed from disk (LogBus streaming constructor).
struct LogBusStream {
  /// The log file (can-utils candump format, candump_log.hpp).
  std::string path;
  /// Checks of the validating pass and of the reader (load_candump_log()).
  CandumpLoadLimits limits;
  /// Capacity, records (>= 1), of the queue between the reader thread and read().
  std::size_t queue_records = kLogBusQueueRecords;
  /// What read() does when the reader thread is behind (the next record is not read from the
  /// file yet): true, wait for it (offline runs: no deadline, the replay stays complete and
  /// deterministic); false, return kWouldBlock and count it in LogBusCounters::reader_behind
  /// (paced runs: the period is not held up; the record comes at a later read(), late).
  bool wait_for_reader = true;
};

/// Replay counters of a LogBus since construction.
struct LogBusCounters {
  std::uint64_t replayed = 0;  ///< Records returned by read() (kOk).
  std::uint64_t filtered = 0;  ///< Records passed over: filters, iface or direction.
  std::uint64_t passes = 0;    ///< Complete passes over the log (> 1 only with loop).
  /// Streaming replay: read() calls that found the queue empty while the reader thread was
  /// still reading (with wait_for_reader they waited, without they returned kWouldBlock).
  std::uint64_t reader_behind = 0;
};

/// A Bus replaying a candump log. read() returns, in log order, the records due at the
/// current time (due time <= time_ns()) that pass the filters, stamped with their due time.
/// Records out of time order in the log (a clock step) are due right after their
/// predecessor, never earlier — canplayer sends those at once too. Error reports in the log
/// (CanFlag::kErrorFrame) are returned like frames and pass the filters (can_filter.hpp);
/// state() stays kOk. The log's plausibility (time order, gaps, an empty log) is checked by
/// load_candump_log(); matching_records() says whether the filters leave anything to replay.
///
/// write() does not go anywhere: it accepts a well-formed frame (kOk, counted as frames_tx)
/// and refuses a malformed one (kError), like a bus with no other node listening. To keep
/// what the controller sends during a replay, wrap the LogBus in a RecordingBus
/// (bus_recorder.hpp).
///
/// Not thread safe. read/write never allocate, throw or lock; one read() passes over at most
/// the filtered records due before the frame it returns. They never block, except a streaming
/// replay with wait_for_reader when the reader thread is behind (LogBusStream).
///
/// Memory: the in-memory constructor keeps the records; the streaming one keeps
/// LogBusStream::queue_records records plus the reader's fixed buffer (CandumpLogReader,
/// 128 KiB), whatever the size of the log.
class LogBus final : public Bus {
 public:
  /// Takes the records (load_candump_log()). Throws std::invalid_argument naming the field if
  /// `iface` is not a valid interface name, loop_gap_ns < 0, loop is set and the pass period
  /// (log span + loop_gap_ns) is 0, or offset_ns + log span overflows int64.
  explicit LogBus(std::vector<CandumpRecord> records, LogBusSettings settings = {});

  /// Streams the log `stream.path` from disk. A first pass reads the whole file in constant
  /// memory with load_candump_log()'s checks and counts (`stats`, if not null; the same
  /// errors: std::runtime_error "path:line:column: what", "path: no frame records ..."), and
  /// the figures below (size, span, matching records); then a reader thread reads the file
  /// again (once per pass with loop) into a queue of stream.queue_records records, filled
  /// before the constructor returns. If the file changes so that a later read does not give
  /// the same number of records, or fails, the replay ends there: reader_error() says why.
  /// Throws std::invalid_argument as the other constructor, or if queue_records is 0.
  explicit LogBus(const LogBusStream& stream, LogBusSettings settings = {},
                  CandumpLoadStats* stats = nullptr);
  ~LogBus() override;
  LogBus(const LogBus&) = delete;
  LogBus& operator=(const LogBus&) = delete;

  /// Next due record that passes the filters (kOk; frame.timestamp_ns = its due time), or
  /// kWouldBlock if none is due yet or the log is exhausted.
  IoStatus read(CanFrame& frame) noexcept override;
  /// Accepts a well-formed frame (kOk) and discards it; kError if check_frame() fails.
  IoStatus write(const CanFrame& frame) noexcept override;
  /// Always kOk: a log holds no controller state (error reports come back through read()).
  BusState state() const noexcept override { return BusState::kOk; }
  /// frames_rx = replayed, frames_tx = writes accepted, errors = writes refused.
  BusCounters counters() const noexcept override { return counters_; }

  /// Sets the replay clock, ns. Meant to be non-decreasing.
  void set_time_ns(std::int64_t t_ns) noexcept { now_ns_ = t_ns; }
  /// Current replay time, ns.
  std::int64_t time_ns() const noexcept { return now_ns_; }

  /// Replay counters.
  const LogBusCounters& log_counters() const noexcept { return log_counters_; }
  /// Records of the current pass not yet returned or filtered.
  std::size_t remaining() const noexcept { return count_ - cursor_; }
  /// True when every record has been returned or filtered and loop is off.
  bool finished() const noexcept { return !settings_.loop && cursor_ == count_; }
  /// Due time of the next record of the current pass (passing the filters or not), ns;
  /// meaningless when finished() or the log is empty.
  std::int64_t next_due_ns() const noexcept;
  /// Span of the log: latest record time − first record time, ns (0 for 0 or 1 record).
  std::int64_t span_ns() const noexcept { return span_ns_; }
  /// Number of records in the log.
  std::size_t size() const noexcept { return count_; }
  /// Records of one pass that pass the filters, `iface` and `received_only`: what read() can
  /// ever return per pass. 0 means the replay feeds the controller nothing (an empty log, or
  /// a log of another device's ids or interface); callers report it as an error (the run
  /// harness: before the first period). Counted at construction.
  std::size_t matching_records() const noexcept { return matching_; }
  /// Records of one pass that are controller error reports (CanFlag::kErrorFrame) and pass
  /// the filters. They are returned by read() like frames (state() is not driven by them);
  /// the protocol decoders ignore them (can_frame.hpp, frame acceptance).
  std::size_t matching_error_reports() const noexcept { return matching_errors_; }
  /// The settings the bus was built with.
  const LogBusSettings& settings() const noexcept { return settings_; }
  /// True for a streaming replay (LogBusStream).
  bool streaming() const noexcept { return stream_ != nullptr; }
  /// True for a streaming replay whose read() waits for its reader thread
  /// (LogBusStream::wait_for_reader).
  bool waits_for_reader() const noexcept;
  /// Streaming replay: why the reader thread stopped before the end of the log ("path:line:
  /// column: what", or a changed record count); empty if it did not. Not for the real-time
  /// path (allocates): read it after the run.
  std::string reader_error() const;

 private:
  struct Stream;  // reader thread and queue of a streaming replay (log_bus.cpp)

  bool accepts(const CandumpRecord& record) const noexcept;
  void check_settings();  // iface and loop gap; sets iface_
  void check_span();      // offset and loop checks once first_ns_ and span_ns_ are known
  // The next record of the current pass (cursor_ < count_), or nullptr if a streaming
  // replay's reader has none yet (counted; waits first with wait_for_reader) or stopped.
  const CandumpRecord* peek() const noexcept;
  void take() noexcept;  // moves past the record peek() returned

  std::vector<CandumpRecord> records_;  // in-memory replay; empty when streaming
  std::unique_ptr<Stream> stream_;      // streaming replay; null in memory
  std::size_t count_ = 0;               // records of one pass
  LogBusSettings settings_;
  CandumpIface iface_;  // settings_.iface, checked; size 0 = any
  std::int64_t first_ns_ = 0;
  std::int64_t span_ns_ = 0;
  std::int64_t pass_base_ns_ = 0;   // due time of the first record of the current pass
  std::int64_t latest_due_ns_ = 0;  // due time of the last record taken (monotonic release)
  std::size_t cursor_ = 0;
  std::size_t matching_ = 0;
  std::size_t matching_errors_ = 0;
  std::int64_t now_ns_ = 0;
  BusCounters counters_{};
  mutable LogBusCounters log_counters_{};  // reader_behind counted by peek() (const)
};

}  // namespace numen::hal
