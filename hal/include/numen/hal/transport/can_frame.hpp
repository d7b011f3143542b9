#pragma once
/// @file can_frame.hpp
/// CanFrame: one classic CAN 2.0 or CAN FD data/remote/error frame as it crosses a
/// numen::hal::Bus. The fields map one to one onto Linux SocketCAN's `struct canfd_frame`
/// (linux/can.h: can_id with CAN_EFF_FLAG / CAN_RTR_FLAG / CAN_ERR_FLAG, len, flags with
/// CANFD_BRS / CANFD_ESI) plus a receive timestamp (SO_TIMESTAMPNS), so the SocketCAN
/// backend converts without loss. Frame rules: ISO 11898-1:2015.

#include <array>
#include <cstdint>

namespace numen::hal {

/// Bit flags of CanFrame::flags. Combine with `|`.
struct CanFlag {
  /// 29-bit identifier (CAN 2.0B extended frame). SocketCAN: CAN_EFF_FLAG in can_id.
  static constexpr std::uint8_t kExtendedId = 1u << 0;
  /// Remote transmission request (classic CAN only; `len` is the requested length, no data).
  /// SocketCAN: CAN_RTR_FLAG.
  static constexpr std::uint8_t kRemote = 1u << 1;
  /// CAN FD frame (FDF bit): `len` may be one of 0–8, 12, 16, 20, 24, 32, 48, 64.
  /// SocketCAN: a frame read as `struct canfd_frame` (CANFD_FDF).
  static constexpr std::uint8_t kFd = 1u << 2;
  /// CAN FD bit-rate switch: the data phase is sent at the data bit rate. SocketCAN: CANFD_BRS.
  static constexpr std::uint8_t kBitRateSwitch = 1u << 3;
  /// CAN FD error-state indicator: the sender is error passive. SocketCAN: CANFD_ESI.
  static constexpr std::uint8_t kErrorStateIndicator = 1u << 4;
  /// Error report from the CAN controller, not a frame on the wire; `id` holds the error
  /// class and `data` the details (SocketCAN: CAN_ERR_FLAG, linux/can/error.h).
  static constexpr std::uint8_t kErrorFrame = 1u << 5;
};

/// Largest 11-bit (standard) identifier mask.
inline constexpr std::uint32_t kStandardIdMask = 0x7FFu;
/// Largest 29-bit (extended) identifier mask.
inline constexpr std::uint32_t kExtendedIdMask = 0x1FFFFFFFu;
/// Maximum payload of a classic CAN frame, bytes.
inline constexpr std::uint8_t kMaxClassicLen = 8;
/// Maximum payload of a CAN FD frame, bytes.
inline constexpr std::uint8_t kMaxFdLen = 64;

/// One CAN frame. Plain value type (no heap), 80 bytes.
struct CanFrame {
  /// Identifier: 11 bits (0–0x7FF) or, with CanFlag::kExtendedId, 29 bits (0–0x1FFFFFFF).
  /// For CANopen this is the COB-ID.
  std::uint32_t id = 0;
  /// CanFlag bits.
  std::uint8_t flags = 0;
  /// Payload length in bytes (not the DLC code): 0–8 classic; a valid FD length with kFd.
  std::uint8_t len = 0;
  /// Payload; bytes at index >= len are unspecified (zero when built by numen).
  std::array<std::uint8_t, kMaxFdLen> data{};
  /// Time on the bus clock, ns: receive time for a frame read from a Bus, intended send
  /// time for a frame written (a Bus may overwrite it with its own transmit time).
  std::int64_t timestamp_ns = 0;

  /// True if the identifier is 29 bits.
  constexpr bool extended() const noexcept { return (flags & CanFlag::kExtendedId) != 0; }
  /// True for a remote transmission request.
  constexpr bool remote() const noexcept { return (flags & CanFlag::kRemote) != 0; }
  /// True for a CAN FD frame.
  constexpr bool fd() const noexcept { return (flags & CanFlag::kFd) != 0; }
  /// True for a controller error report.
  constexpr bool error_frame() const noexcept { return (flags & CanFlag::kErrorFrame) != 0; }
};

// Frame acceptance: the one place that says which frames a protocol decoder (PDO, SYNC, NMT,
// heartbeat, EMCY) takes as "its" frame. A decoder asks two questions, in this order:
//  1. Is the frame on my 11-bit identifier? (has_standard_id) An error report is not a frame
//     on the wire (its id holds error-class bits, linux/can/error.h) and a 29-bit frame with
//     the same number is a different identifier (ISO 11898-1 IDE bit): both are "not mine"
//     (kWrongId, counted as unknown), never a malformed message of mine.
//  2. Is it the kind of frame my protocol is defined on? (is_classic_data_frame) A remote
//     request or a CAN FD frame on my identifier is mine but wrong (kNotDataFrame: rejected
//     and counted as malformed). CANopen CiA 301 services and numen's PDOs are classic CAN.
// matches_classic_id() is both at once. Error reports go to bus-state handling only
// (SocketCanBus::state(), decode_error_frame()).

/// True if `frame` carries an 11-bit identifier on the wire: not an error report
/// (CanFlag::kErrorFrame) and not 29-bit (CanFlag::kExtendedId). Classic or FD, data or remote.
constexpr bool is_standard_frame(const CanFrame& frame) noexcept {
  return (frame.flags & (CanFlag::kErrorFrame | CanFlag::kExtendedId)) == 0;
}

/// True if `frame` is on the 11-bit identifier `id` (a CANopen COB-ID): is_standard_frame()
/// and frame.id == id. Data, remote or FD frame alike; see is_classic_data_frame() for the kind.
constexpr bool has_standard_id(const CanFrame& frame, std::uint32_t id) noexcept {
  return is_standard_frame(frame) && frame.id == id;
}

/// True if `frame` is a classic CAN data frame with an 11-bit identifier: not remote, not
/// CAN FD, not an error report, not 29-bit. The only kind CiA 301 services and numen's PDOs use.
constexpr bool is_classic_data_frame(const CanFrame& frame) noexcept {
  return (frame.flags & (CanFlag::kRemote | CanFlag::kErrorFrame | CanFlag::kExtendedId |
                         CanFlag::kFd)) == 0;
}

/// True if `frame` is a classic CAN data frame on the 11-bit identifier `id`:
/// has_standard_id(frame, id) && is_classic_data_frame(frame).
constexpr bool matches_classic_id(const CanFrame& frame, std::uint32_t id) noexcept {
  return frame.id == id && is_classic_data_frame(frame);
}

/// Why a CanFrame is not a well-formed frame (check_frame()).
enum class FrameError : std::uint8_t {
  kNone,             ///< Well formed.
  kIdOutOfRange,     ///< id wider than 11 bits (standard) or 29 bits (extended).
  kLengthTooLong,    ///< Classic frame with len > 8.
  kInvalidFdLength,  ///< FD frame whose len is not 0–8, 12, 16, 20, 24, 32, 48 or 64.
  kRemoteFd,         ///< Remote request flagged as FD (FD has no remote frames).
  kFdFlagWithoutFd,  ///< Bit-rate switch or error-state indicator on a classic frame.
};

/// True if `len` is a payload length CAN FD can carry (0–8, 12, 16, 20, 24, 32, 48, 64).
constexpr bool is_valid_fd_length(std::uint8_t len) noexcept {
  return len <= 8 || len == 12 || len == 16 || len == 20 || len == 24 || len == 32 || len == 48 ||
         len == 64;
}

/// Payload length of a 4-bit DLC code (0–15): 0–8 map to themselves; 9–15 map to 12, 16, 20,
/// 24, 32, 48, 64 for FD (`fd` = true) and to 8 for classic CAN (ISO 11898-1 §8.4.2.4).
/// Codes above 15 are masked to 4 bits.
constexpr std::uint8_t dlc_to_len(std::uint8_t dlc, bool fd) noexcept {
  constexpr std::uint8_t kFdLen[16] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64};
  dlc &= 0x0F;
  if (!fd && dlc > 8) return 8;
  return kFdLen[dlc];
}

/// Smallest DLC code (0–15) whose payload length covers `len` bytes; 15 for len > 48.
constexpr std::uint8_t len_to_dlc(std::uint8_t len) noexcept {
  if (len <= 8) return len;
  if (len <= 12) return 9;
  if (len <= 16) return 10;
  if (len <= 20) return 11;
  if (len <= 24) return 12;
  if (len <= 32) return 13;
  if (len <= 48) return 14;
  return 15;
}

/// Checks the identifier range and the length/flag rules of `frame`. Error frames are only
/// checked for len <= 8 and a 29-bit id. Never throws, never allocates.
FrameError check_frame(const CanFrame& frame) noexcept;

/// Short English name of a FrameError (static string).
const char* to_string(FrameError error) noexcept;

}  // namespace numen::hal
