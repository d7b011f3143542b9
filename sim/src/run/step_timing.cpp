/// @file step_timing.cpp
/// The scene's step timed at load (step_timing.hpp).

#include "numen/sim/run/step_timing.hpp"

#include <algorithm>
#include <cstdio>
#include <stdexcept>
#include <vector>

#include <nlohmann/json.hpp>

#include "numen/core/data.hpp"
#include "numen/core/step.hpp"
#include "numen/platform/monotonic_clock.hpp"

namespace numen::sim {

StepTiming time_scene_step(const Scene& scene, int max_steps, double budget_s) {
  StepTiming t;
  t.multirate = scene.multirate.has_value();
  t.period_s = t.multirate ? scene.multirate->scene_dt_s : scene.model.dt;
  core::Data data = core::make_data(scene.model);
  core::step(scene.model, data);  // warm-up: first touch of the model's and data's pages
  std::vector<double> us;
  us.reserve(static_cast<std::size_t>(std::max(max_steps, 1)));
  const std::int64_t start = platform::monotonic_now_ns();
  const auto budget_ns = static_cast<std::int64_t>(budget_s * 1e9);
  for (int k = 0; k < std::max(max_steps, 1); ++k) {
    const std::int64_t t0 = platform::monotonic_now_ns();
    core::step(scene.model, data);
    const std::int64_t t1 = platform::monotonic_now_ns();
    us.push_back(static_cast<double>(t1 - t0) * 1e-3);
    if (k >= 2 && t1 - start > budget_ns) break;
  }
  t.steps = static_cast<int>(us.size());
  t.max_us = *std::max_element(us.begin(), us.end());
  std::nth_element(us.begin(), us.begin() + static_cast<std::ptrdiff_t>(us.size() / 2), us.end());
  t.median_us = us[us.size() / 2];
  return t;
}

namespace {

std::string fixed(double v, int digits) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*f", digits, v);
  return buf;
}

std::string period_text(const StepTiming& t) {
  return fixed(t.period_s * 1e6, 0) + " us " + (t.multirate ? "scene period" : "period");
}

}  // namespace

std::optional<std::string> step_timing_warning(const StepTiming& t) {
  const double period_us = t.period_s * 1e6;
  if (!(t.median_us > kStepTimingWarnShare * period_us)) return std::nullopt;
  const std::string took = "the scene's step took " + fixed(t.median_us, 0) +
                           " us at load (median of " + std::to_string(t.steps) +
                           " steps from the loaded state: the tool at rest, no contact)";
  if (!(t.median_us > period_us))
    return took + ", " + fixed(100.0 * t.median_us / period_us, 0) + "% of its " + period_text(t) +
           ": a run's step adds the hand's contacts and the run's measurements, so a paced run "
           "(--realtime, a real bus) may overrun its periods (docs/realtime.md, \"Before a paced "
           "run\")";
  return took + " against its " + period_text(t) +
         ": a paced run (--realtime, a real bus) will overrun its periods. It does not bound an "
         "offline run's speed: a run's step adds the hand's contacts and the run's measurements, "
         "and the organ's resting nodes save work (the run's step_time_us says; docs/realtime.md, "
         "\"Before a paced run\")";
}

std::string describe_step_timing(const StepTiming& t) {
  return "step at load: median " + fixed(t.median_us, 1) + " us, max " + fixed(t.max_us, 1) +
         " us over " + std::to_string(t.steps) + " steps, against the " + period_text(t) + " (" +
         fixed(100.0 * t.median_us / (t.period_s * 1e6), 1) + "% of it)";
}

std::string with_step_timing_json(const std::string& json_object, const StepTiming& t) {
  nlohmann::ordered_json j = nlohmann::ordered_json::parse(json_object, nullptr, false);
  if (!j.is_object()) throw std::invalid_argument("with_step_timing_json: not a JSON object");
  j["step_at_load"] = {{"median_us", t.median_us},
                       {"max_us", t.max_us},
                       {"steps", t.steps},
                       {"period_s", t.period_s},
                       {"multirate", t.multirate}};
  return j.dump(-1, ' ', false, nlohmann::ordered_json::error_handler_t::replace);
}

}  // namespace numen::sim
