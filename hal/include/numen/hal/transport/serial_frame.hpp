#pragma once
/// @file serial_frame.hpp
/// The wire format of one CanFrame on a serial line (SerialBus), and a streaming decoder that
/// cuts a received byte stream back into frames.
///
/// Payload (before stuffing), 8 + d bytes:
///
///   offset 0        flags   u8   CanFlag bits (bits 6–7 reserved, must be 0)
///   offset 1..4     id      u32  little endian (CiA 301 byte order, as the CANopen payloads)
///   offset 5        len     u8   payload length in bytes (not the DLC code)
///   offset 6..      data    len bytes, data[0] first (none for a remote request, whose len
///                                is the requested length: d = 0 then, else d = len)
///   offset 6+d      crc     u16  CRC-16/IBM-3740 (crc16.hpp) of bytes 0..5+d, BIG endian
///                                (most significant byte first: the CRC of the whole payload,
///                                crc included, is then 0)
///
/// On the line: COBS(payload) (cobs.hpp; 9–73 bytes, no 0x00 inside) followed by one 0x00
/// delimiter. No timestamp travels: the receiver stamps a frame with its own receive time.
/// Bytes of data[] at index >= len are not sent and decode as 0.

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "numen/hal/transport/can_frame.hpp"

namespace numen::hal {

/// The byte that ends every frame on the line (and that COBS keeps out of the frame).
inline constexpr std::uint8_t kSerialDelimiter = 0x00;
/// Payload bytes before the data: flags (1), id (4), len (1).
inline constexpr std::size_t kSerialHeaderSize = 6;
/// CRC bytes after the data.
inline constexpr std::size_t kSerialCrcSize = 2;
/// Smallest payload (len = 0), bytes.
inline constexpr std::size_t kSerialMinPayload = kSerialHeaderSize + kSerialCrcSize;
/// Largest payload (CAN FD, len = 64), bytes.
inline constexpr std::size_t kSerialMaxPayload = kSerialMinPayload + kMaxFdLen;
/// Smallest COBS encoding of a frame (len = 0), bytes, delimiter excluded.
inline constexpr std::size_t kSerialMinEncoded = kSerialMinPayload + 1;
/// Largest COBS encoding of a frame (len = 64), bytes, delimiter excluded.
inline constexpr std::size_t kSerialMaxEncoded = kSerialMaxPayload + 1;
/// Largest frame on the line: COBS encoding plus delimiter, bytes.
inline constexpr std::size_t kSerialMaxFrameOnLine = kSerialMaxEncoded + 1;
/// CanFlag bits that a serial frame may carry; the others are reserved (must be 0).
inline constexpr std::uint8_t kSerialKnownFlags =
    CanFlag::kExtendedId | CanFlag::kRemote | CanFlag::kFd | CanFlag::kBitRateSwitch |
    CanFlag::kErrorStateIndicator | CanFlag::kErrorFrame;

/// Why encode_serial_frame() failed.
enum class SerialEncodeError : std::uint8_t {
  kNone,            ///< Success.
  kMalformedFrame,  ///< check_frame() != kNone, or reserved flag bits set.
  kOutputTooSmall,  ///< The output buffer is shorter than the frame on the line.
};

/// Result of encode_serial_frame(): bytes written (delimiter included) or an error.
struct SerialEncodeResult {
  std::size_t length = 0;                              ///< Bytes written (0 on error).
  SerialEncodeError error = SerialEncodeError::kNone;  ///< kNone on success.
  /// True on success.
  constexpr bool ok() const noexcept { return error == SerialEncodeError::kNone; }
};

/// Writes `frame` as it goes on the line (COBS(payload) + 0x00, 10–74 bytes) into `out`.
/// `frame.timestamp_ns` is not sent. Never allocates.
SerialEncodeResult encode_serial_frame(const CanFrame& frame, std::span<std::uint8_t> out) noexcept;

/// Event counters of a serial receiver since construction. Every non-delimiter byte received
/// either ends in a decoded frame or is counted in garbage_bytes; every rejected chunk (bytes
/// up to a delimiter) is counted in exactly one of torn_frames, cobs_errors, crc_errors and
/// malformed_frames, checked in that order.
struct SerialCounters {
  /// Frames decoded intact (before user-space filtering).
  std::uint64_t frames = 0;
  /// Bytes discarded: bytes of rejected chunks, plus bytes skipped while hunting for a
  /// delimiter after an over-long chunk. Delimiters are not counted.
  std::uint64_t garbage_bytes = 0;
  /// Chunks of a length no frame has: a delimiter after 1–8 bytes (it arrived early), or
  /// more than kSerialMaxEncoded bytes without a delimiter (the delimiter was lost).
  std::uint64_t torn_frames = 0;
  /// Chunks that are not valid COBS: a code byte announces bytes beyond the delimiter (a
  /// frame cut inside a block, or a corrupted code byte).
  std::uint64_t cobs_errors = 0;
  /// Chunks whose CRC-16 does not match (corrupted bytes, or frames merged by a lost
  /// delimiter).
  std::uint64_t crc_errors = 0;
  /// Chunks with a correct CRC that do not carry a well-formed CanFrame: reserved flag bits,
  /// len disagreeing with the payload size, or check_frame() != kNone. A sender bug.
  std::uint64_t malformed_frames = 0;
  /// Decoded frames that no CanFilter passed (SerialBus only; never returned).
  std::uint64_t filtered = 0;
  /// Times frame synchronisation was lost: rejections that follow an intact frame (or the
  /// start). Consecutive rejections with no intact frame between them count once.
  std::uint64_t resyncs = 0;

  /// Rejected chunks: torn + COBS + CRC + malformed.
  constexpr std::uint64_t rejected() const noexcept {
    return torn_frames + cobs_errors + crc_errors + malformed_frames;
  }
};

/// Streaming decoder of serial frames. Bytes are fed in pieces of any size; the decoder
/// keeps the current chunk (at most kSerialMaxEncoded bytes) in a fixed buffer and decodes
/// it when the delimiter arrives. The first byte fed is taken as the start of a frame.
///
/// Resynchronisation: every 0x00 ends a chunk and starts the next, so a damaged chunk costs
/// only the frame (or garbage) it holds and decoding resumes with the byte after its
/// delimiter. An empty chunk (0x00 right after 0x00) is idle fill and is ignored. A chunk
/// that grows past kSerialMaxEncoded bytes is rejected at once (torn) and the bytes up to
/// the next 0x00 are skipped. Checks of a chunk, in order: length (torn), COBS (cobs error),
/// CRC (crc error), layout and check_frame() (malformed).
/// Never allocates, throws or blocks. Not thread safe.
class SerialFrameDecoder {
 public:
  /// Result of one feed() call.
  struct Result {
    std::size_t consumed = 0;  ///< Bytes of the input used (the rest must be fed again).
    bool frame_ready = false;  ///< True if `frame` now holds a decoded frame.
  };

  /// Consumes bytes of `bytes` up to and including the delimiter of the first intact frame
  /// (which is written to `frame`, timestamp_ns = 0, data past len zeroed), or all of them.
  /// `frame` is left unchanged when no frame is ready. Call again with the unconsumed rest.
  Result feed(std::span<const std::uint8_t> bytes, CanFrame& frame) noexcept;

  /// Counters since construction (filtered stays 0: filtering is the bus's job).
  const SerialCounters& counters() const noexcept { return counters_; }

  /// Bytes of an unfinished chunk held (0 between frames).
  std::size_t buffered() const noexcept { return length_; }

  /// True while skipping bytes up to the next delimiter after an over-long chunk.
  bool hunting() const noexcept { return hunting_; }

  /// Drops the unfinished chunk (not counted) and takes the next byte as the start of a
  /// frame. Counters are kept.
  void reset() noexcept;

 private:
  // Decodes the complete chunk in chunk_[0, length_); true and `frame` set if intact.
  bool finish_chunk(CanFrame& frame) noexcept;
  void reject(std::uint64_t& cause, std::size_t bytes) noexcept;

  std::array<std::uint8_t, kSerialMaxEncoded> chunk_{};
  std::size_t length_ = 0;
  bool hunting_ = false;
  bool in_sync_ = true;
  SerialCounters counters_{};
};

}  // namespace numen::hal
