/// @file axis.cpp
/// Axis value <-> encoder counts and torque <-> per mille conversions; axis validation.

#include "numen/hal/device/axis.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

#include "../hex_text.hpp"

namespace numen::hal {
namespace {

[[noreturn]] void fail(std::string_view where, const char* field, const std::string& what) {
  throw std::invalid_argument(std::string(where) + ": " + field + " " + what);
}

using detail::hex_cob_id;

std::string num(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

}  // namespace

double wrap_angle(double angle) noexcept {
  if (!std::isfinite(angle)) return angle;
  double r = std::remainder(angle, 2.0 * std::numbers::pi);  // [-π, π]
  if (r <= -std::numbers::pi) r += 2.0 * std::numbers::pi;   // (-π, π]
  return r;
}

double axis_difference(double a, double b, bool wraps) noexcept {
  const double d = a - b;
  return wraps ? wrap_angle(d) : d;
}

double counts_to_value(const AxisConfig& axis, std::int32_t counts) noexcept {
  const auto delta = static_cast<std::int64_t>(counts) - axis.offset_counts;
  const double v =
      static_cast<double>(axis.sign) * static_cast<double>(delta) / axis.counts_per_unit;
  return axis.wraps ? wrap_angle(v) : v;
}

std::int32_t value_to_counts(const AxisConfig& axis, double value) noexcept {
  if (std::isnan(value)) return axis.offset_counts;
  if (axis.wraps) value = wrap_angle(value);
  const double c = static_cast<double>(axis.offset_counts) +
                   std::round(static_cast<double>(axis.sign) * value * axis.counts_per_unit);
  constexpr double kLo = std::numeric_limits<std::int32_t>::min();
  constexpr double kHi = std::numeric_limits<std::int32_t>::max();
  if (!(c > kLo)) return std::numeric_limits<std::int32_t>::min();
  if (!(c < kHi)) return std::numeric_limits<std::int32_t>::max();
  return static_cast<std::int32_t>(c);
}

double torque_limit(const AxisConfig& axis) noexcept {
  return std::min(axis.max_torque, 32.767 * axis.rated_torque);
}

std::int16_t torque_per_mille(const AxisConfig& axis, double torque) noexcept {
  if (!std::isfinite(torque)) return 0;
  const double pm = std::round(static_cast<double>(axis.sign) * 1000.0 * torque / axis.rated_torque);
  constexpr double kLo = std::numeric_limits<std::int16_t>::min();
  constexpr double kHi = std::numeric_limits<std::int16_t>::max();
  return static_cast<std::int16_t>(std::clamp(pm, kLo, kHi));
}

double per_mille_to_torque(const AxisConfig& axis, std::int16_t per_mille) noexcept {
  return static_cast<double>(axis.sign) * static_cast<double>(per_mille) * axis.rated_torque /
         1000.0;
}

void validate_axis(const AxisConfig& a, std::string_view where) {
  auto cob_ok = [](std::uint32_t id) { return id >= 0x001 && id <= 0x7FF && id != 0x080; };
  if (a.name.empty()) fail(where, "name", "must not be empty");
  if (!cob_ok(a.encoder_cob_id)) {
    fail(where, "encoder_cob_id",
         "must be an 11-bit COB-ID in 0x001-0x7FF other than 0x080 (SYNC) (got " +
             hex_cob_id(a.encoder_cob_id) + ")");
  }
  if (a.drive_cob_id != 0 && !cob_ok(a.drive_cob_id)) {
    fail(where, "drive_cob_id",
         "must be 0 (no motor) or an 11-bit COB-ID in 0x001-0x7FF other than 0x080 (got " +
             hex_cob_id(a.drive_cob_id) + ")");
  }
  if (a.drive_cob_id != 0 && a.drive_cob_id == a.encoder_cob_id) {
    fail(where, "drive_cob_id", "must differ from encoder_cob_id");
  }
  if (!std::isfinite(a.counts_per_unit) || a.counts_per_unit <= 0.0) {
    fail(where, "counts_per_unit", "must be finite and > 0 (got " + num(a.counts_per_unit) + ")");
  }
  if (a.sign != 1 && a.sign != -1) {
    fail(where, "sign", "must be +1 or -1 (got " + std::to_string(a.sign) + ")");
  }
  if (!std::isfinite(a.min)) fail(where, "min", "must be finite (got " + num(a.min) + ")");
  if (!std::isfinite(a.max)) fail(where, "max", "must be finite (got " + num(a.max) + ")");
  if (!(a.min < a.max)) {
    fail(where, "min", "must be < max (got min " + num(a.min) + ", max " + num(a.max) + ")");
  }
  if (a.wraps && (a.min < -std::numbers::pi - 1e-12 || a.max > std::numbers::pi + 1e-12)) {
    fail(where, "min/max",
         "of a wrapping axis must lie in [-pi, pi] (got min " + num(a.min) + ", max " + num(a.max) +
             ")");
  }
  if (std::isnan(a.max_speed) || a.max_speed <= 0.0) {
    fail(where, "max_speed", "must be > 0 (or +inf) (got " + num(a.max_speed) + ")");
  }
  if (!std::isfinite(a.rated_torque) || a.rated_torque <= 0.0) {
    fail(where, "rated_torque", "must be finite and > 0 (got " + num(a.rated_torque) + ")");
  }
  if (!std::isfinite(a.max_torque) || a.max_torque < 0.0) {
    fail(where, "max_torque", "must be finite and >= 0 (got " + num(a.max_torque) + ")");
  }
}

}  // namespace numen::hal
