/// @file admittance_hand.cpp
/// The motion of an emulated admittance device: drive lag and the hand's spring–damper.

#include "numen/sim/device/admittance_hand.hpp"

#include <cmath>
#include <stdexcept>

#include "numen/hal/device/axis.hpp"
#include "numen/hal/device/kinematics_factory.hpp"

namespace numen::sim {
namespace {

bool non_negative(double v) noexcept { return std::isfinite(v) && v >= 0.0; }

}  // namespace

AdmittanceHand::AdmittanceHand(const hal::DeviceConfig& device, const HandSettings& hand,
                               double lag_s)
    : device_(device),
      hand_settings_(hand),
      lag_s_(lag_s),
      kinematics_(hal::make_kinematics(device_)) {
  validate(hand, device_.name);
  if (!non_negative(lag_s))
    throw std::invalid_argument(device_.name + ": drive lag must be finite and >= 0");
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
  const double alpha = lag_s_ > 0.0 ? 1.0 - std::exp(-dt / lag_s_) : 1.0;
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
  state_.handle_wrench = hand_wrench(hand_settings_, hand_pose_, hand_twist_, dev,
                                     hal::twist_from_rates(kinematics_->jacobian(q), qdot));
  return state_;
}

}  // namespace numen::sim
