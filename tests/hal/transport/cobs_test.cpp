// Tests of numen/hal/transport/cobs.hpp: the examples of the encoding rules, the 253/254/255-byte run
// edges, errors, length bounds and random round trips.
#include "numen/hal/transport/cobs.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <vector>

#include "alloc_counter.hpp"
#include "numen/hal/transport/splitmix64.hpp"

namespace {

using numen::hal::cobs_decode;
using numen::hal::cobs_encode;
using numen::hal::cobs_encoded_length;
using numen::hal::cobs_max_encoded_length;
using numen::hal::CobsError;
using numen::hal::CobsResult;
using numen::hal::SplitMix64;

using Bytes = std::vector<std::uint8_t>;

Bytes encode(const Bytes& in) {
  Bytes out(cobs_max_encoded_length(in.size()) + 8, 0xEE);
  const CobsResult r = cobs_encode(in, out);
  EXPECT_TRUE(r.ok()) << to_string(r.error);
  out.resize(r.length);
  return out;
}

Bytes decode(const Bytes& in) {
  Bytes out(in.size() + 8, 0xEE);
  const CobsResult r = cobs_decode(in, out);
  EXPECT_TRUE(r.ok()) << to_string(r.error);
  out.resize(r.length);
  return out;
}

Bytes run(std::size_t n, std::uint8_t first = 1) {
  Bytes b(n);
  for (std::size_t i = 0; i < n; ++i) b[i] = static_cast<std::uint8_t>(first + i % 255);
  for (auto& x : b) x = x == 0 ? 1 : x;
  return b;
}

Bytes cat(Bytes a, const Bytes& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

TEST(Cobs, ShortPacketsEncodeByTheBlockRule) {
  EXPECT_EQ(encode({}), (Bytes{0x01}));
  EXPECT_EQ(encode({0x00}), (Bytes{0x01, 0x01}));
  EXPECT_EQ(encode({0x00, 0x00}), (Bytes{0x01, 0x01, 0x01}));
  EXPECT_EQ(encode({0x00, 0x11, 0x00}), (Bytes{0x01, 0x02, 0x11, 0x01}));
  EXPECT_EQ(encode({0x11, 0x22, 0x00, 0x33}), (Bytes{0x03, 0x11, 0x22, 0x02, 0x33}));
  EXPECT_EQ(encode({0x11, 0x22, 0x33, 0x44}), (Bytes{0x05, 0x11, 0x22, 0x33, 0x44}));
  EXPECT_EQ(encode({0x11, 0x00, 0x00, 0x00}), (Bytes{0x02, 0x11, 0x01, 0x01, 0x01}));
  for (const Bytes& b : {Bytes{}, Bytes{0}, Bytes{0, 0}, Bytes{0, 0x11, 0}, Bytes{0x11, 0, 0, 0}}) {
    EXPECT_EQ(decode(encode(b)), b);
  }
}

TEST(Cobs, AllZerosBecomeAllOnes) {
  for (std::size_t n = 1; n <= 600; ++n) {
    const Bytes enc = encode(Bytes(n, 0));
    ASSERT_EQ(enc, Bytes(n + 1, 0x01)) << n;
    ASSERT_EQ(decode(enc), Bytes(n, 0)) << n;
  }
}

TEST(Cobs, Run253FitsOneBlock) {
  const Bytes in = run(253);
  const Bytes enc = encode(in);
  EXPECT_EQ(enc, cat({0xFE}, in));
  EXPECT_EQ(decode(enc), in);
}

TEST(Cobs, Run254IsOneFullBlockWithNoFinalEmptyBlock) {
  const Bytes in = run(254);
  const Bytes enc = encode(in);
  EXPECT_EQ(enc, cat({0xFF}, in));
  EXPECT_EQ(cobs_max_encoded_length(254), 255u);
  EXPECT_EQ(decode(enc), in);
  // The form with the empty final block 0x01 (the paper's algorithm run literally) decodes
  // to the same packet.
  EXPECT_EQ(decode(cat(enc, {0x01})), in);
  // A zero after the full block: the zero's block 0x01, then the final empty block.
  const Bytes with_zero = cat(in, {0x00});
  EXPECT_EQ(encode(with_zero), cat(cat({0xFF}, in), {0x01, 0x01}));
  EXPECT_EQ(decode(encode(with_zero)), with_zero);
}

TEST(Cobs, Run255SpillsIntoASecondBlock) {
  const Bytes in = run(255);
  const Bytes enc = encode(in);
  Bytes expected = cat({0xFF}, Bytes(in.begin(), in.begin() + 254));
  expected.push_back(0x02);
  expected.push_back(in[254]);
  EXPECT_EQ(enc, expected);
  EXPECT_EQ(enc.size(), cobs_max_encoded_length(255));
  EXPECT_EQ(decode(enc), in);
}

TEST(Cobs, EncodedLengthIsExactAndWithinTheBound) {
  SplitMix64 rng(1);
  for (std::size_t n = 0; n < 1200; n += 1 + rng.below(7)) {
    for (int zeros : {0, 1, 50}) {  // percent of zero bytes
      Bytes b(n);
      for (auto& x : b) {
        x = rng.below(100) < static_cast<std::uint32_t>(zeros)
                ? 0
                : static_cast<std::uint8_t>(1 + rng.below(255));
      }
      const Bytes enc = encode(b);
      ASSERT_EQ(enc.size(), cobs_encoded_length(b)) << n;
      ASSERT_LE(enc.size(), cobs_max_encoded_length(n)) << n;
      if (zeros == 0) {
        ASSERT_EQ(enc.size(), cobs_max_encoded_length(n)) << n;  // no zero: the worst case
      }
    }
  }
}

TEST(Cobs, RandomRoundTripsHaveNoZeroByte) {
  SplitMix64 rng(42);
  for (int k = 0; k < 2000; ++k) {
    const std::size_t n = rng.below(700);
    Bytes b(n);
    const std::uint32_t zero_percent = rng.below(101);
    for (auto& x : b) {
      x = rng.below(100) < zero_percent ? 0 : static_cast<std::uint8_t>(rng.next());
    }
    const Bytes enc = encode(b);
    for (std::uint8_t x : enc) ASSERT_NE(x, 0);
    ASSERT_EQ(decode(enc), b) << "length " << n;
  }
}

TEST(Cobs, EncodeRefusesAnOutputOneByteShort) {
  for (const Bytes& in : {Bytes{}, Bytes{0x00}, run(10), run(254), run(255)}) {
    const std::size_t need = cobs_encoded_length(in);
    Bytes out(need - 1);
    const CobsResult r = cobs_encode(in, out);
    EXPECT_EQ(r.error, CobsError::kOutputTooSmall) << in.size();
    EXPECT_EQ(r.length, 0u);
    out.resize(need);
    EXPECT_TRUE(cobs_encode(in, out).ok()) << in.size();
  }
}

TEST(Cobs, DecodeErrors) {
  std::array<std::uint8_t, 16> out{};
  auto dec = [&](const Bytes& in) { return cobs_decode(in, out); };
  EXPECT_EQ(dec({0x00}).error, CobsError::kZeroInInput);              // a zero code
  EXPECT_EQ(dec({0x03, 0x11, 0x00}).error, CobsError::kZeroInInput);  // a zero data byte
  EXPECT_EQ(dec({0x02, 0x11, 0x00, 0x01}).error, CobsError::kZeroInInput);
  EXPECT_EQ(dec({0x05, 0x11, 0x22}).error, CobsError::kCodeOverrun);  // cut inside a block
  EXPECT_EQ(dec({0x02, 0x11, 0x04, 0x22}).error, CobsError::kCodeOverrun);
  EXPECT_EQ(dec({0xFF}).error, CobsError::kCodeOverrun);
  const CobsResult r = dec({0x05, 0x11, 0x22});
  EXPECT_EQ(r.length, 0u);
  // Output too small: 4 bytes into 3, and a block's implied zero into a full buffer.
  std::array<std::uint8_t, 3> small{};
  EXPECT_EQ(cobs_decode(Bytes{0x05, 1, 2, 3, 4}, small).error, CobsError::kOutputTooSmall);
  EXPECT_EQ(cobs_decode(Bytes{0x04, 1, 2, 3, 0x01}, small).error, CobsError::kOutputTooSmall);
  EXPECT_TRUE(cobs_decode(Bytes{0x04, 1, 2, 3}, small).ok());
  // Empty input: an empty packet, no error.
  const CobsResult empty = dec({});
  EXPECT_TRUE(empty.ok());
  EXPECT_EQ(empty.length, 0u);
}

TEST(Cobs, EncodeAndDecodeDoNotAllocate) {
  const Bytes in = cat(run(300), Bytes(20, 0));
  Bytes enc(cobs_max_encoded_length(in.size()));
  Bytes dec(in.size());
  numen::test::AllocationGuard guard;
  CobsResult e{};
  CobsResult d{};
  for (int i = 0; i < 50; ++i) {
    e = cobs_encode(in, enc);
    d = cobs_decode(std::span<const std::uint8_t>(enc.data(), e.length), dec);
  }
  EXPECT_EQ(guard.count(), 0);
  ASSERT_TRUE(d.ok());
  EXPECT_EQ(dec, in);
}

}  // namespace
