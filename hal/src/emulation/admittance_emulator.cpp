/// @file admittance_emulator.cpp

#include "numen/hal/emulation/admittance_emulator.hpp"

#include <cmath>
#include <span>
#include <stdexcept>

#include "numen/core/rigid_body.hpp"
#include "numen/hal/canopen/canopen.hpp"
#include "numen/hal/canopen/cia402.hpp"
#include "numen/hal/device/force_sensor.hpp"
#include "numen/hal/device/kinematics_factory.hpp"

namespace numen::hal {
namespace {

bool non_negative(double v) noexcept { return std::isfinite(v) && v >= 0.0; }

}  // namespace

AdmittanceEmulator::AdmittanceEmulator(DeviceConfig device, AdmittanceConfig admittance,
                                       const AdmittanceEmulatorSettings& settings)
    : device_(std::move(device)),
      admittance_(std::move(admittance)),
      settings_(settings),
      kinematics_(make_kinematics(device_)),
      rpdo_map_(csp_drive_rpdo_mapping()) {
  validate(device_, admittance_);
  if (!non_negative(settings.k_hand) || !non_negative(settings.c_hand) ||
      !non_negative(settings.k_hand_rot) || !non_negative(settings.c_hand_rot) ||
      !non_negative(settings.lag_s))
    throw std::invalid_argument(device_.name +
                                ": hand gains and drive lag must be finite and >= 0");
  const int n = kinematics_->num_axes();
  q_ = AxisVector::Zero(n);
  qdot_ = AxisVector::Zero(n);
  target_ = AxisVector::Zero(n);
  hand_pose_ = kinematics_->forward(q_);
}

void AdmittanceEmulator::set_axis_values(const AxisVector& q) noexcept {
  if (q.size() != q_.size()) return;
  q_ = q;
  target_ = q;
  qdot_.setZero();
}

void AdmittanceEmulator::set_hand(const core::Pose& pose, const core::Twist& twist) noexcept {
  hand_pose_ = pose;
  hand_twist_ = twist;
}

void AdmittanceEmulator::on_sync(const CanFrame& frame, Bus& port) noexcept {
  const double dt =
      had_sync_ ? static_cast<double>(frame.timestamp_ns - last_sync_ns_) * 1e-9 : 0.0;
  last_sync_ns_ = frame.timestamp_ns;
  had_sync_ = true;
  const double alpha = settings_.lag_s > 0.0 ? 1.0 - std::exp(-dt / settings_.lag_s) : 1.0;
  for (int i = 0; i < q_.size(); ++i) {
    if (!enabled_[static_cast<std::size_t>(i)] || dt <= 0.0) {
      qdot_[i] = 0.0;
      continue;
    }
    const bool wraps = device_.axes[static_cast<std::size_t>(i)].wraps;
    const double step = alpha * axis_difference(target_[i], q_[i], wraps);
    q_[i] = wraps ? wrap_angle(q_[i] + step) : q_[i] + step;
    qdot_[i] = step / dt;
  }
  // The hand's spring–damper on the handle (controlled frame), world.
  const core::Pose dev = kinematics_->forward(q_);
  const Jacobian j = kinematics_->jacobian(q_);
  const core::Vec6 twist = j * qdot_;
  const core::Vec3 v_dev = twist.head<3>();
  const core::Vec3 w_dev = twist.tail<3>();
  hand_wrench_.force = settings_.k_hand * (hand_pose_.position - dev.position) +
                       settings_.c_hand * (hand_twist_.linear - v_dev);
  hand_wrench_.torque =
      settings_.k_hand_rot * core::quat_log(hand_pose_.orientation * dev.orientation.conjugate()) +
      settings_.c_hand_rot * (hand_twist_.angular - w_dev);
  ++counters_.syncs;
  if (silent_) return;
  // Reported by the sensor: its frame, torque about its origin.
  const core::Pose& s = admittance_.sensor.sensor_in_tool;
  const core::Quat r = dev.orientation * s.orientation;
  const core::Vec3 origin = dev.position + dev.orientation * s.position;
  core::Wrench in_sensor;
  in_sensor.force = r.conjugate() * hand_wrench_.force;
  in_sensor.torque =
      r.conjugate() * (hand_wrench_.torque + (dev.position - origin).cross(hand_wrench_.force));
  CanFrame f, t;
  encode_force_tpdos(admittance_.sensor, in_sensor, frame.timestamp_ns, f, t);
  if (port.write(f) != IoStatus::kOk) ++counters_.tx_failed;
  if (port.write(t) != IoStatus::kOk) ++counters_.tx_failed;
}

void AdmittanceEmulator::on_frame(const CanFrame& frame, Bus& device_port) noexcept {
  if (is_sync(frame)) {
    on_sync(frame, device_port);
    return;
  }
  for (std::size_t i = 0; i < admittance_.rpdo_cob_ids.size(); ++i) {
    if (!has_standard_id(frame, admittance_.rpdo_cob_ids[i])) continue;
    std::array<std::int64_t, 2> v{};
    if (rpdo_map_.unpack(frame, std::span<std::int64_t>(v.data(), v.size())) != PdoStatus::kOk) {
      ++counters_.rpdos_rejected;
      return;
    }
    ++counters_.rpdos;
    const auto cw = static_cast<std::uint16_t>(v[0]);
    const bool enable = decode_controlword(cw) == ControlCommand::kEnableOperation;
    enabled_[i] = enable ? 1 : 0;
    if (enable)
      target_[static_cast<int>(i)] =
          counts_to_value(device_.axes[i], static_cast<std::int32_t>(v[1]));
    return;
  }
}

int AdmittanceEmulator::poll(Bus& device_port, int max_frames) noexcept {
  int n = 0;
  CanFrame frame;
  while (n < max_frames && device_port.read(frame) == IoStatus::kOk) {
    on_frame(frame, device_port);
    ++n;
  }
  return n;
}

}  // namespace numen::hal
