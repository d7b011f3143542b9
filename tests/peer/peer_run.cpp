/// @file peer_run.cpp
/// Stepping and timing each engine over a scene.

#include "peer_run.hpp"

#include <algorithm>

#include "mujoco_engine.hpp"
#include "numen/core/step.hpp"
#include "numen/platform/monotonic_clock.hpp"
#include "numen/sim/scene/scene.hpp"

namespace numen::peer {

std::vector<int> held_bodies(const InputRecording& inputs) {
  std::vector<int> held;
  for (const StepInput& in : inputs)
    if (in.held_body >= 0 && std::find(held.begin(), held.end(), in.held_body) == held.end())
      held.push_back(in.held_body);
  std::sort(held.begin(), held.end());
  return held;
}

PeerRow run_numen(const PeerScene& scene) {
  const core::Model& model = scene.model;
  core::Data data = core::make_data(model);
  MetricAccumulator metrics(model);
  std::vector<std::int64_t> ns;
  ns.reserve(scene.inputs.size());
  PeerRow row;
  row.scene = scene.name;
  row.engine = "numen";
  row.variant =
      std::string(sim::to_string(model.integrator)) + ", " + sim::to_string(model.coupling_mode);
  for (const StepInput& in : scene.inputs) {
    apply_step_input(model, in, data);
    const std::int64_t t0 = platform::monotonic_now_ns();
    core::step(model, data);
    const std::int64_t t1 = platform::monotonic_now_ns();
    ns.push_back(t1 - t0);
    row.contacts_max = std::max(row.contacts_max, data.num_contacts);
    metrics.add(in, data.bodies);
  }
  row.steps = static_cast<std::int64_t>(ns.size());
  percentiles_us(ns, row.step_median_us, row.step_p99_us);
  row.metrics = metrics.result();
  row.divergences = static_cast<int>(data.nonfinite_steps);
  return row;
}

PeerRow run_mujoco(const PeerScene& scene, Drive drive) {
  MujocoEngine engine(scene.model, drive, held_bodies(scene.inputs));
  MetricAccumulator metrics(scene.model);
  std::vector<core::BodyState> states;
  engine.read_states(states);
  std::vector<std::int64_t> ns;
  ns.reserve(scene.inputs.size());
  PeerRow row;
  row.scene = scene.name;
  row.engine = "mujoco";
  row.variant = to_string(drive);
  for (const StepInput& in : scene.inputs) {
    engine.apply(in);
    const std::int64_t t0 = platform::monotonic_now_ns();
    engine.step();
    const std::int64_t t1 = platform::monotonic_now_ns();
    ns.push_back(t1 - t0);
    row.contacts_max = std::max(row.contacts_max, engine.num_contacts());
    engine.read_states(states);
    metrics.add(in, states);
  }
  row.steps = static_cast<std::int64_t>(ns.size());
  percentiles_us(ns, row.step_median_us, row.step_p99_us);
  row.metrics = metrics.result();
  row.divergences = engine.divergences();
  return row;
}

std::vector<PeerRow> run_comparison(const std::vector<PeerScene>& scenes,
                                    void (*progress)(const PeerRow&)) {
  std::vector<PeerRow> rows;
  for (const PeerScene& s : scenes) {
    const PeerRow n = run_numen(s);
    rows.push_back(n);
    if (progress) progress(rows.back());
    for (Drive d : {Drive::kMocapWeld, Drive::kPdForce}) {
      PeerRow r = run_mujoco(s, d);
      r.ratio_numen_over_this = r.step_median_us > 0.0 ? n.step_median_us / r.step_median_us : 0.0;
      rows.push_back(r);
      if (progress) progress(rows.back());
    }
  }
  return rows;
}

}  // namespace numen::peer
