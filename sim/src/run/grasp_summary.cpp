/// @file grasp_summary.cpp
/// The grasps of a run in its summary (grasp_summary.hpp).

#include "numen/sim/run/grasp_summary.hpp"

#include <iomanip>
#include <sstream>

#include "numen/sim/run/run_summary.hpp"

namespace numen::sim {

std::string format_grasp_event(const core::Model& model, const core::GraspModel& grasper,
                               const core::GraspRecord& record) {
  std::ostringstream os;
  os << std::fixed << std::setprecision(3) << record.time << " s " << core::to_string(record.event)
     << ' ' << grasper.name << ": ";
  if (record.body >= 0) {
    os << model.bodies[static_cast<std::size_t>(record.body)].name << " (" << record.nodes << " grip springs";
  } else if (record.net >= 0) {
    os << model.nets[static_cast<std::size_t>(record.net)].name << " (" << record.nodes << " nodes";
  } else if (record.thread >= 0 && record.thread < model.num_threads()) {
    const std::string& name = model.threads[static_cast<std::size_t>(record.thread)].name;
    os << "thread " << (name.empty() ? std::to_string(record.thread) : name) << " (" << record.nodes << " nodes";
  } else {
    os << "? (";
  }
  if (record.event != core::GraspEvent::kGrasp) os << ", pull " << record.grip_force << " N";
  os << ')';
  return os.str();
}

void summarize_grasps(const core::Model& model, const core::Data& data, RunSummary& s) {
  s.grasping = !model.grasps.empty();
  for (std::size_t i = 0; i < model.grasps.size() && i < data.grasps.size(); ++i) {
    const core::GraspState& g = data.grasps[i];
    s.grasps_started += g.grasps;
    s.grasps_released += g.releases;
    s.grasps_slipped += g.slips;
    for (int k = 0; k < g.logged; ++k)
      s.grasp_events.push_back(format_grasp_event(model, model.grasps[i], g.log[static_cast<std::size_t>(k)]));
    const std::int64_t events = g.grasps + g.releases + g.slips;
    if (events > g.logged)
      s.grasp_events.push_back(model.grasps[i].name + ": " + std::to_string(events - g.logged) +
                               " later events counted, not listed");
  }
}

}  // namespace numen::sim
