#pragma once
/// @file exchange.hpp
/// What the two loops of a multirate god-object hand each other (numen/core/multirate.hpp,
/// docs/multirate.md): the device loop's report (MultirateDeviceReport), the scene loop's report
/// (MultirateSceneReport: the intermediate model, i.e. the planes, and the scene's StepOutputs).

#include <array>
#include <cstdint>
#include <vector>

#include "numen/core/data.hpp"
#include "numen/core/multirate/planes.hpp"
#include "numen/core/step_outputs.hpp"
#include "numen/core/types.hpp"

namespace numen::core {

/// What the device loop hands the scene loop (MultirateGodObject::write_report()): the
/// god-object's state, and the impulses its planes gave the scene bodies as running totals, so
/// that a report the scene loop never read loses nothing.
struct MultirateDeviceReport {
  std::int64_t period = 0;   ///< Device periods stepped when written.
  int body = -1;             ///< The held body (scene body index; −1: none held).
  /// The states of the god-object's bodies (god_object_bodies() of `body`, in that order;
  /// world); room for the largest god-object.
  std::vector<BodyState> states;
  /// Per scene body: Σ over all device periods of the impulse the planes gave it (N·s) and its
  /// moment about its centre of mass as the device loop moved it (N·m·s).
  std::vector<Wrench> impulse_total;
  std::int64_t switches = 0;  ///< select() calls that changed the god-object so far.
  int released_body = -1;     ///< The held body the last switch released (−1: none).
  std::vector<BodyState> released_states;  ///< Its god-object's bodies' states at the switch.
  /// Per needle (Model::needles): > 0 when the device loop found the needle's tip pressing on
  /// the tissue's planes by its puncture force along its tangent (the force then, N; latched
  /// until the scene loop makes the puncture, or withdrawn when the force falls back below it),
  /// 0 otherwise (docs/multirate-suturing.md, "A needle in the device loop").
  std::vector<double> puncture_requests;
};

/// What the scene loop hands the device loop (MultirateGodObject::scene_step()), its report: the
/// intermediate model for the god-object it sampled and the snapshot of the scene (where a
/// switch starts the new god-object).
struct MultirateSceneReport {
  ContactPlaneSet planes;
  int body = -1;                     ///< The god-object the planes are for (−1: none).
  std::int64_t sample_period = -1;   ///< MultirateDeviceReport::period of the sample.
  /// The scene at the scene step's end (where a switch starts the new god-object), copied so
  /// that the device loop never reads the scene loop's Data: what the single-rate view
  /// (MultirateGodObject::view()) needs. Sized like the scene's Data; its contacts are those not
  /// on the god-object.
  StepOutputs scene;
};

}  // namespace numen::core
