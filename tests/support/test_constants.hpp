#pragma once
/// @file test_constants.hpp
/// Constants the test files share: time in the nanoseconds of the monotonic clock that hal and
/// platform count in, and π. Header-only.

#include <cstdint>
#include <numbers>

namespace numen::test {

/// One millisecond in nanoseconds (the unit of every `*_ns` time of hal and platform).
inline constexpr std::int64_t kMs = 1'000'000;
/// π.
inline constexpr double kPi = std::numbers::pi;

}  // namespace numen::test
