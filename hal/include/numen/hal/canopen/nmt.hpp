#pragma once
/// @file nmt.hpp
/// CANopen network management (NMT), CiA 301 §7.2.8.3.1 and §7.3.2:
///  - the NMT node control message the controller (NMT master) sends, COB-ID 0x000, 2 bytes:
///    byte 0 command specifier (NmtCommand), byte 1 node id (0 = all nodes);
///  - the NMT states a node reports in its heartbeat (NmtState, CiA 301 §7.2.8.3.2);
///  - NmtNodeModel, the slave-side NMT state machine (CiA 301 §7.3.2.2, figure "NMT state
///    diagram of a CANopen device") for the simulated instrument device that answers NMT.
/// Pure protocol logic: no I/O, every function and member below except the NmtNodeModel
/// constructor is noexcept and allocation free. See docs/protocol.md.
/// Only classic CAN data frames with an 11-bit identifier are CiA 301 NMT messages; remote
/// requests and CAN FD frames on COB-ID 0x000 are refused; error reports and 29-bit frames
/// are not on it (can_frame.hpp, frame acceptance).

#include <cstdint>

#include "numen/hal/transport/can_frame.hpp"
#include "numen/hal/canopen/canopen.hpp"

namespace numen::hal {

/// COB-ID of the NMT node control message (CiA 301 §7.2.8.3.1.1; highest priority).
inline constexpr std::uint32_t kNmtCobId = 0x000;
/// Payload length of the NMT node control message, bytes.
inline constexpr std::uint8_t kNmtLen = 2;
/// Node id addressing every node in an NMT node control message (CiA 301 §7.2.8.3.1.1).
inline constexpr std::uint8_t kNmtAllNodes = 0;

/// NMT node control command specifier, byte 0 of the message (CiA 301 §7.2.8.3.1.1).
enum class NmtCommand : std::uint8_t {
  kStartRemoteNode = 0x01,      ///< Enter NMT state operational.
  kStopRemoteNode = 0x02,       ///< Enter NMT state stopped.
  kEnterPreOperational = 0x80,  ///< Enter NMT state pre-operational.
  kResetNode = 0x81,            ///< Reset application, then communication (initialisation).
  kResetCommunication = 0x82,   ///< Reset communication parameters (initialisation).
};

/// True if `cs` is one of the five NMT command specifiers of CiA 301.
constexpr bool is_nmt_command(std::uint8_t cs) noexcept {
  return cs == 0x01 || cs == 0x02 || cs == 0x80 || cs == 0x81 || cs == 0x82;
}

/// Short English name of an NmtCommand (static string), e.g. "start remote node".
const char* to_string(NmtCommand command) noexcept;

/// NMT state byte of a heartbeat / boot-up message (CiA 301 §7.2.8.3.2, table "NMT states
/// in the heartbeat message"); bit 7 is reserved and 0 in a heartbeat.
/// In NmtNodeModel, kBootUp stands for the NMT state "initialisation": the node's only
/// transmission in it is the boot-up message (a heartbeat carrying 0x00).
enum class NmtState : std::uint8_t {
  kBootUp = 0x00,          ///< Boot-up message / initialisation.
  kStopped = 0x04,         ///< Stopped: only NMT and error control.
  kOperational = 0x05,     ///< Operational: all communication objects.
  kPreOperational = 0x7F,  ///< Pre-operational: everything but PDOs.
};

/// True if `value` is one of the four NMT state bytes of a heartbeat (0x00, 0x04, 0x05, 0x7F).
constexpr bool is_nmt_state(std::uint8_t value) noexcept {
  return value == 0x00 || value == 0x04 || value == 0x05 || value == 0x7F;
}

/// Short English name of an NmtState (static string): "boot-up", "stopped", "operational",
/// "pre-operational"; "unknown" for any other value.
const char* to_string(NmtState state) noexcept;

/// One NMT node control message.
struct NmtMessage {
  NmtCommand command = NmtCommand::kEnterPreOperational;  ///< Command specifier.
  std::uint8_t node_id = kNmtAllNodes;  ///< Addressed node 1–127, or 0 for all nodes.
};

/// Outcome of decoding an NMT node control message (decode_nmt()).
enum class NmtDecodeStatus : std::uint8_t {
  kOk,                ///< Decoded.
  kWrongId,           ///< COB-ID is not 0x000: not an NMT message.
  kNotDataFrame,      ///< COB-ID 0x000 but remote or CAN FD frame. (Error reports and
                      ///< 29-bit frames are not on COB-ID 0x000: kWrongId.)
  kWrongLength,       ///< Payload length is not 2.
  kUnknownCommand,    ///< Byte 0 is not a CiA 301 command specifier.
  kNodeIdOutOfRange,  ///< Byte 1 is above 127.
};

/// Short English name of an NmtDecodeStatus (static string).
const char* to_string(NmtDecodeStatus status) noexcept;

/// Builds the NMT node control message `command` for `node_id` (1–127, or 0 = all nodes)
/// stamped `timestamp_ns`: COB-ID 0x000, 2 bytes {cs, node_id}. Returns false and leaves
/// `out` unchanged if `node_id` > 127 or `command` is not a CiA 301 command specifier.
/// Example: start node 5 -> id 0x000, data 01 05.
bool encode_nmt(NmtCommand command, std::uint8_t node_id, std::int64_t timestamp_ns,
                CanFrame& out) noexcept;

/// Decodes an NMT node control message into `out` (unchanged unless kOk). Checks, in order:
/// COB-ID 0x000 (kWrongId); 11-bit classic data frame (kNotDataFrame); length exactly 2
/// (kWrongLength); command specifier (kUnknownCommand); node id <= 127 (kNodeIdOutOfRange).
NmtDecodeStatus decode_nmt(const CanFrame& frame, NmtMessage& out) noexcept;

/// Communication objects whose use depends on the NMT state (CiA 301 §7.3.2.2, table
/// "NMT states and communication objects").
enum class CommObject : std::uint8_t {
  kPdo,           ///< Process data objects (TPDO / RPDO).
  kSdo,           ///< Service data objects.
  kSync,          ///< SYNC consumption / production.
  kTime,          ///< TIME stamp object.
  kEmcy,          ///< Emergency object.
  kNmt,           ///< NMT node control (reception of NMT commands).
  kErrorControl,  ///< Heartbeat (and, in initialisation, the boot-up message).
};

/// Short English name of a CommObject (static string).
const char* to_string(CommObject object) noexcept;

/// True if a node in NMT state `state` may use `object` (CiA 301 §7.3.2.2):
///  - initialisation (kBootUp): only error control, i.e. the boot-up message;
///  - pre-operational: everything but PDOs;
///  - operational: everything;
///  - stopped: NMT and error control (heartbeat) only.
/// False for a value that is not an NmtState.
constexpr bool nmt_allows(NmtState state, CommObject object) noexcept {
  switch (state) {
    case NmtState::kBootUp:
      return object == CommObject::kErrorControl;
    case NmtState::kPreOperational:
      return object != CommObject::kPdo;
    case NmtState::kOperational:
      return true;
    case NmtState::kStopped:
      return object == CommObject::kNmt || object == CommObject::kErrorControl;
  }
  return false;
}

/// Which reset brought an NmtNodeModel into initialisation last.
enum class NmtReset : std::uint8_t {
  kPowerOn,        ///< Construction: application and communication at power-on values.
  kNode,           ///< Reset node: application parameters (manufacturer and profile
                   ///< area, 2000h–9FFFh) and then communication parameters to power-on values.
  kCommunication,  ///< Reset communication: communication parameters (1000h–1FFFh) only.
};

/// Short English name of an NmtReset (static string).
const char* to_string(NmtReset reset) noexcept;

/// What an NmtNodeModel did with one NMT frame or command.
enum class NmtApplyResult : std::uint8_t {
  kApplied,              ///< The command was for this node (or all) and was executed.
  kNotAddressed,         ///< A valid NMT message for another node: ignored.
  kIgnoredInitialising,  ///< For this node, but the node is in initialisation (CiA 301: no
                         ///< NMT transitions leave initialisation except its completion).
  kNotNmt,               ///< Not COB-ID 0x000: not an NMT message, ignored.
  kMalformed,            ///< COB-ID 0x000 but rejected by decode_nmt(): counted.
};

/// Short English name of an NmtApplyResult (static string).
const char* to_string(NmtApplyResult result) noexcept;

/// Counters of an NmtNodeModel since construction.
struct NmtNodeCounters {
  std::uint64_t commands_applied = 0;      ///< Commands executed (kApplied).
  std::uint64_t not_addressed = 0;         ///< Valid NMT messages for other nodes.
  std::uint64_t ignored_initialising = 0;  ///< Commands received during initialisation.
  std::uint64_t malformed = 0;             ///< COB-ID 0x000 frames decode_nmt() refused.
  std::uint64_t resets = 0;                ///< Reset node + reset communication executed.
  std::uint64_t boot_ups = 0;              ///< Boot-up messages produced (take_boot_up()).
};

/// Slave-side NMT state machine of one CANopen node (CiA 301 §7.3.2, figure "NMT state diagram"):
///
///     power-on / reset ──> initialisation ──(boot-up message sent)──> pre-operational
///     pre-operational ──start──> operational ──stop──> stopped ──enter pre-op──> pre-op ...
///     any state but initialisation ──reset node / reset communication──> initialisation
///
/// Start, stop and enter pre-operational are accepted in pre-operational, operational and
/// stopped (a command for the current state changes nothing but counts as applied).
/// Initialisation ends only through take_boot_up(), which yields the boot-up message and
/// enters pre-operational. Not thread safe. All members but the constructor are noexcept and
/// allocation free.
class NmtNodeModel {
 public:
  /// A node with id `node_id` (1–127) just powered on: state kBootUp (initialisation), the
  /// boot-up message pending. Throws std::invalid_argument naming the value if `node_id` is
  /// 0 or above 127.
  explicit NmtNodeModel(std::uint8_t node_id);

  /// The node id.
  std::uint8_t node_id() const noexcept { return node_id_; }
  /// Current NMT state (kBootUp = initialisation).
  NmtState state() const noexcept { return state_; }
  /// True if the node may use `object` in its current state (nmt_allows()).
  bool allows(CommObject object) const noexcept { return nmt_allows(state_, object); }
  /// The reset that started the current or last initialisation.
  NmtReset last_reset() const noexcept { return last_reset_; }
  /// Counters since construction.
  const NmtNodeCounters& counters() const noexcept { return counters_; }

  /// Decodes `frame` (decode_nmt()) and applies the command if it is for this node or for
  /// all nodes. Frames with another COB-ID are kNotNmt and not counted.
  NmtApplyResult on_frame(const CanFrame& frame) noexcept;

  /// Applies `command` addressed to this node: kApplied, or kIgnoredInitialising while in
  /// initialisation. A reset command enters initialisation (the boot-up message is then
  /// pending again) and records the kind of reset. A value that is not a CiA 301 command
  /// specifier (a cast from a bad byte) changes nothing: kMalformed, counted.
  NmtApplyResult apply(NmtCommand command) noexcept;

  /// If the node is in initialisation: completes it — writes the boot-up message (COB-ID
  /// 0x700 + node id, 1 byte 0x00, stamped `now_ns`) into `out`, enters pre-operational and
  /// returns true. Otherwise returns false and leaves `out` unchanged. The caller must send
  /// the frame (and keep it for a retry if the bus refuses it).
  bool take_boot_up(std::int64_t now_ns, CanFrame& out) noexcept;

 private:
  std::uint8_t node_id_;
  NmtState state_ = NmtState::kBootUp;
  NmtReset last_reset_ = NmtReset::kPowerOn;
  NmtNodeCounters counters_;
};

}  // namespace numen::hal
