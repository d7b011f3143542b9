/// @file task_summary.cpp
/// A bimanual task's figures (task_summary.hpp).

#include "numen/sim/run/task_summary.hpp"

#include <algorithm>
#include <cstdint>
#include <iomanip>
#include <sstream>
#include <vector>

#include "numen/core/grasp.hpp"
#include "numen/core/model.hpp"
#include "numen/sim/run/run_summary.hpp"

namespace numen::sim {
namespace {

/// One logged event of one grasper about one body.
struct ObjectEvent {
  double time = 0.0;
  int grasper = -1;
  bool grasp = false;  ///< A grasp; else a let-go (release or slip).
  bool slip = false;
};

std::string plural(std::int64_t n, const char* one, const char* many) {
  return std::to_string(n) + " " + (n == 1 ? one : many);
}

}  // namespace

double distance_to_capsule_axis(const core::Obstacle& o, const core::Vec3& p) noexcept {
  const core::Vec3 axis = o.pose.orientation * core::Vec3::UnitZ();
  const double along = std::clamp(axis.dot(p - o.pose.position), -o.half_length, o.half_length);
  return (p - (o.pose.position + along * axis)).norm();
}

void summarize_task(const Scene& scene, const core::Data& data, RunSummary& s) {
  const core::Model& m = scene.model;
  const std::size_t graspers = std::min(m.grasps.size(), data.grasps.size());
  std::vector<std::int64_t> given(graspers, 0), taken(graspers, 0);
  if (scene.task) {
    const SceneTask& task = *scene.task;
    TaskSummary& t = s.task;
    t.enabled = true;
    t.objects = static_cast<std::int64_t>(task.objects.size());
    double first_grasp = -1.0, last_placement = -1.0;
    for (std::size_t g = 0; g < graspers; ++g) {
      const core::GraspState& st = data.grasps[g];
      if (st.grasps + st.releases + st.slips > st.logged)
        s.warnings.push_back("task: grasper \"" + m.grasps[g].name + "\" had more events than its log keeps (" +
                             std::to_string(core::kGraspLogSize) + "): the task's figures count the first only");
    }
    for (const int body : task.objects) {
      std::vector<ObjectEvent> events;
      for (std::size_t g = 0; g < graspers; ++g) {
        const core::GraspState& st = data.grasps[g];
        for (int k = 0; k < st.logged; ++k) {
          const core::GraspRecord& r = st.log[static_cast<std::size_t>(k)];
          if (r.body != body) continue;
          events.push_back({r.time, static_cast<int>(g), r.event == core::GraspEvent::kGrasp,
                            r.event == core::GraspEvent::kSlip});
        }
      }
      // In time; in one step a grasp before a let-go (a hand-over within a step).
      std::stable_sort(events.begin(), events.end(), [](const ObjectEvent& a, const ObjectEvent& b) {
        return a.time != b.time ? a.time < b.time : (a.grasp && !b.grasp);
      });
      std::vector<int> holders;
      std::int64_t grasps = 0, handovers = 0, letgos = 0;
      const ObjectEvent* last_letgo = nullptr;
      for (const ObjectEvent& e : events) {
        if (e.grasp) {
          ++grasps;
          if (first_grasp < 0.0 || e.time < first_grasp) first_grasp = e.time;
          holders.push_back(e.grasper);
          continue;
        }
        holders.erase(std::remove(holders.begin(), holders.end(), e.grasper), holders.end());
        if (!holders.empty()) {
          ++handovers;
          ++given[static_cast<std::size_t>(e.grasper)];
          for (const int h : holders) ++taken[static_cast<std::size_t>(h)];
        } else {
          ++letgos;
          last_letgo = &e;
        }
      }
      const core::Vec3 at = data.bodies[static_cast<std::size_t>(body)].position;
      int peg = -1;
      double nearest = task.reach;
      for (const int o : task.pegs) {
        const double d = distance_to_capsule_axis(m.obstacles[static_cast<std::size_t>(o)], at);
        if (d <= nearest) {
          nearest = d;
          peg = o;
        }
      }
      const bool held = !holders.empty();
      const bool placed = !held && peg >= 0 && last_letgo != nullptr && !last_letgo->slip;
      const std::int64_t drops = letgos - (placed ? 1 : 0);
      t.handovers += handovers;
      t.drops += drops;
      t.placed += placed ? 1 : 0;
      t.transferred += placed && handovers > 0 ? 1 : 0;
      if (placed) last_placement = std::max(last_placement, last_letgo->time);
      std::ostringstream os;
      os << std::fixed << std::setprecision(3) << m.bodies[static_cast<std::size_t>(body)].name << ": "
         << plural(grasps, "grasp", "grasps") << ", " << plural(handovers, "hand-over", "hand-overs") << ", "
         << plural(drops, "drop", "drops") << "; ";
      if (placed)
        os << "placed on " << m.obstacles[static_cast<std::size_t>(peg)].name << " at " << last_letgo->time << " s";
      else if (held)
        os << "still held at the end";
      else
        os << "ends " << (peg >= 0 ? "on " + m.obstacles[static_cast<std::size_t>(peg)].name : std::string("on no peg"))
           << " at (" << std::setprecision(1) << at.x() * 1e3 << ", " << at.y() * 1e3 << ", " << at.z() * 1e3
           << ") mm";
      t.lines.push_back(os.str());
    }
    if (last_placement >= 0.0 && first_grasp >= 0.0) t.time_s = last_placement - first_grasp;
  }
  for (std::size_t g = 0; g < graspers; ++g) {
    const core::GraspState& st = data.grasps[g];
    const int device = grasper_device(scene, static_cast<int>(g));
    std::ostringstream os;
    os << std::fixed << std::setprecision(3) << m.grasps[g].name;
    if (device >= 0) {
      const bool several = static_cast<std::size_t>(device) < s.devices.size();
      os << " (device " << (several ? s.devices[static_cast<std::size_t>(device)].name : scene.device.name) << ")";
      os << ": " << st.grasps << " started, " << st.releases << " released, " << st.slips << " slipped";
      if (scene.task) os << "; hand-overs " << given[g] << " given, " << taken[g] << " taken";
      os << "; feedback force on its hand max "
         << (several ? s.devices[static_cast<std::size_t>(device)].feedback_force_max_n : s.feedback_force_max_n)
         << " N";
    } else {
      os << " (no device drives its jaws): " << st.grasps << " started, " << st.releases << " released, "
         << st.slips << " slipped";
      if (scene.task) os << "; hand-overs " << given[g] << " given, " << taken[g] << " taken";
    }
    s.grasper_lines.push_back(os.str());
  }
}

}  // namespace numen::sim
