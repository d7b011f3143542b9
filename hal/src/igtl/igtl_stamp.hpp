#pragma once
/// @file igtl_stamp.hpp
/// A message's timestamp from ns (private to hal/igtl): OpenIGTLink's 64-bit timestamp is
/// seconds (upper 32 bits) and a fraction of a second in 2⁻³² s (lower 32 bits); the fraction
/// is rounded to the nearest 2⁻³² s, which igtl_stamp_ns() rounds back to the same ns.

#include <igtlMessageBase.h>

#include <algorithm>
#include <cstdint>

namespace numen::hal {

/// The raw 64-bit timestamp of `timestamp_ns` (ns since the sender's epoch; negative: 0): the
/// seconds in the upper 32 bits, the fraction in 2⁻³² s in the lower 32.
inline std::uint64_t igtl_stamp_raw(std::int64_t timestamp_ns) noexcept {
  const auto ns = static_cast<std::uint64_t>(std::max<std::int64_t>(timestamp_ns, 0));
  const std::uint64_t sec = ns / 1'000'000'000u;
  const std::uint64_t sub = ns % 1'000'000'000u;
  const std::uint64_t frac =
      std::min<std::uint64_t>(((sub << 32) + 500'000'000u) / 1'000'000'000u, 0xFFFFFFFFu);
  return (sec << 32) | frac;
}

/// Sets `m`'s timestamp to `timestamp_ns` (igtl_stamp_raw()).
inline void igtl_set_stamp_ns(igtl::MessageBase& m, std::int64_t timestamp_ns) {
  const std::uint64_t raw = igtl_stamp_raw(timestamp_ns);
  m.SetTimeStamp(static_cast<unsigned int>(raw >> 32),
                 static_cast<unsigned int>(raw & 0xFFFFFFFFu));
}

}  // namespace numen::hal
