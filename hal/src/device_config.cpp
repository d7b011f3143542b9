/// @file device_config.cpp
/// DeviceConfig validation and the default trocar / pose tracker / phantom configurations.

#include "numen/hal/device_config.hpp"

#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

#include "geometry_check.hpp"
#include "numen/hal/canopen.hpp"

namespace numen::hal {
namespace {

constexpr double kPi = std::numbers::pi;

std::string device_name(const DeviceConfig& c) { return "device '" + c.name + "'"; }

[[noreturn]] void fail(const DeviceConfig& c, const std::string& field, const std::string& what) {
  throw std::invalid_argument(device_name(c) + ": " + field + " " + what);
}

AxisConfig axis(const char* name, std::uint8_t node, bool drive, double counts_per_unit, double min,
                double max, double max_speed, bool wraps, double rated, double max_torque) {
  AxisConfig a;
  a.name = name;
  a.encoder_cob_id = encoder_tpdo_cob_id(node);
  a.drive_cob_id = drive ? drive_rpdo_cob_id(node) : 0;
  a.counts_per_unit = counts_per_unit;
  a.min = min;
  a.max = max;
  a.max_speed = max_speed;
  a.wraps = wraps;
  a.rated_torque = rated;
  a.max_torque = drive ? max_torque : 0.0;
  return a;
}

void check_node_range(std::uint8_t first, int count, const char* what) {
  if (first < 1 || first + count - 1 > kMaxNodeId) {
    throw std::invalid_argument(std::string(what) + ": first_node_id must be in 1.." +
                                std::to_string(kMaxNodeId - count + 1) + " (got " +
                                std::to_string(first) + ")");
  }
}

}  // namespace

const char* to_string(DeviceKind kind) noexcept {
  switch (kind) {
    case DeviceKind::kTrocarInstrument:
      return "trocar instrument";
    case DeviceKind::kPoseTracker:
      return "pose tracker";
    case DeviceKind::kPhantom:
      return "phantom";
  }
  return "unknown";
}

int expected_axis_count(DeviceKind kind) noexcept {
  switch (kind) {
    case DeviceKind::kTrocarInstrument:
      return TrocarKinematics::kNumAxes;
    case DeviceKind::kPoseTracker:
      return PoseTrackerKinematics::kNumAxes;
    case DeviceKind::kPhantom:
      return PhantomKinematics::kNumAxes;
  }
  return 0;
}

void validate(const DeviceConfig& c) {
  const int expected = expected_axis_count(c.kind);
  if (expected == 0) fail(c, "kind", "is not a known device kind");
  if (static_cast<int>(c.axes.size()) != expected) {
    fail(c, "axes",
         std::string("must have ") + std::to_string(expected) + " entries for a " +
             to_string(c.kind) + " (got " + std::to_string(c.axes.size()) + ")");
  }
  for (std::size_t i = 0; i < c.axes.size(); ++i) {
    const std::string where =
        device_name(c) + ": axes[" + std::to_string(i) + "] '" + c.axes[i].name + "'";
    validate_axis(c.axes[i], where);
    // Every COB-ID (encoders and drives) used once on the bus.
    for (std::size_t j = 0; j < i; ++j) {
      const AxisConfig& a = c.axes[i];
      const AxisConfig& b = c.axes[j];
      const bool clash = a.encoder_cob_id == b.encoder_cob_id ||
                         a.encoder_cob_id == b.drive_cob_id ||
                         (a.has_drive() &&
                          (a.drive_cob_id == b.encoder_cob_id || a.drive_cob_id == b.drive_cob_id));
      if (clash) {
        throw std::invalid_argument(where + ": a COB-ID is already used by axes[" +
                                    std::to_string(j) + "] '" + b.name + "'");
      }
    }
  }
  if (!std::isfinite(c.control_period_s) || c.control_period_s <= 0.0) {
    fail(c, "control_period_s",
         "must be finite and > 0 (got " + std::to_string(c.control_period_s) + ")");
  }
  const double age = c.effective_max_sample_age_s();
  if (!std::isfinite(age) || age <= 0.0 || age > 1e6) {
    fail(c, "max_sample_age_s", "must be finite and > 0 (got " + std::to_string(age) + ")");
  }
  if (!std::isfinite(c.jump_tolerance_counts) || c.jump_tolerance_counts < 0.0) {
    fail(c, "jump_tolerance_counts",
         "must be finite and >= 0 (got " + std::to_string(c.jump_tolerance_counts) + ")");
  }
  const std::string prefix = device_name(c) + ": ";
  detail::checked_position(c.tool_offset.position, prefix + "tool_offset.position");
  detail::checked_unit_quaternion(c.tool_offset.orientation, prefix + "tool_offset.orientation");
  switch (c.kind) {
    case DeviceKind::kTrocarInstrument:
      detail::checked_position(c.trocar.point, prefix + "trocar.point");
      detail::checked_unit_quaternion(c.trocar.orientation, prefix + "trocar.orientation");
      break;
    case DeviceKind::kPoseTracker:
      detail::checked_position(c.tracker.base.position, prefix + "tracker.base.position");
      detail::checked_unit_quaternion(c.tracker.base.orientation,
                                      prefix + "tracker.base.orientation");
      break;
    case DeviceKind::kPhantom:
      detail::checked_position(c.phantom.base.position, prefix + "phantom.base.position");
      detail::checked_unit_quaternion(c.phantom.base.orientation,
                                      prefix + "phantom.base.orientation");
      if (!std::isfinite(c.phantom.l1) || c.phantom.l1 <= 0.0) {
        fail(c, "phantom.l1", "must be finite and > 0 (got " + std::to_string(c.phantom.l1) + ")");
      }
      if (!std::isfinite(c.phantom.l2) || c.phantom.l2 <= 0.0) {
        fail(c, "phantom.l2", "must be finite and > 0 (got " + std::to_string(c.phantom.l2) + ")");
      }
      break;
  }
}

DeviceConfig make_default_trocar_config(std::uint8_t first) {
  check_node_range(first, TrocarKinematics::kNumAxes, "make_default_trocar_config");
  const double per_rad = 16384.0 / (2.0 * kPi);  // 14-bit single-turn encoder
  const double per_m = 1e5;                      // 10 µm linear scale
  const auto n = [first](int i) { return static_cast<std::uint8_t>(first + i); };
  DeviceConfig c;
  c.name = "trocar_instrument";
  c.kind = DeviceKind::kTrocarInstrument;
  //                 name       node  drive counts  min    max    speed wraps rated max_torque
  c.axes.push_back(axis("pivot_x", n(0), true, per_rad, -1.2, 1.2, 10.0, false, 0.5, 1.0));
  c.axes.push_back(axis("pivot_y", n(1), true, per_rad, -1.2, 1.2, 10.0, false, 0.5, 1.0));
  c.axes.push_back(axis("depth", n(2), true, per_m, 0.0, 0.35, 2.0, false, 5.0, 10.0));
  c.axes.push_back(axis("roll", n(3), false, per_rad, -kPi, kPi, 30.0, true, 1.0, 0.0));
  c.axes.push_back(axis("jaw", n(4), false, per_rad, 0.0, 1.2, 30.0, false, 1.0, 0.0));
  return c;
}

DeviceConfig make_default_pose_tracker_config(std::uint8_t first) {
  check_node_range(first, PoseTrackerKinematics::kNumAxes, "make_default_pose_tracker_config");
  const auto n = [first](int i) { return static_cast<std::uint8_t>(first + i); };
  DeviceConfig c;
  c.name = "pose_tracker";
  c.kind = DeviceKind::kPoseTracker;
  const double um = 1e6;    // counts per m
  const double urad = 1e6;  // counts per rad
  c.axes.push_back(axis("x", n(0), false, um, -1.0, 1.0, 5.0, false, 1.0, 0.0));
  c.axes.push_back(axis("y", n(1), false, um, -1.0, 1.0, 5.0, false, 1.0, 0.0));
  c.axes.push_back(axis("z", n(2), false, um, -1.0, 1.0, 5.0, false, 1.0, 0.0));
  c.axes.push_back(axis("yaw", n(3), false, urad, -kPi, kPi, 30.0, true, 1.0, 0.0));
  c.axes.push_back(axis("pitch", n(4), false, urad, -kPi / 2, kPi / 2, 30.0, false, 1.0, 0.0));
  c.axes.push_back(axis("roll", n(5), false, urad, -kPi, kPi, 30.0, true, 1.0, 0.0));
  return c;
}

DeviceConfig make_default_phantom_config(std::uint8_t first) {
  check_node_range(first, PhantomKinematics::kNumAxes, "make_default_phantom_config");
  const double per_rad_arm = 65536.0 / (2.0 * kPi);     // motor encoders through the capstan
  const double per_rad_gimbal = 16384.0 / (2.0 * kPi);  // 14-bit gimbal encoders
  const auto n = [first](int i) { return static_cast<std::uint8_t>(first + i); };
  DeviceConfig c;
  c.name = "phantom";
  c.kind = DeviceKind::kPhantom;
  //                 name           node  drive  counts          min   max  speed wraps rated max
  c.axes.push_back(axis("turret", n(0), true, per_rad_arm, -1.0, 1.0, 10.0, false, 0.25, 1.0));
  c.axes.push_back(axis("shoulder", n(1), true, per_rad_arm, -0.8, 0.8, 10.0, false, 0.25, 1.0));
  c.axes.push_back(axis("elbow", n(2), true, per_rad_arm, -1.0, 0.7, 10.0, false, 0.25, 1.0));
  c.axes.push_back(
      axis("gimbal_yaw", n(3), false, per_rad_gimbal, -2.6, 2.6, 30.0, false, 1.0, 0.0));
  c.axes.push_back(
      axis("gimbal_pitch", n(4), false, per_rad_gimbal, -1.2, 1.2, 30.0, false, 1.0, 0.0));
  c.axes.push_back(
      axis("stylus_roll", n(5), false, per_rad_gimbal, -kPi, kPi, 30.0, true, 1.0, 0.0));
  return c;
}

}  // namespace numen::hal
