/// @file serial_frame.cpp
/// Serial-line framing of CanFrame: payload layout + CRC-16/IBM-3740, COBS, 0x00 delimiter;
/// streaming decoder with per-cause rejection counters.

#include "numen/hal/transport/serial_frame.hpp"

#include "numen/hal/transport/cobs.hpp"
#include "numen/hal/transport/crc16.hpp"

namespace numen::hal {

SerialEncodeResult encode_serial_frame(const CanFrame& frame,
                                       std::span<std::uint8_t> out) noexcept {
  if ((frame.flags & ~kSerialKnownFlags) != 0 || check_frame(frame) != FrameError::kNone) {
    return {0, SerialEncodeError::kMalformedFrame};
  }
  // A remote request carries no data on the line (its len is the requested length).
  const std::size_t data_len = frame.remote() ? 0 : frame.len;
  std::array<std::uint8_t, kSerialMaxPayload> payload{};
  payload[0] = frame.flags;
  payload[1] = static_cast<std::uint8_t>(frame.id);
  payload[2] = static_cast<std::uint8_t>(frame.id >> 8);
  payload[3] = static_cast<std::uint8_t>(frame.id >> 16);
  payload[4] = static_cast<std::uint8_t>(frame.id >> 24);
  payload[5] = frame.len;
  for (std::size_t i = 0; i < data_len; ++i) payload[kSerialHeaderSize + i] = frame.data[i];
  const std::size_t body = kSerialHeaderSize + data_len;
  const std::uint16_t crc = crc16(std::span<const std::uint8_t>(payload.data(), body));
  payload[body] = static_cast<std::uint8_t>(crc >> 8);
  payload[body + 1] = static_cast<std::uint8_t>(crc);
  const std::size_t size = body + kSerialCrcSize;

  const std::span<const std::uint8_t> in(payload.data(), size);
  if (out.size() < cobs_encoded_length(in) + 1) return {0, SerialEncodeError::kOutputTooSmall};
  const CobsResult enc = cobs_encode(in, out);
  if (!enc.ok()) return {0, SerialEncodeError::kOutputTooSmall};
  out[enc.length] = kSerialDelimiter;
  return {enc.length + 1, SerialEncodeError::kNone};
}

void SerialFrameDecoder::reset() noexcept {
  length_ = 0;
  hunting_ = false;
}

void SerialFrameDecoder::reject(std::uint64_t& cause, std::size_t bytes) noexcept {
  ++cause;
  counters_.garbage_bytes += bytes;
  if (in_sync_) ++counters_.resyncs;
  in_sync_ = false;
}

bool SerialFrameDecoder::finish_chunk(CanFrame& frame) noexcept {
  const std::size_t n = length_;
  length_ = 0;
  if (n == 0) return false;  // idle delimiter
  if (n < kSerialMinEncoded) {
    reject(counters_.torn_frames, n);
    return false;
  }
  std::array<std::uint8_t, kSerialMaxPayload> p{};
  const CobsResult dec = cobs_decode(std::span<const std::uint8_t>(chunk_.data(), n), p);
  // A valid chunk of 9..73 bytes has no 0xFF code (it would need 254 more bytes) and decodes
  // to n - 1 >= 8 bytes; the length test only guards the indexing below.
  if (!dec.ok() || dec.length < kSerialMinPayload) {
    reject(counters_.cobs_errors, n);
    return false;
  }
  const std::size_t size = dec.length;
  const std::size_t body = size - kSerialCrcSize;
  const std::uint16_t sent =
      static_cast<std::uint16_t>((static_cast<std::uint16_t>(p[body]) << 8) | p[body + 1]);
  if (crc16(std::span<const std::uint8_t>(p.data(), body)) != sent) {
    reject(counters_.crc_errors, n);
    return false;
  }
  CanFrame f;
  f.flags = p[0];
  f.id = static_cast<std::uint32_t>(p[1]) | (static_cast<std::uint32_t>(p[2]) << 8) |
         (static_cast<std::uint32_t>(p[3]) << 16) | (static_cast<std::uint32_t>(p[4]) << 24);
  f.len = p[5];
  const std::size_t data_len = body - kSerialHeaderSize;
  const std::size_t expected = f.remote() ? 0 : f.len;
  if ((f.flags & ~kSerialKnownFlags) != 0 || data_len != expected ||
      check_frame(f) != FrameError::kNone) {
    reject(counters_.malformed_frames, n);
    return false;
  }
  for (std::size_t i = 0; i < data_len; ++i) f.data[i] = p[kSerialHeaderSize + i];
  frame = f;
  ++counters_.frames;
  in_sync_ = true;
  return true;
}

SerialFrameDecoder::Result SerialFrameDecoder::feed(std::span<const std::uint8_t> bytes,
                                                    CanFrame& frame) noexcept {
  for (std::size_t i = 0; i < bytes.size(); ++i) {
    const std::uint8_t b = bytes[i];
    if (hunting_) {
      if (b == kSerialDelimiter) {
        hunting_ = false;
      } else {
        ++counters_.garbage_bytes;
      }
      continue;
    }
    if (b == kSerialDelimiter) {
      if (finish_chunk(frame)) return {i + 1, true};
      continue;
    }
    if (length_ == chunk_.size()) {
      // Too long for any frame: the delimiter was lost. Reject what we hold and this byte,
      // then skip to the next delimiter.
      reject(counters_.torn_frames, length_ + 1);
      length_ = 0;
      hunting_ = true;
      continue;
    }
    chunk_[length_++] = b;
  }
  return {bytes.size(), false};
}

}  // namespace numen::hal
