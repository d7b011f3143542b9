/// @file instrument_targets.cpp
/// An instrument sample into a Data's body targets and prescribed joints (instrument_targets.hpp).

#include "numen/sim/device/instrument_targets.hpp"

#include <algorithm>
#include <cmath>
#include <span>
#include <stdexcept>
#include <string>

#include "numen/hal/device/axis.hpp"
#include "numen/hal/device/kinematics_factory.hpp"
#include "numen/sim/device/trajectory_motion.hpp"
#include "numen/sim/scene/scene.hpp"

namespace numen::sim {

InstrumentTargets::InstrumentTargets(const Scene& scene)
    : config_(scene.device),
      kinematics_(hal::make_kinematics(scene.device)),
      binding_(scene.binding),
      explicit_bound_(platform::explicitly_bound_bodies(scene.binding, scene.model.num_bodies())) {
  if (binding_.links.empty()) binding_.links = platform::DeviceBinding::rigid().links;
}

hal::AxisVector InstrumentTargets::axes(const TrajectorySample& tool) const noexcept {
  return instrument_axes(config_, *kinematics_, tool);
}

void InstrumentTargets::set(const hal::AxisVector& q, const hal::AxisVector& qdot,
                            core::Data& data) const noexcept {
  const std::span<const std::uint8_t> bound(explicit_bound_);
  for (const platform::LinkBinding& b : binding_.links) {
    const core::Pose link = kinematics_->link_pose(b.link, q);
    const core::Twist twist = hal::twist_from_rates(kinematics_->link_jacobian(b.link, q), qdot);
    platform::apply_link_target(b, link, twist, data, bound, nullptr);
  }
  for (const platform::AxisPrescription& p : binding_.prescriptions)
    platform::apply_prescription(p, q(p.axis), qdot(p.axis), data);
}

void InstrumentTargets::set(const TrajectorySample& tool, core::Data& data) const noexcept {
  set(axes(tool), hal::AxisVector::Zero(num_axes()), data);
}

void InstrumentTargets::set(const TrajectorySample& tool, const TrajectorySample& later,
                            double interval, core::Data& data) const noexcept {
  const hal::AxisVector q = axes(tool);
  hal::AxisVector qdot = hal::AxisVector::Zero(num_axes());
  if (interval > 0.0) {
    const hal::AxisVector q1 = axes(later);
    for (int i = 0; i < num_axes(); ++i)
      qdot(i) = hal::axis_difference(q1(i), q(i), config_.axes[static_cast<std::size_t>(i)].wraps) /
                interval;
  }
  set(q, qdot, data);
}

void InstrumentTargets::set_at(const Trajectory& trajectory, double t, core::Data& data) const noexcept {
  const double h = trajectory.period();
  const bool moving = h > 0.0 && t < trajectory.duration();
  set(trajectory.at(t), trajectory.at(t + h), moving ? h : 0.0, data);
}

bool InstrumentTargets::held_body_target(const TrajectorySample& tool, const core::Data& data,
                                         core::Pose& pose) const noexcept {
  if (data.held_body < 0) return false;
  const std::span<const std::uint8_t> bound(explicit_bound_);
  const hal::AxisVector q = axes(tool);
  for (const platform::LinkBinding& b : binding_.links) {
    if (platform::bound_body(b, data, bound) != data.held_body) continue;
    core::Twist unused;
    platform::body_target_of(b, kinematics_->link_pose(b.link, q), core::Twist{}, pose, unused);
    return true;
  }
  return false;
}

bool InstrumentTargets::tool_in_held_body(const TrajectorySample& tool, const core::Data& data,
                                          core::Pose& pose) const noexcept {
  core::Pose body;
  if (!held_body_target(tool, data, body)) return false;
  const core::Quat to_body = body.orientation.conjugate();
  pose.position = to_body * (tool.pose.position - body.position);
  pose.orientation = to_body * tool.pose.orientation;
  return true;
}

FeedbackRamp::FeedbackRamp(double soft_start_s, double dt) {
  if (!(std::isfinite(soft_start_s) && soft_start_s >= 0.0) || !(std::isfinite(dt) && dt > 0.0))
    throw std::invalid_argument("FeedbackRamp: soft_start_s must be >= 0 and dt > 0 (s), got " +
                                std::to_string(soft_start_s) + " and " + std::to_string(dt));
  step_ = soft_start_s > 0.0 ? dt / soft_start_s : 0.0;
}

FeedbackRamp::FeedbackRamp(const Scene& scene)
    : FeedbackRamp(scene.device.soft_start_s, scene.model.dt) {}

core::Wrench FeedbackRamp::apply(const core::Data& data) noexcept {
  if ((data.status & core::kInvalidTarget) != 0) {
    // The step held the feedback: render the held wrench, ramp from it once targets come back.
    if (step_ > 0.0 && k_ >= 0) {
      k_ = -1;
      from_ = last_;
    }
    ramp_ = step_ > 0.0 ? 0.0 : 1.0;
    return last_ = step_ > 0.0 ? from_ : data.feedback_wrench;
  }
  if (step_ <= 0.0) {
    ramp_ = 1.0;
    return last_ = data.feedback_wrench;
  }
  if (k_ < 0) k_ = 0;
  ++k_;
  ramp_ = std::min(1.0, static_cast<double>(k_) * step_);
  last_.force = (1.0 - ramp_) * from_.force + ramp_ * data.feedback_wrench.force;
  last_.torque = (1.0 - ramp_) * from_.torque + ramp_ * data.feedback_wrench.torque;
  return last_;
}

void FeedbackRamp::restart() noexcept {
  k_ = 0;
  ramp_ = 0.0;
  from_ = core::Wrench{};
  last_ = core::Wrench{};
}

}  // namespace numen::sim
