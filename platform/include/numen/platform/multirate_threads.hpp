#pragma once
/// @file multirate_threads.hpp
/// MultirateThreads: the scene loop of a core::MultirateGodObject on its own thread, paced at
/// scene_dt, exchanging the device report and the scene report (its planes: the intermediate model)
/// with the device loop through two lock-free TripleBuffers (docs/multirate.md, "Two threads"). The
/// device loop (the caller's real-time thread) calls device_step() every period: it takes the
/// newest model if one came, steps the god-object, publishes its report — never blocking, never
/// allocating, and keeping the last model when a scene step is late
/// (MultirateCounters::stale_models). The scene thread wakes every scene_dt (CLOCK_MONOTONIC,
/// absolute deadlines), takes the newest report, steps the scene and publishes the model; a scene
/// step that runs past its next deadline is counted (scene_overruns) and the thread resumes at the
/// next deadline after now (no catch-up burst). For offline, reproducible runs use
/// MultirateGodObject::step() on one thread instead.

#include <atomic>
#include <cstdint>
#include <string>
#include <thread>
#include <vector>

#include "numen/core/multirate.hpp"
#include "numen/platform/latency_histogram.hpp"
#include "numen/platform/realtime_setup.hpp"
#include "numen/platform/triple_buffer.hpp"

namespace numen::platform {

/// Settings of the scene thread.
struct SceneThreadSettings {
  /// Scheduling and affinity of the scene thread (apply_realtime() on it; memory lock and
  /// stack prefault are the device loop's, process-wide or its own: not applied here).
  int fifo_priority = 0;
  std::vector<int> cpu_affinity;
  /// Timer slack of the scene thread (ns), as RealtimeSettings::timer_slack_ns; 0: leave it.
  std::int64_t timer_slack_ns = 0;
  /// The scene thread's wait before each scene period sleeps until this long before the
  /// deadline and then reads CLOCK_MONOTONIC until it (ns; PeriodicTimer::set_spin_ns(),
  /// clamped to [0, the scene period]; `numen run --scene-spin`): its CPU stays busy, so a
  /// virtual CPU is not halted between scene steps (docs/realtime.md, "Paced on a 16-core
  /// machine"). Needs a CPU of its own (cpu_affinity). 0 (default): one sleep to the deadline.
  std::int64_t spin_ns = 0;
  /// Like RealtimeSettings::strict: a step that fails stops the thread and start() throws
  /// (else the failure is reported in realtime_report() and the thread runs on).
  bool strict = false;
  /// Test hook: extra wall time (ns) the scene thread spends after each scene step (a scene
  /// made artificially slow). 0 in use.
  std::int64_t extra_scene_time_ns = 0;
};

/// What the scene thread did.
struct SceneThreadCounters {
  std::int64_t scene_steps = 0;     ///< Scene periods stepped on the thread.
  std::int64_t scene_overruns = 0;  ///< Scene periods that ended past the next deadline.
  std::int64_t reports_taken = 0;   ///< Scene periods that found a new device report.
};

/// The scene thread of a multirate god-object (see the file comment). Not copyable.
class MultirateThreads {
 public:
  /// Keeps a reference to `god_object` (must outlive this). Sizes the buffers from it
  /// (allocates); does not start the thread.
  MultirateThreads(core::MultirateGodObject& god_object, std::int64_t scene_period_ns,
                   SceneThreadSettings settings = {});
  ~MultirateThreads();
  MultirateThreads(const MultirateThreads&) = delete;
  MultirateThreads& operator=(const MultirateThreads&) = delete;

  /// Runs one scene step on the calling thread (the first model, so that the device loop
  /// starts with planes), then starts the scene thread, first deadline one scene period from
  /// now. Returns once the thread has applied its settings. Throws std::system_error if the
  /// thread cannot start, std::logic_error if started, std::runtime_error (the failed steps)
  /// when SceneThreadSettings::strict and a step failed (the thread has then ended).
  void start();
  /// Stops and joins the scene thread (idempotent). After it the god-object's scene loop may be
  /// stepped on the calling thread again.
  void stop() noexcept;
  bool running() const noexcept { return thread_.joinable(); }

  /// Device loop (the caller's thread): one device period — the newest model if one came,
  /// MultirateGodObject::device_step(), the report published. Never allocates, throws, locks
  /// or blocks.
  void device_step() noexcept;

  /// The scene thread's counters (read them after stop() for exact values).
  SceneThreadCounters counters() const noexcept;
  /// Wall time of the scene steps on the thread (ns; read after stop()).
  const LatencyHistogram& scene_step_time() const noexcept { return scene_time_; }
  /// The outcome of applying SceneThreadSettings on the thread (after start(); describe()).
  const RealtimeReport& realtime_report() const noexcept { return realtime_; }

 private:
  void run() noexcept;

  core::MultirateGodObject& god_object_;
  std::int64_t period_ns_;
  SceneThreadSettings settings_;
  TripleBuffer<core::MultirateDeviceReport> reports_;       // device → scene
  TripleBuffer<core::MultirateSceneReport> scene_reports_;  // scene → device
  std::thread thread_;
  std::atomic<bool> stop_{false};
  std::atomic<std::int64_t> scene_steps_{0};
  std::atomic<std::int64_t> scene_overruns_{0};
  std::atomic<std::int64_t> reports_taken_{0};
  LatencyHistogram scene_time_;
  RealtimeReport realtime_;
  std::atomic<bool> setup_done_{false};  // the thread applied its settings (start() waits)
  std::string setup_error_;              // strict and a step failed: why (written before setup_done_)
};

}  // namespace numen::platform
