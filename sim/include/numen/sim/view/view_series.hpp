#pragma once
/// @file view_series.hpp
/// The replay's series (docs/viewer.md "Replay"): what the page plots over a whole recording,
/// read from every frame of the file once, decimated to a bounded number of points, and the
/// recording's status events (faults, safe states, step status), never decimated.

#include <cstddef>
#include <string>

namespace numen::sim {

class ViewFrameSource;

/// Points a replay's series holds at most (plus the last frame).
inline constexpr std::size_t kViewSeriesMaxPoints = 2000;
/// Status events a replay's series lists at most (the count of all is given too).
inline constexpr std::size_t kViewSeriesMaxEvents = 256;

/// The series of `source`'s frames as a JSON object (the replay session message's "series"):
///   "frames": N, "stride": s = max(1, ceil(N / max_points)),
///   "frame": the frames sampled (0, s, 2s, ... and N − 1),
///   "t": their simulated time (s),
///   "tool_mm", "hand_mm", "intent_mm", "force_n", "step_us", "contacts": for each sampled
///     frame i the largest value over frames [i, i + s) (peaks survive the decimation): tool,
///     hand (target) and hand's intent (the frame's device_loop; the target's in replay)
///     penetration (mm), |feedback force| (N), step time (µs), contact count,
///   "lifecycle": the largest hal::LifecycleState over [i, i + s) (4: fault, 3: safe stop),
///   "step_status": the OR of core::StepStatus bits over [i, i + s),
///   "events": each frame where the lifecycle or the step status changes (the first
///     kViewSeriesMaxEvents: frame, t, lifecycle, step_status, fault_cause), "event_count": all of
///     them,
///   "grasp_events": each grasp, release and slip, at the first frame whose grasper's count of
///     it grew (the frame's grasp array: counts, so a grasp between two decimated frames is not
///     lost; the first kViewSeriesMaxEvents: frame, t, grasper, "event" — "grasp", "release" or
///     "slip" —, body, net and thread held (−1: none; at a release or slip, what the previous
///     frame held)), "grasp_event_count": all of them.
/// Throws std::runtime_error naming the frame when a frame does not decode (a recording's
/// reader checked them already). Reads every frame once: setup, not the loop.
std::string view_replay_series(ViewFrameSource& source, std::size_t max_points = kViewSeriesMaxPoints);

}  // namespace numen::sim
