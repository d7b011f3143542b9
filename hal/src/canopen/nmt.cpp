/// @file nmt.cpp
/// NMT node control codec and the slave-side NMT state machine (CiA 301 §7.2.8.3.1, §7.3.2).

#include "numen/hal/canopen/nmt.hpp"

#include <stdexcept>
#include <string>

#include "numen/hal/canopen/heartbeat.hpp"

namespace numen::hal {

const char* to_string(NmtCommand command) noexcept {
  switch (command) {
    case NmtCommand::kStartRemoteNode:
      return "start remote node";
    case NmtCommand::kStopRemoteNode:
      return "stop remote node";
    case NmtCommand::kEnterPreOperational:
      return "enter pre-operational";
    case NmtCommand::kResetNode:
      return "reset node";
    case NmtCommand::kResetCommunication:
      return "reset communication";
  }
  return "unknown";
}

const char* to_string(NmtState state) noexcept {
  switch (state) {
    case NmtState::kBootUp:
      return "boot-up";
    case NmtState::kStopped:
      return "stopped";
    case NmtState::kOperational:
      return "operational";
    case NmtState::kPreOperational:
      return "pre-operational";
  }
  return "unknown";
}

const char* to_string(NmtDecodeStatus status) noexcept {
  switch (status) {
    case NmtDecodeStatus::kOk:
      return "ok";
    case NmtDecodeStatus::kWrongId:
      return "wrong COB-ID";
    case NmtDecodeStatus::kNotDataFrame:
      return "not a classic 11-bit data frame";
    case NmtDecodeStatus::kWrongLength:
      return "wrong length";
    case NmtDecodeStatus::kUnknownCommand:
      return "unknown command specifier";
    case NmtDecodeStatus::kNodeIdOutOfRange:
      return "node id out of range";
  }
  return "unknown";
}

const char* to_string(CommObject object) noexcept {
  switch (object) {
    case CommObject::kPdo:
      return "PDO";
    case CommObject::kSdo:
      return "SDO";
    case CommObject::kSync:
      return "SYNC";
    case CommObject::kTime:
      return "TIME";
    case CommObject::kEmcy:
      return "EMCY";
    case CommObject::kNmt:
      return "NMT";
    case CommObject::kErrorControl:
      return "error control";
  }
  return "unknown";
}

const char* to_string(NmtReset reset) noexcept {
  switch (reset) {
    case NmtReset::kPowerOn:
      return "power-on";
    case NmtReset::kNode:
      return "reset node";
    case NmtReset::kCommunication:
      return "reset communication";
  }
  return "unknown";
}

const char* to_string(NmtApplyResult result) noexcept {
  switch (result) {
    case NmtApplyResult::kApplied:
      return "applied";
    case NmtApplyResult::kNotAddressed:
      return "not addressed";
    case NmtApplyResult::kIgnoredInitialising:
      return "ignored during initialisation";
    case NmtApplyResult::kNotNmt:
      return "not NMT";
    case NmtApplyResult::kMalformed:
      return "malformed";
  }
  return "unknown";
}

bool encode_nmt(NmtCommand command, std::uint8_t node_id, std::int64_t timestamp_ns,
                CanFrame& out) noexcept {
  const auto cs = static_cast<std::uint8_t>(command);
  if (!is_nmt_command(cs) || node_id > kMaxNodeId) return false;
  CanFrame f;
  f.id = kNmtCobId;
  f.len = kNmtLen;
  f.data[0] = cs;
  f.data[1] = node_id;
  f.timestamp_ns = timestamp_ns;
  out = f;
  return true;
}

NmtDecodeStatus decode_nmt(const CanFrame& frame, NmtMessage& out) noexcept {
  if (!has_standard_id(frame, kNmtCobId)) return NmtDecodeStatus::kWrongId;
  if (!is_classic_data_frame(frame)) return NmtDecodeStatus::kNotDataFrame;
  if (frame.len != kNmtLen) return NmtDecodeStatus::kWrongLength;
  if (!is_nmt_command(frame.data[0])) return NmtDecodeStatus::kUnknownCommand;
  if (frame.data[1] > kMaxNodeId) return NmtDecodeStatus::kNodeIdOutOfRange;
  out.command = static_cast<NmtCommand>(frame.data[0]);
  out.node_id = frame.data[1];
  return NmtDecodeStatus::kOk;
}

NmtNodeModel::NmtNodeModel(std::uint8_t node_id) : node_id_(node_id) {
  if (node_id == 0 || node_id > kMaxNodeId) {
    throw std::invalid_argument("NmtNodeModel: node_id " + std::to_string(node_id) +
                                " out of range 1-127");
  }
}

NmtApplyResult NmtNodeModel::on_frame(const CanFrame& frame) noexcept {
  NmtMessage msg;
  const NmtDecodeStatus s = decode_nmt(frame, msg);
  if (s == NmtDecodeStatus::kWrongId) return NmtApplyResult::kNotNmt;
  if (s != NmtDecodeStatus::kOk) {
    ++counters_.malformed;
    return NmtApplyResult::kMalformed;
  }
  if (msg.node_id != kNmtAllNodes && msg.node_id != node_id_) {
    ++counters_.not_addressed;
    return NmtApplyResult::kNotAddressed;
  }
  return apply(msg.command);
}

NmtApplyResult NmtNodeModel::apply(NmtCommand command) noexcept {
  // CiA 301 NMT state diagram: initialisation is left only by its own completion (the
  // boot-up message); every command is accepted in pre-operational, operational, stopped.
  if (state_ == NmtState::kBootUp) {
    ++counters_.ignored_initialising;
    return NmtApplyResult::kIgnoredInitialising;
  }
  switch (command) {
    case NmtCommand::kStartRemoteNode:
      state_ = NmtState::kOperational;
      break;
    case NmtCommand::kStopRemoteNode:
      state_ = NmtState::kStopped;
      break;
    case NmtCommand::kEnterPreOperational:
      state_ = NmtState::kPreOperational;
      break;
    case NmtCommand::kResetNode:
      state_ = NmtState::kBootUp;
      last_reset_ = NmtReset::kNode;
      ++counters_.resets;
      break;
    case NmtCommand::kResetCommunication:
      state_ = NmtState::kBootUp;
      last_reset_ = NmtReset::kCommunication;
      ++counters_.resets;
      break;
    default:
      // Not a CiA 301 command specifier (a cast from a bad byte): change nothing.
      ++counters_.malformed;
      return NmtApplyResult::kMalformed;
  }
  ++counters_.commands_applied;
  return NmtApplyResult::kApplied;
}

bool NmtNodeModel::take_boot_up(std::int64_t now_ns, CanFrame& out) noexcept {
  if (state_ != NmtState::kBootUp) return false;
  if (!encode_heartbeat(node_id_, NmtState::kBootUp, now_ns, out)) return false;
  state_ = NmtState::kPreOperational;
  ++counters_.boot_ups;
  return true;
}

}  // namespace numen::hal
