/// @file admittance_emulator.cpp

#include "numen/hal/emulation/admittance_emulator.hpp"

#include <cmath>
#include <span>
#include <stdexcept>

#include "numen/hal/canopen/canopen.hpp"
#include "numen/hal/canopen/cia402.hpp"
#include "numen/hal/device/force_sensor.hpp"
#include "numen/hal/device/kinematics_factory.hpp"

namespace numen::hal {

AdmittanceEmulator::AdmittanceEmulator(DeviceConfig device, AdmittanceConfig admittance)
    : device_(std::move(device)),
      admittance_(std::move(admittance)),
      kinematics_(make_kinematics(device_)),
      rpdo_map_(csp_drive_rpdo_mapping()) {
  validate(device_, admittance_);
  const int n = kinematics_->num_axes();
  q_ = AxisVector::Zero(n);
  qdot_ = AxisVector::Zero(n);
  commands_.torque = AxisVector::Zero(n);
  commands_.position_target = AxisVector::Zero(n);
}

void AdmittanceEmulator::set_axis_values(const AxisVector& q) noexcept {
  if (q.size() != q_.size()) return;
  q_ = q;
  commands_.position_target = q;
  qdot_.setZero();
}

void AdmittanceEmulator::on_sync(const CanFrame& frame, Bus& port) noexcept {
  if (const DeviceMotionState* s = move(frame.timestamp_ns, commands_)) {
    q_ = s->q;
    qdot_ = s->qdot;
    hand_wrench_ = s->handle_wrench;
  } else {
    qdot_.setZero();
    hand_wrench_ = core::Wrench{};
  }
  ++counters_.syncs;
  if (silent_) return;
  // Reported by the sensor: its frame, torque about its origin.
  const core::Pose dev = kinematics_->forward(q_);
  const core::Pose& sp = admittance_.sensor.sensor_in_tool;
  const core::Quat r = dev.orientation * sp.orientation;
  const core::Vec3 origin = dev.position + dev.orientation * sp.position;
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
    commands_.enabled[i] = enable ? 1 : 0;
    if (enable)
      commands_.position_target[static_cast<int>(i)] =
          counts_to_value(device_.axes[i], static_cast<std::int32_t>(v[1]));
    return;
  }
}

}  // namespace numen::hal
