/// @file sample_check.cpp
/// Plausibility checks of decoded encoder values: finite, in range, fresh, no jump.

#include "numen/hal/device/sample_check.hpp"

#include <cmath>
#include <limits>

namespace numen::hal {

const char* sample_fault_name(FaultMask fault) noexcept {
  switch (fault) {
    case SampleFault::kNone:
      return "none";
    case SampleFault::kMalformed:
      return "malformed";
    case SampleFault::kNonFinite:
      return "non-finite";
    case SampleFault::kOutOfRange:
      return "out of range";
    case SampleFault::kStale:
      return "stale";
    case SampleFault::kJump:
      return "jump";
    case SampleFault::kNoData:
      return "no data";
    default:
      return "multiple";
  }
}

AxisCheckLimits make_check_limits(const AxisConfig& axis, double max_sample_age_s,
                                  double jump_tolerance_counts) noexcept {
  AxisCheckLimits l;
  l.min = axis.min;
  l.max = axis.max;
  l.max_speed = axis.max_speed;
  l.jump_tolerance = jump_tolerance_counts / axis.counts_per_unit;
  l.wraps = axis.wraps;
  const double age_ns = std::round(max_sample_age_s * 1e9);
  l.max_age_ns = age_ns >= 9.2e18 ? std::numeric_limits<std::int64_t>::max()
                                  : static_cast<std::int64_t>(age_ns);
  return l;
}

FaultMask check_fresh(const AxisCheckLimits& limits, std::int64_t stamp_ns,
                      std::int64_t now_ns) noexcept {
  // Differences of bus times; both are well inside ±2^62 in practice.
  const std::int64_t age = now_ns - stamp_ns;
  return (age > limits.max_age_ns || age < -limits.max_age_ns) ? SampleFault::kStale
                                                               : SampleFault::kNone;
}

FaultMask check_range(const AxisCheckLimits& limits, double value) noexcept {
  if (!std::isfinite(value)) return SampleFault::kNonFinite;
  return (value < limits.min || value > limits.max) ? SampleFault::kOutOfRange : SampleFault::kNone;
}

FaultMask check_jump(const AxisCheckLimits& limits, double value, std::int64_t stamp_ns,
                     const AcceptedValue* last) noexcept {
  if (last == nullptr || !std::isfinite(limits.max_speed)) return SampleFault::kNone;
  const double dt =
      stamp_ns > last->time_ns ? static_cast<double>(stamp_ns - last->time_ns) * 1e-9 : 0.0;
  const double allowed = limits.max_speed * dt + limits.jump_tolerance;
  return std::abs(axis_difference(value, last->q, limits.wraps)) > allowed ? SampleFault::kJump
                                                                               : SampleFault::kNone;
}

FaultMask check_sample(const AxisCheckLimits& limits, double value, std::int64_t stamp_ns,
                       std::int64_t now_ns, const AcceptedValue* last) noexcept {
  if (!std::isfinite(value)) return SampleFault::kNonFinite;
  return check_range(limits, value) | check_fresh(limits, stamp_ns, now_ns) |
         check_jump(limits, value, stamp_ns, last);
}

}  // namespace numen::hal
