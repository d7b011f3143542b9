/// @file pointer_path.cpp
/// A pointer recording replayed through the relative-pose integrator into the target poses
/// at its report times (see pointer_path.hpp).

#include "numen/sim/input/pointer_path.hpp"

#include <algorithm>
#include <cmath>
#include <memory>
#include <stdexcept>

#include "numen/hal/input/evemu_replay.hpp"

namespace numen::sim {

namespace {

/// s: a report time this close to a sample time is at it (1 ps, far below the 1 ns of the
/// recording's clock and of the loop's).
constexpr double kReportSnap = 1e-12;

bool same_pose(const core::Pose& a, const core::Pose& b) noexcept {
  return a.position == b.position && a.orientation.coeffs() == b.orientation.coeffs();
}

}  // namespace

PointerPath::PointerPath(const std::vector<hal::InputEvent>& events,
                         const hal::RelativePoseIntegratorSettings& settings, double jaw)
    : jaw_(jaw), events_(events.size()) {
  if (!std::isfinite(jaw)) throw std::invalid_argument("PointerPath: jaw is not finite");
  hal::RelativePoseIntegrator integrator(settings);
  hal::EvemuReplay replay(events, 0);
  poses_.push_back({0.0, integrator.target()});
  // Every due time of the recording in turn: the reports due then are applied together, as a
  // live period reads every report that arrived since the previous one.
  while (!replay.finished()) {
    const std::int64_t due_ns = replay.next_due_ns();
    replay.set_time_ns(due_ns);
    replay.feed(integrator);
    if (!same_pose(integrator.target(), poses_.back().pose)) {
      poses_.push_back({static_cast<double>(due_ns) * 1e-9, integrator.target()});
    }
  }
  poses_.shrink_to_fit();
  duration_ = static_cast<double>(replay.span_ns()) * 1e-9;
  counters_ = integrator.counters();
}

TrajectorySample PointerPath::evaluate(double t) const noexcept {
  const double tc = t > 0.0 ? std::min(t, duration_) : 0.0;  // NaN → 0
  // Last stored pose at or before tc (poses_[0] is at 0). A report within kReportSnap of tc
  // counts as at tc: a period at a report's time in ns (k · dt as a double) must see it, as
  // a live period reading at that time does.
  const auto it = std::upper_bound(poses_.begin(), poses_.end(), tc + kReportSnap,
                                   [](double v, const Stamped& s) { return v < s.time; });
  const Stamped& s = *(it - 1);
  TrajectorySample out;
  out.time = tc;
  out.pose = s.pose;
  out.jaw = jaw_;
  return out;
}

std::size_t PointerPath::memory_bytes() const noexcept {
  return sizeof(PointerPath) + poses_.capacity() * sizeof(Stamped);
}

ComputedMotion::FarthestPoint PointerPath::farthest_point(const Placement& placement) const noexcept {
  FarthestPoint far;
  for (const Stamped& s : poses_) {
    const double d = apply(placement, s.pose.position).norm();
    if (d > far.distance || !std::isfinite(d)) far = {d, s.time};
  }
  return far;
}

Trajectory PointerPath::sample(double dt) const {
  return sample_motion(std::make_shared<const PointerPath>(*this), dt, "trajectory.dt");
}

}  // namespace numen::sim
