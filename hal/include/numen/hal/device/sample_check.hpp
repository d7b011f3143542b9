#pragma once
/// @file sample_check.hpp
/// The plausibility checks applied to every decoded encoder value before it becomes a target
/// (docs/architecture.md, the period's walk: finite, in range, fresh, plausible jump).
/// A value that fails any check is rejected: the axis keeps its last accepted value.

#include <cstdint>

#include "numen/hal/device/axis.hpp"

namespace numen::hal {

/// Bit set of failed checks for one axis (or the union over axes).
using FaultMask = std::uint8_t;

/// The bits of a FaultMask.
struct SampleFault {
  /// No check failed.
  static constexpr FaultMask kNone = 0;
  /// The PDO had the axis's COB-ID but a wrong length or was not a data frame.
  static constexpr FaultMask kMalformed = 1u << 0;
  /// The decoded value is NaN or infinite.
  static constexpr FaultMask kNonFinite = 1u << 1;
  /// The value is outside [min, max].
  static constexpr FaultMask kOutOfRange = 1u << 2;
  /// |now − timestamp| > max sample age (no fresh frame, or a clock mismatch).
  static constexpr FaultMask kStale = 1u << 3;
  /// |value − last accepted| > max_speed · Δt + jump tolerance (Δt between their timestamps).
  static constexpr FaultMask kJump = 1u << 4;
  /// No value has ever been accepted on this axis (not counted as a rejection).
  static constexpr FaultMask kNoData = 1u << 5;
};

/// Short English name of one SampleFault bit ("stale", ...); "none" for 0, "multiple" if
/// several bits are set.
const char* sample_fault_name(FaultMask fault) noexcept;

/// Limits of the checks of one axis, in axis units.
struct AxisCheckLimits {
  double min = 0.0;             ///< Lowest accepted value, m or rad.
  double max = 0.0;             ///< Highest accepted value, m or rad.
  double max_speed = 0.0;       ///< m/s or rad/s; +infinity disables the jump check.
  double jump_tolerance = 0.0;  ///< Allowance on top of max_speed · Δt, m or rad.
  bool wraps = false;           ///< Use the wrapped difference in the jump check.
  std::int64_t max_age_ns = 0;  ///< Oldest accepted sample, ns.
};

/// The limits of `axis` with the device-wide max sample age (s) and jump tolerance (counts,
/// converted with the axis's counts_per_unit).
AxisCheckLimits make_check_limits(const AxisConfig& axis, double max_sample_age_s,
                                  double jump_tolerance_counts) noexcept;

/// The last accepted value of an axis, for the jump check.
struct AcceptedValue {
  double q = 0.0;            ///< The axis value, m or rad.
  std::int64_t time_ns = 0;  ///< Bus timestamp of its frame.
};

/// Freshness alone: kStale if |now_ns − stamp_ns| > max_age_ns, else kNone.
FaultMask check_fresh(const AxisCheckLimits& limits, std::int64_t stamp_ns,
                      std::int64_t now_ns) noexcept;

/// Range alone: kNonFinite for a non-finite value, kOutOfRange outside [min, max], else kNone.
FaultMask check_range(const AxisCheckLimits& limits, double value) noexcept;

/// Jump alone: kJump if |value ⊖ last.q| > max_speed · Δt + jump_tolerance, Δt = max(0,
/// stamp − last.time) (⊖ wrapped on a wrapping axis); kNone without a last value or with
/// max_speed = +∞.
FaultMask check_jump(const AxisCheckLimits& limits, double value, std::int64_t stamp_ns,
                     const AcceptedValue* last) noexcept;

/// All checks of a newly decoded `value` stamped `stamp_ns`, at time `now_ns`, against the
/// last accepted value `last` (nullptr before the first): non-finite (then nothing else is
/// checked), out of range, stale, jump (Δt = max(0, stamp − last.time)). Returns the union of
/// the failed bits; kNone means accept.
FaultMask check_sample(const AxisCheckLimits& limits, double value, std::int64_t stamp_ns,
                       std::int64_t now_ns, const AcceptedValue* last) noexcept;

}  // namespace numen::hal
