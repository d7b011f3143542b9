#pragma once
/// @file can_test_frames.hpp
/// CAN frames for the SocketCAN tests (host: tests/hal/socketcan_bus_test.cpp; guest:
/// tests/hil/socketcan_bus_hil_test.cpp; the CANopen tests): a data frame with a seeded or a
/// given payload, a controller error report, a field-by-field comparison and the
/// CLOCK_MONOTONIC time. Header-only.

#include <gtest/gtest.h>
#include <linux/can/error.h>
#include <time.h>

#include <cstdint>
#include <initializer_list>

#include "numen/hal/transport/can_frame.hpp"

namespace numen::test {

/// Monotonic time (ns), as SocketCanBus stamps frames.
inline std::int64_t mono_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

/// A frame `id` with CanFlag `flags` and `len` bytes seed, seed + 7, seed + 14, … (no payload
/// for a remote request).
inline hal::CanFrame make(std::uint32_t id, std::uint8_t flags, std::uint8_t len,
                          std::uint8_t seed = 1) {
  hal::CanFrame f;
  f.id = id;
  f.flags = flags;
  f.len = len;
  if ((flags & hal::CanFlag::kRemote) == 0) {
    for (std::uint8_t i = 0; i < len; ++i) f.data[i] = static_cast<std::uint8_t>(seed + 7 * i);
  }
  return f;
}

/// A data frame `id` with the payload `bytes` (at most 8), stamped `t` (ns).
inline hal::CanFrame raw_frame(std::uint32_t id, std::initializer_list<std::uint8_t> bytes,
                               std::int64_t t = 0) {
  hal::CanFrame f;
  f.id = id;
  f.timestamp_ns = t;
  for (std::uint8_t b : bytes) f.data[f.len++] = b;
  return f;
}

/// A controller error report of error `classes` (linux/can/error.h) with controller detail
/// byte `ctrl` (data[1]).
inline hal::CanFrame error_frame(std::uint32_t classes, std::uint8_t ctrl = 0) {
  hal::CanFrame f;
  f.id = classes;
  f.flags = hal::CanFlag::kErrorFrame;
  f.len = CAN_ERR_DLC;
  f.data[1] = ctrl;
  return f;
}

/// Expects equal id, flags, length and payload (payload not compared for remote requests).
inline void expect_same(const hal::CanFrame& a, const hal::CanFrame& b) {
  EXPECT_EQ(a.id, b.id);
  EXPECT_EQ(a.flags, b.flags);
  ASSERT_EQ(a.len, b.len);
  if (!a.remote()) {
    for (std::uint8_t i = 0; i < a.len; ++i) EXPECT_EQ(a.data[i], b.data[i]) << "byte " << +i;
  }
}

}  // namespace numen::test
