/// @file device_config.cpp
/// DeviceConfig validation and the default trocar / pose tracker / phantom configurations.

#include "numen/hal/device/device_config.hpp"

#include <cmath>
#include <cstdio>
#include <numbers>
#include <stdexcept>
#include <string>
#include <string_view>

#include "../hex_text.hpp"
#include "geometry_check.hpp"
#include "numen/hal/canopen/canopen.hpp"
#include "numen/hal/canopen/emcy.hpp"
#include "numen/hal/canopen/heartbeat.hpp"
#include "numen/hal/canopen/nmt.hpp"

namespace numen::hal {
namespace {

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

using detail::hex_cob_id;

// A COB-ID a PDO must not use in the managed stack: NMT, SYNC / EMCY, heartbeat.
bool reserved_cob_id(std::uint32_t id) noexcept {
  return id == kNmtCobId || (id >= kSyncCobId && id <= kEmcyBaseCobId + kMaxNodeId) ||
         (id >= kHeartbeatBaseCobId && id <= kHeartbeatBaseCobId + kMaxNodeId);
}

// Builds the mapping (PdoMapping validates it) and checks its required objects.
void check_mapping(const std::vector<PdoEntry>& entries, const std::string& where,
                   std::initializer_list<PdoEntry> required,
                   std::initializer_list<PdoEntry> allowed, bool position_either) {
  try {
    const PdoMapping m(std::span<const PdoEntry>(entries.data(), entries.size()), where);
    (void)m;
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(where + ": " + e.what());
  }
  auto name = [](const PdoEntry& e) {
    char buf[24];
    std::snprintf(buf, sizeof buf, "0x%04X:%02X", e.index, e.subindex);
    return std::string(buf);
  };
  for (const PdoEntry& e : entries) {
    bool ok = false;
    for (const PdoEntry& a : allowed) ok = ok || mapping_entry_value(a) == mapping_entry_value(e);
    if (!ok) {
      throw std::invalid_argument(where + ": object " + name(e) + " (" +
                                  std::to_string(e.bit_length) +
                                  " bits) cannot be mapped here (see docs/scenes.md)");
    }
  }
  const std::span<const PdoEntry> span(entries.data(), entries.size());
  if (position_either) {
    if (find_mapped(span, PdoObject::kPositionValue) < 0 &&
        find_mapped(span, PdoObject::kPositionActualValue) < 0) {
      throw std::invalid_argument(where +
                                  ": must map the position value 0x6004:00 or the position "
                                  "actual value 0x6064:00 (32 bits)");
    }
    if (find_mapped(span, PdoObject::kPositionValue) >= 0 &&
        find_mapped(span, PdoObject::kPositionActualValue) >= 0) {
      throw std::invalid_argument(where + ": maps both 0x6004:00 and 0x6064:00 (one position)");
    }
  }
  for (const PdoEntry& r : required) {
    if (find_mapped(span, r) < 0) {
      throw std::invalid_argument(where + ": must map object " + name(r));
    }
  }
}

void validate_canopen(const DeviceConfig& c) {
  const CanopenConfig& co = c.canopen;
  if (!co.managed) return;
  const std::string dev = device_name(c) + ": canopen";
  if (co.axes.size() != c.axes.size()) {
    throw std::invalid_argument(dev + ".axes must have one entry per axis (" +
                                std::to_string(c.axes.size()) + "), got " +
                                std::to_string(co.axes.size()));
  }
  if (co.controller_node_id < 1 || co.controller_node_id > kMaxNodeId) {
    throw std::invalid_argument(dev + ".controller_node_id must be in 1..127 (got " +
                                std::to_string(co.controller_node_id) + ")");
  }
  if (co.controller_heartbeat_period_ms < 1) {
    throw std::invalid_argument(dev + ".controller_heartbeat_period_ms must be >= 1");
  }
  if (co.effective_drive_heartbeat_timeout_ms() <= co.controller_heartbeat_period_ms) {
    throw std::invalid_argument(dev + ".drive_heartbeat_timeout_ms (" +
                                std::to_string(co.effective_drive_heartbeat_timeout_ms()) +
                                ") must exceed the controller heartbeat period (" +
                                std::to_string(co.controller_heartbeat_period_ms) + " ms)");
  }
  if (co.startup_timeout_ms < 1)
    throw std::invalid_argument(dev + ".startup_timeout_ms must be >= 1");
  if (co.startup_retry_ms < 1) throw std::invalid_argument(dev + ".startup_retry_ms must be >= 1");
  if (co.sdo_timeout_ms < 1) throw std::invalid_argument(dev + ".sdo_timeout_ms must be >= 1");
  std::vector<std::uint32_t> ids;  // every PDO COB-ID, to find duplicates
  std::vector<std::string> owners;
  for (std::size_t i = 0; i < co.axes.size(); ++i) {
    const CanopenAxisConfig& x = co.axes[i];
    const AxisConfig& a = c.axes[i];
    const std::string where = dev + ".axes[" + std::to_string(i) + "] '" + a.name + "'";
    if (x.node_id < 1 || x.node_id > kMaxNodeId) {
      throw std::invalid_argument(where + ": node_id must be in 1..127 (got " +
                                  std::to_string(x.node_id) + ")");
    }
    if (x.node_id == co.controller_node_id) {
      throw std::invalid_argument(where + ": node_id " + std::to_string(x.node_id) +
                                  " is the controller's node id");
    }
    if (x.heartbeat_period_ms < 1) {
      throw std::invalid_argument(where + ": heartbeat_period_ms must be >= 1");
    }
    if (x.effective_heartbeat_timeout_ms() <= x.heartbeat_period_ms) {
      throw std::invalid_argument(
          where + ": heartbeat_timeout_ms (" + std::to_string(x.effective_heartbeat_timeout_ms()) +
          ") must exceed heartbeat_period_ms (" + std::to_string(x.heartbeat_period_ms) + ")");
    }
    for (std::size_t j = 0; j < i; ++j) {
      const CanopenAxisConfig& y = co.axes[j];
      if (y.node_id == x.node_id &&
          (y.heartbeat_period_ms != x.heartbeat_period_ms ||
           y.effective_heartbeat_timeout_ms() != x.effective_heartbeat_timeout_ms())) {
        throw std::invalid_argument(where + ": node " + std::to_string(x.node_id) +
                                    " is shared with axes[" + std::to_string(j) +
                                    "] but its heartbeat period / timeout differ");
      }
    }
    check_mapping(x.encoder_tpdo, where + ".encoder_tpdo", {},
                  {PdoObject::kPositionValue, PdoObject::kPositionValueUnsigned,
                   PdoObject::kPositionActualValue, PdoObject::kStatusword,
                   PdoObject::kTorqueActualValue, PdoObject::kModesOfOperationDisplay},
                  true);
    ids.push_back(a.encoder_cob_id);
    owners.push_back(where + " encoder TPDO");
    if (a.has_drive()) {
      if (x.drive_tpdo_cob_id == 0 || x.drive_tpdo_cob_id > kStandardIdMask) {
        throw std::invalid_argument(where +
                                    ": drive_tpdo_cob_id must be an 11-bit COB-ID on a "
                                    "driven axis (got " +
                                    hex_cob_id(x.drive_tpdo_cob_id) + ")");
      }
      check_mapping(
          x.drive_rpdo, where + ".drive_rpdo", {PdoObject::kControlword, PdoObject::kTargetTorque},
          {PdoObject::kControlword, PdoObject::kTargetTorque, PdoObject::kModesOfOperation}, false);
      check_mapping(x.drive_tpdo, where + ".drive_tpdo", {PdoObject::kStatusword},
                    {PdoObject::kStatusword, PdoObject::kTorqueActualValue,
                     PdoObject::kModesOfOperationDisplay, PdoObject::kPositionActualValue},
                    false);
      ids.push_back(a.drive_cob_id);
      owners.push_back(where + " drive RPDO");
      ids.push_back(x.drive_tpdo_cob_id);
      owners.push_back(where + " drive TPDO");
    } else if (x.drive_tpdo_cob_id != 0) {
      throw std::invalid_argument(where + ": drive_tpdo_cob_id " + hex_cob_id(x.drive_tpdo_cob_id) +
                                  " on an axis without a drive (drive_cob_id = 0)");
    }
  }
  for (std::size_t i = 0; i < ids.size(); ++i) {
    if (reserved_cob_id(ids[i])) {
      throw std::invalid_argument(owners[i] + ": COB-ID " + hex_cob_id(ids[i]) +
                                  " is reserved in the managed stack (NMT 0x000, SYNC/EMCY "
                                  "0x080-0x0FF, heartbeat 0x700-0x77F)");
    }
    for (std::size_t j = 0; j < i; ++j) {
      if (ids[i] == ids[j]) {
        throw std::invalid_argument(owners[i] + ": COB-ID " + hex_cob_id(ids[i]) +
                                    " is already used by the " + owners[j]);
      }
    }
  }
}

}  // namespace

CanopenAxisConfig make_canopen_axis(std::uint8_t node_id, bool has_drive) {
  CanopenAxisConfig x;
  x.node_id = node_id;
  const PdoMapping enc = encoder_tpdo_mapping();
  x.encoder_tpdo.assign(enc.entries().begin(), enc.entries().end());
  if (has_drive) {
    x.drive_tpdo_cob_id = kTpdo2BaseCobId + node_id;
    const PdoMapping rx = drive_rpdo_mapping();
    const PdoMapping tx = drive_tpdo_mapping();
    x.drive_rpdo.assign(rx.entries().begin(), rx.entries().end());
    x.drive_tpdo.assign(tx.entries().begin(), tx.entries().end());
  }
  return x;
}

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

const char* to_string(VelocityEstimator estimator) noexcept {
  switch (estimator) {
    case VelocityEstimator::kDifference:
      return "difference";
    case VelocityEstimator::kFilter:
      return "filter";
    case VelocityEstimator::kFoaw:
      return "foaw";
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
  if (std::isnan(c.velocity_cutoff_hz) || c.velocity_cutoff_hz <= 0.0) {
    fail(c, "velocity_cutoff_hz",
         "must be > 0 Hz (+inf: no filter) (got " + std::to_string(c.velocity_cutoff_hz) + ")");
  }
  if (std::string_view(to_string(c.velocity_estimator)) == "unknown") {
    fail(c, "velocity_estimator",
         "must be difference, filter or foaw (got " +
             std::to_string(static_cast<int>(c.velocity_estimator)) + ")");
  }
  if (c.foaw_max_window < 1 || c.foaw_max_window > kFoawMaxWindow) {
    fail(c, "foaw_max_window",
         "must be in [1, " + std::to_string(kFoawMaxWindow) + "] sample intervals (got " +
             std::to_string(c.foaw_max_window) + ")");
  }
  if (!std::isfinite(c.foaw_noise_counts) || c.foaw_noise_counts < 0.0) {
    fail(c, "foaw_noise_counts",
         "must be finite and >= 0 counts (got " + std::to_string(c.foaw_noise_counts) + ")");
  }
  if (!std::isfinite(c.passivity.velocity_threshold) || c.passivity.velocity_threshold < 0.0)
    fail(c, "passivity.velocity_threshold",
         "must be finite and >= 0 (got " + std::to_string(c.passivity.velocity_threshold) + ")");
  if (!(c.passivity.energy_limit > 0.0))
    fail(c, "passivity.energy_limit",
         "must be > 0 J (+inf: no limit) (got " + std::to_string(c.passivity.energy_limit) + ")");
  if (!std::isfinite(c.soft_start_s) || c.soft_start_s < 0.0 || c.soft_start_s > kMaxSoftStartS) {
    fail(c, "soft_start_s",
         "must be finite and in [0, 10] s (got " + std::to_string(c.soft_start_s) + ")");
    static_assert(kMaxSoftStartS == 10.0, "the message above names the bound");
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
  validate_canopen(c);
}

namespace {
// One CANopen entry per axis: node first + i, drives where the axis has one.
void add_canopen(DeviceConfig& c, std::uint8_t first) {
  c.canopen.axes.clear();
  for (std::size_t i = 0; i < c.axes.size(); ++i) {
    c.canopen.axes.push_back(
        make_canopen_axis(static_cast<std::uint8_t>(first + i), c.axes[i].has_drive()));
  }
}
}  // namespace

DeviceConfig make_default_trocar_config(std::uint8_t first) {
  check_node_range(first, TrocarKinematics::kNumAxes, "make_default_trocar_config");
  const double per_rad = 16384.0 / (2.0 * std::numbers::pi);  // 14-bit single-turn encoder
  const double per_m = 1e5;                      // 10 µm linear scale
  const auto n = [first](int i) { return static_cast<std::uint8_t>(first + i); };
  DeviceConfig c;
  c.name = "trocar_instrument";
  c.kind = DeviceKind::kTrocarInstrument;
  //                 name       node  drive counts  min    max    speed wraps rated max_torque
  c.axes.push_back(axis("pivot_x", n(0), true, per_rad, -1.2, 1.2, 10.0, false, 0.5, 1.0));
  c.axes.push_back(axis("pivot_y", n(1), true, per_rad, -1.2, 1.2, 10.0, false, 0.5, 1.0));
  c.axes.push_back(axis("depth", n(2), true, per_m, 0.0, 0.35, 2.0, false, 5.0, 10.0));
  c.axes.push_back(axis("roll", n(3), false, per_rad, -std::numbers::pi, std::numbers::pi, 30.0,
                        true, 1.0, 0.0));
  // jaw: one turn of its single-turn encoder; recorded gripper angles go negative (squeeze).
  c.axes.push_back(axis("jaw", n(4), false, per_rad, -std::numbers::pi, std::numbers::pi, 30.0,
                        false, 1.0, 0.0));
  add_canopen(c, first);
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
  c.axes.push_back(
      axis("yaw", n(3), false, urad, -std::numbers::pi, std::numbers::pi, 30.0, true, 1.0, 0.0));
  c.axes.push_back(axis("pitch", n(4), false, urad, -std::numbers::pi / 2, std::numbers::pi / 2,
                        30.0, false, 1.0, 0.0));
  c.axes.push_back(
      axis("roll", n(5), false, urad, -std::numbers::pi, std::numbers::pi, 30.0, true, 1.0, 0.0));
  add_canopen(c, first);
  return c;
}

DeviceConfig make_default_phantom_config(std::uint8_t first) {
  check_node_range(first, PhantomKinematics::kNumAxes, "make_default_phantom_config");
  const double per_rad_arm =
      65536.0 / (2.0 * std::numbers::pi);  // motor encoders through the capstan
  const double per_rad_gimbal = 16384.0 / (2.0 * std::numbers::pi);  // 14-bit gimbal encoders
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
  c.axes.push_back(axis("stylus_roll", n(5), false, per_rad_gimbal, -std::numbers::pi,
                        std::numbers::pi, 30.0, true, 1.0, 0.0));
  add_canopen(c, first);
  return c;
}

}  // namespace numen::hal
