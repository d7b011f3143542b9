/// @file admittance_device.cpp

#include "numen/hal/device/admittance_device.hpp"

#include <algorithm>
#include <cmath>
#include <span>
#include <stdexcept>
#include <string>

#include "numen/hal/device/kinematics_factory.hpp"

namespace numen::hal {
namespace {

bool reserved_cob_id(std::uint32_t id) noexcept {
  return id < 0x001 || id > 0x7FF || (id >= 0x080 && id <= 0x0FF) || (id >= 0x700 && id <= 0x77F);
}

}  // namespace

AdmittanceConfig make_admittance_config(const DeviceConfig& device) {
  AdmittanceConfig a;
  for (const AxisConfig& axis : device.axes)
    a.rpdo_cob_ids.push_back(0x200u + (axis.encoder_cob_id - 0x180u));
  return a;
}

void validate(const DeviceConfig& device, const AdmittanceConfig& admittance) {
  const std::string name = device.name + ": admittance";
  if (admittance.rpdo_cob_ids.size() != device.axes.size())
    throw std::invalid_argument(
        name + ": rpdo_cob_ids has " + std::to_string(admittance.rpdo_cob_ids.size()) +
        " entries, the device " + std::to_string(device.axes.size()) + " axes");
  validate(admittance.sensor, name + " force_sensor");
  const std::uint32_t f = admittance.sensor.effective_force_cob_id();
  const std::uint32_t t = admittance.sensor.effective_torque_cob_id();
  for (std::size_t i = 0; i < admittance.rpdo_cob_ids.size(); ++i) {
    const std::uint32_t id = admittance.rpdo_cob_ids[i];
    const std::string where =
        name + ": axis " + device.axes[i].name + " rpdo_cob_id " + std::to_string(id);
    if (reserved_cob_id(id))
      throw std::invalid_argument(where + " is not a free 11-bit PDO COB-ID");
    if (id == f || id == t) throw std::invalid_argument(where + " is a force sensor COB-ID");
    for (std::size_t j = 0; j < device.axes.size(); ++j) {
      if (id == device.axes[j].encoder_cob_id)
        throw std::invalid_argument(where + " is the encoder COB-ID of axis " +
                                    device.axes[j].name);
      if (j < i && id == admittance.rpdo_cob_ids[j])
        throw std::invalid_argument(where + " is used twice");
    }
  }
  for (const AxisConfig& axis : device.axes)
    if (axis.encoder_cob_id == f || axis.encoder_cob_id == t)
      throw std::invalid_argument(name + ": force sensor COB-ID is the encoder COB-ID of axis " +
                                  axis.name);
}

AdmittanceDevice::AdmittanceDevice(DeviceConfig device, AdmittanceConfig admittance,
                                   const AxisVector& q0)
    : device_(std::move(device)),
      admittance_(std::move(admittance)),
      kinematics_(make_kinematics(device_)),  // validates the DeviceConfig
      sensor_(admittance_.sensor),
      rpdo_map_(csp_drive_rpdo_mapping()) {
  validate(device_, admittance_);
  const int n = kinematics_->num_axes();
  if (q0.size() != 0 && q0.size() != n)
    throw std::invalid_argument(device_.name + ": initial set-points have " +
                                std::to_string(q0.size()) + " entries, the device " +
                                std::to_string(n) + " axes");
  q_ = q0.size() == 0 ? AxisVector::Zero(n) : q0;
  for (int i = 0; i < n; ++i)
    counts_[static_cast<std::size_t>(i)] =
        value_to_counts(device_.axes[static_cast<std::size_t>(i)], q_[i]);
}

core::Wrench AdmittanceDevice::world_wrench(const core::Wrench& sensor_wrench,
                                            const core::Vec3& about) const noexcept {
  const core::Pose tool = kinematics_->forward(q_);
  const core::Pose& s = admittance_.sensor.sensor_in_tool;
  const core::Quat r = tool.orientation * s.orientation;
  const core::Vec3 origin = tool.position + tool.orientation * s.position;
  core::Wrench w;
  w.force = r * sensor_wrench.force;
  w.torque = r * sensor_wrench.torque + (origin - about).cross(w.force);
  return w;
}

const AxisVector& AdmittanceDevice::set_pose(const core::Pose& pose) noexcept {
  const AxisVector q = kinematics_->inverse(pose, q_);
  if (!q.allFinite()) {
    ++counters_.ik_rejected;
    return q_;
  }
  for (int i = 0; i < q_.size(); ++i) {
    const AxisConfig& a = device_.axes[static_cast<std::size_t>(i)];
    double v = q[i];
    if (v < a.min || v > a.max) {
      v = std::clamp(v, a.min, a.max);
      ++counters_.clamped_to_range;
    }
    const double step = a.max_speed * device_.control_period_s;
    const double d = axis_difference(v, q_[i], a.wraps);
    if (std::isfinite(step) && std::abs(d) > step) {
      v = q_[i] + std::copysign(step, d);
      if (a.wraps) v = wrap_angle(v);
      ++counters_.rate_limited;
    }
    q_[i] = v;
  }
  return q_;
}

void AdmittanceDevice::reset_setpoints(const AxisVector& q) noexcept {
  if (q.size() == q_.size()) q_ = q;
}

IoStatus AdmittanceDevice::write_setpoints(std::uint16_t controlword, Bus& bus,
                                           std::int64_t now_ns) noexcept {
  IoStatus first = IoStatus::kOk;
  for (int i = 0; i < q_.size(); ++i) {
    const auto k = static_cast<std::size_t>(i);
    counts_[k] = value_to_counts(device_.axes[k], q_[i]);
    const std::int64_t values[2] = {controlword, counts_[k]};
    CanFrame f;
    f.id = admittance_.rpdo_cob_ids[k];
    f.timestamp_ns = now_ns;
    rpdo_map_.pack(std::span<const std::int64_t>(values, 2), f);
    const IoStatus s = bus.write(f);
    if (s == IoStatus::kOk) {
      ++counters_.rpdos_written;
    } else {
      ++counters_.write_failures;
      if (first == IoStatus::kOk) first = s;
    }
  }
  return first;
}

}  // namespace numen::hal
