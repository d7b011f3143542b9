#pragma once
/// @file device_sample.hpp
/// hal::DeviceSample: one checked sample of an instrument's encoders — its axis values, rates
/// and displacements, the poses and twists of its links, the checks that failed — as
/// InstrumentDevice::sample() decodes it, once. The device face's period state
/// (hal::DeviceState, device_state.hpp) holds it: an impedance device's read() assigns the
/// sample there whole, not field by field.

#include <array>
#include <cstdint>

#include "numen/core/types.hpp"
#include "numen/hal/device/kinematics.hpp"
#include "numen/hal/device/sample_check.hpp"

namespace numen::hal {

/// The outcome of one InstrumentDevice::sample().
struct DeviceSample {
  /// True if every axis has an accepted value and no check failed this period: the pose is
  /// fresh and plausible.
  bool valid = false;
  /// True once every axis has had at least one accepted value (the pose is meaningful; it
  /// may be held from an earlier period if `valid` is false).
  bool ready = false;
  /// Controlled frame's pose, world (hal's name for it: the loop binds it as the god-object's
  /// target). Always finite; built from the last accepted axis values (0 clamped into
  /// [min, max] for an axis without one). link_poses[0].
  core::Pose pose;
  /// Controlled frame's twist, world: J(q) q̇. q̇ of an axis is the estimate of
  /// DeviceConfig::velocity_estimator from the accepted values, bounded by the axis's
  /// max_speed: the backward difference, or it low-pass filtered at
  /// DeviceConfig::velocity_cutoff_hz (RateEstimator, rate_estimator.hpp), or the adaptive
  /// window's end-fit slope (FoawEstimator, foaw_estimator.hpp). It is 0 before two accepted
  /// values; held through a rejected or missing value while the held value is fresh; 0 (and
  /// the estimator restarted) once the held value is stale.
  core::Twist twist;
  /// Number of links of the kinematics (Kinematics::num_links(), 1..kMaxLinks): entries
  /// [0, num_links) of link_poses and link_twists are valid, the others are left default.
  int num_links = 1;
  /// Pose of each link, world: Kinematics::link_pose(l, q), from the same held axis values as
  /// `pose`. link_poses[0] == pose.
  std::array<core::Pose, kMaxLinks> link_poses{};
  /// Twist of each link, world, linear part at the link's origin: J_l(q) q̇ with
  /// J_l = Kinematics::link_jacobian(l, q). link_twists[0] == twist.
  std::array<core::Twist, kMaxLinks> link_twists{};
  /// Axis values used for `pose`, m or rad (n entries).
  AxisVector q;
  /// Axis rates used for `twist`, m/s or rad/s (n entries): the estimates described at
  /// `twist`, |q̇_i| <= axes[i].max_speed. The one speed estimate of an axis.
  AxisVector qdot;
  /// The period's displacement of each axis, m or rad (n entries): q of this sample minus q of
  /// the last one (the short way across ±π on a wrapping axis), 0 when the last sample was not
  /// valid (and after construction or reset()). Not a speed estimate: the motion of the values
  /// the control periods used, from one period to the next — the flow Δq_i = v_i T of
  /// the passivity observer's port (Hannaford & Ryu's E −= τ Δq; ImpedanceDevice::write()),
  /// which must see every step the rendered torque was applied over, unfiltered.
  AxisVector dq;
  /// Union of the failed checks over all axes this period (SampleFault bits).
  FaultMask faults = SampleFault::kNone;
  /// Failed checks per axis this period (entries >= n are 0).
  std::array<FaultMask, kMaxAxes> axis_faults{};
  /// Per axis: sample() calls since the axis last accepted a value — 0 if it accepted one in
  /// this call; counted from construction / reset() while it has none (saturates at 2³²−1).
  /// An axis holding a not-yet-stale value still counts up: this is the encoder watchdog's
  /// input (SafetyInputs::periods_since_accepted). Entries >= n are 0.
  std::array<std::uint32_t, kMaxAxes> periods_since_accepted{};
  /// `now_ns` given to sample().
  std::int64_t time_ns = 0;
};

}  // namespace numen::hal
