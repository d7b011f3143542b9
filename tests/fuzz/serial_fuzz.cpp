/// @file serial_fuzz.cpp
/// libFuzzer harness of the serial-line framing (hal/transport/serial_frame.hpp, hal/transport/cobs.hpp): the
/// input is a received byte stream, fed to SerialFrameDecoder in pieces of varying size.
/// Every frame it returns must be well formed (check_frame()), encode again and decode from
/// that encoding to the same frame; the decoder's frame counter must match. The input, as a
/// packet, must also survive COBS encode + decode unchanged.

#include <algorithm>
#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "fuzz_input.hpp"
#include "numen/hal/transport/cobs.hpp"
#include "numen/hal/transport/serial_frame.hpp"

namespace {

using numen::hal::CanFrame;

bool same(const CanFrame& a, const CanFrame& b) {
  if (a.id != b.id || a.flags != b.flags || a.len != b.len) return false;
  return a.remote() || std::equal(a.data.begin(), a.data.begin() + a.len, b.data.begin());
}

void check_round_trip(const CanFrame& frame) {
  if (numen::hal::check_frame(frame) != numen::hal::FrameError::kNone)
    numen::fuzz::finding("serial: the decoder returned a malformed frame");
  std::array<std::uint8_t, numen::hal::kSerialMaxFrameOnLine> line{};
  const auto encoded = numen::hal::encode_serial_frame(frame, line);
  if (!encoded.ok()) numen::fuzz::finding("serial: a decoded frame does not encode");
  numen::hal::SerialFrameDecoder decoder;
  CanFrame again;
  const auto r = decoder.feed(std::span(line.data(), encoded.length), again);
  if (!r.frame_ready || r.consumed != encoded.length)
    numen::fuzz::finding("serial: an encoded frame does not decode");
  if (!same(frame, again)) numen::fuzz::finding("serial: decode(encode(frame)) differs");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::span<const std::uint8_t> input(data, size);

  // The stream, in pieces of 1..64 bytes (sizes from a fixed sequence, so that the same input
  // is cut the same way every time).
  numen::hal::SerialFrameDecoder decoder;
  std::uint64_t frames = 0;
  std::size_t pos = 0;
  std::size_t piece = size > 0 ? 1 + data[0] % 64 : 1;
  while (pos < size) {
    std::span<const std::uint8_t> rest = input.subspan(pos, std::min(piece, size - pos));
    while (!rest.empty()) {
      CanFrame frame;
      const auto r = decoder.feed(rest, frame);
      if (r.consumed == 0 || r.consumed > rest.size())
        numen::fuzz::finding("serial: feed() consumed nothing or too much");
      if (r.frame_ready) {
        ++frames;
        check_round_trip(frame);
      }
      pos += r.consumed;
      rest = rest.subspan(r.consumed);
    }
    piece = 1 + (piece * 37 + 11) % 64;
  }
  if (decoder.counters().frames != frames)
    numen::fuzz::finding("serial: counters().frames != frames returned");
  if (decoder.buffered() > numen::hal::kSerialMaxEncoded)
    numen::fuzz::finding("serial: buffered() over the chunk size");

  // COBS on its own: any packet round-trips.
  std::vector<std::uint8_t> encoded(numen::hal::cobs_max_encoded_length(size));
  const auto e = numen::hal::cobs_encode(input, encoded);
  if (!e.ok() || e.length != numen::hal::cobs_encoded_length(input))
    numen::fuzz::finding("serial: cobs_encode failed");
  if (std::find(encoded.begin(), encoded.begin() + e.length, 0) != encoded.begin() + e.length)
    numen::fuzz::finding("serial: a COBS encoding holds a zero");
  std::vector<std::uint8_t> decoded(size);
  const auto d = numen::hal::cobs_decode(std::span(encoded.data(), e.length), decoded);
  if (!d.ok() || d.length != size || !std::equal(decoded.begin(), decoded.end(), data))
    numen::fuzz::finding("serial: cobs_decode(cobs_encode(x)) != x");
  // And any input as COBS bytes: decodes or fails cleanly, never past the output.
  std::vector<std::uint8_t> out(size);
  (void)numen::hal::cobs_decode(input, out);
  return 0;
}
