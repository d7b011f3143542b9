/// @file log_bus.cpp
/// Replay of a candump log as bus input, relative timing, user-space acceptance filters.

#include "numen/hal/transport/log_bus.hpp"

#include <algorithm>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

namespace numen::hal {

LogBus::LogBus(std::vector<CandumpRecord> records, LogBusSettings settings)
    : records_(std::move(records)), settings_(std::move(settings)) {
  if (!settings_.iface.empty())
    iface_ = make_candump_iface(settings_.iface, "LogBusSettings.iface");
  if (settings_.loop_gap_ns < 0) {
    throw std::invalid_argument("LogBusSettings.loop_gap_ns must be >= 0 (got " +
                                std::to_string(settings_.loop_gap_ns) + ")");
  }
  if (!records_.empty()) {
    first_ns_ = records_.front().timestamp_ns;
    for (const CandumpRecord& r : records_)
      span_ns_ = std::max(span_ns_, r.timestamp_ns - first_ns_);
  }
  if (settings_.offset_ns > std::numeric_limits<std::int64_t>::max() - span_ns_) {
    throw std::invalid_argument("LogBusSettings.offset_ns " + std::to_string(settings_.offset_ns) +
                                " + log span " + std::to_string(span_ns_) + " ns overflows int64");
  }
  if (settings_.loop && !records_.empty() && span_ns_ + settings_.loop_gap_ns <= 0) {
    throw std::invalid_argument(
        "LogBusSettings.loop needs a pass period > 0: the log spans 0 ns, set loop_gap_ns > 0");
  }
  pass_base_ns_ = settings_.offset_ns;
  latest_due_ns_ = pass_base_ns_;
  for (const CandumpRecord& r : records_) {
    if (!accepts(r)) continue;
    ++matching_;
    if (r.frame.error_frame()) ++matching_errors_;
  }
}

std::int64_t LogBus::next_due_ns() const noexcept {
  if (cursor_ >= records_.size()) return latest_due_ns_;
  const std::int64_t due = pass_base_ns_ + (records_[cursor_].timestamp_ns - first_ns_);
  return std::max(due, latest_due_ns_);
}

bool LogBus::accepts(const CandumpRecord& record) const noexcept {
  if (iface_.size != 0 && !(record.iface == iface_)) return false;
  if (settings_.received_only && record.direction == CandumpDirection::kTransmitted) return false;
  return passes(settings_.filters, record.frame);
}

IoStatus LogBus::read(CanFrame& frame) noexcept {
  for (;;) {
    if (cursor_ == records_.size()) {
      if (!settings_.loop || records_.empty()) return IoStatus::kWouldBlock;
      // Next pass: its first record is due one period after this pass's first.
      const std::int64_t next_base = pass_base_ns_ + span_ns_ + settings_.loop_gap_ns;
      if (next_base > now_ns_) return IoStatus::kWouldBlock;
      pass_base_ns_ = next_base;
      latest_due_ns_ = next_base;
      cursor_ = 0;
    }
    const std::int64_t due = next_due_ns();
    if (due > now_ns_) return IoStatus::kWouldBlock;
    const CandumpRecord& record = records_[cursor_];
    ++cursor_;
    latest_due_ns_ = due;
    if (cursor_ == records_.size()) ++log_counters_.passes;
    if (!accepts(record)) {
      ++log_counters_.filtered;
      continue;
    }
    frame = record.frame;
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
