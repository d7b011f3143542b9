#pragma once
/// @file crc16.hpp
/// CRC-16/IBM-3740, the checksum of the serial-line frames (serial_frame.hpp). Also known as
/// CRC-16/CCITT-FALSE and CRC-16/AUTOSAR. Parameters in the Rocksoft model (R. N. Williams,
/// "A painless guide to CRC error detection algorithms", 1993, §15), as listed in
/// G. Cook's "Catalogue of parametrised CRC algorithms":
///
///   width=16 poly=0x1021 init=0xFFFF refin=false refout=false xorout=0x0000
///   check=0x29B1 (the CRC of the 9 ASCII bytes "123456789") residue=0x0000
///
/// Bits are processed most significant first (no reflection). Because xorout is 0, the
/// running register is the CRC itself: crc16_update(crc16(a), b) == crc16(a followed by b).
/// Appending the CRC most significant byte first makes the CRC of the whole message 0
/// (the residue). Table driven (one 256-entry constexpr table, 512 bytes); never allocates.

#include <cstdint>
#include <span>

namespace numen::hal {

/// Initial register value of CRC-16/IBM-3740 (the CRC of zero bytes).
inline constexpr std::uint16_t kCrc16Init = 0xFFFF;

/// CRC-16/IBM-3740 check value: the CRC of the ASCII bytes "123456789".
inline constexpr std::uint16_t kCrc16Check = 0x29B1;

/// Continues a CRC-16/IBM-3740 over `bytes`, starting from register `crc` (kCrc16Init for a
/// new message, or the result of an earlier call to continue it). Returns the new register,
/// which is the CRC of everything fed so far.
std::uint16_t crc16_update(std::uint16_t crc, std::span<const std::uint8_t> bytes) noexcept;

/// CRC-16/IBM-3740 of `bytes` (crc16_update(kCrc16Init, bytes)).
std::uint16_t crc16(std::span<const std::uint8_t> bytes) noexcept;

}  // namespace numen::hal
