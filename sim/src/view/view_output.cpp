#include "numen/sim/view/view_output.hpp"

#include <time.h>

#include <algorithm>
#include <cmath>
#include <utility>

#include "numen/platform/monotonic_clock.hpp"
#include "numen/sim/run/run_summary.hpp"
#include "numen/sim/view/view_scene.hpp"

namespace numen::sim {
namespace {

/// The recording (if any) ahead of the other sinks.
std::vector<platform::StateFrameSink*> with_recording(std::vector<platform::StateFrameSink*> sinks,
                                                      ViewRecordingWriter* writer) {
  if (writer != nullptr) sinks.insert(sinks.begin(), writer);
  return sinks;
}

platform::StateStreamSettings stream_settings(double rate_hz, bool wait) {
  platform::StateStreamSettings settings;
  settings.display_rate_hz = rate_hz;
  settings.full_queue = wait ? hal::FullQueuePolicy::kWait : hal::FullQueuePolicy::kDrop;
  return settings;
}

std::unique_ptr<ViewRecordingWriter> open_recording(const Scene& scene, const std::string& path,
                                                    double rate_hz) {
  if (path.empty()) return nullptr;
  return std::make_unique<ViewRecordingWriter>(
      path, view_scene_message(scene, view_frame_layout(scene), rate_hz));
}

}  // namespace

ViewOutput::ViewOutput(const Scene& scene, const std::string& record_path,
                       std::vector<platform::StateFrameSink*> sinks, double rate_hz, bool wait)
    : writer_(open_recording(scene, record_path, rate_hz)),
      stream_(view_frame_layout(scene), with_recording(std::move(sinks), writer_.get()),
              stream_settings(rate_hz, wait)) {
  stream_.start();
}

ViewOutput::~ViewOutput() { finish(); }

void ViewOutput::finish() {
  stream_.stop();
  if (writer_) writer_->close();
}

void ViewOutput::summarize(RunSummary& s) const {
  const platform::StateStreamCounters c = stream_.counters();
  s.view_streamed = true;
  s.view_frames_published = static_cast<std::int64_t>(c.published);
  s.view_frames_decimated = static_cast<std::int64_t>(c.decimated);
  s.view_frames_dropped = static_cast<std::int64_t>(c.dropped);
  s.view_frames_delivered = static_cast<std::int64_t>(c.delivered);
  s.view_bytes = static_cast<std::int64_t>(c.bytes);
  s.view_sink_errors = static_cast<std::int64_t>(c.sink_errors);
  if (writer_) {
    s.view_recorded = true;
    s.view_record_frames = static_cast<std::int64_t>(writer_->frames());
    s.view_record_io_errors = static_cast<std::int64_t>(writer_->io_errors());
  }
}

ViewPacer::ViewPacer(double dt_s, double speed, std::int64_t wall0_ns,
                     const std::atomic<bool>* stop) noexcept
    : stop_(stop) {
  if (!(speed > 0.0)) return;
  const double ns = dt_s * 1e9 / speed;  // may be +inf for a tiny speed
  period_ns_ = ns >= static_cast<double>(kMaxPeriodNs)
                   ? kMaxPeriodNs
                   : std::max<std::int64_t>(1, std::llround(ns));
  next_ns_ = wall0_ns;
}

void ViewPacer::wait() noexcept {
  if (period_ns_ == 0) return;
  const std::int64_t now = platform::monotonic_now_ns();
  next_ns_ += period_ns_;  // at most one period of 31.7 years per call: no overflow
  if (now > next_ns_ + period_ns_)  // late by a whole period or more: re-phase, do not burst
    next_ns_ += (now - next_ns_) / period_ns_ * period_ns_;
  for (;;) {
    if (stop_ != nullptr && stop_->load(std::memory_order_relaxed)) return;
    const std::int64_t left = next_ns_ - platform::monotonic_now_ns();
    if (left <= 0) return;
    const std::int64_t until = next_ns_ - left + std::min(left, kStopPollNs);
    const timespec ts{static_cast<time_t>(until / 1'000'000'000),
                      static_cast<long>(until % 1'000'000'000)};
    clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr);  // EINTR: loop again
  }
}

}  // namespace numen::sim
