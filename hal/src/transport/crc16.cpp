/// @file crc16.cpp
/// CRC-16/IBM-3740 (poly 0x1021, init 0xFFFF, not reflected, xorout 0), one table lookup per
/// byte, most significant bit first.

#include "numen/hal/transport/crc16.hpp"

#include <array>
#include <cstddef>

namespace numen::hal {
namespace {

constexpr std::uint16_t kPoly = 0x1021;

// Register after shifting the byte value `index` (placed in the top 8 bits) through eight
// rounds of polynomial division: the table entry for that value.
constexpr std::uint16_t table_entry(std::uint16_t index) noexcept {
  std::uint16_t r = static_cast<std::uint16_t>(index << 8);
  for (int bit = 0; bit < 8; ++bit) {
    r = (r & 0x8000u) != 0 ? static_cast<std::uint16_t>((r << 1) ^ kPoly)
                           : static_cast<std::uint16_t>(r << 1);
  }
  return r;
}

constexpr std::array<std::uint16_t, 256> make_table() noexcept {
  std::array<std::uint16_t, 256> t{};
  for (std::uint16_t i = 0; i < 256; ++i) t[i] = table_entry(i);
  return t;
}

constexpr std::array<std::uint16_t, 256> kTable = make_table();

constexpr std::uint16_t update(std::uint16_t crc, const std::uint8_t* p, std::size_t n) noexcept {
  for (std::size_t i = 0; i < n; ++i) {
    crc = static_cast<std::uint16_t>((crc << 8) ^ kTable[((crc >> 8) ^ p[i]) & 0xFFu]);
  }
  return crc;
}

// The catalogue check value, verified at compile time.
constexpr std::uint8_t kCheckInput[] = {'1', '2', '3', '4', '5', '6', '7', '8', '9'};
static_assert(update(kCrc16Init, kCheckInput, sizeof(kCheckInput)) == kCrc16Check);
static_assert(kTable[1] == kPoly);

}  // namespace

std::uint16_t crc16_update(std::uint16_t crc, std::span<const std::uint8_t> bytes) noexcept {
  return update(crc, bytes.data(), bytes.size());
}

std::uint16_t crc16(std::span<const std::uint8_t> bytes) noexcept {
  return update(kCrc16Init, bytes.data(), bytes.size());
}

}  // namespace numen::hal
