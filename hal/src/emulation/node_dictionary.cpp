/// @file node_dictionary.cpp
/// (internal) An emulated node's communication objects and their download rules.

#include "node_dictionary.hpp"

#include <array>

#include "numen/hal/canopen/sdo.hpp"

namespace numen::hal::emulation {
namespace {

constexpr std::uint32_t kInvalidBit = 0x80000000u;

std::uint32_t le(std::span<const std::uint8_t> b) noexcept {
  std::uint32_t v = 0;
  for (std::size_t i = 0; i < b.size() && i < 4; ++i) v |= static_cast<std::uint32_t>(b[i]) << (8 * i);
  return v;
}

std::uint32_t current(const ObjectDictionary& od, SdoAddress a) noexcept {
  std::uint32_t v = 0;
  (void)od.read_unsigned(a, v);
  return v;
}

bool receive_pdo(std::uint16_t index) noexcept { return index < 0x1800; }  // 0x14xx / 0x16xx

/// COB-IDs an enabled PDO may not use: NMT, SYNC / EMCY, SDO, heartbeat, LSS.
bool reserved_pdo_cob_id(std::uint32_t id) noexcept {
  return id == 0 || (id >= 0x080 && id <= 0x0FF) || (id >= 0x581 && id <= 0x5FF) ||
         (id >= 0x601 && id <= 0x67F) || (id >= 0x701 && id <= 0x77F) || id == 0x7E4 || id == 0x7E5;
}

std::uint32_t check_cob_id(const ObjectDictionary& od, SdoAddress a, std::span<const std::uint8_t> b) noexcept {
  const std::uint32_t v = le(b);
  if ((v & 0x20000000u) != 0 || (v & 0x1FFFF800u) != 0) return SdoAbort::kInvalidValue;
  if ((v & kInvalidBit) != 0) return 0;  // disabling (with any id) is always allowed
  const std::uint32_t cur = current(od, a);
  if (reserved_pdo_cob_id(v & 0x7FFu)) return SdoAbort::kInvalidValue;
  if ((cur & kInvalidBit) == 0 && (cur & 0x7FFu) != (v & 0x7FFu)) return SdoAbort::kInvalidValue;
  return 0;
}

std::uint32_t check_transmission_type(const ObjectDictionary&, SdoAddress a,
                                      std::span<const std::uint8_t> b) noexcept {
  const std::uint32_t v = le(b);
  if (receive_pdo(a.index)) return v <= 0xF0 ? 0 : SdoAbort::kInvalidValue;
  return v == 1 ? 0 : SdoAbort::kInvalidValue;
}

/// True for the objects the emulated node consumes from an RPDO (receive) or produces in a
/// TPDO (DeviceEmulator: on_frame, on_sync_managed).
bool emulator_handles(const PdoEntry& e, bool receive) noexcept {
  if (receive) {
    return same_object(e, PdoObject::kControlword) || same_object(e, PdoObject::kTargetTorque) ||
           same_object(e, PdoObject::kModesOfOperation);
  }
  return same_object(e, PdoObject::kStatusword) || same_object(e, PdoObject::kTorqueActualValue) ||
         same_object(e, PdoObject::kModesOfOperationDisplay) ||
         same_object(e, PdoObject::kPositionActualValue) || same_object(e, PdoObject::kPositionValue);
}

/// The entry a mapping value names, if this dictionary can map it in this direction.
bool mappable(const ObjectDictionary& od, std::uint32_t value, bool receive, PdoEntry& out) noexcept {
  PdoEntry known;
  if (!find_known_pdo_object(value, known) || !emulator_handles(known, receive)) return false;
  const OdEntry* e = od.find({known.index, known.subindex});
  if (e == nullptr || !e->pdo_mappable || e->value.size() * 8 != known.bit_length) return false;
  if (receive ? e->access == OdAccess::kReadOnly : e->access == OdAccess::kWriteOnly) return false;
  out = known;
  return true;
}

bool pdo_enabled(const ObjectDictionary& od, std::uint16_t map_index) noexcept {
  return (current(od, {static_cast<std::uint16_t>(map_index - 0x200), 1}) & kInvalidBit) == 0;
}

/// A valid mapping to try entries on (copied, so no allocation at run time).
const PdoMapping& scratch() noexcept {
  static const PdoMapping m = encoder_tpdo_mapping();
  return m;
}

std::uint32_t check_mapping_count(const ObjectDictionary& od, SdoAddress a,
                                  std::span<const std::uint8_t> b) noexcept {
  if (pdo_enabled(od, a.index)) return SdoAbort::kUnsupportedAccess;
  const std::uint32_t n = le(b);
  if (n > kMaxPdoEntries) return SdoAbort::kValueTooHigh;
  if (n == 0) return 0;
  std::array<PdoEntry, kMaxPdoEntries> entries{};
  for (std::uint32_t i = 0; i < n; ++i) {
    const std::uint32_t v = current(od, {a.index, static_cast<std::uint8_t>(i + 1)});
    if (!mappable(od, v, receive_pdo(a.index), entries[i])) return SdoAbort::kNotMappable;
  }
  PdoMapping m = scratch();
  const MappingProblem p = m.try_assign(std::span<const PdoEntry>(entries.data(), n));
  if (p.kind == MappingProblem::kTooLong) return SdoAbort::kPdoLength;
  return p.kind == MappingProblem::kNone ? 0 : SdoAbort::kNotMappable;
}

std::uint32_t check_mapping_entry(const ObjectDictionary& od, SdoAddress a,
                                  std::span<const std::uint8_t> b) noexcept {
  if (pdo_enabled(od, a.index) || current(od, {a.index, 0}) != 0) return SdoAbort::kUnsupportedAccess;
  const std::uint32_t v = le(b);
  PdoEntry e;
  if (v != 0 && !mappable(od, v, receive_pdo(a.index), e)) return SdoAbort::kNotMappable;
  return 0;
}

std::uint32_t check_sync(const ObjectDictionary&, SdoAddress, std::span<const std::uint8_t> b) noexcept {
  return le(b) == 0x80u ? 0 : SdoAbort::kInvalidValue;
}

std::uint32_t check_consumer(const ObjectDictionary&, SdoAddress, std::span<const std::uint8_t> b) noexcept {
  const std::uint32_t v = le(b);
  if (v == 0) return 0;
  const std::uint32_t node = (v >> 16) & 0xFFu;
  if ((v >> 24) != 0 || node < 1 || node > 127 || (v & 0xFFFFu) == 0) return SdoAbort::kInvalidValue;
  return 0;
}

std::uint32_t check_max_torque(const ObjectDictionary&, SdoAddress, std::span<const std::uint8_t> b) noexcept {
  const std::uint32_t v = le(b);
  if (v < 1) return SdoAbort::kValueTooLow;
  return v > 32767 ? SdoAbort::kValueTooHigh : 0;
}

}  // namespace

void add_pdo(ObjectDictionary& od, std::uint16_t comm, std::uint32_t cob_id, const PdoMapping& mapping) {
  (void)scratch();  // constructed at setup, not on the first download
  od.add_unsigned({comm, 0}, OdAccess::kReadOnly, 2, 1);
  od.add_unsigned({comm, 1}, OdAccess::kReadWrite, cob_id, 4);
  od.set_rules({comm, 1}, &check_cob_id);
  od.add_unsigned({comm, 2}, OdAccess::kReadWrite, 1, 1);
  od.set_rules({comm, 2}, &check_transmission_type);
  const auto map = static_cast<std::uint16_t>(comm + 0x200);
  od.add_unsigned({map, 0}, OdAccess::kReadWrite, static_cast<std::uint32_t>(mapping.size()), 1);
  od.set_rules({map, 0}, &check_mapping_count);
  const auto values = mapping.mapping_parameter();
  for (std::size_t i = 0; i < kMaxPdoEntries; ++i) {
    const SdoAddress a{map, static_cast<std::uint8_t>(i + 1)};
    od.add_unsigned(a, OdAccess::kReadWrite, values[i], 4);
    od.set_rules(a, &check_mapping_entry);
  }
}

void add_communication(ObjectDictionary& od, std::uint16_t heartbeat_ms, std::uint8_t controller_node,
                       std::uint16_t controller_timeout_ms) {
  od.add_unsigned({0x1005, 0}, OdAccess::kReadWrite, 0x80, 4);
  od.set_rules({0x1005, 0}, &check_sync);
  if (controller_node != 0) {
    od.add_unsigned({0x1016, 0}, OdAccess::kReadOnly, 1, 1);
    od.add_unsigned({0x1016, 1}, OdAccess::kReadWrite,
                    static_cast<std::uint32_t>(controller_node) << 16 | controller_timeout_ms, 4);
    od.set_rules({0x1016, 1}, &check_consumer);
  }
  od.add_unsigned({0x1017, 0}, OdAccess::kReadWrite, heartbeat_ms, 2);
}

void add_drive(ObjectDictionary& od, std::size_t m, std::int8_t mode, std::int16_t max_torque_per_mille) {
  auto at = [m](std::uint16_t index) { return SdoAddress{drive_object(index, m), 0}; };
  od.add_unsigned(at(0x6040), OdAccess::kReadWrite, 0, 2);
  od.set_rules(at(0x6040), nullptr, true);
  od.add_unsigned(at(0x6041), OdAccess::kReadOnly, 0, 2);
  od.set_rules(at(0x6041), nullptr, true);
  od.add_unsigned(at(0x6060), OdAccess::kReadWrite, static_cast<std::uint8_t>(mode), 1);
  od.set_rules(at(0x6060), nullptr, true);
  od.add_unsigned(at(0x6061), OdAccess::kReadOnly, static_cast<std::uint8_t>(mode), 1);
  od.set_rules(at(0x6061), nullptr, true);
  od.add_unsigned(at(0x6071), OdAccess::kReadWrite, 0, 2);
  od.set_rules(at(0x6071), nullptr, true);
  od.add_unsigned(at(0x6072), OdAccess::kReadWrite, static_cast<std::uint16_t>(max_torque_per_mille), 2);
  od.set_rules(at(0x6072), &check_max_torque);
  od.add_unsigned(at(0x6077), OdAccess::kReadOnly, 0, 2);
  od.set_rules(at(0x6077), nullptr, true);
}

void add_position(ObjectDictionary& od) {
  od.add_unsigned({0x6004, 0}, OdAccess::kReadOnly, 0, 4);
  od.set_rules({0x6004, 0}, nullptr, true);
  od.add_unsigned({0x6064, 0}, OdAccess::kReadOnly, 0, 4);
  od.set_rules({0x6064, 0}, nullptr, true);
}

void read_pdo(const ObjectDictionary& od, std::uint16_t comm, std::uint32_t& cob_id, bool& enabled,
              PdoMapping& mapping) noexcept {
  const std::uint32_t cob = current(od, {comm, 1});
  cob_id = cob & 0x7FFu;
  const auto map = static_cast<std::uint16_t>(comm + 0x200);
  const std::uint32_t n = current(od, {map, 0});
  enabled = (cob & kInvalidBit) == 0 && n > 0 && n <= kMaxPdoEntries;
  if (!enabled) return;
  // The same mapping as now (the configuration's, or the one last applied): kept as it is
  // (its signedness included); else the entries as the rules let them in.
  const auto now = mapping.mapping_parameter();
  bool same = mapping.size() == n;
  for (std::uint32_t i = 0; i < n && same; ++i)
    same = now[i] == current(od, {map, static_cast<std::uint8_t>(i + 1)});
  if (same) return;
  std::array<PdoEntry, kMaxPdoEntries> entries{};
  for (std::uint32_t i = 0; i < n; ++i) {
    if (!find_known_pdo_object(current(od, {map, static_cast<std::uint8_t>(i + 1)}), entries[i])) {
      enabled = false;  // not reached: the rules let only known objects in
      return;
    }
  }
  if (mapping.try_assign(std::span<const PdoEntry>(entries.data(), n)).kind != MappingProblem::kNone)
    enabled = false;
}

}  // namespace numen::hal::emulation
