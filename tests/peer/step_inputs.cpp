/// @file step_inputs.cpp
/// Recording and replaying the device inputs of core::step.

#include "step_inputs.hpp"

#include <algorithm>
#include <memory>

#include "numen/core/step.hpp"
#include "numen/sim/run/run.hpp"

namespace numen::peer {

InputRecording record_scene_inputs(const sim::Scene& scene, int steps) {
  InputRecording rec;
  rec.reserve(static_cast<std::size_t>(std::max(steps, 0)));
  auto runner = std::make_unique<sim::SceneRunner>(scene);
  for (int k = 0; k < steps; ++k) {
    runner->period();
    const core::Data& d = runner->data();
    StepInput in;
    in.held_body = d.held_body;
    in.target = d.target;
    in.target_twist = d.target_twist;
    in.body_targets = d.body_targets;
    in.joint_prescribed = d.joint_prescribed;
    rec.push_back(std::move(in));
  }
  return rec;
}

void apply_step_input(const core::Model& model, const StepInput& input, core::Data& data) noexcept {
  if (data.held_body != input.held_body) core::set_held_body(model, data, input.held_body);
  data.target = input.target;
  data.target_twist = input.target_twist;
  std::copy(input.body_targets.begin(), input.body_targets.end(), data.body_targets.begin());
  std::copy(input.joint_prescribed.begin(), input.joint_prescribed.end(),
            data.joint_prescribed.begin());
}

}  // namespace numen::peer
