/// @file multirate_threads.cpp
/// The scene thread of a multirate god-object (multirate_threads.hpp).

#include "numen/platform/multirate_threads.hpp"

#include <time.h>

#include <cerrno>
#include <stdexcept>

#include "numen/platform/monotonic_clock.hpp"
#include "numen/platform/periodic_timer.hpp"

namespace numen::platform {

MultirateThreads::MultirateThreads(core::MultirateGodObject& god_object, std::int64_t scene_period_ns,
                                   SceneThreadSettings settings)
    : god_object_(god_object),
      period_ns_(scene_period_ns),
      settings_(std::move(settings)),
      reports_(god_object.make_report()),
      scene_reports_(god_object.make_scene_report()) {
  if (scene_period_ns <= 0) throw std::invalid_argument("multirate: the scene period must be > 0 ns");
}

MultirateThreads::~MultirateThreads() { stop(); }

void MultirateThreads::start() {
  if (thread_.joinable()) throw std::logic_error("multirate: the scene thread is already running");
  // The first model, on this thread, before the device loop's first period.
  god_object_.write_report(reports_.back());
  reports_.publish();
  reports_.acquire();
  god_object_.scene_step(reports_.front(), scene_reports_.back());
  scene_reports_.publish();
  stop_.store(false);
  setup_done_.store(false);
  setup_error_.clear();
  thread_ = std::thread([this] { run(); });
  setup_done_.wait(false);  // setup time: the thread's scheduling and affinity applied
  if (!setup_error_.empty()) {
    thread_.join();  // it ended without a scene step
    throw std::runtime_error("scene thread: " + setup_error_);
  }
}

void MultirateThreads::stop() noexcept {
  stop_.store(true);
  if (thread_.joinable()) thread_.join();
}

void MultirateThreads::device_step() noexcept {
  const core::MultirateSceneReport* fresh =
      scene_reports_.acquire() ? &scene_reports_.front() : nullptr;
  god_object_.device_step(fresh);
  god_object_.write_report(reports_.back());
  reports_.publish();
}

SceneThreadCounters MultirateThreads::counters() const noexcept {
  SceneThreadCounters c;
  c.scene_steps = scene_steps_.load();
  c.scene_overruns = scene_overruns_.load();
  c.reports_taken = reports_taken_.load();
  return c;
}

void MultirateThreads::run() noexcept {
  RealtimeSettings rt;
  rt.fifo_priority = settings_.fifo_priority;
  rt.cpu_affinity = settings_.cpu_affinity;
  rt.timer_slack_ns = settings_.timer_slack_ns;
  rt.strict = settings_.strict;
  try {
    realtime_ = apply_realtime(rt);  // allocates: before the loop
  } catch (const std::exception& e) {
    // Strict and a step failed, or an invalid priority (the caller's settings are checked
    // before): the report says so; strict ends the thread and start() throws.
    realtime_.scheduling.status = RealtimeStepStatus::kFailed;
    realtime_.scheduling.message = e.what();
    if (settings_.strict) setup_error_ = e.what();
  }
  setup_done_.store(true);
  setup_done_.notify_one();
  if (!setup_error_.empty()) return;
  PeriodicTimer timer(period_ns_, monotonic_now_ns());
  timer.set_spin_ns(settings_.spin_ns);
  while (!stop_.load(std::memory_order_relaxed)) {
    const Wakeup w = timer.wait_next(&stop_, kStopSliceNs);  // stop() heard in a long period
    if (w.stopped) break;
    if (w.overrun) scene_overruns_.fetch_add(1, std::memory_order_relaxed);
    if (stop_.load(std::memory_order_relaxed)) break;
    const std::int64_t t0 = monotonic_now_ns();
    if (reports_.acquire()) reports_taken_.fetch_add(1, std::memory_order_relaxed);
    god_object_.scene_step(reports_.front(), scene_reports_.back());
    scene_reports_.publish();
    scene_time_.record(monotonic_now_ns() - t0);
    scene_steps_.fetch_add(1, std::memory_order_relaxed);
    if (settings_.extra_scene_time_ns > 0) {  // test hook: a slow scene
      const std::int64_t until = monotonic_now_ns() + settings_.extra_scene_time_ns;
      const timespec ts{static_cast<time_t>(until / 1'000'000'000), static_cast<long>(until % 1'000'000'000)};
      while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
      }
    }
  }
}

}  // namespace numen::platform
