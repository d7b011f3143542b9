#pragma once
/// @file canopen.hpp
/// The CANopen frames numen exchanges each control period (CiA 301 predefined connection set):
///  - SYNC, COB-ID 0x080, 0 bytes or 1 byte counter, sent by the controller every period;
///  - encoder position TPDO (CiA 406 style), default COB-ID 0x180 + node id, 4 bytes:
///    position value (object 0x6004) as int32 little endian, counts;
///  - drive torque RPDO (CiA 402 style), default COB-ID 0x200 + node id, 2 bytes:
///    target torque (object 0x6071) as int16 little endian, per mille of the rated torque.
/// See docs/protocol.md. Every function here is noexcept and allocation free.

#include <cstdint>

#include "numen/hal/transport/can_frame.hpp"

namespace numen::hal {

/// COB-ID of the SYNC object (CiA 301 §7.2.5, predefined connection set).
inline constexpr std::uint32_t kSyncCobId = 0x080;
/// Base COB-ID of TPDO1 (0x180 + node id); numen's encoder position PDO.
inline constexpr std::uint32_t kTpdo1BaseCobId = 0x180;
/// Base COB-ID of RPDO1 (0x200 + node id); numen's drive torque PDO.
inline constexpr std::uint32_t kRpdo1BaseCobId = 0x200;
/// Largest CANopen node id.
inline constexpr std::uint8_t kMaxNodeId = 127;
/// Payload length of the encoder position PDO, bytes.
inline constexpr std::uint8_t kPositionPdoLen = 4;
/// Payload length of the drive torque PDO, bytes.
inline constexpr std::uint8_t kTorquePdoLen = 2;

/// Default encoder TPDO COB-ID of a node: 0x180 + node_id (node_id 1–127).
constexpr std::uint32_t encoder_tpdo_cob_id(std::uint8_t node_id) noexcept {
  return kTpdo1BaseCobId + node_id;
}
/// Default drive RPDO COB-ID of a node: 0x200 + node_id (node_id 1–127).
constexpr std::uint32_t drive_rpdo_cob_id(std::uint8_t node_id) noexcept {
  return kRpdo1BaseCobId + node_id;
}

/// Outcome of decoding a PDO.
enum class DecodeStatus : std::uint8_t {
  kOk,            ///< Value decoded.
  kWrongId,       ///< Not on the expected 11-bit COB-ID (also: a 29-bit frame with its number,
                  ///< an error report whatever its class bits; has_standard_id()).
  kWrongLength,   ///< Right COB-ID, wrong payload length: a malformed PDO.
  kNotDataFrame,  ///< Right COB-ID but a remote request or a CAN FD frame.
};

/// Short English name of a DecodeStatus (static string).
const char* to_string(DecodeStatus status) noexcept;

/// A SYNC frame stamped `timestamp_ns`. counter == 0: no data byte (CiA 301 without
/// counter); counter 1–240: one data byte carrying it (CiA 301 synchronous counter).
CanFrame make_sync(std::int64_t timestamp_ns, std::uint8_t counter = 0) noexcept;

/// True if `frame` is a SYNC: standard data frame, COB-ID 0x080, length 0 or 1.
bool is_sync(const CanFrame& frame) noexcept;

/// The encoder position TPDO: COB-ID `cob_id`, 4 bytes, `counts` as int32 little endian.
CanFrame encode_position_pdo(std::uint32_t cob_id, std::int32_t counts,
                             std::int64_t timestamp_ns) noexcept;

/// Decodes an encoder position TPDO expected on `cob_id` into `counts` (unchanged unless kOk).
/// Checks, in order: COB-ID (kWrongId), data frame with 11-bit id (kNotDataFrame), length
/// exactly 4 (kWrongLength).
DecodeStatus decode_position_pdo(const CanFrame& frame, std::uint32_t cob_id,
                                 std::int32_t& counts) noexcept;

/// The drive torque RPDO: COB-ID `cob_id`, 2 bytes, `per_mille` of the rated torque as int16
/// little endian (CiA 402 object 0x6071 target torque).
CanFrame encode_torque_pdo(std::uint32_t cob_id, std::int16_t per_mille,
                           std::int64_t timestamp_ns) noexcept;

/// Decodes a drive torque RPDO expected on `cob_id` into `per_mille` (unchanged unless kOk).
/// Same checks as decode_position_pdo() with length exactly 2.
DecodeStatus decode_torque_pdo(const CanFrame& frame, std::uint32_t cob_id,
                               std::int16_t& per_mille) noexcept;

}  // namespace numen::hal
