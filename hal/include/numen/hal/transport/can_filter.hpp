#pragma once
/// @file can_filter.hpp
/// CanFilter: an acceptance filter on the identifier, with the semantics of SocketCAN's
/// `struct can_filter` (linux/can.h; CAN_RAW_FILTER socket option): a received frame passes
/// a filter when `(frame_id & mask) == (id & mask)`, where frame_id carries the extended-frame
/// bit like SocketCAN's can_id. A port with a filter list passes a frame if any filter
/// matches; an empty list passes everything. Used by the SocketCAN backend (as kernel
/// filters) and by the transports that filter in user space (log replay, serial).

#include <cstdint>
#include <span>

#include "numen/hal/transport/can_frame.hpp"

namespace numen::hal {

/// Bit set in CanFilter::id / CanFilter::mask for a 29-bit frame (SocketCAN CAN_EFF_FLAG).
inline constexpr std::uint32_t kFilterExtendedBit = 0x80000000u;
/// Bit set in CanFilter::id / CanFilter::mask for a remote frame (SocketCAN CAN_RTR_FLAG).
inline constexpr std::uint32_t kFilterRemoteBit = 0x40000000u;

/// One acceptance filter (SocketCAN `struct can_filter` without CAN_INV_FILTER).
struct CanFilter {
  /// Identifier to match, with kFilterExtendedBit / kFilterRemoteBit as in SocketCAN can_id.
  std::uint32_t id = 0;
  /// Bits of the identifier (and flag bits) that must equal those of `id`.
  std::uint32_t mask = 0;
};

/// A filter passing exactly the 11-bit data frame `cob_id` (not its remote request, not a
/// 29-bit frame with the same number): mask = 0x7FF | extended bit | remote bit.
constexpr CanFilter exact_standard_filter(std::uint32_t cob_id) noexcept {
  return CanFilter{cob_id & kStandardIdMask, kStandardIdMask | kFilterExtendedBit | kFilterRemoteBit};
}

/// A filter passing the 11-bit frames `cob_id` of every kind: data frame and remote request
/// (mask = 0x7FF | extended bit). For an id whose decoder counts a remote request as malformed
/// (an encoder TPDO): filtered out, it would be lost without a trace.
constexpr CanFilter standard_id_filter(std::uint32_t cob_id) noexcept {
  return CanFilter{cob_id & kStandardIdMask, kStandardIdMask | kFilterExtendedBit};
}

/// A filter passing the 29-bit frames numbered `id` (data or remote): mask = 0x1FFFFFFF |
/// extended bit. Such a frame is not the 11-bit COB-ID `id` (ISO 11898-1); a controller that
/// counts it as an unknown identifier must receive it to count it.
constexpr CanFilter extended_id_filter(std::uint32_t id) noexcept {
  return CanFilter{(id & kExtendedIdMask) | kFilterExtendedBit, kExtendedIdMask | kFilterExtendedBit};
}

/// The SocketCAN-style identifier of `frame`: id plus kFilterExtendedBit / kFilterRemoteBit.
constexpr std::uint32_t filter_key(const CanFrame& frame) noexcept {
  std::uint32_t key = frame.id;
  if (frame.extended()) key |= kFilterExtendedBit;
  if (frame.remote()) key |= kFilterRemoteBit;
  return key;
}

/// True if `frame` passes `filter`.
constexpr bool matches(const CanFilter& filter, const CanFrame& frame) noexcept {
  return (filter_key(frame) & filter.mask) == (filter.id & filter.mask);
}

/// True if `frame` passes any filter of `filters`, or `filters` is empty. Error reports
/// (CanFlag::kErrorFrame) are not data frames and are not subject to the list: they pass.
constexpr bool passes(std::span<const CanFilter> filters, const CanFrame& frame) noexcept {
  if (filters.empty() || frame.error_frame()) return true;
  for (const CanFilter& f : filters) {
    if (matches(f, frame)) return true;
  }
  return false;
}

}  // namespace numen::hal
