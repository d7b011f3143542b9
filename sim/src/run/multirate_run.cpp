/// @file multirate_run.cpp

#include "numen/sim/run/multirate_run.hpp"

#include <cmath>
#include <utility>

#include "numen/sim/run/run_summary.hpp"

namespace numen::sim {

MultirateRun::MultirateRun(const Scene& scene) : scene_(&scene) {
  if (!scene.multirate) return;
  const core::MultirateSettings settings{scene.multirate->ratio, scene.multirate->margin_m,
                                         scene.multirate->tools, scene.multirate->fold_step_s,
                                         scene.multirate->other_devices,
                                         scene.multirate->carried};
  god_object_ = std::make_unique<core::MultirateGodObject>(
      scene.model, scene.model.initial_held_body, settings);
}

MultirateRun::~MultirateRun() { stop(); }

void MultirateRun::step(const core::Model& model, core::Data& run_data) noexcept {
  (void)model;
  if (!god_object_) return;
  core::MultirateGodObject& m = *god_object_;
  m.select(run_data.held_body);  // every held body is one of the tools (parse_multirate)
  m.take_targets(run_data);
  if (scene_thread_)
    scene_thread_->device_step();
  else
    m.step();
  m.write_feedback(run_data);  // what the loop maps to commands; the rest of the view in view()
}

void MultirateRun::finish(const core::Model& model, core::Data& run_data) noexcept {
  (void)model;
  if (god_object_) god_object_->view(run_data);
}

void MultirateRun::start_scene_thread(const platform::SceneThreadSettings& settings) {
  if (!god_object_ || scene_thread_) return;
  const auto period = static_cast<std::int64_t>(std::llround(scene_->multirate->scene_dt_s * 1e9));
  scene_thread_ = std::make_unique<platform::MultirateThreads>(*god_object_, period, settings);
  scene_thread_->start();
}

void MultirateRun::stop() noexcept {
  if (scene_thread_) scene_thread_->stop();
}

void MultirateRun::summarize(RunSummary& s) const {
  if (!god_object_) return;
  const core::MultirateCounters& c = god_object_->counters();
  s.multirate.scene_steps = c.scene_steps;
  s.multirate.planes_max = c.planes_max;
  s.multirate.planes_dropped = c.planes_dropped;
  s.multirate.switches = c.switches;
  s.multirate.stale_models = c.stale_models;
  s.multirate.reset_energy_j = c.reset_energy;
  s.multirate.reset_energy_max_j = c.reset_energy_max;
  s.multirate.folded_scene_steps = c.folded_scene_steps;
  if (scene_thread_) {
    s.multirate.scene_thread = true;
    s.multirate.scene_overruns = scene_thread_->counters().scene_overruns;
    s.multirate.scene_step_us = summarize_ns(scene_thread_->scene_step_time());
  }
  if (c.planes_dropped > 0)
    s.warnings.push_back("multirate: " + std::to_string(c.planes_dropped) +
                         " contacts of the god-object found beyond the room for " +
                         std::to_string(core::kMaxContactPlanes) +
                         " planes: the device loop did not see those surfaces");
}

void MultirateRun::describe_scene_thread(const platform::SceneThreadSettings& settings,
                                         std::vector<std::string>& lines) const {
  if (!scene_thread_) return;
  for (const std::string& line : platform::describe(scene_thread_->realtime_report()))
    if ((settings.fifo_priority != 0 && line.rfind("scheduling:", 0) == 0) ||
        (!settings.cpu_affinity.empty() && line.rfind("cpu affinity:", 0) == 0) ||
        (settings.timer_slack_ns > 0 && line.rfind("timer slack:", 0) == 0))
      lines.push_back("scene thread " + line);
}

}  // namespace numen::sim
