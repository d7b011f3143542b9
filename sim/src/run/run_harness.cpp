/// @file run_harness.cpp
/// RunHarness (run_harness.hpp): what every run's harness owns and does, whichever kind of
/// device its wiring assembles.

#include "numen/sim/run/run_harness.hpp"

#include <cmath>
#include <utility>

namespace numen::sim {

RunHarness::RunHarness(const Scene& scene, std::size_t trace_capacity)
    : scene_(&scene),
      bus_(scene.bus),
      data_(core::make_data(scene.model)),
      multirate_(scene),
      divergence_(scene.model, data_),
      period_ns_(static_cast<std::int64_t>(std::llround(scene.model.dt * 1e9))),
      phase_ns_(static_cast<std::int64_t>(std::llround(scene.compute_phase_s * 1e9))) {
  trace_.reserve(trace_capacity);
  describe_scene(scene, acc_);
}

RunHarness::~RunHarness() = default;

void RunHarness::disassemble() noexcept {
  multirate_.stop();
  loop_.reset();
  rig_.reset();
}

void RunHarness::start_scene_thread(const platform::SceneThreadSettings& settings) {
  multirate_.start_scene_thread(settings);
}

void RunHarness::stream_view(const std::string& record_path,
                             std::vector<platform::StateFrameSink*> sinks, double rate_hz,
                             bool wait) {
  view_ = std::make_unique<ViewOutput>(*scene_, record_path, std::move(sinks), rate_hz, wait);
}

void RunHarness::summarize_periods(RunSummary& s) const {
  s.steps = k_;
  s.sim_time_s = static_cast<double>(k_) * scene_->model.dt;
  s.step_time_us = summarize_ns(loop_->step_time());
  s.solver_iterations_mean =
      k_ > 0 ? static_cast<double>(solver_iterations_sum_) / static_cast<double>(k_) : 0.0;
  s.nonfinite_steps = data_.nonfinite_steps;
  s.invalid_target_steps = data_.invalid_target_steps;
  s.contact_overflow = data_.contact_overflow_steps;
  s.nan_detected = data_.nonfinite_steps > 0;
  for (const auto& b : data_.bodies)
    s.nan_detected = s.nan_detected || !b.position.allFinite() || !b.orientation.coeffs().allFinite();
  for (const auto& n : data_.nodes)
    s.nan_detected = s.nan_detected || !n.position.allFinite() || !n.velocity.allFinite();
  for (auto dir :
       {hal::SimBus::Direction::kControllerToDevice, hal::SimBus::Direction::kDeviceToController}) {
    s.bus_frames_dropped += static_cast<std::int64_t>(bus_.link_counters(dir).dropped);
    s.bus_frames_corrupted += static_cast<std::int64_t>(bus_.link_counters(dir).corrupted());
  }
}

}  // namespace numen::sim
