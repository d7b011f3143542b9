/// @file trajectory_motion.cpp
/// The replayed hand of an emulated impedance instrument.

#include "numen/sim/device/trajectory_motion.hpp"

#include "numen/hal/device/kinematics_factory.hpp"
#include "numen/hal/device/trocar_kinematics.hpp"
#include "numen/sim/device/hand_servo.hpp"

namespace numen::sim {

hal::AxisVector instrument_axes(const hal::DeviceConfig& config, const hal::Kinematics& kinematics,
                                const TrajectorySample& s) noexcept {
  if (config.kind == hal::DeviceKind::kTrocarInstrument)
    return static_cast<const hal::TrocarKinematics&>(kinematics).inverse_tool(s.pose, s.jaw);
  core::Pose controlled;  // tracked frame · tool_offset
  controlled.position = s.pose.position + s.pose.orientation * config.tool_offset.position;
  controlled.orientation = s.pose.orientation * config.tool_offset.orientation;
  return kinematics.inverse(controlled, hal::AxisVector());
}

TrajectoryMotion::TrajectoryMotion(const hal::DeviceConfig& config, const Trajectory& trajectory,
                                   std::int64_t start_ns)
    : config_(config),
      trajectory_(&trajectory),
      start_ns_(start_ns),
      kinematics_(hal::make_kinematics(config)) {
  const int n = kinematics_->num_axes();
  state_.q = hal::AxisVector::Zero(n);
  state_.qdot = hal::AxisVector::Zero(n);
}

hal::AxisVector TrajectoryMotion::axes_at(std::int64_t t_ns) const noexcept {
  TrajectorySample s = trajectory_->at(static_cast<double>(t_ns - start_ns_) * 1e-9);
  if (servo_) s.pose.position += servo_->offset();
  return instrument_axes(config_, *kinematics_, s);
}

const hal::DeviceMotionState& TrajectoryMotion::at_sync(std::int64_t t_ns,
                                                        const hal::DriveCommands& commands) noexcept {
  (void)commands;  // a rigid hand: the drives' torques do not move it
  if (start_at_sync_) {
    start_ns_ = t_ns;
    start_at_sync_ = false;
  }
  state_.q = axes_at(t_ns);
  return state_;
}

}  // namespace numen::sim
