/// @file admittance_device.cpp

#include "numen/hal/device/admittance_device.hpp"

#include <algorithm>
#include <cmath>
#include <span>
#include <stdexcept>
#include <string>

#include "numen/hal/canopen/cia402.hpp"
#include "numen/core/feedback.hpp"
#include "numen/hal/device/kinematics_factory.hpp"

namespace numen::hal {
namespace {

bool reserved_admittance_cob_id(std::uint32_t id) noexcept {
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
    if (reserved_admittance_cob_id(id))
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

namespace {

const LifecycleSettings& lifecycle_settings(const std::string& name, const AdmittanceSettings& s) {
  if (s.force_timeout_periods == 0)
    throw std::invalid_argument(name + ": force_timeout_periods must be >= 1");
  if (s.safe_stop_timeout_periods == 0)
    throw std::invalid_argument(name + ": safe_stop_timeout_periods must be >= 1");
  return s;  // the lifecycle's settings are the base of the device's
}

}  // namespace

AdmittanceDevice::AdmittanceDevice(DeviceConfig device, AdmittanceConfig admittance, Bus& bus,
                                   const AxisVector& q0, const AdmittanceSettings& settings)
    : Device(bus),
      device_(std::move(device)),
      admittance_(std::move(admittance)),
      settings_(settings),
      kinematics_(make_kinematics(device_)),  // validates the DeviceConfig
      sensor_(admittance_.sensor),
      rpdo_map_(csp_drive_rpdo_mapping()),
      lifecycle_(lifecycle_settings(device_.name, settings)) {
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
  lifecycle_.configure();  // kUnconfigured → kInactive: read and supervised, drives disabled
}

DeviceSupervision AdmittanceDevice::supervise(std::int64_t now_ns, bool overrun) noexcept {
  const std::uint64_t period = periods_++;
  overrun_streak_ = overrun ? overrun_streak_ + 1 : 0;
  if (!sample_.valid) ++counters_.invalid_periods;
  const bool out_of_range = (sample_.faults & SampleFault::kOutOfRange) != 0;
  const bool timed_out = sample_.periods_since_valid >= settings_.force_timeout_periods;
  const bool overruns = settings_.overrun_limit > 0 && overrun_streak_ >= settings_.overrun_limit;
  LifecycleInputs in;
  in.fault = out_of_range || timed_out || overruns;
  in.cause_present = !sample_.valid || overruns;
  in.drives_disabled = disable_sent_;
  const LifecycleUpdate u = lifecycle_.update(now_ns, in);
  DeviceSupervision out;
  out.entered_safe_stop = u.entered_safe_stop;
  if (u.entered_safe_stop && !has_first_fault_) {
    // Several at once: the first of out of range, timeout, overruns.
    first_fault_ = FaultRecord{};
    first_fault_.cause = out_of_range ? FaultCause::kForceOutOfRange
                         : timed_out  ? FaultCause::kForceTimeout
                                      : FaultCause::kOverruns;
    first_fault_.value = out_of_range ? static_cast<double>(sample_.faults)
                         : timed_out  ? static_cast<double>(sample_.periods_since_valid)
                                      : static_cast<double>(overrun_streak_);
    first_fault_.time_ns = now_ns;
    first_fault_.period = period;
    first_fault_.latched = true;
    has_first_fault_ = true;
  }
  if (rearm_pending_ && lifecycle_.state() == LifecycleState::kFault &&
      lifecycle_.rearm() == LifecycleResult::kOk) {
    rearm_pending_ = false;
    has_first_fault_ = false;
  }
  if (!shutting_down() && !activation_held() && settings_.auto_activate &&
      lifecycle_.state() == LifecycleState::kInactive && sample_.valid) {
    out.activated = lifecycle_.activate() == LifecycleResult::kOk;
  }
  out.lifecycle = lifecycle_.state();
  return out;
}

RearmResult AdmittanceDevice::rearm() noexcept {
  if (!lifecycle_.latched()) return RearmResult::kNotLatched;
  rearm_pending_ = true;
  return RearmResult::kAccepted;
}

void AdmittanceDevice::on_shutdown() noexcept {
  rearm_pending_ = false;
  if (lifecycle_.state() == LifecycleState::kActive) (void)lifecycle_.deactivate();
}

IoStatus AdmittanceDevice::write_pose(const core::Pose* pose, std::int64_t now_ns) noexcept {
  const bool active = lifecycle_.state() == LifecycleState::kActive && !shutting_down();
  if (active) {
    if (pose != nullptr) set_pose(*pose);
    controlword_ = Controlword::kEnableOperation;
    disable_sent_ = false;
  } else {
    controlword_ = Controlword::kShutdown;
    ++counters_.hold_periods;
  }
  const IoStatus s = write_setpoints(controlword_, now_ns);
  note(s);
  if (!active && s == IoStatus::kOk) disable_sent_ = true;
  return s;
}

core::Wrench AdmittanceDevice::sensor_to_world(const core::Wrench& sensor_wrench,
                                               core::Vec3& origin) const noexcept {
  const core::Pose tool = kinematics_->forward(q_);
  const core::Pose& s = admittance_.sensor.sensor_in_tool;
  const core::Quat r = tool.orientation * s.orientation;
  origin = tool.position + tool.orientation * s.position;
  core::Wrench w;
  w.force = r * sensor_wrench.force;
  w.torque = r * sensor_wrench.torque;
  return w;
}

core::Wrench AdmittanceDevice::world_wrench(const core::Wrench& sensor_wrench,
                                            const core::Vec3& about) const noexcept {
  core::Vec3 origin;
  const core::Wrench w = sensor_to_world(sensor_wrench, origin);
  return core::carry_wrench(w, origin, about);
}

void AdmittanceDevice::end_read(std::int64_t now_ns, DeviceState& state) noexcept {
  sample_ = sensor_.sample(now_ns);
  state.valid = sample_.valid;
  state.ready = true;
  state.faults = sample_.faults;
  state.wrench = sensor_to_world(sample_.wrench, state.wrench_point);
}

const DeviceOutput& AdmittanceDevice::write(const DeviceCommand& command, std::int64_t now_ns) noexcept {
  output_.status = write_pose(command.pose, now_ns);
  output_.controlword = controlword_;
  output_.gated = controlword_ != Controlword::kEnableOperation;
  output_.torque_commanded = false;
  output_.ramp = 1.0;
  return output_;
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

IoStatus AdmittanceDevice::write_setpoints(std::uint16_t controlword,
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
    const IoStatus s = bus_->write(f);
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
