/// @file peer_metrics.cpp
/// Penetration and free-space tracking error from body states.

#include "peer_metrics.hpp"

#include <algorithm>
#include <cmath>

#include "numen/core/collision.hpp"

namespace numen::peer {

MetricAccumulator::MetricAccumulator(const core::Model& model)
    : model_(&model), ghost_(core::make_data(model)) {}

void MetricAccumulator::add(const StepInput& input,
                            const std::vector<core::BodyState>& bodies) noexcept {
  const core::Model& model = *model_;
  ++acc_.steps;
  for (const core::BodyState& b : bodies)
    if (!b.position.allFinite() || !b.orientation.coeffs().allFinite()) {
      ++acc_.nonfinite_steps;
      return;
    }
  const int held = input.held_body;
  if (held < 0 || held >= model.num_bodies()) return;
  std::copy(bodies.begin(), bodies.end(), ghost_.bodies.begin());
  core::detect_contacts(model, ghost_);
  const int tree = model.articulation.body_tree[static_cast<std::size_t>(held)];
  double deepest = 0.0;
  int tool_contacts = 0;
  for (int i = 0; i < ghost_.num_contacts; ++i) {
    const core::Contact& c = ghost_.contacts[static_cast<std::size_t>(i)];
    const bool a = model.articulation.body_tree[static_cast<std::size_t>(c.body_a)] == tree;
    const bool b =
        c.body_b >= 0 && model.articulation.body_tree[static_cast<std::size_t>(c.body_b)] == tree;
    if (!a && !b) continue;
    deepest = std::max(deepest, c.depth);
    ++tool_contacts;
  }
  acc_.penetration_max_mm = std::max(acc_.penetration_max_mm, deepest * 1e3);
  if (tool_contacts == 0) {
    const double e =
        (bodies[static_cast<std::size_t>(held)].position - input.target.position).norm();
    free_sq_ += e * e;
    if (e * 1e3 > acc_.tracking_max_mm) {
      acc_.tracking_max_mm = e * 1e3;
      acc_.tracking_max_step = acc_.steps - 1;
    }
    ++acc_.free_steps;
  }
}

PeerMetrics MetricAccumulator::result() const noexcept {
  PeerMetrics r = acc_;
  r.tracking_rms_mm =
      r.free_steps ? std::sqrt(free_sq_ / static_cast<double>(r.free_steps)) * 1e3 : 0.0;
  return r;
}

}  // namespace numen::peer
