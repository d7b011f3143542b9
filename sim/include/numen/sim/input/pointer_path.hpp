#pragma once
/// @file pointer_path.hpp
/// PointerPath: the target motion of a mouse recording — the paper's mouse device: relative
/// displacement with a clutch. The events of an evemu recording (hal/input/evemu_log.hpp) are
/// replayed on their own clock (hal::EvemuReplay, the first event at t = 0) into a
/// hal::RelativePoseIntegrator, the same integrator a live hal::EvdevPointer feeds; the target
/// it holds after each report is the hand pose the scene's device follows.
///
/// Stored at the recording's report times, not at the control period: one pose per report
/// that moved the target (a report with the clutch released moves nothing and stores nothing),
/// so memory depends on the recording only, never on dt or on the run's duration. Between two
/// reports the pose holds (zero-order hold, as a live pointer's target does between the
/// periods that read its reports); sampled at dt (sample()), a report's jump is spread over
/// the period that contains it and twist_at() reports its displacement / dt there, as the
/// integrator's end_period() twist does live.
///
/// Frames and units: world frame, m, s, rad, unit quaternions; the integrator's settings say
/// how counts map to motion (hal/input/relative_pose_integrator.hpp).

#include <cstddef>
#include <vector>

#include "numen/core/types.hpp"
#include "numen/hal/input/input_event.hpp"
#include "numen/hal/input/relative_pose_integrator.hpp"
#include "numen/sim/input/computed_motion.hpp"
#include "numen/sim/input/trajectory.hpp"

namespace numen::sim {

/// The target after each report of a replayed pointer recording. Immutable once built;
/// evaluate() is real-time safe (binary search over the report times, no allocation).
class PointerPath final : public ComputedMotion {
 public:
  /// Replays `events` (in file order, times as recorded, ns) through a
  /// hal::RelativePoseIntegrator built with `settings` (its initial_pose is the target at
  /// t = 0) and keeps the target after every report that moved it. `jaw` is the jaw angle
  /// of the whole motion (rad). Load time: allocates; throws std::invalid_argument from the
  /// integrator's constructor for bad settings (the scene loader checks them first, with
  /// their place in the scene file), or for a non-finite jaw.
  PointerPath(const std::vector<hal::InputEvent>& events,
              const hal::RelativePoseIntegratorSettings& settings, double jaw = 0.0);

  /// The target of the last report at or before `t` (s since the recording's first event),
  /// the initial pose before the first; clamped to [0, duration()] (NaN → 0).
  TrajectorySample evaluate(double t) const noexcept override;
  /// Span of the recording (s): its latest event time − its first event time.
  double duration() const noexcept override { return duration_; }
  /// Bytes kept: the stored poses.
  std::size_t memory_bytes() const noexcept override;
  /// Exact: the stored pose farthest from the origin once placed.
  FarthestPoint farthest_point(const Placement& placement) const noexcept override;

  /// This motion sampled at period `dt` (s): sample_motion() on a copy (knots computed on
  /// demand). Throws InputError (key "trajectory.dt") for dt not finite and > 0 or too small.
  Trajectory sample(double dt) const;

  /// Poses stored: 1 (the initial pose) + the reports that moved the target.
  std::size_t size() const noexcept { return poses_.size(); }
  /// Time of stored pose `i` (s; precondition i < size()).
  double time(std::size_t i) const noexcept { return poses_[i].time; }
  /// Stored pose `i` (precondition i < size()).
  const core::Pose& pose(std::size_t i) const noexcept { return poses_[i].pose; }
  /// The integrator's counters at the end of the replay: reports applied, moving, ignored
  /// (clutch released or changed within the report), clamped to the workspace, dropped.
  const hal::RelativePoseCounters& counters() const noexcept { return counters_; }
  /// Events replayed.
  std::size_t events() const noexcept { return events_; }

 private:
  struct Stamped {
    double time = 0.0;  // s since the recording's first event
    core::Pose pose;
  };
  std::vector<Stamped> poses_;
  double duration_ = 0.0;
  double jaw_ = 0.0;
  std::size_t events_ = 0;
  hal::RelativePoseCounters counters_{};
};

}  // namespace numen::sim
