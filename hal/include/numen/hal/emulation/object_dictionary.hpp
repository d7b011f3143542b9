#pragma once
/// @file object_dictionary.hpp
/// A device's CANopen object dictionary as the emulated devices serve it over SDO
/// (sdo_server.hpp; CiA 301 §7.4): entries addressed by index and sub-index, each with its
/// access rights and its value as the bytes an SDO transfers (little endian, as CiA 301 puts
/// numbers on the bus). Fixed-length entries (the numeric types) keep their length; a
/// variable-length entry (VISIBLE_STRING, OCTET_STRING, DOMAIN) may be written with any
/// length up to the capacity it was added with. An entry may carry a check the device runs
/// before a download takes effect (its value rules, e.g. the CiA 301 PDO sequence), answering
/// with an abort code. Setup (add(), save_defaults()) allocates; lookups, writes and
/// restore_defaults() do not.

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "numen/hal/canopen/sdo.hpp"

namespace numen::hal {

/// Access rights of an entry (CiA 301 §7.4.2: ro, wo, rw; const is read-only here).
enum class OdAccess : std::uint8_t { kReadOnly, kWriteOnly, kReadWrite };

class ObjectDictionary;

/// A device's check of a download to `address` of `od` with `bytes` (length already checked):
/// 0 to accept, or the SDO abort code (SdoAbort) to refuse it.
using OdWriteCheck = std::uint32_t (*)(const ObjectDictionary& od, SdoAddress address,
                                       std::span<const std::uint8_t> bytes) noexcept;

/// One entry.
struct OdEntry {
  SdoAddress address;
  OdAccess access = OdAccess::kReadWrite;
  bool variable_length = false;        ///< A download may change the length (≤ capacity).
  std::vector<std::uint8_t> value;     ///< Current value, bytes as on the bus.
  std::size_t capacity = 0;            ///< Largest length a download may give (variable only).
  bool pdo_mappable = false;           ///< May be mapped to a PDO (CiA 301 PDOMapping).
  OdWriteCheck check = nullptr;        ///< Run by write() before a download takes effect.
};

/// The entries of one device. Indices are unique per (index, sub-index).
class ObjectDictionary {
 public:
  /// Adds an entry of fixed length `value.size()` (≥ 1). Throws std::invalid_argument for a
  /// duplicate address or an empty value.
  void add(SdoAddress address, OdAccess access, std::span<const std::uint8_t> value);
  /// Adds an unsigned number of `bytes` (1, 2 or 4) little endian.
  void add_unsigned(SdoAddress address, OdAccess access, std::uint32_t value, std::size_t bytes);
  /// Sets the check of the entry at `address` (which must exist: std::invalid_argument) and
  /// whether it is PDO-mappable.
  void set_rules(SdoAddress address, OdWriteCheck check, bool pdo_mappable = false);
  /// Records every entry's current value as its default (restore_defaults()).
  void save_defaults();
  /// Puts back the defaults of the entries with index in [first, last] (CiA 301: reset
  /// communication restores 0x1000–0x1FFF, reset node every entry). noexcept, no allocation.
  void restore_defaults(std::uint16_t first, std::uint16_t last) noexcept;
  /// Sets an entry's value from the device's side (a live process value such as 0x6041),
  /// as `bytes` little-endian bytes of `value`, ignoring access rights; false if there is no
  /// such entry or its length differs. noexcept, no allocation.
  bool set_unsigned(SdoAddress address, std::uint64_t value) noexcept;
  /// Adds a variable-length entry (VISIBLE_STRING: `text` without a terminating NUL) that a
  /// download may rewrite up to `capacity` bytes (≥ text.size(), ≥ 1).
  void add_string(SdoAddress address, OdAccess access, const std::string& text,
                  std::size_t capacity);

  /// The entry at `address`; nullptr if none. noexcept, no allocation.
  const OdEntry* find(SdoAddress address) const noexcept;
  OdEntry* find(SdoAddress address) noexcept;
  /// True if some entry has this index (whatever its sub-index): tells kNoSubIndex from
  /// kNoObject.
  bool has_index(std::uint16_t index) const noexcept;
  /// Writes `bytes` into the entry at `address` as a download would, checking existence,
  /// access, length and the entry's check; returns 0 or the SDO abort code (SdoAbort).
  /// noexcept, no allocation.
  std::uint32_t write(SdoAddress address, std::span<const std::uint8_t> bytes) noexcept;
  /// Reads an entry's value as an unsigned little-endian number (at most 4 bytes used).
  /// False if there is no such entry.
  bool read_unsigned(SdoAddress address, std::uint32_t& out) const noexcept;
  /// Largest value length of any entry (the server's staging buffer).
  std::size_t max_length() const noexcept;
  /// Every entry, in the order added (tests and the SDO server's fuzz harness pick
  /// addresses from it). noexcept, no allocation.
  std::span<const OdEntry> entries() const noexcept { return entries_; }

 private:
  std::vector<OdEntry> entries_;
  std::vector<std::vector<std::uint8_t>> defaults_;  // save_defaults(), per entry
};

}  // namespace numen::hal
