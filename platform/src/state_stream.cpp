#include "numen/platform/state_stream.hpp"

#include <pthread.h>
#include <sched.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace numen::platform {
namespace {

const StateStreamSettings& checked(const StateStreamSettings& s) {
  if (!(s.display_rate_hz > 0.0))
    throw std::invalid_argument("StateStreamSettings.display_rate_hz must be > 0 (got " +
                                std::to_string(s.display_rate_hz) + ")");
  if (s.pool_frames < 2)
    throw std::invalid_argument("StateStreamSettings.pool_frames must be >= 2 (got " +
                                std::to_string(s.pool_frames) + ")");
  if (s.poll_period_ns <= 0)
    throw std::invalid_argument("StateStreamSettings.poll_period_ns must be > 0 (got " +
                                std::to_string(s.poll_period_ns) + ")");
  return s;
}

hal::RecordWriterSettings queue_settings(const StateStreamSettings& s) {
  // One queue slot per buffer: a taken buffer always finds room in the queue.
  return hal::RecordWriterSettings{s.pool_frames, s.poll_period_ns, s.full_queue};
}

}  // namespace

StateStream::StateStream(const StateFrameLayout& layout, std::vector<StateFrameSink*> sinks,
                         const StateStreamSettings& settings)
    : layout_(layout),
      settings_(checked(settings)),
      sinks_(std::move(sinks)),
      frame_capacity_(layout.max_frame_bytes()),
      pool_(settings.pool_frames * frame_capacity_),
      frame_bytes_(settings.pool_frames, 0),
      free_(settings.pool_frames),
      queue_(*this, queue_settings(settings), "StateStreamSettings") {
  for (std::uint32_t i = 0; i < settings_.pool_frames; ++i) free_.push(i);
  interval_s_ = std::isfinite(settings_.display_rate_hz) ? 1.0 / settings_.display_rate_hz : 0.0;
}

StateStream::~StateStream() { stop(); }

void StateStream::start(std::function<void()> on_thread_start) {
  queue_.start([init = std::move(on_thread_start)] {
    sched_param param{};
    param.sched_priority = 0;
    pthread_setschedparam(pthread_self(), SCHED_OTHER, &param);  // never the loop's policy
    if (init) init();
  });
}

void StateStream::stop() {
  queue_.stop();  // delivers what is queued and flushes the sinks, if the thread ran
  // Frames published while the thread was not running: delivered here, then flushed.
  if (queue_.drain() > 0 && !flush()) queue_.count_io_error();
}

bool StateStream::take_buffer(std::uint32_t& slot) noexcept {
  if (have_loop_slot_) {
    slot = loop_slot_;
    have_loop_slot_ = false;
    return true;
  }
  // kWait: the queue's own wait (it wakes the consumer, which refills the free list).
  return free_.pop(slot) || queue_.wait_for_room([&]() noexcept { return free_.pop(slot); });
}

bool StateStream::publish(const core::Data& data, const PeriodReport& report,
                          std::span<const double> axis_torques,
                          const StateFrameFigures& figures,
                          std::span<const FrameDeviceInput> extra_devices) noexcept {
  periods_.fetch_add(1, std::memory_order_relaxed);
  // What happened since the last frame reaches the next one (decimated or dropped periods).
  pending_sample_faults_ |= report.sample_faults;
  pending_bus_down_ = pending_bus_down_ || figures.bus_down;
  const std::size_t extras = std::min(extra_devices.size(), extra_inputs_.size());
  for (std::size_t i = 0; i < extras; ++i) {
    if (extra_devices[i].report != nullptr)
      extra_pending_faults_[i] |= extra_devices[i].report->sample_faults;
    extra_pending_bus_down_[i] = extra_pending_bus_down_[i] || extra_devices[i].bus_down;
  }
  const double t = data.time * 1e9;
  const std::int64_t t_ns = std::isfinite(t) && std::abs(t) < 9e18 ? std::llround(t) : 0;
  if (have_published_ && interval_s_ > 0.0 && t_ns < next_due_ns_) {
    decimated_.fetch_add(1, std::memory_order_relaxed);
    return false;
  }
  // The next instant of the grid t0 + j/rate; instants already passed are skipped (no burst).
  if (!have_published_) {
    first_ns_ = t_ns;
    grid_index_ = 0;
    have_published_ = true;
  }
  if (interval_s_ > 0.0) {
    const double since = static_cast<double>(t_ns - first_ns_) * 1e-9;
    grid_index_ = std::max(grid_index_ + 1, static_cast<std::int64_t>(std::floor(since / interval_s_)) + 1);
    next_due_ns_ = first_ns_ + std::llround(static_cast<double>(grid_index_) * interval_s_ * 1e9);
  }
  std::uint32_t slot = 0;
  if (!take_buffer(slot)) {
    dropped_.fetch_add(1, std::memory_order_relaxed);
    return false;
  }
  const std::span<std::byte> buffer(pool_.data() + slot * frame_capacity_, frame_capacity_);
  PeriodReport since = report;  // the period's, with the sample faults since the last frame
  since.sample_faults = pending_sample_faults_;
  StateFrameFigures figures_since = figures;
  figures_since.bus_down = pending_bus_down_;
  for (std::size_t i = 0; i < extras; ++i) {  // each device's, likewise
    extra_inputs_[i] = extra_devices[i];
    if (extra_devices[i].report == nullptr) continue;  // refused by the encoder
    extra_reports_[i] = *extra_devices[i].report;
    extra_reports_[i].sample_faults = extra_pending_faults_[i];
    extra_inputs_[i].report = &extra_reports_[i];
    extra_inputs_[i].bus_down = extra_pending_bus_down_[i];
  }
  // More devices than a loop runs do not match any layout: the encoder refuses them.
  const std::span<const FrameDeviceInput> extra_since =
      extra_devices.size() > extra_inputs_.size()
          ? extra_devices
          : std::span<const FrameDeviceInput>(extra_inputs_.data(), extras);
  const std::size_t bytes = encode_state_frame(layout_, data, since, axis_torques, figures_since,
                                               buffer, extra_since);
  if (bytes == 0) {
    encode_failures_.fetch_add(1, std::memory_order_relaxed);
    loop_slot_ = slot;  // kept for the next period: only the consumer pushes on the free list
    have_loop_slot_ = true;
    return false;
  }
  pending_sample_faults_ = 0;
  pending_bus_down_ = false;
  extra_pending_faults_.fill(0);
  extra_pending_bus_down_.fill(false);
  frame_bytes_[slot] = static_cast<std::uint32_t>(bytes);
  queue_.push(slot);  // capacity == pool size: never full while we hold a buffer
  published_.fetch_add(1, std::memory_order_relaxed);
  return true;
}

hal::SinkResult StateStream::write(const std::uint32_t& slot) noexcept {
  const std::span<const std::byte> frame(pool_.data() + slot * frame_capacity_, frame_bytes_[slot]);
  bool ok = true;
  for (StateFrameSink* sink : sinks_) ok = sink->write_frame(frame) && ok;
  delivered_.fetch_add(1, std::memory_order_relaxed);
  bytes_.fetch_add(frame.size(), std::memory_order_relaxed);
  free_.push(slot);
  return ok ? hal::SinkResult::kWritten : hal::SinkResult::kIoError;
}

bool StateStream::flush() noexcept {
  bool ok = true;
  for (StateFrameSink* sink : sinks_) ok = sink->flush() && ok;
  return ok;  // a failure is counted by the queue (its io_errors: sink_errors)
}

StateStreamCounters StateStream::counters() const noexcept {
  // The queue counts the kWait waits and the failed writes and flushes (once each).
  const hal::RecordWriterCounters q = queue_.counters();
  StateStreamCounters c;
  c.periods = periods_.load(std::memory_order_relaxed);
  c.published = published_.load(std::memory_order_relaxed);
  c.decimated = decimated_.load(std::memory_order_relaxed);
  c.dropped = dropped_.load(std::memory_order_relaxed);
  c.waits = q.waits;
  c.encode_failures = encode_failures_.load(std::memory_order_relaxed);
  c.delivered = delivered_.load(std::memory_order_relaxed);
  c.sink_errors = q.io_errors;
  c.bytes = bytes_.load(std::memory_order_relaxed);
  return c;
}

}  // namespace numen::platform
