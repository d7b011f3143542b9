/// @file monotonic_clock.cpp

#include "numen/platform/monotonic_clock.hpp"

#include <time.h>

namespace numen::platform {

std::int64_t monotonic_now_ns() noexcept {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

}  // namespace numen::platform
