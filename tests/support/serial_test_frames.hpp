#pragma once
/// @file serial_test_frames.hpp
/// Frames and their bytes on the line for the serial tests (tests/hal/serial_frame_test.cpp,
/// tests/hal/serial_bus_test.cpp). Header-only.

#include <gtest/gtest.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "numen/hal/transport/can_frame.hpp"
#include "numen/hal/transport/serial_frame.hpp"

namespace numen::test {

using Bytes = std::vector<std::uint8_t>;

/// A frame `id` with CanFlag `flags` carrying `data` (len = data.size()).
inline hal::CanFrame make(std::uint32_t id, std::uint8_t flags, Bytes data) {
  hal::CanFrame f;
  f.id = id;
  f.flags = flags;
  f.len = static_cast<std::uint8_t>(data.size());
  for (std::size_t i = 0; i < data.size(); ++i) f.data[i] = data[i];
  return f;
}

/// Expects `a` and `b` to be identical frames: id, flags, len and all 64 data bytes (those past
/// len are zero on both sides of a round trip).
inline void expect_identical(const hal::CanFrame& a, const hal::CanFrame& b) {
  EXPECT_EQ(a.id, b.id);
  EXPECT_EQ(a.flags, b.flags);
  EXPECT_EQ(a.len, b.len);
  EXPECT_EQ(a.data, b.data);
}

/// The bytes of `f` on the line (encode_serial_frame(); expects success).
inline Bytes encode(const hal::CanFrame& f) {
  std::array<std::uint8_t, hal::kSerialMaxFrameOnLine> buf{};
  const hal::SerialEncodeResult r = hal::encode_serial_frame(f, buf);
  EXPECT_TRUE(r.ok());
  return Bytes(buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(r.length));
}

}  // namespace numen::test
