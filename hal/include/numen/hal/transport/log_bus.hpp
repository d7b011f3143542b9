#pragma once
/// @file log_bus.hpp
/// LogBus: a Bus that replays a recorded candump log (candump_log.hpp) as bus input, on a
/// clock set by the caller like SimBus, so a field recording runs again on a desk. Replay
/// timing is relative, as canplayer's: the first record is due at `offset_ns`, every other
/// record at offset_ns + (its log time − the first record's log time).

#include <cstddef>
#include <cstdint>
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

/// Replay counters of a LogBus since construction.
struct LogBusCounters {
  std::uint64_t replayed = 0;  ///< Records returned by read() (kOk).
  std::uint64_t filtered = 0;  ///< Records passed over: filters, iface or direction.
  std::uint64_t passes = 0;    ///< Complete passes over the log (> 1 only with loop).
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
/// Not thread safe. read/write never allocate, throw, lock or block; one read() passes over
/// at most the filtered records due before the frame it returns.
class LogBus final : public Bus {
 public:
  /// Takes the records (load_candump_log()). Throws std::invalid_argument naming the field if
  /// `iface` is not a valid interface name, loop_gap_ns < 0, loop is set and the pass period
  /// (log span + loop_gap_ns) is 0, or offset_ns + log span overflows int64.
  explicit LogBus(std::vector<CandumpRecord> records, LogBusSettings settings = {});

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
  std::size_t remaining() const noexcept { return records_.size() - cursor_; }
  /// True when every record has been returned or filtered and loop is off.
  bool finished() const noexcept { return !settings_.loop && cursor_ == records_.size(); }
  /// Due time of the next record of the current pass (passing the filters or not), ns;
  /// meaningless when finished() or the log is empty.
  std::int64_t next_due_ns() const noexcept;
  /// Span of the log: latest record time − first record time, ns (0 for 0 or 1 record).
  std::int64_t span_ns() const noexcept { return span_ns_; }
  /// Number of records in the log.
  std::size_t size() const noexcept { return records_.size(); }
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

 private:
  bool accepts(const CandumpRecord& record) const noexcept;

  std::vector<CandumpRecord> records_;
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
  LogBusCounters log_counters_{};
};

}  // namespace numen::hal
