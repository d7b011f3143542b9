#pragma once
/// @file step_timing.hpp
/// A short timing of a scene's step at load (`numen run`, `numen info`): whether the scene's
/// world can keep its period on this machine before a paced run finds out by overrunning.
/// The step is core::step() of the whole model from its loaded state (the tool at rest where
/// the scene puts it, the organ's nets included, their nodes resting only after ten quiet
/// steps): not a bound of a run's step either way — a run adds the contacts the hand makes, the
/// device and the run's measurements, and saves the work of the organ's resting nodes
/// (docs/realtime.md, "Before a paced run").

#include <optional>
#include <string>

#include "numen/sim/scene/scene.hpp"

namespace numen::sim {

/// What time_scene_step() measured.
struct StepTiming {
  int steps = 0;           ///< Steps timed (after one untimed warm-up step).
  double median_us = 0.0;  ///< Median wall time of one step (µs, CLOCK_MONOTONIC).
  double max_us = 0.0;     ///< Longest step (µs).
  /// The period the step must fit (s): the scene loop's period scene_dt of a [multirate]
  /// scene (its scene step is this step plus the intermediate model's building), else dt.
  double period_s = 0.0;
  bool multirate = false;  ///< period_s is a [multirate] scene period.
};

/// Steps a copy of `scene`'s model from its loaded state and times each step: at most
/// `max_steps` steps (≥ 1) and, past the first 3, no more than `budget_s` of wall time in all
/// (a 200 000-triangle organ must not make the load wait). Setup code: allocates the copy.
StepTiming time_scene_step(const Scene& scene, int max_steps = 20, double budget_s = 0.25);

/// A median step at load above this share of its period is a warning: a run's step adds what
/// the timing leaves out (the hand's contacts, the run's measurements), so a paced run may not
/// keep the period (docs/realtime.md, "Before a paced run").
inline constexpr double kStepTimingWarnShare = 0.5;

/// The warning of a timing whose median step is above kStepTimingWarnShare of its period, else
/// nothing: above the period, a paced run will overrun its periods; between, it may. Names the
/// median, the steps, the period and what the timing leaves out; it claims no offline real-time
/// factor (the timing bounds a run's step neither way: the run adds contacts and measurements,
/// its resting nodes save work).
std::optional<std::string> step_timing_warning(const StepTiming& timing);

/// One line for `numen info`: "step at load: median X us, max Y us over N steps, against the
/// Z us period (A% of it)".
std::string describe_step_timing(const StepTiming& timing);

/// `numen info --json`: the JSON object `json_object` (one line, as format_scene_info_json()
/// writes it) with the member "step_at_load": {"median_us", "max_us", "steps", "period_s",
/// "multirate"} added last, the figures describe_step_timing() prints. Throws
/// std::invalid_argument when `json_object` is not a JSON object.
std::string with_step_timing_json(const std::string& json_object, const StepTiming& timing);

}  // namespace numen::sim
