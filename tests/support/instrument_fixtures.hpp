#pragma once
/// @file instrument_fixtures.hpp
/// Instruments shared by the controller-side device tests (instrument_device_test.cpp,
/// minimal_device_test.cpp): a trocar and a phantom arm with fixed placements, axis values
/// inside their limits, encoder TPDOs fed frame by frame, and link wrenches.

#include <array>
#include <cstdint>
#include <numbers>

#include <gtest/gtest.h>

#include "kinematics_check.hpp"
#include "numen/hal/canopen/canopen.hpp"
#include "numen/hal/device/device_config.hpp"
#include "numen/hal/device/instrument_device.hpp"
#include "numen/hal/device/phantom_kinematics.hpp"
#include "numen/hal/transport/splitmix64.hpp"

namespace numen::test {

/// The default trocar (nodes from 1) with its pivot 0.2 m up, pointing down.
inline hal::DeviceConfig trocar_config() {
  hal::DeviceConfig c = hal::make_default_trocar_config(1);
  c.trocar.point = core::Vec3(0, 0, 0.2);
  c.trocar.orientation = core::Quat(Eigen::AngleAxisd(std::numbers::pi, core::Vec3::UnitX()));
  return c;
}

/// The default phantom (nodes from 30), base moved and turned, a tool tip ahead of the gimbal.
inline hal::DeviceConfig phantom_config() {
  hal::DeviceConfig c = hal::make_default_phantom_config(30);
  c.phantom.base.position = core::Vec3(0.1, 0.0, 0.2);
  c.phantom.base.orientation = core::Quat(Eigen::AngleAxisd(0.3, core::Vec3::UnitZ()));
  c.tool_offset.position = core::Vec3(0.03, 0.0, 0.0);  // a tip ahead of the gimbal along the pen
  return c;
}

/// Trocar axis values (rad, rad, m, rad, rad) inside the default limits.
inline constexpr double kQ0[5] = {0.1, -0.2, 0.1, 0.5, 0.3};
/// Phantom axis values (rad) inside the default limits.
inline constexpr double kP0[6] = {0.2, -0.3, 0.4, 0.5, -0.4, 1.0};

/// Feeds one position TPDO per axis of `dev` for axis values q, stamped t.
inline void feed(hal::InstrumentDevice& dev, const double* q, std::int64_t t) {
  for (int i = 0; i < dev.num_axes(); ++i) {
    const hal::AxisConfig& a = dev.config().axes[static_cast<std::size_t>(i)];
    EXPECT_TRUE(
        dev.on_frame(hal::encode_position_pdo(a.encoder_cob_id, hal::value_to_counts(a, q[i]), t)));
  }
}

/// One random wrench per phantom link (seeded, reproducible), each part of norm up to ~scale.
inline std::array<core::Wrench, hal::PhantomKinematics::kNumLinks> some_link_wrenches(double scale) {
  hal::SplitMix64 rng(314);
  std::array<core::Wrench, hal::PhantomKinematics::kNumLinks> w;
  for (core::Wrench& x : w) x = random_wrench(rng, scale);
  return w;
}

}  // namespace numen::test
