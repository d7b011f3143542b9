#pragma once
/// @file pdo_mapping.hpp
/// Static PDO mapping (CiA 301 §7.4.8, PDO mapping parameter objects 0x1600–0x17FF for RPDOs
/// and 0x1A00–0x1BFF for TPDOs): a PDO's payload is the concatenation, in mapping order, of the
/// mapped objects' values, each little endian, starting at bit 0 of byte 0. numen maps whole
/// bytes only (8, 16 or 32 bits per object) and classic CAN frames (at most 64 bits in all).
///
/// A mapping entry as stored in the mapping parameter (sub 1…8) is the UNSIGNED32
/// `index << 16 | subindex << 8 | bit length`, e.g. 0x60710010 = target torque, 16 bits.
/// The entry's signedness is not in that word (it is the object's data type in the object
/// dictionary), so PdoEntry carries it.
///
/// Construction (setup) validates and throws std::invalid_argument; pack()/unpack() are
/// noexcept, allocation free and return a status (bad input is rejected, never truncated).

#include <array>
#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <span>
#include <string_view>

#include "numen/hal/transport/can_frame.hpp"

namespace numen::hal {

/// One mapped object.
struct PdoEntry {
  std::uint16_t index = 0;      ///< Object index, 0x0001–0xFFFF.
  std::uint8_t subindex = 0;    ///< Object subindex.
  std::uint8_t bit_length = 0;  ///< 8, 16 or 32.
  bool is_signed = false;       ///< INTEGERn (sign extended on unpack) rather than UNSIGNEDn.
};

/// True if two entries name the same object (index and subindex).
constexpr bool same_object(const PdoEntry& a, const PdoEntry& b) noexcept {
  return a.index == b.index && a.subindex == b.subindex;
}

/// The UNSIGNED32 a mapping parameter sub-entry holds for `entry` (CiA 301 §7.4.8):
/// index << 16 | subindex << 8 | bit length.
constexpr std::uint32_t mapping_entry_value(const PdoEntry& entry) noexcept {
  return (static_cast<std::uint32_t>(entry.index) << 16) |
         (static_cast<std::uint32_t>(entry.subindex) << 8) | entry.bit_length;
}

/// The entry a mapping parameter sub-entry `value` describes; the signedness comes from the
/// object's data type, given as `is_signed`. Not validated (PdoMapping's constructor does).
constexpr PdoEntry mapping_entry_from_value(std::uint32_t value, bool is_signed) noexcept {
  return PdoEntry{static_cast<std::uint16_t>(value >> 16), static_cast<std::uint8_t>(value >> 8),
                  static_cast<std::uint8_t>(value), is_signed};
}

/// Standard objects numen maps (CiA 402-2 drive profile, CiA 406 encoder profile).
struct PdoObject {
  /// 0x6040:00 controlword, UNSIGNED16 (drive RPDO).
  static constexpr PdoEntry kControlword{0x6040, 0x00, 16, false};
  /// 0x6041:00 statusword, UNSIGNED16 (drive TPDO).
  static constexpr PdoEntry kStatusword{0x6041, 0x00, 16, false};
  /// 0x6071:00 target torque, INTEGER16, per mille of the rated torque 0x6076 (drive RPDO).
  static constexpr PdoEntry kTargetTorque{0x6071, 0x00, 16, true};
  /// 0x6077:00 torque actual value, INTEGER16, per mille of the rated torque (drive TPDO).
  static constexpr PdoEntry kTorqueActualValue{0x6077, 0x00, 16, true};
  /// 0x6064:00 position actual value, INTEGER32, position units (drive TPDO).
  static constexpr PdoEntry kPositionActualValue{0x6064, 0x00, 32, true};
  /// 0x6004:00 position value of a CiA 406 encoder, read as INTEGER32 counts. CiA 406 types it
  /// UNSIGNED32; numen reads it signed (as decode_position_pdo does) so a preset near 0 gives
  /// a working range of ±2³¹ counts around it. Same 32 bits on the wire.
  static constexpr PdoEntry kPositionValue{0x6004, 0x00, 32, true};
  /// 0x6004:00 position value as CiA 406 types it, UNSIGNED32 counts.
  static constexpr PdoEntry kPositionValueUnsigned{0x6004, 0x00, 32, false};
  /// 0x607A:00 target position, INTEGER32, position units (CiA 402-2; the cyclic set-point in
  /// cyclic synchronous position mode, modes of operation 8).
  static constexpr PdoEntry kTargetPosition{0x607A, 0x00, 32, true};
  /// 0x6060:00 modes of operation, INTEGER8 (10 = cyclic synchronous torque).
  static constexpr PdoEntry kModesOfOperation{0x6060, 0x00, 8, true};
  /// 0x6061:00 modes of operation display, INTEGER8.
  static constexpr PdoEntry kModesOfOperationDisplay{0x6061, 0x00, 8, true};
};

/// The standard object a mapping parameter sub-entry `value` (index << 16 | subindex << 8 |
/// bit length, CiA 301 §7.4.8) names, with its signedness, if it is one of the PdoObject
/// entries numen knows (0x6004, 0x6040, 0x6041, 0x6060, 0x6061, 0x6064, 0x6071, 0x6077; 0x6004
/// is returned signed, as numen reads it). Returns false and leaves `out` unchanged for any
/// other object or a bit length that does not match the object's data type. Used by the scene
/// loader to turn `[device.canopen]` mapping lists into PdoEntry values.
bool find_known_pdo_object(std::uint32_t value, PdoEntry& out) noexcept;

/// Index of the first entry of `mapping` naming the same object as `object` (same_object()),
/// or -1 if it is not mapped.
int find_mapped(std::span<const PdoEntry> mapping, const PdoEntry& object) noexcept;

/// Most objects in one PDO (CiA 301: mapping parameter sub 0 = 0…64; numen: whole bytes of a
/// classic frame, so at most 8).
inline constexpr std::size_t kMaxPdoEntries = 8;
/// Most bits in one classic CAN PDO.
inline constexpr unsigned kMaxPdoBits = 64;

/// One value per mapped object, in mapping order (only the first size() are used).
using PdoValues = std::array<std::int64_t, kMaxPdoEntries>;

/// Outcome of PdoMapping::pack / unpack.
enum class PdoStatus : std::uint8_t {
  kOk,               ///< Packed / unpacked.
  kWrongLength,      ///< unpack: the frame's length is not the mapping's length (malformed PDO).
  kNotDataFrame,     ///< unpack: not a classic 11-bit data frame (remote, CAN FD, error
                     ///< report, 29-bit; is_classic_data_frame()).
  kWrongValueCount,  ///< The value span's size is not the number of mapped objects.
  kValueOutOfRange,  ///< pack: a value does not fit its object's type (e.g. 70000 as UNSIGNED16).
};

/// Short English name of a PdoStatus (static string).
const char* to_string(PdoStatus status) noexcept;

/// Why a list of entries is not a valid mapping (PdoMapping::try_assign()).
struct MappingProblem {
  enum Kind : std::uint8_t {
    kNone,       ///< Valid.
    kEmpty,      ///< No entries.
    kTooMany,    ///< More than kMaxPdoEntries.
    kZeroIndex,  ///< Entry `entry` has index 0.
    kBitLength,  ///< Entry `entry` is not 8, 16 or 32 bits.
    kDuplicate,  ///< Entry `entry` maps the object of entry `other` again.
    kTooLong,    ///< Entry `entry` brings the mapping to `bits` > 64.
  };
  Kind kind = kNone;
  std::size_t entry = 0;  ///< 0-based position of the offending entry.
  std::size_t other = 0;
  unsigned bits = 0;
};

/// A static PDO mapping: up to 8 objects of 8/16/32 bits, at most 64 bits in all. Plain value
/// type, no heap.
class PdoMapping {
 public:
  /// Validates `entries` and fixes the byte offsets. Throws std::invalid_argument naming
  /// `name` and the entry (position, index:subindex) when: there are no entries or more than
  /// kMaxPdoEntries; an index is 0; a bit length is not 8, 16 or 32; the total exceeds 64 bits;
  /// an object is mapped twice.
  PdoMapping(std::span<const PdoEntry> entries, std::string_view name = "PDO");
  /// As above, from a braced list.
  PdoMapping(std::initializer_list<PdoEntry> entries, std::string_view name = "PDO");

  /// Replaces this mapping by `entries` if they are valid (the constructor's rules), else
  /// leaves it unchanged and says why. noexcept, no allocation: a device applying a mapping
  /// written over SDO at run time.
  MappingProblem try_assign(std::span<const PdoEntry> entries) noexcept;

  /// Number of mapped objects.
  std::size_t size() const noexcept { return size_; }
  /// The mapped objects, in order.
  std::span<const PdoEntry> entries() const noexcept { return {entries_.data(), size_}; }
  /// Byte offset of entry `i` in the payload (i < size()).
  std::uint8_t offset(std::size_t i) const noexcept { return offsets_[i]; }
  /// Payload length, bytes (sum of the bit lengths / 8).
  std::uint8_t length() const noexcept { return length_; }
  /// The mapping parameter sub-entries (CiA 301 §7.4.8): sub 0 = size(), sub i = the UNSIGNED32
  /// of entry i − 1 (mapping_entry_value). Entries past size() are 0.
  std::array<std::uint32_t, kMaxPdoEntries> mapping_parameter() const noexcept;

  /// Writes `values` (one per entry, `values.size() == size()`) into `frame`: len = length(),
  /// data[0, len) the little-endian fields, data[len, 8) zeroed. id, flags and timestamp are
  /// left to the caller. kWrongValueCount / kValueOutOfRange leave `frame` unchanged.
  PdoStatus pack(std::span<const std::int64_t> values, CanFrame& frame) const noexcept;

  /// Reads the values of `frame` into `values` (`values.size() == size()`), sign extending
  /// signed entries and zero extending unsigned ones. Checks, in order: value count, an 11-bit
  /// classic 11-bit data frame (not remote, CAN FD, 29-bit or an error report: kNotDataFrame), length exactly length()
  /// (kWrongLength). The COB-ID is the caller's to check. `values` is unchanged unless kOk.
  PdoStatus unpack(const CanFrame& frame, std::span<std::int64_t> values) const noexcept;

 private:
  PdoMapping() noexcept = default;
  MappingProblem assign(std::span<const PdoEntry> entries) noexcept;

  std::array<PdoEntry, kMaxPdoEntries> entries_{};
  std::array<std::uint8_t, kMaxPdoEntries> offsets_{};
  std::size_t size_ = 0;
  std::uint8_t length_ = 0;
};

/// The drive RPDO numen sends to a CiA 402 drive in cst mode: controlword 0x6040 (bytes 0–1),
/// target torque 0x6071 (bytes 2–3); 4 bytes. Mapping 0x1600: 0x60400010, 0x60710010.
PdoMapping drive_rpdo_mapping();
/// The drive RPDO numen sends to a CiA 402 drive in cyclic synchronous position mode (csp,
/// modes of operation 8; CiA 402-2 §"Cyclic synchronous position mode"): controlword 0x6040
/// (bytes 0–1), target position 0x607A (bytes 2–5, INTEGER32 counts); 6 bytes. Mapping 0x1600:
/// 0x60400010, 0x607A0020. Used for admittance devices (docs/protocol.md).
PdoMapping csp_drive_rpdo_mapping();
/// The drive TPDO a CiA 402 drive sends on SYNC: statusword 0x6041 (bytes 0–1), torque actual
/// value 0x6077 (bytes 2–3); 4 bytes. Mapping 0x1A00: 0x60410010, 0x60770010.
PdoMapping drive_tpdo_mapping();
/// The encoder TPDO a CiA 406 encoder sends on SYNC: position value 0x6004 (bytes 0–3, read as
/// INTEGER32); 4 bytes. Mapping 0x1A00: 0x60040020.
PdoMapping encoder_tpdo_mapping();

}  // namespace numen::hal
