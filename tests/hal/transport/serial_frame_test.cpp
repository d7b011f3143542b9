// Tests of numen/hal/transport/serial_frame.hpp: the worked example byte for byte, round trips of every
// frame kind, encoder refusals, and the streaming decoder: resynchronisation after each kind
// of damage with exact counters, byte-at-a-time == one chunk, bit flips never yield a wrong
// frame, byte accounting on random input, no allocation.
#include "numen/hal/transport/serial_frame.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <vector>

#include "alloc_counter.hpp"
#include "numen/hal/transport/cobs.hpp"
#include "numen/hal/transport/crc16.hpp"
#include "numen/hal/transport/splitmix64.hpp"

#include "serial_test_frames.hpp"

namespace numen::hal {
namespace serial_frame_test {  // named: the unity build shares a TU with other test files

using test::Bytes;
using test::encode;
using test::make;

Bytes cat(std::initializer_list<Bytes> parts) {
  Bytes out;
  for (const Bytes& p : parts) out.insert(out.end(), p.begin(), p.end());
  return out;
}

// A frame on the line built from an arbitrary payload with a correct CRC (for frames the
// encoder refuses to produce).
Bytes line_from_payload(Bytes payload) {
  const std::uint16_t c = crc16(payload);
  payload.push_back(static_cast<std::uint8_t>(c >> 8));
  payload.push_back(static_cast<std::uint8_t>(c));
  Bytes out(cobs_max_encoded_length(payload.size()) + 1);
  const CobsResult r = cobs_encode(payload, out);
  out.resize(r.length);
  out.push_back(0x00);
  return out;
}

using numen::test::expect_identical;

// Feeds `bytes` in pieces of `step` bytes (0: all at once) and collects the frames.
std::vector<CanFrame> feed_all(SerialFrameDecoder& dec, const Bytes& bytes, std::size_t step) {
  std::vector<CanFrame> frames;
  std::size_t pos = 0;
  while (pos < bytes.size()) {
    const std::size_t n = step == 0 ? bytes.size() - pos : std::min(step, bytes.size() - pos);
    std::span<const std::uint8_t> piece(bytes.data() + pos, n);
    while (!piece.empty()) {
      CanFrame f;
      const SerialFrameDecoder::Result r = dec.feed(piece, f);
      if (r.frame_ready) frames.push_back(f);
      EXPECT_TRUE(r.frame_ready || r.consumed == piece.size());
      piece = piece.subspan(r.consumed);
    }
    pos += n;
  }
  return frames;
}

void expect_counters(const SerialCounters& c, const SerialCounters& want) {
  EXPECT_EQ(c.frames, want.frames);
  EXPECT_EQ(c.garbage_bytes, want.garbage_bytes);
  EXPECT_EQ(c.torn_frames, want.torn_frames);
  EXPECT_EQ(c.cobs_errors, want.cobs_errors);
  EXPECT_EQ(c.crc_errors, want.crc_errors);
  EXPECT_EQ(c.malformed_frames, want.malformed_frames);
  EXPECT_EQ(c.filtered, want.filtered);
  EXPECT_EQ(c.resyncs, want.resyncs);
}

// The worked example of docs/protocol.md: TPDO1 of node 1 (COB-ID 0x181) carrying the 32-bit
// encoder position 0x1234 little endian.
TEST(SerialFrame, WorkedExampleBytesOnTheLine) {
  const CanFrame f = make(0x181, 0, {0x34, 0x12, 0x00, 0x00});
  // Payload: 00 | 81 01 00 00 | 04 | 34 12 00 00 | B0 66 (CRC 0xB066, big endian).
  const Bytes payload{0x00, 0x81, 0x01, 0x00, 0x00, 0x04, 0x34, 0x12, 0x00, 0x00};
  EXPECT_EQ(crc16(payload), 0xB066);
  const Bytes expected{0x01, 0x03, 0x81, 0x01, 0x01, 0x04, 0x04,
                       0x34, 0x12, 0x01, 0x03, 0xB0, 0x66, 0x00};
  EXPECT_EQ(encode(f), expected);
  SerialFrameDecoder dec;
  const std::vector<CanFrame> got = feed_all(dec, expected, 0);
  ASSERT_EQ(got.size(), 1u);
  expect_identical(got[0], f);
  EXPECT_EQ(got[0].timestamp_ns, 0);
}

TEST(SerialFrame, ExtendedFrameWithoutZerosIsOneCobsBlock) {
  const CanFrame f =
      make(0x1ABCDEF1, CanFlag::kExtendedId, {0x11, 0x22, 0x33, 0x44, 0x55, 0x66, 0x77, 0x88});
  const Bytes expected{0x11, 0x01, 0xF1, 0xDE, 0xBC, 0x1A, 0x08, 0x11, 0x22,
                       0x33, 0x44, 0x55, 0x66, 0x77, 0x88, 0xD3, 0xE4, 0x00};
  EXPECT_EQ(encode(f), expected);
}

std::vector<CanFrame> all_kinds() {
  std::vector<CanFrame> v;
  v.push_back(make(0x000, 0, {}));
  v.push_back(make(0x7FF, 0, {0x0A, 0x0D, 0x11, 0x13, 0x00, 0xFF, 0x03, 0x7F}));
  v.push_back(make(0x1FFFFFFF, CanFlag::kExtendedId, {1, 2, 3}));
  CanFrame rtr = make(0x601, CanFlag::kRemote, {});
  rtr.len = 8;  // requested length; no data travels
  v.push_back(rtr);
  Bytes fd64(64);
  for (std::size_t i = 0; i < 64; ++i) fd64[i] = static_cast<std::uint8_t>(i * 37);
  v.push_back(make(0x123, CanFlag::kFd | CanFlag::kBitRateSwitch, fd64));
  v.push_back(make(0x18DA00F1, CanFlag::kExtendedId | CanFlag::kFd | CanFlag::kErrorStateIndicator,
                   Bytes(12, 0x00)));
  v.push_back(make(0x004, CanFlag::kErrorFrame, {0, 0x10, 0, 0, 0, 0, 0, 0}));
  return v;
}

TEST(SerialFrame, EveryFrameKindRoundTrips) {
  SerialFrameDecoder dec;
  Bytes line;
  const std::vector<CanFrame> sent = all_kinds();
  for (const CanFrame& f : sent) {
    const Bytes e = encode(f);
    EXPECT_GE(e.size(), kSerialMinEncoded + 1);
    EXPECT_LE(e.size(), kSerialMaxFrameOnLine);
    EXPECT_EQ(e.back(), 0x00);
    for (std::size_t i = 0; i + 1 < e.size(); ++i) ASSERT_NE(e[i], 0x00);
    line.insert(line.end(), e.begin(), e.end());
  }
  const std::vector<CanFrame> got = feed_all(dec, line, 0);
  ASSERT_EQ(got.size(), sent.size());
  for (std::size_t i = 0; i < sent.size(); ++i) expect_identical(got[i], sent[i]);
  EXPECT_EQ(got[3].len, 8);  // the remote request's requested length survives
  expect_counters(dec.counters(), SerialCounters{.frames = sent.size()});
}

TEST(SerialFrame, LargestFrameNeedsExactlyTheMaximumBuffer) {
  Bytes data(64, 0x5A);
  const CanFrame f = make(0x100, CanFlag::kFd, data);
  std::array<std::uint8_t, kSerialMaxFrameOnLine> exact{};
  const SerialEncodeResult r = encode_serial_frame(f, exact);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r.length, kSerialMaxFrameOnLine);
  std::array<std::uint8_t, kSerialMaxFrameOnLine - 1> short_buf{};
  EXPECT_EQ(encode_serial_frame(f, short_buf).error, SerialEncodeError::kOutputTooSmall);
}

TEST(SerialFrame, EncoderRefusesMalformedFrames) {
  std::array<std::uint8_t, kSerialMaxFrameOnLine> buf{};
  CanFrame too_long = make(0x100, 0, Bytes(8, 1));
  too_long.len = 9;
  EXPECT_EQ(encode_serial_frame(too_long, buf).error, SerialEncodeError::kMalformedFrame);
  EXPECT_EQ(encode_serial_frame(make(0x800, 0, {}), buf).error,
            SerialEncodeError::kMalformedFrame);  // 12-bit id on a standard frame
  EXPECT_EQ(encode_serial_frame(make(0x100, 0x40, {}), buf).error,
            SerialEncodeError::kMalformedFrame);  // reserved flag bit
}

TEST(SerialFrame, DataPastLenIsNotSentAndDecodesAsZero) {
  CanFrame f = make(0x181, 0, {1, 2});
  f.data[5] = 0x99;  // garbage past len
  f.timestamp_ns = 12345;
  SerialFrameDecoder dec;
  const std::vector<CanFrame> got = feed_all(dec, encode(f), 0);
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].data[5], 0);
  EXPECT_EQ(got[0].timestamp_ns, 0);
  EXPECT_EQ(encode(f), encode(make(0x181, 0, {1, 2})));
}

TEST(SerialFrame, FeedStopsAfterEachFrameAndLeavesTheFrameAloneOtherwise) {
  const Bytes a = encode(make(0x181, 0, {1}));
  const Bytes b = encode(make(0x182, 0, {2}));
  const Bytes line = cat({a, b});
  SerialFrameDecoder dec;
  CanFrame f = make(0x7AA, 0, {9});
  SerialFrameDecoder::Result r = dec.feed(std::span(line).first(a.size() - 1), f);
  EXPECT_FALSE(r.frame_ready);
  EXPECT_EQ(r.consumed, a.size() - 1);
  EXPECT_EQ(f.id, 0x7AAu);  // unchanged
  EXPECT_EQ(dec.buffered(), a.size() - 1);
  r = dec.feed(std::span(line).subspan(a.size() - 1), f);
  EXPECT_TRUE(r.frame_ready);
  EXPECT_EQ(r.consumed, 1u);
  EXPECT_EQ(f.id, 0x181u);
  EXPECT_EQ(dec.buffered(), 0u);
  r = dec.feed(std::span(line).subspan(a.size()), f);
  EXPECT_TRUE(r.frame_ready);
  EXPECT_EQ(r.consumed, b.size());
  EXPECT_EQ(f.id, 0x182u);
}

TEST(SerialFrame, IdleDelimitersAreIgnored) {
  SerialFrameDecoder dec;
  const Bytes line = cat({Bytes{0, 0, 0}, encode(make(0x181, 0, {1})), Bytes{0, 0}});
  EXPECT_EQ(feed_all(dec, line, 0).size(), 1u);
  expect_counters(dec.counters(), SerialCounters{.frames = 1});
}

// The damaged stream of the resynchronisation tests: good frames with one damage of each kind
// between them. Returns the good frames that must come out.
struct DamagedStream {
  Bytes line;
  std::vector<CanFrame> survivors;
  SerialCounters counters;
};

DamagedStream damaged_stream() {
  DamagedStream s;
  std::vector<CanFrame> good;
  for (std::uint32_t i = 0; i < 6; ++i) {
    good.push_back(make(0x181 + i, 0, {static_cast<std::uint8_t>(i), 0x10, 0x00, 0x20}));
  }
  const CanFrame one_block =
      make(0x1ABCDEF1, CanFlag::kExtendedId, {0x11, 0x22, 0x33, 0x44, 0x55, 0x66, 0x77, 0x88});
  const Bytes one_block_line = encode(one_block);  // 0x11 + 16 bytes + 0x00 (see above)

  Bytes noise(100);  // 100 non-zero bytes with no delimiter: over-long chunk
  for (std::size_t i = 0; i < noise.size(); ++i) noise[i] = static_cast<std::uint8_t>(1 + i);
  Bytes flipped = encode(good[3]);
  flipped[8] ^= 0x04;  // a data byte: 0x10 -> 0x14
  const Bytes cut = encode(good[2]);
  Bytes malformed = line_from_payload({0x00, 0x00, 0x01, 0x00, 0x00, 0x09,  // classic, len 9
                                       1, 2, 3, 4, 5, 6, 7, 8, 9});

  s.line = cat({
      encode(good[0]),
      noise,
      Bytes{0x00},  // torn (too long): 100 bytes
      encode(good[1]),
      Bytes(cut.begin(), cut.begin() + 5),
      Bytes{0x00},  // torn: 5 bytes
      flipped,      // crc error
      encode(good[4]),
      Bytes(one_block_line.begin(), one_block_line.begin() + 12),
      Bytes{0x00},              // cobs: 12
      Bytes{0xA5, 0x5A, 0x00},  // torn: 2 bytes of garbage
      malformed,                // malformed
      encode(good[5]),
  });
  s.survivors = {good[0], good[1], good[4], good[5]};
  s.counters.frames = 4;
  s.counters.torn_frames = 3;
  s.counters.cobs_errors = 1;
  s.counters.crc_errors = 1;
  s.counters.malformed_frames = 1;
  s.counters.garbage_bytes = 100 + 5 + (flipped.size() - 1) + 12 + 2 + (malformed.size() - 1);
  // Lost sync after good[0], good[1] (torn, then crc: one episode), good[4] (cobs, torn and
  // malformed: one episode).
  s.counters.resyncs = 3;
  return s;
}

TEST(SerialFrameDecoder, ResynchronisesAfterEachKindOfDamageAndCountsItsCause) {
  const DamagedStream s = damaged_stream();
  SerialFrameDecoder dec;
  const std::vector<CanFrame> got = feed_all(dec, s.line, 0);
  ASSERT_EQ(got.size(), s.survivors.size());
  for (std::size_t i = 0; i < got.size(); ++i) expect_identical(got[i], s.survivors[i]);
  expect_counters(dec.counters(), s.counters);
  EXPECT_EQ(dec.counters().rejected(), 6u);
  EXPECT_FALSE(dec.hunting());
  EXPECT_EQ(dec.buffered(), 0u);
}

TEST(SerialFrameDecoder, ByteAtATimeGivesTheSameResultAsOneChunk) {
  const DamagedStream s = damaged_stream();
  for (std::size_t step : {1u, 2u, 3u, 7u, 64u}) {
    SerialFrameDecoder dec;
    const std::vector<CanFrame> got = feed_all(dec, s.line, step);
    ASSERT_EQ(got.size(), s.survivors.size()) << "step " << step;
    for (std::size_t i = 0; i < got.size(); ++i) expect_identical(got[i], s.survivors[i]);
    expect_counters(dec.counters(), s.counters);
  }
}

TEST(SerialFrameDecoder, OverLongChunkIsRejectedAtOnceAndTheRestSkipped) {
  SerialFrameDecoder dec;
  CanFrame f;
  const Bytes ones(kSerialMaxEncoded, 0x01);  // 73 bytes: still a possible frame
  dec.feed(ones, f);
  EXPECT_FALSE(dec.hunting());
  EXPECT_EQ(dec.buffered(), kSerialMaxEncoded);
  dec.feed(Bytes{0x01}, f);  // the 74th byte without a delimiter
  EXPECT_TRUE(dec.hunting());
  EXPECT_EQ(dec.buffered(), 0u);
  expect_counters(dec.counters(),
                  SerialCounters{.garbage_bytes = 74, .torn_frames = 1, .resyncs = 1});
  dec.feed(Bytes(10, 0x42), f);
  EXPECT_EQ(dec.counters().garbage_bytes, 84u);
  const std::vector<CanFrame> got = feed_all(dec, cat({Bytes{0x00}, encode(make(1, 0, {}))}), 0);
  EXPECT_FALSE(dec.hunting());
  ASSERT_EQ(got.size(), 1u);  // the delimiter ended the hunt; the next frame is intact
  EXPECT_EQ(dec.counters().torn_frames, 1u);
}

TEST(SerialFrameDecoder, LargestFrameIsNotTooLong) {
  SerialFrameDecoder dec;
  const std::vector<CanFrame> got =
      feed_all(dec, encode(make(0x100, CanFlag::kFd, Bytes(64, 0xA7))), 0);
  EXPECT_EQ(got.size(), 1u);
  EXPECT_EQ(dec.counters().torn_frames, 0u);
}

TEST(SerialFrameDecoder, ChunkOfEightBytesIsTornNineIsChecked) {
  SerialFrameDecoder dec;
  feed_all(dec, cat({Bytes(8, 0x09), Bytes{0x00}}), 0);  // 8 bytes: no frame is that short
  EXPECT_EQ(dec.counters().torn_frames, 1u);
  feed_all(dec, cat({Bytes(9, 0x01), Bytes{0x00}}), 0);  // 9 bytes: valid COBS, bad CRC
  EXPECT_EQ(dec.counters().torn_frames, 1u);
  EXPECT_EQ(dec.counters().crc_errors, 1u);
  EXPECT_EQ(dec.counters().resyncs, 1u);  // no intact frame between: one episode
}

TEST(SerialFrameDecoder, MalformedCausesAreAllCaught) {
  const std::vector<Bytes> payloads{
      {0x40, 0x81, 0x01, 0x00, 0x00, 0x00},                             // reserved flag bit 6
      {0x00, 0x81, 0x01, 0x00, 0x00, 0x02, 0xAA},                       // len 2, one data byte
      {0x00, 0x81, 0x01, 0x00, 0x00, 0x00, 0xAA},                       // len 0, one data byte
      {0x00, 0x00, 0x08, 0x00, 0x00, 0x00},                             // 11-bit id 0x800
      {0x04, 0x81, 0x01, 0x00, 0x00, 0x09, 1, 2, 3, 4, 5, 6, 7, 8, 9},  // FD len 9
      {0x06, 0x81, 0x01, 0x00, 0x00, 0x00},                             // remote + FD
      {0x08, 0x81, 0x01, 0x00, 0x00, 0x00},                             // BRS on a classic frame
      {0x02, 0x81, 0x01, 0x00, 0x00, 0x02, 0xAA, 0xBB},                 // remote carrying data
  };
  SerialFrameDecoder dec;
  Bytes line;
  for (const Bytes& p : payloads) line = cat({line, line_from_payload(p)});
  EXPECT_TRUE(feed_all(dec, line, 0).empty());
  EXPECT_EQ(dec.counters().malformed_frames, payloads.size());
  EXPECT_EQ(dec.counters().crc_errors, 0u);
}

// Every single-bit flip anywhere in a frame on the line (delimiter included): no frame other
// than the ones sent ever comes out, the damage costs at most the flipped frame and (when the
// delimiter itself is hit) the frame merged with it, and decoding is in sync afterwards.
TEST(SerialFrameDecoder, NoBitFlipYieldsAWrongFrame) {
  const CanFrame a = make(0x181, 0, {0x34, 0x12, 0x00, 0x00});
  const CanFrame b = make(0x1ABCDEF1, CanFlag::kExtendedId, {1, 2, 3, 4, 5, 6, 7, 8});
  const CanFrame c = make(0x281, 0, {0xFF, 0x00});
  const CanFrame d = make(0x381, CanFlag::kFd, Bytes(12, 0x00));
  for (const CanFrame& victim : {a, b, d}) {
    const Bytes v = encode(victim);
    for (std::size_t bit = 0; bit < v.size() * 8; ++bit) {
      Bytes hit = v;
      hit[bit / 8] ^= static_cast<std::uint8_t>(1u << (bit % 8));
      SerialFrameDecoder dec;
      const std::vector<CanFrame> got =
          feed_all(dec, cat({encode(c), hit, encode(c), encode(a)}), 0);
      const bool delimiter_hit = bit / 8 == v.size() - 1;
      ASSERT_GE(got.size(), delimiter_hit ? 2u : 3u) << "bit " << bit;
      ASSERT_LE(got.size(), 3u) << "bit " << bit;
      expect_identical(got.front(), c);
      expect_identical(got.back(), a);
      if (got.size() == 3) expect_identical(got[1], c);
      EXPECT_GE(dec.counters().rejected(), 1u) << "bit " << bit;
    }
  }
}

// Random bytes: never a crash, and every byte is accounted for.
TEST(SerialFrameDecoder, RandomBytesAreAllAccountedFor) {
  SplitMix64 rng(99);
  SerialFrameDecoder dec;
  // Noise (5 % zeros) with 50 good frames in it, each after a delimiter that ends the noise.
  Bytes line;
  auto noise = [&](std::size_t n) {
    for (std::size_t i = 0; i < n; ++i) {
      line.push_back(rng.below(20) == 0 ? 0 : static_cast<std::uint8_t>(rng.next()));
    }
  };
  for (std::uint32_t k = 0; k < 50; ++k) {
    noise(rng.below(8000));
    line.push_back(0x00);
    const Bytes e = encode(make(0x100 + k, 0, {1, 2, 3}));
    line.insert(line.end(), e.begin(), e.end());
  }
  noise(3000);
  std::size_t frame_bytes = 0;
  const std::vector<CanFrame> got = feed_all(dec, line, 0);
  EXPECT_GE(got.size(), 50u);  // every inserted frame (noise may, rarely, pass a CRC too)
  for (const CanFrame& f : got) frame_bytes += encode(f).size() - 1;
  std::size_t zeros = 0;
  for (std::uint8_t x : line) zeros += x == 0;
  const SerialCounters& k = dec.counters();
  EXPECT_EQ(k.garbage_bytes + frame_bytes + zeros + dec.buffered(), line.size());
  EXPECT_EQ(k.frames, got.size());
  EXPECT_GT(k.torn_frames, 0u);
  EXPECT_GT(k.cobs_errors, 0u);
  EXPECT_GT(k.crc_errors, 0u);
}

TEST(SerialFrameDecoder, DecodingAndEncodingDoNotAllocate) {
  const DamagedStream s = damaged_stream();
  SerialFrameDecoder dec;
  std::array<std::uint8_t, kSerialMaxFrameOnLine> buf{};
  const CanFrame f = make(0x123, CanFlag::kFd, Bytes(64, 0x77));
  std::size_t frames = 0;
  numen::test::AllocationGuard guard;
  for (int rep = 0; rep < 20; ++rep) {
    std::span<const std::uint8_t> rest(s.line);
    while (!rest.empty()) {
      CanFrame out;
      const SerialFrameDecoder::Result r = dec.feed(rest, out);
      frames += r.frame_ready ? 1 : 0;
      rest = rest.subspan(r.consumed);
    }
    const SerialEncodeResult e = encode_serial_frame(f, buf);
    CanFrame out;
    frames += dec.feed(std::span<const std::uint8_t>(buf.data(), e.length), out).frame_ready;
  }
  EXPECT_EQ(guard.count(), 0);
  EXPECT_EQ(frames, 20u * (s.survivors.size() + 1));
}

}  // namespace serial_frame_test
}  // namespace numen::hal
