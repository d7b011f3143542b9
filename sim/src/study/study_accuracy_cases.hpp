#pragma once
/// @file study_accuracy_cases.hpp
/// The cases of `numen study accuracy` (study_accuracy.hpp): each simulates its tool with an
/// integrator at a step and returns the tool's points and frames every 10 ms. Internal to
/// numen::sim.

#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/types.hpp"

namespace numen::sim::accuracy {

/// Period of the samples compared (s): every step of the grid divides it.
inline constexpr double kSamplePeriod = 0.01;

/// The tool's state at t = k · kSamplePeriod, k = 1 … horizon / kSamplePeriod: per sample,
/// `points_per_sample` points (m, world: bodies' centres of mass, net nodes) and
/// `frames_per_sample` orientations (bodies'), sample-major.
struct Samples {
  int points_per_sample = 0;
  int frames_per_sample = 0;
  std::vector<core::Vec3> points;
  std::vector<core::Quat> frames;
  double cpu_s = 0.0;  ///< Thread CPU time of the stepping loop (s).
  std::int64_t steps = 0;
  std::int64_t nonfinite_steps = 0;  ///< core::Data::nonfinite_steps at the end.
};

/// One case of the study.
class AccuracyCase {
 public:
  virtual ~AccuracyCase() = default;
  /// Simulated time of a full study (s, a multiple of kSamplePeriod).
  virtual double default_horizon() const = 0;
  /// Runs `integrator` at step `dt` (dividing kSamplePeriod) over `horizon` (s).
  virtual Samples simulate(core::Integrator integrator, double dt, double horizon) const = 0;
  /// True when exact() gives the closed-form solution.
  virtual bool has_closed_form() const { return false; }
  /// The exact samples over `horizon` (closed-form cases only).
  virtual Samples exact(double /*horizon*/) const { return {}; }
  /// Relative cost of one step (for the progress bar's estimate).
  virtual double step_cost() const { return 1.0; }
};

/// Case "free-body": closed-form damped oscillator (study_accuracy_free_body.cpp).
std::unique_ptr<AccuracyCase> make_free_body_case();
/// Onset depth δ0 of case "wall-smoothed" (m): the wall's material with the smoothed C¹
/// contact onset (core::MaterialPair::onset_depth), half the linear law's 0.2 mm rest depth.
inline constexpr double kWallOnsetDepth = 1e-4;

/// Cases "wall" (`onset_depth` 0: the linear penalty law) and "wall-smoothed" (kWallOnsetDepth):
/// god-object pushed into a plane (study_accuracy_wall.cpp).
std::unique_ptr<AccuracyCase> make_wall_case(double onset_depth);
/// Cases "articulated" and "deformable": the scene at `scene_path` driven by its recorded
/// trajectory, interpolated C¹ in axis space, from `t0` (s) on (study_accuracy_scene.cpp).
std::unique_ptr<AccuracyCase> make_scene_case(const std::string& scene_path, double t0,
                                              double horizon, double step_cost);

/// True for the second-order schemes: the trapezoidal rule and TR-BDF2.
bool second_order(core::Integrator integrator) noexcept;

/// Time at which a step starting at t feeds its time-dependent inputs: t + h/2 for the
/// trapezoidal rule and TR-BDF2 (both are applied to the step's linearisation with its inputs
/// held: second order needs the midpoint), t for the Euler schemes.
double input_time(core::Integrator integrator, double t, double dt) noexcept;

/// `model` with `integrator` and step `dt`, finalized again. Throws std::runtime_error if
/// finalize_model() refuses it.
core::Model with_scheme(const core::Model& model, core::Integrator integrator, double dt);

/// Thread CPU time (s), CLOCK_THREAD_CPUTIME_ID.
double thread_cpu_seconds() noexcept;

/// Steps `data` from t = 0 over `horizon` at model.dt, calling inputs(t, t_in, data) before
/// each step (t its start, t_in = input_time()) and collect(data, samples) every
/// kSamplePeriod. Times the loop.
template <class Inputs, class Collect>
Samples run_stepping(const core::Model& model, core::Data& data, double horizon, Inputs&& inputs,
                     Collect&& collect, int points, int frames);

}  // namespace numen::sim::accuracy

#include "numen/core/step.hpp"

namespace numen::sim::accuracy {

template <class Inputs, class Collect>
Samples run_stepping(const core::Model& model, core::Data& data, double horizon, Inputs&& inputs,
                     Collect&& collect, int points, int frames) {
  Samples s;
  s.points_per_sample = points;
  s.frames_per_sample = frames;
  const double h = model.dt;
  const auto per_sample = static_cast<std::int64_t>(std::llround(kSamplePeriod / h));
  const auto samples = static_cast<std::int64_t>(std::llround(horizon / kSamplePeriod));
  s.points.reserve(static_cast<std::size_t>(samples * points));
  s.frames.reserve(static_cast<std::size_t>(samples * frames));
  const double start = thread_cpu_seconds();
  std::int64_t k = 0;
  for (std::int64_t j = 0; j < samples; ++j) {
    for (std::int64_t i = 0; i < per_sample; ++i, ++k) {
      const double t = static_cast<double>(k) * h;
      inputs(t, input_time(model.integrator, t, h), data);
      core::step(model, data);
    }
    collect(data, s);
  }
  s.cpu_s = thread_cpu_seconds() - start;
  s.steps = k;
  s.nonfinite_steps = data.nonfinite_steps;
  return s;
}

}  // namespace numen::sim::accuracy
