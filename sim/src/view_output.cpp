#include "numen/sim/view_output.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include "numen/sim/run.hpp"
#include "numen/sim/view_scene.hpp"

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

ViewPacer::ViewPacer(double dt_s, double speed, std::int64_t wall0_ns) noexcept {
  if (speed > 0.0)
    timer_.emplace(std::max<std::int64_t>(1, std::llround(dt_s * 1e9 / speed)), wall0_ns);
}

void ViewPacer::wait() noexcept {
  if (timer_) timer_->wait_next();
}

}  // namespace numen::sim
