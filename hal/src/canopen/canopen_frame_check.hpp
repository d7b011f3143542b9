#pragma once
/// @file canopen_frame_check.hpp
/// Internal (not installed): helpers on int64 ns times shared by the CiA 301 service code
/// (NMT, heartbeat, EMCY). The frame acceptance rule is can_frame.hpp's (is_classic_data_frame).

#include <cstdint>
#include <limits>

#include "numen/hal/transport/can_frame.hpp"

namespace numen::hal::detail {

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
