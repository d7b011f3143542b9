/// @file pdo_mapping.cpp
/// Static PDO mapping: validation, packing and unpacking (CiA 301 §7.4.8).

#include "numen/hal/canopen/pdo_mapping.hpp"

#include <cstdio>
#include <stdexcept>
#include <string>

namespace numen::hal {
namespace {

// "PDO mapping 'name' entry 2 (0x6071:00)" for error messages.
std::string where(std::string_view name, std::size_t position, const PdoEntry& e) {
  char buf[48];
  std::snprintf(buf, sizeof buf, " entry %zu (0x%04X:%02X)", position, e.index, e.subindex);
  return "PDO mapping '" + std::string(name) + "'" + buf;
}

constexpr bool fits(std::int64_t v, const PdoEntry& e) noexcept {
  const unsigned n = e.bit_length;  // 8, 16 or 32
  if (e.is_signed) {
    const std::int64_t lim = std::int64_t{1} << (n - 1);
    return v >= -lim && v < lim;
  }
  return v >= 0 && v < (std::int64_t{1} << n);
}

}  // namespace

const char* to_string(PdoStatus status) noexcept {
  switch (status) {
    case PdoStatus::kOk:
      return "ok";
    case PdoStatus::kWrongLength:
      return "wrong length";
    case PdoStatus::kNotDataFrame:
      return "not a data frame";
    case PdoStatus::kWrongValueCount:
      return "wrong value count";
    case PdoStatus::kValueOutOfRange:
      return "value out of range";
  }
  return "unknown";
}

PdoMapping::PdoMapping(std::initializer_list<PdoEntry> entries, std::string_view name)
    : PdoMapping(std::span<const PdoEntry>(entries.begin(), entries.size()), name) {}

PdoMapping::PdoMapping(std::span<const PdoEntry> entries, std::string_view name) {
  const MappingProblem p = assign(entries);
  if (p.kind == MappingProblem::kNone) return;
  const std::size_t pos = p.entry + 1;  // mapping parameter sub-index
  switch (p.kind) {
    case MappingProblem::kEmpty:
      throw std::invalid_argument("PDO mapping '" + std::string(name) +
                                  "': no mapped objects (at least 1 needed)");
    case MappingProblem::kTooMany:
      throw std::invalid_argument(where(name, kMaxPdoEntries + 1, entries[kMaxPdoEntries]) +
                                  ": more than " + std::to_string(kMaxPdoEntries) +
                                  " mapped objects (" + std::to_string(entries.size()) + ")");
    case MappingProblem::kZeroIndex:
      throw std::invalid_argument(where(name, pos, entries[p.entry]) + ": index 0 is not an object");
    case MappingProblem::kBitLength:
      throw std::invalid_argument(where(name, pos, entries[p.entry]) + ": bit length " +
                                  std::to_string(entries[p.entry].bit_length) +
                                  " is not 8, 16 or 32");
    case MappingProblem::kDuplicate:
      throw std::invalid_argument(where(name, pos, entries[p.entry]) +
                                  ": object already mapped as entry " + std::to_string(p.other + 1));
    case MappingProblem::kTooLong:
      throw std::invalid_argument(where(name, pos, entries[p.entry]) + ": mapping reaches " +
                                  std::to_string(p.bits) + " bits, more than " +
                                  std::to_string(kMaxPdoBits) + " (one classic CAN frame)");
    case MappingProblem::kNone:
      break;
  }
}

MappingProblem PdoMapping::assign(std::span<const PdoEntry> entries) noexcept {
  MappingProblem p;
  if (entries.empty()) {
    p.kind = MappingProblem::kEmpty;
    return p;
  }
  if (entries.size() > kMaxPdoEntries) {
    p.kind = MappingProblem::kTooMany;
    p.entry = kMaxPdoEntries;
    return p;
  }
  unsigned bits = 0;
  for (std::size_t i = 0; i < entries.size(); ++i) {
    const PdoEntry& e = entries[i];
    p.entry = i;
    if (e.index == 0) p.kind = MappingProblem::kZeroIndex;
    else if (e.bit_length != 8 && e.bit_length != 16 && e.bit_length != 32) p.kind = MappingProblem::kBitLength;
    for (std::size_t j = 0; j < i && p.kind == MappingProblem::kNone; ++j) {
      if (same_object(entries[j], e)) {
        p.kind = MappingProblem::kDuplicate;
        p.other = j;
      }
    }
    if (p.kind == MappingProblem::kNone && bits + e.bit_length > kMaxPdoBits) {
      p.kind = MappingProblem::kTooLong;
      p.bits = bits + e.bit_length;
    }
    if (p.kind != MappingProblem::kNone) return p;
    entries_[i] = e;
    offsets_[i] = static_cast<std::uint8_t>(bits / 8);
    bits += e.bit_length;
  }
  size_ = entries.size();
  length_ = static_cast<std::uint8_t>(bits / 8);
  return p;
}

MappingProblem PdoMapping::try_assign(std::span<const PdoEntry> entries) noexcept {
  PdoMapping m;
  const MappingProblem p = m.assign(entries);
  if (p.kind == MappingProblem::kNone) *this = m;
  return p;
}

std::array<std::uint32_t, kMaxPdoEntries> PdoMapping::mapping_parameter() const noexcept {
  std::array<std::uint32_t, kMaxPdoEntries> out{};
  for (std::size_t i = 0; i < size_; ++i) out[i] = mapping_entry_value(entries_[i]);
  return out;
}

PdoStatus PdoMapping::pack(std::span<const std::int64_t> values, CanFrame& frame) const noexcept {
  if (values.size() != size_) return PdoStatus::kWrongValueCount;
  for (std::size_t i = 0; i < size_; ++i) {
    if (!fits(values[i], entries_[i])) return PdoStatus::kValueOutOfRange;
  }
  frame.len = length_;
  for (std::size_t b = length_; b < kMaxClassicLen; ++b) frame.data[b] = 0;
  for (std::size_t i = 0; i < size_; ++i) {
    // Two's complement of the low bit_length bits, least significant byte first.
    const auto u = static_cast<std::uint64_t>(values[i]);
    const unsigned bytes = entries_[i].bit_length / 8u;
    for (unsigned k = 0; k < bytes; ++k) {
      frame.data[offsets_[i] + k] = static_cast<std::uint8_t>(u >> (8 * k));
    }
  }
  return PdoStatus::kOk;
}

PdoStatus PdoMapping::unpack(const CanFrame& frame, std::span<std::int64_t> values) const noexcept {
  if (values.size() != size_) return PdoStatus::kWrongValueCount;
  if (!is_classic_data_frame(frame)) return PdoStatus::kNotDataFrame;
  if (frame.len != length_) return PdoStatus::kWrongLength;
  for (std::size_t i = 0; i < size_; ++i) {
    const PdoEntry& e = entries_[i];
    const unsigned bytes = e.bit_length / 8u;
    std::uint64_t u = 0;
    for (unsigned k = 0; k < bytes; ++k) {
      u |= static_cast<std::uint64_t>(frame.data[offsets_[i] + k]) << (8 * k);
    }
    if (e.is_signed) {
      const std::uint64_t sign = std::uint64_t{1} << (e.bit_length - 1);
      values[i] = static_cast<std::int64_t>((u ^ sign) - sign);  // sign extension
    } else {
      values[i] = static_cast<std::int64_t>(u);
    }
  }
  return PdoStatus::kOk;
}

PdoMapping drive_rpdo_mapping() {
  return PdoMapping({PdoObject::kControlword, PdoObject::kTargetTorque}, "drive RPDO");
}

PdoMapping csp_drive_rpdo_mapping() {
  return PdoMapping({PdoObject::kControlword, PdoObject::kTargetPosition}, "csp drive RPDO");
}

PdoMapping drive_tpdo_mapping() {
  return PdoMapping({PdoObject::kStatusword, PdoObject::kTorqueActualValue}, "drive TPDO");
}

PdoMapping encoder_tpdo_mapping() {
  return PdoMapping({PdoObject::kPositionValue}, "encoder TPDO");
}

bool find_known_pdo_object(std::uint32_t value, PdoEntry& out) noexcept {
  constexpr PdoEntry kKnown[] = {PdoObject::kPositionValue,
                                 PdoObject::kControlword,
                                 PdoObject::kStatusword,
                                 PdoObject::kModesOfOperation,
                                 PdoObject::kModesOfOperationDisplay,
                                 PdoObject::kPositionActualValue,
                                 PdoObject::kTargetTorque,
                                 PdoObject::kTorqueActualValue};
  for (const PdoEntry& e : kKnown) {
    if (mapping_entry_value(e) == value) {
      out = e;
      return true;
    }
  }
  return false;
}

int find_mapped(std::span<const PdoEntry> mapping, const PdoEntry& object) noexcept {
  for (std::size_t i = 0; i < mapping.size(); ++i) {
    if (same_object(mapping[i], object)) return static_cast<int>(i);
  }
  return -1;
}

}  // namespace numen::hal
