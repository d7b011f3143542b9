#pragma once
/// @file view_output.hpp
/// A run's state stream (docs/viewer.md), as the run harness holds it (RunHarness::stream_view(),
/// published by SceneRunner, run.cpp, and AdmittanceRunner, admittance_run.cpp): the platform::StateStream, the view recording it
/// feeds (`--record-view`), the further sinks (`--view`'s server), its figures in the run
/// summary, and the pacing of an offline run that a live viewer watches (`--speed`).

#include <atomic>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "numen/platform/state_stream.hpp"
#include "numen/sim/scene/scene.hpp"
#include "numen/sim/view/view_recording.hpp"

namespace numen::sim {

struct RunSummary;

/// The stream of one run: made and started on the setup thread, published on the loop's.
class ViewOutput {
 public:
  /// Lays out the frames of `scene` (view_frame_layout), opens the view recording at
  /// `record_path` unless empty (written first, then `sinks`, not owned, which must outlive
  /// this), and starts the stream's thread at `rate_hz` frames per simulated second; `wait`:
  /// the loop waits for the consumers (offline runs), else frames are dropped and counted.
  /// Throws InputError at --record-view when the file cannot be created.
  ViewOutput(const Scene& scene, const std::string& record_path,
             std::vector<platform::StateFrameSink*> sinks, double rate_hz, bool wait);
  /// finish().
  ~ViewOutput();
  ViewOutput(const ViewOutput&) = delete;
  ViewOutput& operator=(const ViewOutput&) = delete;

  /// The loop's side (after core::step): platform::StateStream::publish() — device 0's
  /// `report` and `axis_values`, the loop's other devices' `extra_devices` (as many as the
  /// scene's Scene::extra_devices). noexcept, no allocation, no lock; waits only when made with
  /// `wait`.
  void publish(const core::Data& data, const platform::PeriodReport& report,
               std::span<const double> axis_values, const platform::StateFrameFigures& figures,
               std::span<const platform::FrameDeviceInput> extra_devices = {}) noexcept {
    stream_.publish(data, report, axis_values, figures, extra_devices);
  }
  /// Delivers what is queued, stops the thread and closes the recording. Idempotent.
  void finish();
  /// Writes the stream's and the recording's figures into `s` (view_* fields).
  void summarize(RunSummary& s) const;

 private:
  std::unique_ptr<ViewRecordingWriter> writer_;  // --record-view
  platform::StateStream stream_;
};

/// Paces an unpaced run (simulated bus or log, no --realtime) for a live viewer (`--speed`):
/// each wait() sleeps until the next period is due at `speed` × real time, on absolute
/// CLOCK_MONOTONIC deadlines from `wall0_ns` (no drift; a run that falls behind re-phases
/// instead of bursting, as platform::PeriodicTimer does). `speed` <= 0: wait() returns at once.
/// A stop request is always heard: the sleep is cut into slices of at most kStopPollNs, and
/// wait() returns as soon as `*stop` is true (a period of 10⁶ s at `--speed 1e-9` ends within
/// one slice of a SIGTERM).
class ViewPacer {
 public:
  /// Longest slice of one sleep (ns): the latency of a stop request during a wait.
  static constexpr std::int64_t kStopPollNs = 10'000'000;
  /// Longest period (ns) a pacer keeps: about 31.7 years (dt / speed beyond it is clamped).
  static constexpr std::int64_t kMaxPeriodNs = 1'000'000'000'000'000'000;
  /// `stop`: the run's stop request (RunOptions::stop), or nullptr; must outlive the pacer.
  ViewPacer(double dt_s, double speed, std::int64_t wall0_ns,
            const std::atomic<bool>* stop = nullptr) noexcept;
  /// Sleeps until the next period of this pacer is due, or until a stop is requested.
  void wait() noexcept;

 private:
  std::int64_t period_ns_ = 0;  // 0: no pacing
  std::int64_t next_ns_ = 0;    // absolute CLOCK_MONOTONIC deadline of the next period
  const std::atomic<bool>* stop_ = nullptr;
};

}  // namespace numen::sim
