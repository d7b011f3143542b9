#pragma once
/// @file grasp_summary.hpp
/// The grasps of a run in its summary (docs/grasping.md, docs/outputs.md `grasp.*`): the counts
/// over the scene's graspers and their logged events.

#include <string>

#include "numen/core/data.hpp"
#include "numen/core/grasp.hpp"
#include "numen/core/model.hpp"

namespace numen::sim {

struct RunSummary;

/// One logged event (core::GraspRecord) of grasper `grasper` as a line: "6.961 s grasp
/// grasper: organ (7 nodes)", "8.611 s slip grasper: organ (4 nodes, pull 5.005 N)", "… block
/// (10 grip springs)", "… thread suture (3 nodes)". Time in s (3 decimals), the body's or the
/// net's name, or "thread" and the thread's name (its index if it has none).
std::string format_grasp_event(const core::Model& model, const core::GraspModel& grasper,
                               const core::GraspRecord& record);

/// Fills `s`'s grasp figures from `data` after a run of `model`: RunSummary::grasping (the scene
/// has a grasper), the started, released and slipped counts summed over the graspers, and each
/// grasper's logged events (format_grasp_event(); a note when a grasper logged more events than
/// core::kGraspLogSize). Allocates (end of run).
void summarize_grasps(const core::Model& model, const core::Data& data, RunSummary& s);

}  // namespace numen::sim
