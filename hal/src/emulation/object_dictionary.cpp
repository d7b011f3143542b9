/// @file object_dictionary.cpp

#include "numen/hal/emulation/object_dictionary.hpp"

#include <algorithm>
#include <stdexcept>

namespace numen::hal {

void ObjectDictionary::add(SdoAddress address, OdAccess access, std::span<const std::uint8_t> value) {
  if (value.empty())
    throw std::invalid_argument("object dictionary: entry " + to_string(address) + " has no bytes");
  if (find(address) != nullptr)
    throw std::invalid_argument("object dictionary: entry " + to_string(address) + " added twice");
  OdEntry e;
  e.address = address;
  e.access = access;
  e.value.assign(value.begin(), value.end());
  e.capacity = value.size();
  entries_.push_back(std::move(e));
}

void ObjectDictionary::add_unsigned(SdoAddress address, OdAccess access, std::uint32_t value,
                                    std::size_t bytes) {
  if (bytes != 1 && bytes != 2 && bytes != 4)
    throw std::invalid_argument("object dictionary: entry " + to_string(address) +
                                ": an unsigned number has 1, 2 or 4 bytes");
  std::uint8_t b[4];
  for (std::size_t i = 0; i < 4; ++i) b[i] = static_cast<std::uint8_t>(value >> (8 * i));
  add(address, access, std::span<const std::uint8_t>(b, bytes));
}

void ObjectDictionary::add_string(SdoAddress address, OdAccess access, const std::string& text,
                                  std::size_t capacity) {
  if (capacity < std::max<std::size_t>(1, text.size()))
    throw std::invalid_argument("object dictionary: entry " + to_string(address) +
                                ": capacity below the text's length");
  if (find(address) != nullptr)
    throw std::invalid_argument("object dictionary: entry " + to_string(address) + " added twice");
  OdEntry e;
  e.address = address;
  e.access = access;
  e.variable_length = true;
  e.value.reserve(capacity);
  e.value.assign(text.begin(), text.end());
  e.capacity = capacity;
  entries_.push_back(std::move(e));
}

const OdEntry* ObjectDictionary::find(SdoAddress address) const noexcept {
  for (const OdEntry& e : entries_)
    if (e.address == address) return &e;
  return nullptr;
}

OdEntry* ObjectDictionary::find(SdoAddress address) noexcept {
  for (OdEntry& e : entries_)
    if (e.address == address) return &e;
  return nullptr;
}

bool ObjectDictionary::has_index(std::uint16_t index) const noexcept {
  return std::any_of(entries_.begin(), entries_.end(),
                     [index](const OdEntry& e) { return e.address.index == index; });
}

std::uint32_t ObjectDictionary::write(SdoAddress address, std::span<const std::uint8_t> bytes) noexcept {
  OdEntry* e = find(address);
  if (e == nullptr) return has_index(address.index) ? SdoAbort::kNoSubIndex : SdoAbort::kNoObject;
  if (e->access == OdAccess::kReadOnly) return SdoAbort::kReadOnly;
  if (e->variable_length) {
    if (bytes.size() > e->capacity) return SdoAbort::kLengthTooHigh;
  } else if (bytes.size() != e->value.size()) {
    return bytes.size() > e->value.size() ? SdoAbort::kLengthTooHigh : SdoAbort::kLengthTooLow;
  }
  if (e->check != nullptr) {
    const std::uint32_t code = e->check(*this, address, bytes);
    if (code != 0) return code;
  }
  e->value.assign(bytes.begin(), bytes.end());  // within the reserved capacity: no allocation
  return 0;
}

void ObjectDictionary::set_rules(SdoAddress address, OdWriteCheck check, bool pdo_mappable) {
  OdEntry* e = find(address);
  if (e == nullptr)
    throw std::invalid_argument("object dictionary: no entry " + to_string(address) + " to give rules");
  e->check = check;
  e->pdo_mappable = pdo_mappable;
}

void ObjectDictionary::save_defaults() {
  defaults_.clear();
  for (const OdEntry& e : entries_) defaults_.push_back(e.value);
}

void ObjectDictionary::restore_defaults(std::uint16_t first, std::uint16_t last) noexcept {
  for (std::size_t i = 0; i < entries_.size() && i < defaults_.size(); ++i) {
    OdEntry& e = entries_[i];
    if (e.address.index < first || e.address.index > last) continue;
    e.value.assign(defaults_[i].begin(), defaults_[i].end());  // length ≤ capacity: no allocation
  }
}

bool ObjectDictionary::set_unsigned(SdoAddress address, std::uint64_t value) noexcept {
  OdEntry* e = find(address);
  if (e == nullptr || e->value.empty() || e->value.size() > 8) return false;
  for (std::size_t i = 0; i < e->value.size(); ++i) e->value[i] = static_cast<std::uint8_t>(value >> (8 * i));
  return true;
}

bool ObjectDictionary::read_unsigned(SdoAddress address, std::uint32_t& out) const noexcept {
  const OdEntry* e = find(address);
  if (e == nullptr) return false;
  out = 0;
  for (std::size_t i = 0; i < std::min<std::size_t>(4, e->value.size()); ++i)
    out |= static_cast<std::uint32_t>(e->value[i]) << (8 * i);
  return true;
}

std::size_t ObjectDictionary::max_length() const noexcept {
  std::size_t n = 0;
  for (const OdEntry& e : entries_) n = std::max(n, e.capacity);
  return n;
}

}  // namespace numen::hal
