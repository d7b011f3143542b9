#pragma once
/// @file scripted_path.hpp
/// Scripted target motion from a scene: a sequence of segments (line, circle,
/// hold, step), each with an orientation (constant, or spinning at a constant
/// world angular velocity) and a jaw angle, sampled into a Trajectory at the
/// control period. Used for demos and for extreme-case tests (a step is a jump
/// of the target, the worst input a coupling spring can get).
///
/// Frames and units: positions in the scene's world frame (m), times (s),
/// angles (rad), angular velocities in the world frame (rad/s), quaternions
/// Hamilton (w, x, y, z), normalised on input.
///
/// Continuity: each segment starts where the previous one ended (position,
/// orientation, jaw) unless it gives its own start; a segment that gives a
/// start different from the previous end makes the target jump there.
///
/// Load time: building a ScriptedPath and sampling it allocate and throw
/// InputError with file and line left 0 (the scene loader fills them) and the
/// key "<prefix>[i].<field>", e.g. "path[2].radius". evaluate() is noexcept
/// and does not allocate.

#include <cstddef>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "numen/core/types.hpp"
#include "numen/sim/input/computed_motion.hpp"
#include "numen/sim/input/trajectory.hpp"

namespace numen::sim {

/// Straight line at constant speed from `from` to `to` in `duration`.
struct LineSegment {
  std::optional<core::Vec3> from;  ///< Start (m, world); none = where the previous segment ended.
  core::Vec3 to = core::Vec3::Zero();  ///< End (m, world).
  double duration = 0.0;               ///< Time to go from `from` to `to` (s, > 0).
};

/// Uniform circular motion: p(τ) = centre + radius (cos φ e1 + sin φ e2),
/// φ = start_phase + 2π τ / period, with n = axis / |axis|, e1 = the unit
/// projection of world x on the plane normal to n (world y if n is within
/// ~26° of x), e2 = n × e1. The motion turns right-handed about `axis`.
struct CircleSegment {
  /// Centre (m, world); none = placed so that the circle starts (at
  /// start_phase) where the previous segment ended.
  std::optional<core::Vec3> centre;
  double radius = 0.0;  ///< Radius (m, > 0).
  core::Vec3 axis =
      core::Vec3::UnitZ();   ///< Normal of the circle's plane (world, non-zero; any length).
  double period = 0.0;       ///< Time of one turn (s, > 0).
  double start_phase = 0.0;  ///< Phase φ at the segment start (rad), from e1 toward e2.
  double duration = 0.0;     ///< Time on the circle (s, > 0; may exceed one period).
};

/// Stay still for `duration`.
struct HoldSegment {
  std::optional<core::Vec3>
      position;           ///< Where (m, world); none = where the previous segment ended.
  double duration = 0.0;  ///< s, > 0.
};

/// A jump: hold at A (`from`) until `step_time`, then hold at B (`to`, with
/// orientation `to_orientation`) until `duration`. Sampled at period dt, the
/// target moves from A to B in one sample interval (the jump is as sharp as
/// the sampling allows), so twist_at() reports (B − A) / dt there.
struct StepSegment {
  std::optional<core::Vec3> from;      ///< A (m, world); none = where the previous segment ended.
  core::Vec3 to = core::Vec3::Zero();  ///< B (m, world).
  /// Orientation after the jump (normalised); none = unchanged (the orientation before the jump).
  std::optional<core::Quat> to_orientation;
  double step_time = 0.0;  ///< Time of the jump from the segment start (s, in [0, duration]).
  double duration = 0.0;   ///< s, > 0.
};

/// One segment of a scripted path: a shape plus orientation and jaw.
struct PathSegment {
  std::variant<LineSegment, CircleSegment, HoldSegment, StepSegment>
      shape;  ///< The position motion.
  /// Orientation of the tip frame at the segment start (normalised); none =
  /// where the previous segment ended (identity for the first one unless the
  /// path's start says otherwise).
  std::optional<core::Quat> orientation;
  /// Constant world angular velocity (rad/s) of a spin: q(τ) = exp(ω τ) q_start,
  /// a rotation about a fixed world axis at |ω| rad/s. Zero = constant orientation.
  core::Vec3 angular_velocity = core::Vec3::Zero();
  std::optional<double> jaw;  ///< Jaw angle over the segment (rad); none = the previous one.
  /// Time (s, ≥ 0, ≤ duration) over which the jaw goes linearly from the previous segment's
  /// angle to `jaw` at the segment's start; 0: it jumps there (a jaw encoder's jump check,
  /// max_speed · dt, refuses a jump larger than one period's travel).
  double jaw_time = 0.0;
};

/// A validated sequence of segments with their starts resolved; a ComputedMotion.
class ScriptedPath final : public ComputedMotion {
 public:
  /// Validates `segments` and resolves where each starts. `start` is the
  /// pose and jaw before the first segment (time ignored); `key_prefix` names
  /// the list in error keys ("path" gives "path[2].radius").
  /// Throws InputError (file and line 0, key "<prefix>[i].<field>") for an
  /// empty list, a duration not finite and > 0, a jaw_time not in [0, duration], a radius or period not finite
  /// and > 0, a zero or non-finite axis, a step_time outside [0, duration], a
  /// quaternion of zero norm, any non-finite number, or a position (start,
  /// from, to, position, centre; a circle's centre distance + radius) farther
  /// than kMaxTargetDistance (10 m) from the world origin.
  explicit ScriptedPath(std::vector<PathSegment> segments, const TrajectorySample& start = {},
                        std::string key_prefix = "path");

  /// Total duration (s): the sum of the segment durations.
  double duration() const noexcept override;
  /// Number of segments.
  std::size_t size() const noexcept { return segments_.size(); }
  /// Time at which segment `i` starts (s; precondition i < size()).
  double segment_start(std::size_t i) const noexcept;

  /// Exact target at time `t` (s), clamped to [0, duration()] (NaN → 0). At a
  /// boundary between segments (within 1 ps) the later segment is used; a step
  /// is at B from step_time on. Real-time safe (noexcept, no allocation).
  TrajectorySample evaluate(double t) const noexcept override;

  /// The path sampled at period `dt` (s) into a Trajectory: knot k is
  /// evaluate(min(k dt, duration())), k = 0 .. ceil(duration / dt) (the last
  /// knot holds the end). The knots are computed on demand from a copy of
  /// this path (memory independent of dt and of the duration). Throws InputError for dt not finite and > 0
  /// (key "<prefix>.dt"), a spin turning π or more per sample (key
  /// "<prefix>[i].angular_velocity") or a circle of period <= 2 dt (key
  /// "<prefix>[i].period"): the samples could not represent them.
  Trajectory sample(double dt) const;
  /// Bytes this path keeps (segments), for memory reports.
  std::size_t memory_bytes() const noexcept override;

  /// The position of the path farthest from the origin once moved by `placement`: its
  /// distance (m) and time (s). Exact for lines, holds and steps (their end points); a
  /// circle is evaluated every degree of the arc it sweeps (≤ 0.008 % low).
  FarthestPoint farthest_point(const Placement& placement) const noexcept override;

 private:
  enum class Kind { line, circle, hold, step };
  struct Resolved {
    Kind kind = Kind::hold;
    double t0 = 0.0;                    // start time (s)
    double duration = 0.0;              // s
    core::Vec3 a = core::Vec3::Zero();  // line from / hold position / step A (m)
    core::Vec3 b = core::Vec3::Zero();  // line to / step B (m)
    core::Vec3 centre = core::Vec3::Zero();
    core::Vec3 e1 = core::Vec3::UnitX();
    core::Vec3 e2 = core::Vec3::UnitY();
    double radius = 0.0;
    double rate = 0.0;                       // circle angular rate 2π / period (rad/s)
    double phase0 = 0.0;                     // rad
    double step_time = 0.0;                  // s from t0
    core::Quat q0 = core::Quat::Identity();  // orientation at start (step: before the jump)
    core::Quat q1 = core::Quat::Identity();  // step: orientation after the jump
    core::Vec3 spin = core::Vec3::Zero();    // world angular velocity (rad/s)
    double jaw = 0.0;                        // rad
    double jaw0 = 0.0;                       // rad: the jaw before the segment (ramp start)
    double jaw_time = 0.0;                   // s: the ramp from jaw0 to jaw (0: a jump)
  };
  static TrajectorySample evaluate_segment(const Resolved& s, double tau) noexcept;

  std::vector<Resolved> segments_;
  std::string key_prefix_;
};

}  // namespace numen::sim
