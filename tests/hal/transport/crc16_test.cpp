// Tests of numen/hal/transport/crc16.hpp: catalogue check value, incremental == one-shot, an
// independent reference (Boost.CRC), residue, and the error-detection guarantees of 0x1021.
#include "numen/hal/transport/crc16.hpp"

#include <gtest/gtest.h>

#include <array>
#include <boost/crc.hpp>
#include <cstdint>
#include <vector>

#include "alloc_counter.hpp"
#include "numen/hal/transport/splitmix64.hpp"

namespace {

using numen::hal::crc16;
using numen::hal::crc16_update;
using numen::hal::kCrc16Check;
using numen::hal::kCrc16Init;
using numen::hal::SplitMix64;

using Bytes = std::vector<std::uint8_t>;

// Boost.CRC with the catalogue parameters of CRC-16/IBM-3740 (width 16, poly 0x1021,
// init 0xFFFF, xorout 0, refin/refout false): an implementation independent of ours.
std::uint16_t boost_crc(const Bytes& b) {
  boost::crc_optimal<16, 0x1021, 0xFFFF, 0, false, false> c;
  c.process_bytes(b.data(), b.size());
  return static_cast<std::uint16_t>(c.checksum());
}

Bytes random_bytes(SplitMix64& rng, std::size_t n) {
  Bytes b(n);
  for (auto& x : b) x = static_cast<std::uint8_t>(rng.next());
  return b;
}

TEST(Crc16, CatalogueCheckValue) {
  const Bytes ascii{'1', '2', '3', '4', '5', '6', '7', '8', '9'};
  EXPECT_EQ(crc16(ascii), 0x29B1);
  EXPECT_EQ(kCrc16Check, 0x29B1);
  EXPECT_EQ(crc16({}), kCrc16Init);  // nothing processed: the init value (xorout 0)
}

TEST(Crc16, MatchesBoostCrcWithTheSameParameters) {
  SplitMix64 rng(7);
  for (std::size_t n = 0; n < 300; ++n) {
    const Bytes b = random_bytes(rng, n);
    ASSERT_EQ(crc16(b), boost_crc(b)) << "length " << n;
  }
}

TEST(Crc16, IncrementalUpdateEqualsOneShot) {
  SplitMix64 rng(11);
  const Bytes b = random_bytes(rng, 200);
  const std::span<const std::uint8_t> all(b);
  const std::uint16_t one_shot = crc16(all);
  for (std::size_t cut = 0; cut <= b.size(); ++cut) {
    const std::uint16_t head = crc16(all.first(cut));
    ASSERT_EQ(crc16_update(head, all.subspan(cut)), one_shot) << "cut at " << cut;
  }
  // Byte by byte.
  std::uint16_t c = kCrc16Init;
  for (std::size_t i = 0; i < b.size(); ++i) c = crc16_update(c, all.subspan(i, 1));
  EXPECT_EQ(c, one_shot);
}

TEST(Crc16, CrcAppendedMostSignificantByteFirstGivesResidueZero) {
  SplitMix64 rng(3);
  for (std::size_t n : {0u, 1u, 6u, 70u}) {
    Bytes b = random_bytes(rng, n);
    const std::uint16_t c = crc16(b);
    b.push_back(static_cast<std::uint8_t>(c >> 8));
    b.push_back(static_cast<std::uint8_t>(c));
    EXPECT_EQ(crc16(b), 0) << "length " << n;
  }
}

TEST(Crc16, DetectsEverySingleAndDoubleBitErrorInALargestSerialPayload) {
  // 0x1021 = (x + 1) * a primitive polynomial of degree 15: every 1- and 2-bit error within
  // 32767 bits is detected. Checked exhaustively on 72 bytes (the largest serial payload).
  SplitMix64 rng(5);
  Bytes b = random_bytes(rng, 72);
  const std::uint16_t good = crc16(b);
  const std::size_t bits = b.size() * 8;
  for (std::size_t i = 0; i < bits; ++i) {
    b[i / 8] ^= static_cast<std::uint8_t>(1u << (i % 8));
    ASSERT_NE(crc16(b), good) << "bit " << i;
    for (std::size_t j = i + 1; j < bits; ++j) {
      b[j / 8] ^= static_cast<std::uint8_t>(1u << (j % 8));
      ASSERT_NE(crc16(b), good) << "bits " << i << ", " << j;
      b[j / 8] ^= static_cast<std::uint8_t>(1u << (j % 8));
    }
    b[i / 8] ^= static_cast<std::uint8_t>(1u << (i % 8));
  }
}

TEST(Crc16, DoesNotAllocate) {
  std::array<std::uint8_t, 64> b{};
  numen::test::AllocationGuard guard;
  std::uint16_t c = kCrc16Init;
  for (int i = 0; i < 100; ++i) c = crc16_update(c, b);
  EXPECT_EQ(guard.count(), 0);
  EXPECT_EQ(c, crc16(Bytes(100 * b.size(), 0)));
}

}  // namespace
