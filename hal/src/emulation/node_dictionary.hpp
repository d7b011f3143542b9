#pragma once
/// @file node_dictionary.hpp
/// (internal) The CiA 301 communication objects of an emulated node's object dictionary and
/// the rules the node applies to downloads into them (docs/sdo.md, docs/canopen.md "The emulated
/// nodes"): PDO communication and mapping parameters with the CiA 301 sequence, COB-ID SYNC
/// 0x1005, consumer heartbeat 0x1016, producer heartbeat 0x1017; and the CiA 402 drive
/// objects a DCF configures (0x6060 modes of operation, 0x6072 max torque). A refused download
/// is answered with the abort code CiA 301 names for it.

#include <cstdint>

#include "numen/hal/canopen/pdo_mapping.hpp"
#include "numen/hal/emulation/object_dictionary.hpp"

namespace numen::hal::emulation {

/// CiA 402 objects of the m-th drive of a node are at index + m · 0x800 (multi-axis drives).
constexpr std::uint16_t drive_object(std::uint16_t index, std::size_t m) noexcept {
  return static_cast<std::uint16_t>(index + 0x800 * m);
}

/// Adds PDO `comm` (0x1400 + n: an RPDO; 0x1800 + n: a TPDO): communication parameter
/// (sub 0 = 2, sub 1 COB-ID `cob_id`, sub 2 transmission type 1) and mapping parameter at
/// comm + 0x200 (sub 0 = mapping.size(), sub 1–8 the entries, 0 past the count), with their
/// rules:
///  - COB-ID: 29-bit ids and bits 11–28 refused; an enabled id in NMT, SYNC/EMCY, SDO,
///    heartbeat or LSS range refused; changing the id of an enabled PDO refused — all
///    0x06090030 (invalid value);
///  - transmission type: a TPDO sends on every SYNC only (1); an RPDO takes 0–240
///    (synchronous); other values 0x06090030;
///  - mapping: written only while the PDO is disabled (COB-ID bit 31) and, for sub 1–8, the
///    count is 0, else 0x06010000 (unsupported access); an entry must name an object of the
///    dictionary that is PDO-mappable with its exact length and that the emulator consumes
///    (RPDO: 0x6040, 0x6071, 0x6060) or produces (TPDO: 0x6041, 0x6077, 0x6061, 0x6064,
///    0x6004), else 0x06040041; the count must
///    be ≤ 8 (0x06090031) and its entries fit 64 bits (0x06040042).
void add_pdo(ObjectDictionary& od, std::uint16_t comm, std::uint32_t cob_id, const PdoMapping& mapping);

/// Adds 0x1005 COB-ID SYNC (0x80; only 0x80 accepted: the node consumes SYNC and does not
/// produce it) and 0x1017 producer heartbeat time `heartbeat_ms` (any value; 0 stops it).
/// With `controller_node` ≠ 0 also 0x1016 consumer heartbeat time (sub 1 = node << 16 | ms;
/// 0 disables it; reserved bits 24–31 refused).
void add_communication(ObjectDictionary& od, std::uint16_t heartbeat_ms, std::uint8_t controller_node,
                       std::uint16_t controller_timeout_ms);

/// Adds the m-th drive's 0x6040 controlword, 0x6041 statusword, 0x6060 modes of operation
/// (rw), 0x6061 display, 0x6071 target torque, 0x6072 max torque (rw, 1–32767: 0x06090031 /
/// 0x06090032 outside), 0x6077 torque actual value.
void add_drive(ObjectDictionary& od, std::size_t m, std::int8_t mode, std::int16_t max_torque_per_mille);

/// Adds 0x6004 position value and 0x6064 position actual value (PDO-mappable process values).
void add_position(ObjectDictionary& od);

/// The PDO `comm` as the dictionary holds it: its 11-bit COB-ID, whether it is enabled (COB-ID
/// bit 31 clear and at least one object mapped) and, if so, its mapping into `mapping` (left
/// as it is when the dictionary holds the same entries). noexcept, no allocation.
void read_pdo(const ObjectDictionary& od, std::uint16_t comm, std::uint32_t& cob_id, bool& enabled,
              PdoMapping& mapping) noexcept;

}  // namespace numen::hal::emulation
