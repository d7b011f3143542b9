#pragma once
/// @file axis.hpp
/// AxisConfig: one measured (and possibly actuated) joint of an instrument, with the
/// conversions between its value in SI units and the integers on the bus:
///   value  = sign · (counts − offset_counts) / counts_per_unit      (wrapped if `wraps`)
///   counts = offset_counts + round(sign · value · counts_per_unit)  (saturated to int32)
///   per_mille = sign · round(1000 · clamp(τ, ±max_torque) / rated_torque)  (saturated to int16)
/// The torque uses the same sign as the encoder: a positive drive torque is assumed to turn
/// the encoder towards increasing counts (a drive can be made so with CiA 402 polarity 0x607E).

#include <cstdint>
#include <string>
#include <string_view>

namespace numen::hal {

/// Configuration of one axis, provided by the scene. Checked by validate_axis().
struct AxisConfig {
  /// Human-readable name used in error messages and traces (e.g. "pivot_x").
  std::string name;
  /// COB-ID of the encoder's position TPDO (11-bit, not 0x000 or 0x080), e.g. 0x181.
  std::uint32_t encoder_cob_id = 0;
  /// COB-ID of the drive's torque RPDO (11-bit), or 0 when the axis has no motor.
  std::uint32_t drive_cob_id = 0;
  /// Encoder resolution, > 0: counts per metre (prismatic) or per radian (revolute).
  double counts_per_unit = 1.0;
  /// Encoder count at axis value 0.
  std::int32_t offset_counts = 0;
  /// +1 or −1: direction of increasing counts relative to increasing axis value.
  int sign = 1;
  /// Lowest plausible axis value, m or rad (range check). Finite, min < max.
  double min = -1.0;
  /// Highest plausible axis value, m or rad (range check). Finite.
  double max = 1.0;
  /// Highest plausible speed, m/s or rad/s, > 0 (jump check); +infinity disables the check.
  double max_speed = 10.0;
  /// Revolute axis reported in (−π, π]: values are wrapped and the jump check uses the
  /// wrapped difference. min and max must then lie in [−π, π].
  bool wraps = false;
  /// Rated torque of the drive, N·m (revolute) or N (prismatic), > 0: 1000 per mille.
  double rated_torque = 1.0;
  /// Saturation of the commanded torque, N·m or N, >= 0.
  double max_torque = 0.0;

  /// True if the axis has a drive (drive_cob_id != 0).
  bool has_drive() const noexcept { return drive_cob_id != 0; }
};

/// Wraps an angle to (−π, π], rad. Non-finite input is returned unchanged.
double wrap_angle(double angle) noexcept;

/// a − b, wrapped to (−π, π] if `wraps` (shortest signed angle from b to a).
double axis_difference(double a, double b, bool wraps) noexcept;

/// Axis value (m or rad) of an encoder reading; wrapped to (−π, π] if axis.wraps.
double counts_to_value(const AxisConfig& axis, std::int32_t counts) noexcept;

/// Encoder reading of an axis value: round to nearest, saturate to int32. A wrapping axis
/// wraps the value first. NaN gives offset_counts.
std::int32_t value_to_counts(const AxisConfig& axis, double value) noexcept;

/// The torque bound of `axis`, N·m or N: min(max_torque, 32767 · rated_torque / 1000), the
/// largest |τ| the axis allows and its RPDO can carry. ImpedanceDevice::write() clamps to it.
double torque_limit(const AxisConfig& axis) noexcept;

/// Torque (N·m or N) to RPDO per mille without a clamp: sign · round(1000 · τ / rated_torque).
/// For a τ already clamped to ±torque_limit() (ImpedanceDevice::write()); a value outside the int16
/// range (not reached then) is held at its end, non-finite gives 0.
std::int16_t torque_per_mille(const AxisConfig& axis, double torque) noexcept;

/// RPDO per mille to torque, N·m or N (inverse scaling, sign applied; no saturation).
double per_mille_to_torque(const AxisConfig& axis, std::int16_t per_mille) noexcept;

/// Throws std::invalid_argument if a field of `axis` is invalid; the message starts with
/// `where` (e.g. "device 'left': axes[2] 'depth'") and names the field and its value.
void validate_axis(const AxisConfig& axis, std::string_view where);

}  // namespace numen::hal
