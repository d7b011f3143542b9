#pragma once
/// @file computed_motion.hpp
/// ComputedMotion: a target motion that a Trajectory samples on demand instead of storing
/// knots at the control period — a scripted path (scripted_path.hpp: segments) or a replayed
/// pointer recording (pointer_path.hpp: the poses at the recording's report times). Memory is
/// what the motion itself keeps, independent of dt and of the run's duration.
///
/// Frames and units: as Trajectory (world frame, m, s, rad, unit quaternions).

#include <cstddef>
#include <memory>
#include <string>

#include "numen/sim/input/trajectory.hpp"

namespace numen::sim {

/// A target motion evaluated at any time. Implementations are immutable after construction;
/// evaluate() and the other members are real-time safe (noexcept, no allocation).
class ComputedMotion {
 public:
  virtual ~ComputedMotion() = default;

  /// Target at time `t` (s), clamped to [0, duration()] (NaN → 0). Real-time safe.
  virtual TrajectorySample evaluate(double t) const noexcept = 0;
  /// Time of the end of the motion (s, >= 0).
  virtual double duration() const noexcept = 0;
  /// Bytes this motion keeps, for memory reports.
  virtual std::size_t memory_bytes() const noexcept = 0;

  /// The position farthest from the origin once moved by `placement`: its distance (m) and
  /// time (s).
  struct FarthestPoint {
    double distance = 0.0;  ///< m
    double time = 0.0;      ///< s
  };
  /// See FarthestPoint; each implementation says how exact it is.
  virtual FarthestPoint farthest_point(const Placement& placement) const noexcept = 0;

 protected:
  ComputedMotion() = default;
  ComputedMotion(const ComputedMotion&) = default;
  ComputedMotion& operator=(const ComputedMotion&) = default;
};

/// `motion` sampled at period `dt` (s) into a Trajectory that computes its knots on demand:
/// knot k is motion->evaluate(min(k dt, duration())), k = 0 .. ceil(duration / dt) (the last
/// knot holds the end). Throws InputError (file and line 0, key `dt_key`) for dt not finite
/// and > 0 or more than 1e9 knots (dt too small for the duration).
Trajectory sample_motion(std::shared_ptr<const ComputedMotion> motion, double dt,
                         const std::string& dt_key);

}  // namespace numen::sim
