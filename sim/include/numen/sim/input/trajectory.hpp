#pragma once
/// @file trajectory.hpp
/// A target motion given by knots uniform in time: the pose of an instrument's
/// tool tip frame in the world and its jaw (gripper) angle. It is what a
/// recorded or scripted "tracked instrument" feeds to the control loop in place
/// of a device. Building one allocates and may throw InputError (load time);
/// sampling it (`at`, `twist_at`) is real-time safe: noexcept, no allocation.
///
/// Memory: a recorded motion keeps its recorded knots (30 Hz for JIGSAWS); a
/// computed motion (computed_motion.hpp: a scripted path keeps its segments, a
/// replayed pointer recording its poses at the recording's report times)
/// computes its knots on demand. Neither
/// depends on the control period dt or on the run's duration: the loop
/// interpolates at each period's time, nothing is resampled up front.
///
/// Interpolation between samples: linear position, slerp orientation on the
/// shortest arc, linear jaw (docs/architecture.md). Units SI (s, m, rad).

#include <cstddef>
#include <memory>
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
  /// The instrument's tool frame in the world (trocar instrument: the tip, z along the shaft;
  /// pose tracker: the tracked frame): position (m), orientation (unit quaternion). Not the held
  /// body's centre-of-mass frame: InstrumentTargets (instrument_targets.hpp) turns it into that.
  core::Pose pose;
  double jaw = 0.0;   ///< Jaw / gripper opening angle (rad).
};

// Rotation vectors (axis · angle, shortest arc) and their quaternions are
// core::quat_log() / core::quat_exp() (numen/core/rigid_body.hpp).

/// Rotation between `q0` (s = 0) and `q1` (s = 1) on the shortest arc:
/// exp(s · log(q1 q0⁻¹)) q0, i.e. a rotation about a fixed world axis at a
/// constant rate. Same result as Eigen's slerp, computed with atan2 instead of
/// acos so that it stays accurate for the tiny steps between the periods of a 1 kHz loop.
/// Both inputs must be unit quaternions; the result is unit and lies in the
/// hemisphere of `q0` (sign continuity).
core::Quat slerp_shortest(const core::Quat& q0, const core::Quat& q1, double s) noexcept;

class ComputedMotion;

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

/// A target motion with a knot every `period()` seconds from time 0 to
/// `duration()`, knot i at time i · period. Invariants (established by the
/// constructors): period > 0 and finite, at least one knot, every value
/// finite, unit quaternions. Stored knots (recorded motion) also have sign
/// continuity (consecutive quaternions have a non-negative dot product);
/// computed knots (ComputedMotion) may differ in sign, which changes nothing:
/// interpolation and twist take the shortest arc (core::quat_log) either way.
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

  /// Knots computed on demand from `path` (sample_motion(), ScriptedPath::sample(),
  /// PointerPath::sample()): knot k is path->evaluate(min(k · period,
  /// path->duration())) for k = 0 .. count - 1, quaternion normalised. Keeps
  /// only the motion (segments, report poses), never the knots. Throws
  /// InputError (key "trajectory.period" / "trajectory.samples") if period is
  /// not finite and > 0, count is 0 or path is null.
  Trajectory(std::shared_ptr<const ComputedMotion> path, double period, std::size_t count);

  /// Number of knots.
  std::size_t size() const noexcept { return size_; }
  /// True if there is no knot (default-constructed).
  bool empty() const noexcept { return size_ == 0; }
  /// Knot period (s); 0 for an empty trajectory.
  double period() const noexcept { return period_; }
  /// Time of the last knot (s): (size() - 1) · period(); 0 if size() <= 1.
  double duration() const noexcept;
  /// Knot `i`, at time i · period() (precondition i < size()). Real-time safe.
  TrajectorySample operator[](std::size_t i) const noexcept;
  /// Bytes this trajectory keeps (knots or path segments), for memory reports.
  std::size_t memory_bytes() const noexcept;

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

  /// This trajectory moved by `placement` (see transformed()).
  friend Trajectory transformed(const Trajectory& trajectory, const Placement& placement);

 private:
  double period_ = 0.0;
  std::size_t size_ = 0;
  std::vector<TrajectorySample> samples_;  // stored knots (empty for a path)
  std::shared_ptr<const ComputedMotion> path_;  // computed knots (null for stored ones)
  Placement placement_;  // applied to the path's knots
};

/// Image of the point `p` (m, recording frame) under `placement` (world frame).
core::Vec3 apply(const Placement& placement, const core::Vec3& p) noexcept;

/// The whole trajectory moved by `placement`: every position p → p', every
/// orientation q → R q (velocities follow: linear scaled then rotated,
/// angular rotated). Stored knots are transformed; a computed motion's placement is
/// composed with it (still computed on demand). Throws InputError (key "placement.scale" or
/// "placement.orientation") if the scale is not finite and > 0 or the
/// orientation is not finite or has zero norm (it is normalised otherwise).
Trajectory transformed(const Trajectory& trajectory, const Placement& placement);


}  // namespace numen::sim
