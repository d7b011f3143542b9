#pragma once
/// @file step_inputs.hpp
/// The device inputs of core::step, period by period, recorded once so that both engines of a
/// peer comparison are fed exactly the same targets (docs/peer.md). For a scene file they are
/// recorded from a sim::SceneRunner run (simulated bus, encoder decoding, instrument
/// kinematics, tool-switching events): what numen's core::step consumed in each period.

#include <vector>

#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/sim/scene/scene.hpp"

namespace numen::peer {

/// What core::step reads from the device in one period (the inputs of core::Data).
struct StepInput {
  int held_body = -1;        ///< Body the device holds (-1: none); tool switching.
  core::Pose target;         ///< Target of the held body's COM frame (world, m).
  core::Twist target_twist;  ///< Its twist (world; m/s, rad/s).
  /// Per body: its own target (Eq. 6), disabled for bodies the device does not measure.
  std::vector<core::BodyTarget> body_targets;
  /// Per joint: the imposed coordinate of a prescribed joint (rad or m) and its rate.
  std::vector<core::JointPrescription> joint_prescribed;
};

/// One StepInput per period of dt = Model::dt, in order.
using InputRecording = std::vector<StepInput>;

/// Runs `scene` for `steps` periods through sim::SceneRunner (simulated bus, the scene's device,
/// events) and records the inputs core::step consumed in each period. Allocates; throws what
/// SceneRunner throws.
InputRecording record_scene_inputs(const sim::Scene& scene, int steps);

/// Writes `input` into `data` before core::step: the device holds input.held_body
/// (core::set_held_body, only when it changes) and copies the targets and prescriptions.
/// `data` must come from make_data(model) and `input` have the model's body and joint counts.
/// No allocation.
void apply_step_input(const core::Model& model, const StepInput& input, core::Data& data) noexcept;

}  // namespace numen::peer
