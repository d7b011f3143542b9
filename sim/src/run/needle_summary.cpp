/// @file needle_summary.cpp
/// The suture needles of a run in its summary (needle_summary.hpp).

#include "numen/sim/run/needle_summary.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "numen/core/needle.hpp"
#include "numen/core/needle_puncture.hpp"
#include "numen/sim/run/run_summary.hpp"
#include "numen/sim/scene/scene.hpp"

namespace numen::sim {
namespace {

/// The rest position (m, world) of puncture point `p`'s material point: its triangle's nodes at
/// rest on their net's initial pose, by its weights.
std::array<double, 3> rest_point(const core::Model& model, const core::NeedlePuncture& p) noexcept {
  std::array<double, 3> out{};
  if (p.face < 0 || p.net < 0) return out;
  const core::NetModel& net = model.nets[static_cast<std::size_t>(p.net)];
  const core::Pose& pose = model.bodies[static_cast<std::size_t>(net.body)].initial_pose;
  const std::array<int, 3>& f = model.net_faces[static_cast<std::size_t>(p.face)];
  core::Vec3 x = core::Vec3::Zero();
  for (int k = 0; k < 3; ++k)
    x += p.weights[k] * (pose.position +
                         pose.orientation * model.node_rest[static_cast<std::size_t>(f[static_cast<std::size_t>(k)])]);
  return {x.x(), x.y(), x.z()};
}

/// The newest puncture point of `n` that is an exit (`exit`) or an entry; null if none is held.
const core::NeedlePuncture* newest(const core::NeedleState& n, bool exit) noexcept {
  for (int i = n.num_punctures - 1; i >= 0; --i)
    if (n.punctures[static_cast<std::size_t>(i)].exit == exit) return &n.punctures[static_cast<std::size_t>(i)];
  return nullptr;
}

double distance_mm(const std::array<double, 3>& a, const std::array<double, 3>& b) noexcept {
  return 1e3 * std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                         (a[2] - b[2]) * (a[2] - b[2]));
}

const char* plural_of(std::int64_t n, const char* one, const char* many) noexcept {
  return n == 1 ? one : many;
}

}  // namespace

void begin_needle_figures(const Scene& scene, RunSummary& s) {
  const core::Model& m = scene.model;
  s.needles = !m.needles.empty();
  s.needle_runs.assign(m.needles.size(), NeedleRunFigures{});
  for (std::size_t k = 0; k < m.needles.size(); ++k) {
    NeedleRunFigures& r = s.needle_runs[k];
    r.name = m.needles[k].name;
    r.puncture_force_n = m.needles[k].puncture_force > 0.0 ? m.needles[k].puncture_force : 0.0;
    if (k < scene.needle_marks.size()) {
      const NeedleMarks& marks = scene.needle_marks[k];
      for (const core::Vec3& p : marks.entry) r.entry_marks.push_back({p.x(), p.y(), p.z()});
      for (const core::Vec3& p : marks.exit) r.exit_marks.push_back({p.x(), p.y(), p.z()});
    }
  }
}

namespace {

/// The force the needles' puncture ties and the threads' eyelets on tissue and contacts with it
/// put on the nets this step (N, world): the sum of their held node springs' forces
/// (NodeContact::force, on the node),
/// which follow the penalty contacts and the grasp springs in Data::node_contacts.
core::Vec3 tissue_force(const core::Data& data) noexcept {
  const std::size_t size = data.node_contacts.size();
  const auto at = [size](int i) { return static_cast<std::size_t>(std::clamp<std::int64_t>(i, 0, static_cast<std::int64_t>(size))); };
  const std::size_t begin = at(data.num_node_contacts + data.num_node_grasp_springs);
  const std::size_t end = at(data.num_node_contacts + data.num_node_grasp_springs +
                             data.num_node_needle_ties + data.num_node_thread_ties);
  core::Vec3 f = core::Vec3::Zero();
  for (std::size_t i = begin; i < end; ++i) f += data.node_contacts[i].force;
  return f;
}

}  // namespace

void accumulate_needle_figures(const core::Model& model, const core::Data& data, RunSummary& s) noexcept {
  if (s.needles) {
    const double f = tissue_force(data).norm();
    if (f > s.needle_tissue_force_max_n) s.needle_tissue_force_max_n = f, s.needle_tissue_force_max_s = data.time;
  }
  const std::size_t count = std::min(s.needle_runs.size(), data.needles.size());
  for (std::size_t k = 0; k < count; ++k) {
    const core::NeedleState& n = data.needles[k];
    NeedleRunFigures& r = s.needle_runs[k];
    // An entry opens a pass (replacing one still open: an attempt drawn back out); an exit ends
    // the open pass. An entry whose points were all let go without an exit leaves its pass open
    // until the next entry replaces it.
    if (n.punctures_made > r.punctures)
      if (const core::NeedlePuncture* p = newest(n, false)) {
        const bool open = r.num_passes > 0 && r.passes[r.num_passes - 1].exit_s < 0.0;
        if (!open && r.num_passes == r.passes.size()) {
          ++r.passes_lost;
        } else {
          if (!open) ++r.num_passes;
          r.passes[r.num_passes - 1] = NeedlePassFigures{rest_point(model, *p), {}, data.time, -1.0};
        }
      }
    if (n.exits > r.exits && r.num_passes > 0 && r.passes[r.num_passes - 1].exit_s < 0.0)
      if (const core::NeedlePuncture* p = newest(n, true)) {
        NeedlePassFigures& pass = r.passes[r.num_passes - 1];
        pass.exit = rest_point(model, *p), pass.exit_s = data.time;
      }
    if (n.tunnels > r.tunnels && r.first_tunnel_s < 0.0) r.first_tunnel_s = data.time;
    r.punctures = n.punctures_made;
    r.exits = n.exits;
    r.releases = n.releases;
    r.tunnels = n.tunnels;
    r.tunnels_stopped = n.tunnels_stopped;
    r.puncture_tip_force_n = n.puncture_tip_force;
    r.puncture_contact_force_n = n.puncture_contact_force;
    r.deviation_max_mm = std::max(r.deviation_max_mm, n.max_deviation * 1e3);
  }
}

void summarize_needles(RunSummary& s) {
  double last_puncture_s = -1.0;
  for (const NeedleRunFigures& r : s.needle_runs) {
    s.needle_punctures += r.punctures;
    s.needle_exits += r.exits;
    s.needle_releases += r.releases;
    s.needle_tunnels += r.tunnels;
    s.needle_tunnels_stopped += r.tunnels_stopped;
    std::size_t through = 0;
    for (std::size_t i = 0; i < r.num_passes; ++i) through += r.passes[i].exit_s >= 0.0 ? 1 : 0;
    s.needle_passes += static_cast<std::int64_t>(through);
    if (s.needle_puncture_force_n == 0.0) s.needle_puncture_force_n = r.puncture_force_n;  // until a puncture
    const double first_entry_s = r.num_passes > 0 ? r.passes[0].entry_s : -1.0;
    if (r.punctures > 0 && first_entry_s >= last_puncture_s) {
      // The run's last puncture: the needle whose first entry came last.
      last_puncture_s = first_entry_s;
      s.needle_puncture_tip_force_n = r.puncture_tip_force_n;
      s.needle_puncture_contact_force_n = r.puncture_contact_force_n;
      s.needle_puncture_force_n = r.puncture_force_n;
    }
    s.needle_deviation_max_mm = std::max(s.needle_deviation_max_mm, r.deviation_max_mm);
    const std::size_t marked = std::max(r.entry_marks.size(), r.exit_marks.size());
    if (marked > 0) {
      if (!s.needle_marks) s.needle_entry_error_mm = s.needle_exit_error_mm = 0.0;
      s.needle_marks = true;
    }
    std::ostringstream os;
    os << std::fixed << std::setprecision(3) << r.name << ": " << r.punctures << " "
       << plural_of(r.punctures, "puncture", "punctures") << ", " << r.exits << " "
       << plural_of(r.exits, "exit", "exits") << ", " << r.releases << " "
       << plural_of(r.releases, "release", "releases") << ", " << r.tunnels << " "
       << plural_of(r.tunnels, "tunnel", "tunnels") << "; ";
    // One pass (and at most one mark each): "through (in at …, out at …)"; more: each pass by its
    // number, with its marks.
    const bool several = r.num_passes > 1 || marked > 1;
    const auto pass_text = [&os](const NeedlePassFigures& p) {
      if (p.exit_s >= 0.0)
        os << "through (in at " << p.entry_s << " s, out at " << p.exit_s << " s)";
      else
        os << "in at " << p.entry_s << " s, not out";
    };
    if (!several) {
      if (r.num_passes > 0)
        pass_text(r.passes[0]);
      else
        os << "never in";
    } else {
      os << through << " of " << std::max(r.num_passes, marked) << " passes through";
    }
    if (r.passes_lost > 0) os << " (" << r.passes_lost << " more entries not recorded)";
    if (r.punctures > 0)
      os << "; tip force at the last puncture " << r.puncture_tip_force_n << " N (threshold "
         << r.puncture_force_n << " N; its contacts asked " << r.puncture_contact_force_n
         << " N); deviation from the arc max " << r.deviation_max_mm << " mm";
    const auto mark = [&os](const char* what, bool has, double at_s, const std::array<double, 3>& p,
                            const std::array<double, 3>& m, double& largest) {
      if (!has) return;
      if (at_s < 0.0) {
        os << what << " mark missed (none)";
        largest = -1.0;
        return;
      }
      const double e = distance_mm(p, m);
      os << what << " " << e << " mm from its mark";
      if (largest >= 0.0) largest = std::max(largest, e);
    };
    const NeedlePassFigures none{};
    for (std::size_t i = 0; i < std::max(r.num_passes, marked); ++i) {
      const NeedlePassFigures& p = i < r.num_passes ? r.passes[i] : none;
      if (several) {
        os << "; pass " << i + 1 << ": ";
        if (p.entry_s < 0.0)
          os << "never in";
        else
          pass_text(p);
      }
      const bool has_entry = i < r.entry_marks.size(), has_exit = i < r.exit_marks.size();
      const char* separator = several ? ", " : "; ";
      if (has_entry) os << separator;
      mark("entry", has_entry, p.entry_s, p.entry, has_entry ? r.entry_marks[i] : none.entry, s.needle_entry_error_mm);
      if (has_exit) os << separator;
      mark("exit", has_exit, p.exit_s, p.exit, has_exit ? r.exit_marks[i] : none.exit, s.needle_exit_error_mm);
    }
    s.needle_lines.push_back(os.str());
    if (r.tunnels > 0) {
      std::ostringstream w;
      w << std::fixed << std::setprecision(3) << "needle '" << r.name
        << "' went into tissue without puncturing it " << r.tunnels << " "
        << plural_of(r.tunnels, "time", "times") << ", the first at " << r.first_tunnel_s
        << " s (a tunnel: its tip crossed a net's surface inwards within one step, past the "
           "contact that should have held it until the puncture force; docs/suturing.md, \"The "
           "needle through tissue\")";
      s.warnings.push_back(w.str());
    }
  }
}

}  // namespace numen::sim
