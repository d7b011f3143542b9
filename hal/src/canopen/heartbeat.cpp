/// @file heartbeat.cpp
/// Heartbeat message codec, producer and consumer (CiA 301 §7.2.8.3.2).

#include "numen/hal/canopen/heartbeat.hpp"

#include <limits>
#include <stdexcept>
#include <string>

#include "canopen_frame_check.hpp"

namespace numen::hal {
namespace {

void check_node_id(const char* who, std::uint8_t node_id) {
  if (node_id == 0 || node_id > kMaxNodeId) {
    throw std::invalid_argument(std::string(who) + ": node_id " + std::to_string(node_id) +
                                " out of range 1-127");
  }
}

}  // namespace

const char* to_string(HeartbeatDecodeStatus status) noexcept {
  switch (status) {
    case HeartbeatDecodeStatus::kOk:
      return "ok";
    case HeartbeatDecodeStatus::kWrongId:
      return "wrong COB-ID";
    case HeartbeatDecodeStatus::kNotDataFrame:
      return "not a classic 11-bit data frame";
    case HeartbeatDecodeStatus::kWrongLength:
      return "wrong length";
    case HeartbeatDecodeStatus::kUnknownState:
      return "unknown NMT state";
  }
  return "unknown";
}

const char* to_string(HeartbeatStatus status) noexcept {
  switch (status) {
    case HeartbeatStatus::kWaiting:
      return "waiting";
    case HeartbeatStatus::kAlive:
      return "alive";
    case HeartbeatStatus::kLost:
      return "lost";
    case HeartbeatStatus::kBootedUnexpectedly:
      return "booted unexpectedly";
  }
  return "unknown";
}

bool encode_heartbeat(std::uint8_t node_id, NmtState state, std::int64_t timestamp_ns,
                      CanFrame& out) noexcept {
  const auto s = static_cast<std::uint8_t>(state);
  if (node_id == 0 || node_id > kMaxNodeId || !is_nmt_state(s)) return false;
  CanFrame f;
  f.id = heartbeat_cob_id(node_id);
  f.len = kHeartbeatLen;
  f.data[0] = s;
  f.timestamp_ns = timestamp_ns;
  out = f;
  return true;
}

HeartbeatDecodeStatus decode_heartbeat(const CanFrame& frame, std::uint8_t& node_id,
                                       NmtState& state) noexcept {
  if (!is_standard_frame(frame) || frame.id <= kHeartbeatBaseCobId ||
      frame.id > kHeartbeatBaseCobId + kMaxNodeId) {
    return HeartbeatDecodeStatus::kWrongId;
  }
  if (!is_classic_data_frame(frame)) return HeartbeatDecodeStatus::kNotDataFrame;
  if (frame.len != kHeartbeatLen) return HeartbeatDecodeStatus::kWrongLength;
  if (!is_nmt_state(frame.data[0])) return HeartbeatDecodeStatus::kUnknownState;
  node_id = static_cast<std::uint8_t>(frame.id - kHeartbeatBaseCobId);
  state = static_cast<NmtState>(frame.data[0]);
  return HeartbeatDecodeStatus::kOk;
}

// ---------------------------------------------------------------------------------------------
// HeartbeatProducer

HeartbeatProducer::HeartbeatProducer(std::uint8_t node_id, std::int64_t period_ns)
    : node_id_(node_id), period_ns_(period_ns) {
  check_node_id("HeartbeatProducer", node_id);
  if (period_ns < 0) {
    throw std::invalid_argument("HeartbeatProducer: period_ns " + std::to_string(period_ns) +
                                " is negative (0 disables the producer)");
  }
}

void HeartbeatProducer::start(std::int64_t now_ns) noexcept {
  started_ = true;
  last_sent_ns_ = now_ns;
  next_due_ns_ = detail::saturating_add(now_ns, period_ns_);
}

bool HeartbeatProducer::set_period(std::int64_t period_ns) noexcept {
  if (period_ns < 0) return false;
  period_ns_ = period_ns;
  next_due_ns_ = detail::saturating_add(last_sent_ns_, period_ns_);
  return true;
}

bool HeartbeatProducer::poll(std::int64_t now_ns, NmtState state, CanFrame& out) noexcept {
  if (!started_ || period_ns_ == 0 || now_ns < next_due_ns_) return false;
  if (!encode_heartbeat(node_id_, state, now_ns, out)) return false;
  // Next grid point strictly after now: next_due + k·period, k >= 1. Grid points that
  // passed without a poll are skipped (one frame per poll), never re-based on now.
  const std::uint64_t late = detail::elapsed_ns(next_due_ns_, now_ns);
  const std::uint64_t steps = late / static_cast<std::uint64_t>(period_ns_) + 1;
  skipped_ += steps - 1;
  const std::uint64_t advance = steps * static_cast<std::uint64_t>(period_ns_);
  const std::uint64_t room = static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max()) -
                             static_cast<std::uint64_t>(next_due_ns_);
  next_due_ns_ =
      advance > room
          ? std::numeric_limits<std::int64_t>::max()
          : static_cast<std::int64_t>(static_cast<std::uint64_t>(next_due_ns_) + advance);
  last_sent_ns_ = now_ns;
  ++sent_;
  return true;
}

// ---------------------------------------------------------------------------------------------
// HeartbeatConsumer

HeartbeatConsumer::HeartbeatConsumer(std::uint8_t node_id, std::int64_t timeout_ns)
    : node_id_(node_id), timeout_ns_(timeout_ns) {
  check_node_id("HeartbeatConsumer", node_id);
  if (timeout_ns <= 0) {
    throw std::invalid_argument("HeartbeatConsumer: timeout_ns " + std::to_string(timeout_ns) +
                                " for node " + std::to_string(node_id) +
                                " must be > 0 (a node that is not watched has no consumer)");
  }
}

void HeartbeatConsumer::record_loss(std::int64_t detected_ns) noexcept {
  status_ = HeartbeatStatus::kLost;
  ++counters_.losses;
  last_fault_.kind = HeartbeatStatus::kLost;
  last_fault_.node_id = node_id_;
  last_fault_.last_heard_ns = last_heard_ns_;
  last_fault_.deadline_ns = detail::saturating_add(last_heard_ns_, timeout_ns_);
  last_fault_.detected_ns = detected_ns;
}

HeartbeatDecodeStatus HeartbeatConsumer::on_frame(const CanFrame& frame) noexcept {
  if (node_id_ == 0 || !has_standard_id(frame, heartbeat_cob_id(node_id_))) {
    return HeartbeatDecodeStatus::kWrongId;
  }
  std::uint8_t node = 0;
  NmtState state = NmtState::kBootUp;
  const HeartbeatDecodeStatus s = decode_heartbeat(frame, node, state);
  switch (s) {
    case HeartbeatDecodeStatus::kOk:
      break;
    case HeartbeatDecodeStatus::kNotDataFrame:
      ++counters_.not_data;
      return s;
    case HeartbeatDecodeStatus::kWrongLength:
      ++counters_.wrong_length;
      return s;
    case HeartbeatDecodeStatus::kUnknownState:
      ++counters_.unknown_state;
      return s;
    case HeartbeatDecodeStatus::kWrongId:
      return s;  // not reached: the COB-ID was checked above
  }

  const std::int64_t t = frame.timestamp_ns;
  const bool out_of_order = heard_ && t < last_heard_ns_;
  if (out_of_order) ++counters_.out_of_order;
  // A heartbeat stamped at or after the deadline of the previous one proves a silence of the
  // timeout or longer, even if no poll() ran in between: record the loss first.
  const bool gap_was_loss =
      status_ == HeartbeatStatus::kAlive && !out_of_order &&
      detail::elapsed_ns(last_heard_ns_, t) >= static_cast<std::uint64_t>(timeout_ns_);

  if (state == NmtState::kBootUp) {
    ++counters_.boot_ups;
    if (gap_was_loss) record_loss(t);
    if (status_ == HeartbeatStatus::kAlive || status_ == HeartbeatStatus::kLost) {
      // The node had been heard with heartbeats and boots again: it reset (CiA 301: the
      // boot-up message is sent on leaving initialisation). Monitoring restarts with the
      // next heartbeat.
      status_ = HeartbeatStatus::kBootedUnexpectedly;
      ++counters_.unexpected_boot_ups;
      last_fault_.kind = HeartbeatStatus::kBootedUnexpectedly;
      last_fault_.node_id = node_id_;
      last_fault_.last_heard_ns = last_heard_ns_;
      last_fault_.deadline_ns = t;
      last_fault_.detected_ns = t;
    }
    if (!out_of_order) {
      last_heard_ns_ = t;
      last_state_ = NmtState::kBootUp;
    }
    heard_ = true;
    return s;
  }

  ++counters_.heartbeats;
  if (out_of_order) return s;  // older news: neither the deadline nor the state move back
  if (gap_was_loss) record_loss(t);
  if (status_ == HeartbeatStatus::kLost) ++counters_.recoveries;
  status_ = HeartbeatStatus::kAlive;
  last_heard_ns_ = t;
  last_state_ = state;
  heard_ = true;
  return s;
}

HeartbeatStatus HeartbeatConsumer::poll(std::int64_t now_ns) noexcept {
  if (status_ == HeartbeatStatus::kAlive &&
      detail::elapsed_ns(last_heard_ns_, now_ns) >= static_cast<std::uint64_t>(timeout_ns_)) {
    record_loss(now_ns);
  }
  return status_;
}

}  // namespace numen::hal
