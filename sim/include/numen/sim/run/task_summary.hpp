#pragma once
/// @file task_summary.hpp
/// A bimanual task's figures in a run's summary (docs/grasping.md, "Peg transfer";
/// docs/outputs.md `task.*`): per object of the scene's [task], its grasps, hand-overs and
/// drops from the graspers' logs (core::GraspState::log) and whether it ends on a peg.

#include <string>

#include "numen/core/data.hpp"
#include "numen/sim/scene/scene.hpp"

namespace numen::sim {

struct RunSummary;

/// Fills RunSummary::task from `data` after a run of `scene` (nothing without a [task]). Per
/// object, the events of every grasper's log that name it are merged in time (a grasp before a
/// let-go in the same step): a let-go while another grasper holds it is a hand-over; a let-go
/// that leaves it held by none is a drop, unless it is its last, a release, and the object ends
/// within SceneTask::reach of a peg's axis (placed). Placed after a hand-over: transferred. The
/// task's time runs from the first grasp of an object to the last placement. A grasper that
/// logged more events than core::kGraspLogSize makes the figures incomplete: a warning says so.
/// Also fills RunSummary::grasper_lines (each grasper's counts, the hand-overs it gave and took,
/// and the largest feedback force on its device's hand: RunSummary::devices, or the summary's
/// own for one device). Call after the devices are summarized. Allocates (end of run).
void summarize_task(const Scene& scene, const core::Data& data, RunSummary& s);

/// Distance (m) from `p` to the axis segment of capsule obstacle `o` (its from–to).
double distance_to_capsule_axis(const core::Obstacle& o, const core::Vec3& p) noexcept;

}  // namespace numen::sim
