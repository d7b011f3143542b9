#pragma once
/// @file igtl_stamp.hpp
/// A message's timestamp from ns (private to hal/igtl): OpenIGTLink's 64-bit timestamp is
/// seconds (upper 32 bits) and a fraction of a second in 2⁻³² s (lower 32 bits); the fraction
/// is rounded to the nearest 2⁻³² s, which igtl_stamp_ns() rounds back to the same ns.

#include <igtlMessageBase.h>

#include <algorithm>
#include <cstdint>

namespace numen::hal {

/// Sets `m`'s timestamp to `timestamp_ns` (ns since the sender's epoch; negative: 0).
inline void igtl_set_stamp_ns(igtl::MessageBase& m, std::int64_t timestamp_ns) {
  const auto ns = static_cast<std::uint64_t>(std::max<std::int64_t>(timestamp_ns, 0));
  const std::uint64_t sec = ns / 1'000'000'000u;
  const std::uint64_t sub = ns % 1'000'000'000u;
  const std::uint64_t frac =
      std::min<std::uint64_t>(((sub << 32) + 500'000'000u) / 1'000'000'000u, 0xFFFFFFFFu);
  m.SetTimeStamp(static_cast<unsigned int>(sec), static_cast<unsigned int>(frac));
}

}  // namespace numen::hal
