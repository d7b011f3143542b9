/// @file admittance_hand.cpp
/// The motion of an emulated admittance device: drive lag and the hand's spring–damper.

#include "numen/sim/device/admittance_hand.hpp"

#include <cmath>
#include <stdexcept>

#include "numen/core/rigid_body.hpp"
#include "numen/hal/device/axis.hpp"
#include "numen/hal/device/kinematics_factory.hpp"

namespace numen::sim {
namespace {

bool non_negative(double v) noexcept { return std::isfinite(v) && v >= 0.0; }

}  // namespace

AdmittanceHand::AdmittanceHand(const hal::DeviceConfig& device,
                               const AdmittanceHandSettings& settings)
    : device_(device), settings_(settings), kinematics_(hal::make_kinematics(device_)) {
  if (!non_negative(settings.k_hand) || !non_negative(settings.c_hand) ||
      !non_negative(settings.k_hand_rot) || !non_negative(settings.c_hand_rot) ||
      !non_negative(settings.lag_s))
    throw std::invalid_argument(device_.name +
                                ": hand gains and drive lag must be finite and >= 0");
  const int n = kinematics_->num_axes();
  state_.q = hal::AxisVector::Zero(n);
  state_.qdot = hal::AxisVector::Zero(n);
  hand_pose_ = kinematics_->forward(state_.q);
}

void AdmittanceHand::set_axis_values(const hal::AxisVector& q) noexcept {
  if (q.size() != state_.q.size()) return;
  state_.q = q;
  state_.qdot.setZero();
}

void AdmittanceHand::set_hand(const core::Pose& pose, const core::Twist& twist) noexcept {
  hand_pose_ = pose;
  hand_twist_ = twist;
}

const hal::DeviceMotionState& AdmittanceHand::at_sync(std::int64_t t_ns,
                                                      const hal::DriveCommands& c) noexcept {
  const double dt = had_sync_ ? static_cast<double>(t_ns - last_sync_ns_) * 1e-9 : 0.0;
  last_sync_ns_ = t_ns;
  had_sync_ = true;
  hal::AxisVector& q = state_.q;
  hal::AxisVector& qdot = state_.qdot;
  const double alpha = settings_.lag_s > 0.0 ? 1.0 - std::exp(-dt / settings_.lag_s) : 1.0;
  for (int i = 0; i < q.size(); ++i) {
    const auto k = static_cast<std::size_t>(i);
    if (!c.enabled[k] || dt <= 0.0 || i >= c.position_target.size()) {
      qdot[i] = 0.0;
      continue;
    }
    const bool wraps = device_.axes[k].wraps;
    const double step = alpha * hal::axis_difference(c.position_target[i], q[i], wraps);
    q[i] = wraps ? hal::wrap_angle(q[i] + step) : q[i] + step;
    qdot[i] = step / dt;
  }
  // The hand's spring–damper on the handle (controlled frame), world.
  const core::Pose dev = kinematics_->forward(q);
  const hal::Jacobian j = kinematics_->jacobian(q);
  const core::Vec6 twist = j * qdot;
  const core::Vec3 v_dev = twist.head<3>();
  const core::Vec3 w_dev = twist.tail<3>();
  core::Wrench& w = state_.handle_wrench;
  w.force = settings_.k_hand * (hand_pose_.position - dev.position) +
            settings_.c_hand * (hand_twist_.linear - v_dev);
  w.torque =
      settings_.k_hand_rot * core::quat_log(hand_pose_.orientation * dev.orientation.conjugate()) +
      settings_.c_hand_rot * (hand_twist_.angular - w_dev);
  return state_;
}

}  // namespace numen::sim
