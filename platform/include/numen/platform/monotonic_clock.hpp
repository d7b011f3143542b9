#pragma once
/// @file monotonic_clock.hpp
/// CLOCK_MONOTONIC in nanoseconds (Linux). Safe in the real-time loop: a
/// vDSO call, no allocation, no lock.

#include <cstdint>

namespace numen::platform {

/// Current CLOCK_MONOTONIC time (ns since an arbitrary origin).
std::int64_t monotonic_now_ns() noexcept;

}  // namespace numen::platform
