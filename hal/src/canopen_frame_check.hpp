#pragma once
/// @file canopen_frame_check.hpp
/// Internal (not installed): the frame-type rule shared by the CiA 301 service decoders
/// (NMT, heartbeat, EMCY) and helpers on int64 ns times.

#include <cstdint>
#include <limits>

#include "numen/hal/can_frame.hpp"

namespace numen::hal::detail {

/// True if `frame` is a classic CAN data frame with an 11-bit identifier: not remote, not an
/// error report, not 29-bit, not CAN FD (CiA 301 services are defined on classic CAN).
constexpr bool is_classic_standard_data_frame(const CanFrame& frame) noexcept {
  return (frame.flags &
          (CanFlag::kRemote | CanFlag::kErrorFrame | CanFlag::kExtendedId | CanFlag::kFd)) == 0;
}

/// a + b for b >= 0, saturated at INT64_MAX.
constexpr std::int64_t saturating_add(std::int64_t a, std::int64_t b) noexcept {
  return a > std::numeric_limits<std::int64_t>::max() - b ? std::numeric_limits<std::int64_t>::max()
                                                          : a + b;
}

/// later - earlier as an unsigned count of ns; 0 if later <= earlier. Exact for any int64 pair.
constexpr std::uint64_t elapsed_ns(std::int64_t earlier, std::int64_t later) noexcept {
  return later <= earlier ? 0u
                          : static_cast<std::uint64_t>(later) - static_cast<std::uint64_t>(earlier);
}

}  // namespace numen::hal::detail
