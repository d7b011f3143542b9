// Tests of numen/hal/device/axis.hpp: counts and torque scaling, wrapping, saturation, validation.
#include "numen/hal/device/axis.hpp"
#include "test_constants.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

namespace {

using namespace numen::hal;
using numen::test::kPi;

AxisConfig revolute() {
  AxisConfig a;
  a.name = "pivot";
  a.encoder_cob_id = 0x181;
  a.drive_cob_id = 0x201;
  a.counts_per_unit = 1000.0;
  a.offset_counts = 500;
  a.sign = -1;
  a.min = -1.0;
  a.max = 1.0;
  a.max_speed = 5.0;
  a.rated_torque = 0.5;
  a.max_torque = 1.0;
  return a;
}

TEST(Axis, CountsScaleOffsetAndSign) {
  const AxisConfig a = revolute();
  EXPECT_EQ(value_to_counts(a, 0.0), 500);
  EXPECT_EQ(value_to_counts(a, 0.25), 250);  // 500 − 250
  EXPECT_EQ(value_to_counts(a, -0.25), 750);
  EXPECT_DOUBLE_EQ(counts_to_value(a, 250), 0.25);
  EXPECT_EQ(value_to_counts(a, 0.0004), 500);  // rounds to nearest
  EXPECT_EQ(value_to_counts(a, 0.0006), 499);
}

TEST(Axis, RoundTripWithinHalfACount) {
  const AxisConfig a = revolute();
  for (double v = -1.0; v <= 1.0; v += 0.01234) {
    EXPECT_NEAR(counts_to_value(a, value_to_counts(a, v)), v, 0.5 / a.counts_per_unit + 1e-15);
  }
}

TEST(Axis, CountsSaturateToInt32) {
  AxisConfig a = revolute();
  a.sign = 1;
  a.counts_per_unit = 1e9;
  EXPECT_EQ(value_to_counts(a, 1e6), std::numeric_limits<std::int32_t>::max());
  EXPECT_EQ(value_to_counts(a, -1e6), std::numeric_limits<std::int32_t>::min());
  EXPECT_EQ(value_to_counts(a, std::numeric_limits<double>::infinity()),
            std::numeric_limits<std::int32_t>::max());
  EXPECT_EQ(value_to_counts(a, std::nan("")), a.offset_counts);
  // Extreme counts minus offset do not overflow.
  a.offset_counts = std::numeric_limits<std::int32_t>::max();
  EXPECT_DOUBLE_EQ(counts_to_value(a, std::numeric_limits<std::int32_t>::min()),
                   -4294967295.0 / 1e9);
}

TEST(Axis, WrapAngle) {
  EXPECT_DOUBLE_EQ(wrap_angle(0.5), 0.5);
  EXPECT_DOUBLE_EQ(wrap_angle(kPi), kPi);
  EXPECT_DOUBLE_EQ(wrap_angle(-kPi), kPi);
  EXPECT_NEAR(wrap_angle(3 * kPi / 2), -kPi / 2, 1e-15);
  EXPECT_NEAR(wrap_angle(-7.0), -7.0 + 2 * kPi, 1e-15);
  EXPECT_NEAR(axis_difference(kPi - 0.1, -kPi + 0.1, true), -0.2, 1e-12);
  EXPECT_NEAR(axis_difference(kPi - 0.1, -kPi + 0.1, false), 2 * kPi - 0.2, 1e-12);
}

TEST(Axis, WrappingSingleTurnEncoder) {
  AxisConfig a;
  a.name = "roll";
  a.encoder_cob_id = 0x184;
  a.counts_per_unit = 4096.0 / (2 * kPi);
  a.wraps = true;
  a.min = -kPi;
  a.max = kPi;
  EXPECT_NEAR(counts_to_value(a, 4096 + 1024), kPi / 2, 1e-12);  // one turn more
  EXPECT_NEAR(counts_to_value(a, 3072), -kPi / 2, 1e-12);
  EXPECT_EQ(value_to_counts(a, kPi / 2 + 2 * kPi), 1024);
}

// The encoding of a torque ImpedanceDevice::write() has already clamped to torque_limit(): scale by
// rated_torque, apply the sign, round to the nearest per mille.
TEST(Axis, TorqueScalingAndSign) {
  const AxisConfig a = revolute();  // rated 0.5, max 1.0, sign −1
  EXPECT_DOUBLE_EQ(torque_limit(a), 1.0);
  EXPECT_EQ(torque_per_mille(a, 0.25), -500);
  EXPECT_DOUBLE_EQ(per_mille_to_torque(a, -500), 0.25);
  EXPECT_EQ(torque_per_mille(a, -1.0), 2000);
  EXPECT_EQ(torque_per_mille(a, 0.00024), 0) << "rounds to the nearest per mille";
  EXPECT_EQ(torque_per_mille(a, std::nan("")), 0);
}

// The limit ImpedanceDevice::write() clamps to is within what the RPDO's int16 carries, so the
// encoding of a clamped torque is exact; beyond it the encoding saturates (never wraps).
TEST(Axis, TorqueLimitIsWithinTheRpdosRange) {
  AxisConfig a = revolute();
  a.sign = 1;
  a.rated_torque = 0.001;
  a.max_torque = 100.0;
  EXPECT_NEAR(torque_limit(a), 0.032767, 1e-15);
  EXPECT_EQ(torque_per_mille(a, torque_limit(a)), 32767);
  EXPECT_EQ(torque_per_mille(a, -torque_limit(a)), -32767);
  EXPECT_EQ(torque_per_mille(a, 50.0), 32767);  // 50e6 per mille
}

TEST(Axis, ValidationNamesTheField) {
  auto message = [](const AxisConfig& a) -> std::string {
    try {
      validate_axis(a, "device 'd': axes[0] 'pivot'");
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_EQ(message(revolute()), "");
  AxisConfig a = revolute();
  a.counts_per_unit = 0.0;
  EXPECT_NE(message(a).find("counts_per_unit"), std::string::npos);
  EXPECT_NE(message(a).find("axes[0] 'pivot'"), std::string::npos);
  a = revolute();
  a.sign = 2;
  EXPECT_NE(message(a).find("sign"), std::string::npos);
  a = revolute();
  a.encoder_cob_id = 0x080;
  EXPECT_NE(message(a).find("encoder_cob_id"), std::string::npos);
  EXPECT_NE(message(a).find("0x080"), std::string::npos);
  a = revolute();
  a.drive_cob_id = 0x800;
  EXPECT_NE(message(a).find("drive_cob_id"), std::string::npos);
  a = revolute();
  a.min = 2.0;
  EXPECT_NE(message(a).find("min"), std::string::npos);
  a = revolute();
  a.wraps = true;
  a.max = 4.0;
  EXPECT_NE(message(a).find("wrapping"), std::string::npos);
  a = revolute();
  a.max_speed = 0.0;
  EXPECT_NE(message(a).find("max_speed"), std::string::npos);
  a = revolute();
  a.rated_torque = -1.0;
  EXPECT_NE(message(a).find("rated_torque"), std::string::npos);
  a = revolute();
  a.max_torque = -1.0;
  EXPECT_NE(message(a).find("max_torque"), std::string::npos);
  a = revolute();
  a.name.clear();
  EXPECT_NE(message(a).find("name"), std::string::npos);
}

}  // namespace
