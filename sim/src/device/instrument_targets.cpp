/// @file instrument_targets.cpp
/// An instrument sample into a Data's body targets and prescribed joints (instrument_targets.hpp).

#include "numen/sim/device/instrument_targets.hpp"

#include <span>

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

}  // namespace numen::sim
