#pragma once
/// @file trajectory.hpp
/// A target motion sampled uniformly in time: the pose of an instrument's tool
/// tip frame in the world and its jaw (gripper) angle. It is what a recorded
/// or scripted "tracked instrument" feeds to the control loop in place of a
/// device. Building one allocates and may throw InputError (load time);
/// sampling it (`at`, `twist_at`) is real-time safe: noexcept, no allocation.
///
/// Interpolation between samples: linear position, slerp orientation on the
/// shortest arc, linear jaw (DESIGN.md, "Real input"). Units SI (s, m, rad).

#include <cstddef>
#include <span>
#include <vector>

#include "numen/core/rigid_body.hpp"
#include "numen/core/types.hpp"

namespace numen::sim {

/// Largest distance (m) of a target position from the origin of its frame
/// (the scene's world, or a recording's own frame) that an input may hold.
/// The instruments numen drives reach well under a metre (the shipped trocar
/// instrument: 0.35 m of insertion; the Phantom arm: 0.3 m); 10 m leaves room
/// for any bench or room-scale tracker while a position of 1e3 m or 1e100 m —
/// a wrong unit, a corrupt file — is refused at load time instead of reaching
/// the device's inverse kinematics (docs/scenes.md, "Input checks").
inline constexpr double kMaxTargetDistance = 10.0;

/// One sample of a target motion.
struct TrajectorySample {
  double time = 0.0;  ///< Time since the start of the trajectory (s).
  core::Pose pose;    ///< Tool tip frame in the world: position (m), orientation (unit quaternion).
  double jaw = 0.0;   ///< Jaw / gripper opening angle (rad).
};

// Rotation vectors (axis · angle, shortest arc) and their quaternions are
// core::quat_log() / core::quat_exp() (numen/core/rigid_body.hpp).

/// Rotation between `q0` (s = 0) and `q1` (s = 1) on the shortest arc:
/// exp(s · log(q1 q0⁻¹)) q0, i.e. a rotation about a fixed world axis at a
/// constant rate. Same result as Eigen's slerp, computed with atan2 instead of
/// acos so that it stays accurate for the tiny steps of a 1 kHz resampling.
/// Both inputs must be unit quaternions; the result is unit and lies in the
/// hemisphere of `q0` (sign continuity).
core::Quat slerp_shortest(const core::Quat& q0, const core::Quat& q1, double s) noexcept;

/// A target motion sampled every `period()` seconds from time 0 to
/// `duration()`. Invariants (established by the constructor): period > 0 and
/// finite, at least one sample, every value finite, unit quaternions with sign
/// continuity (consecutive quaternions have a non-negative dot product, so
/// there is no q → -q flip between samples), sample i at time i · period.
class Trajectory {
 public:
  /// An empty trajectory (no sample). `at()` returns the identity pose at the
  /// origin, jaw 0; `twist_at()` returns zero. Only useful as a placeholder.
  Trajectory() = default;

  /// Builds from `poses` (tool tip frame in the world) taken every `period`
  /// seconds, the first at time 0, and jaw angles `jaw` (rad; empty = all 0,
  /// otherwise one per pose). Quaternions are normalised and their signs made
  /// continuous. Throws InputError (key "trajectory.<field>") if period is not
  /// finite and > 0, poses is empty, sizes differ, a value is not finite, a
  /// position is farther than kMaxTargetDistance from the origin (key
  /// "trajectory.samples[i].position") or a quaternion has (near) zero norm.
  Trajectory(double period, std::vector<core::Pose> poses, std::vector<double> jaw = {});

  /// Number of samples.
  std::size_t size() const noexcept { return samples_.size(); }
  /// True if there is no sample (default-constructed).
  bool empty() const noexcept { return samples_.empty(); }
  /// Sampling period (s); 0 for an empty trajectory.
  double period() const noexcept { return period_; }
  /// Time of the last sample (s): (size() - 1) · period(); 0 if size() <= 1.
  double duration() const noexcept;
  /// Sample `i` (precondition i < size()).
  const TrajectorySample& operator[](std::size_t i) const noexcept { return samples_[i]; }
  /// All samples, in time order.
  std::span<const TrajectorySample> samples() const noexcept { return samples_; }

  /// Target at time `t` (s): linear position, shortest-arc slerp orientation
  /// and linear jaw between the two samples around `t`; clamped to the first
  /// sample for t <= 0 (and for NaN) and to the last for t >= duration().
  /// The returned time is `t` clamped to [0, duration()]. Real-time safe.
  TrajectorySample at(double t) const noexcept;

  /// Velocity of the target at time `t` (s), world frame: linear velocity of
  /// the tip (m/s) and world angular velocity (rad/s), as the finite
  /// difference over the sample interval that contains `t` — the exact
  /// derivative of the interpolation used by at(): (p[i+1] - p[i]) / period
  /// and core::quat_log(q[i+1] q[i]⁻¹) / period. At a sample instant the
  /// interval that starts there is used (the last interval at t = duration()).
  /// Zero outside [0, duration()] (the clamped pose does not move) and for a
  /// trajectory of fewer than two samples. Real-time safe.
  core::Twist twist_at(double t) const noexcept;

 private:
  double period_ = 0.0;
  std::vector<TrajectorySample> samples_;
};

/// How to place a motion recorded in its own frame into a scene's world:
/// a point p of the recording goes to
///   p' = pose.position + R (scale · (p - origin)),   R = pose.orientation,
/// and an orientation q goes to R q. Jaw angles and times are unchanged.
struct Placement {
  core::Vec3 origin =
      core::Vec3::Zero();  ///< Point of the recording frame (m) sent to pose.position.
  core::Pose pose;         ///< Where `origin` lands (m) and the rotation recording → world.
  double scale = 1.0;      ///< Uniform scale of positions about `origin` (> 0, unitless).
};

/// Image of the point `p` (m, recording frame) under `placement` (world frame).
core::Vec3 apply(const Placement& placement, const core::Vec3& p) noexcept;

/// The whole trajectory moved by `placement`: every position p → p', every
/// orientation q → R q (velocities follow: linear scaled then rotated,
/// angular rotated). Throws InputError (key "placement.scale" or
/// "placement.orientation") if the scale is not finite and > 0 or the
/// orientation is not finite or has zero norm (it is normalised otherwise).
Trajectory transformed(const Trajectory& trajectory, const Placement& placement);

/// The trajectory resampled at period `dt` (s), e.g. 1e-3 for a 1 kHz control
/// loop, by at(): linear position, shortest-arc slerp orientation, linear jaw.
/// Samples at k · dt for k = 0 .. floor(duration / dt) (a tail shorter than
/// dt is dropped; a relative tolerance of 1e-9 keeps the last sample when the
/// duration is a multiple of dt). Throws InputError (key "resample.dt") if dt
/// is not finite and > 0 or the trajectory is empty.
Trajectory resample(const Trajectory& trajectory, double dt);

}  // namespace numen::sim
