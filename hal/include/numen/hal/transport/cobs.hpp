#pragma once
/// @file cobs.hpp
/// Consistent Overhead Byte Stuffing (S. Cheshire, M. Baker, "Consistent Overhead Byte
/// Stuffing", IEEE/ACM Transactions on Networking 7(2):159–170, 1999): rewrites a
/// packet so that it contains no 0x00 byte, which then delimits packets on a byte stream.
///
/// The packet, with a virtual 0x00 appended, is cut after each zero into blocks; each block
/// becomes a code byte n (1–0xFF) followed by its n−1 non-zero bytes, the zero itself being
/// implied. Code 0xFF is a block of 254 non-zero bytes with no implied zero. The implied zero
/// of the last block is the virtual one and is dropped by the decoder. When a 0xFF block
/// exhausts the packet, this encoder stops there rather than adding an empty final block
/// 0x01 (both forms decode to the same packet; the decoder accepts both). Overhead: 1 byte
/// for 0–254 bytes of input, at most ⌈n/254⌉ bytes for n >= 1.
///
/// Encoder and decoder write into caller-provided buffers (which must not overlap the input),
/// never allocate, never throw. The 0x00 delimiter is not part of the encoded bytes here.

#include <cstddef>
#include <cstdint>
#include <span>

namespace numen::hal {

/// Why a COBS encode/decode failed.
enum class CobsError : std::uint8_t {
  kNone,            ///< Success.
  kOutputTooSmall,  ///< The output buffer cannot hold the result.
  kZeroInInput,     ///< decode: a 0x00 byte inside the encoded input (a delimiter, not data).
  kCodeOverrun,     ///< decode: a code byte announces more bytes than the input has left.
};

/// Result of cobs_encode() / cobs_decode(): bytes written, or an error (length 0, output
/// contents unspecified).
struct CobsResult {
  std::size_t length = 0;              ///< Bytes written to the output (0 on error).
  CobsError error = CobsError::kNone;  ///< kNone on success.
  /// True on success.
  constexpr bool ok() const noexcept { return error == CobsError::kNone; }
};

/// Largest COBS encoding of `n` input bytes: n + 1 for n = 0..254, n + ⌈n/254⌉ beyond
/// (a run of 254 non-zero bytes costs one code byte and ends no block with a zero).
constexpr std::size_t cobs_max_encoded_length(std::size_t n) noexcept {
  return n == 0 ? 1 : n + (n + 253) / 254;
}

/// Exact length of the COBS encoding of `input` (what cobs_encode() writes).
std::size_t cobs_encoded_length(std::span<const std::uint8_t> input) noexcept;

/// COBS-encodes `input` (any bytes, possibly empty) into `output`. The result holds no 0x00
/// byte and is at least 1 byte long (the empty packet encodes as 0x01). kOutputTooSmall if
/// `output` is shorter than cobs_encoded_length(input).
CobsResult cobs_encode(std::span<const std::uint8_t> input,
                       std::span<std::uint8_t> output) noexcept;

/// Decodes the COBS bytes `input` (without the delimiter) into `output`. Errors, the first
/// found scanning left to right: kZeroInInput (a 0x00 in `input`), kCodeOverrun (the last
/// code byte announces more bytes than remain: the input was cut), kOutputTooSmall. An empty
/// input decodes to an empty output (the encoder never produces it).
CobsResult cobs_decode(std::span<const std::uint8_t> input,
                       std::span<std::uint8_t> output) noexcept;

/// Short English name of a CobsError (static string).
const char* to_string(CobsError error) noexcept;

}  // namespace numen::hal
