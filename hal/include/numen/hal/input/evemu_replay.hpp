#pragma once
/// @file evemu_replay.hpp
/// EvemuReplay: replays the events of an evemu recording (evemu_log.hpp) on a clock set by
/// the caller, as LogBus replays a candump log: the first event is due at `offset_ns`, every
/// other one at offset_ns + (its time − the first event's time). Events out of time order
/// are due right after their predecessor (like evemu-play, which never sleeps backwards).
/// Per control period: set_time_ns(now), feed(integrator), integrator.end_period(now) — the
/// same sequence as with a live EvdevPointer.

#include <cstddef>
#include <cstdint>
#include <vector>

#include "numen/hal/input/input_event.hpp"
#include "numen/hal/input/relative_pose_integrator.hpp"

namespace numen::hal {

/// A clock-driven source of recorded input events. read() and feed() are noexcept and
/// allocation free. Not thread safe.
class EvemuReplay {
 public:
  /// Takes the events (load_evemu_recording()); the first is due at offset_ns. Throws
  /// std::invalid_argument if offset_ns + the recording's span overflows int64.
  explicit EvemuReplay(std::vector<InputEvent> events, std::int64_t offset_ns = 0);

  /// Sets the replay clock, ns. Meant to be non-decreasing.
  void set_time_ns(std::int64_t t_ns) noexcept { now_ns_ = t_ns; }
  /// Current replay time, ns.
  std::int64_t time_ns() const noexcept { return now_ns_; }

  /// Next due event (due time <= time_ns()) into `event`, its time_ns set to its due time;
  /// false if none is due yet or the recording is exhausted.
  bool read(InputEvent& event) noexcept;
  /// Feeds every due event to `integrator`; returns how many.
  std::size_t feed(RelativePoseIntegrator& integrator) noexcept;

  /// True when every event has been read.
  bool finished() const noexcept { return cursor_ == events_.size(); }
  /// Due time of the next event, ns; meaningless when finished().
  std::int64_t next_due_ns() const noexcept;
  /// Events not yet read.
  std::size_t remaining() const noexcept { return events_.size() - cursor_; }
  /// Span of the recording: latest event time − first event time, ns.
  std::int64_t span_ns() const noexcept { return span_ns_; }
  /// Events in the recording.
  std::size_t size() const noexcept { return events_.size(); }

 private:
  std::vector<InputEvent> events_;
  std::int64_t offset_ns_ = 0;
  std::int64_t first_ns_ = 0;
  std::int64_t span_ns_ = 0;
  std::int64_t latest_due_ns_ = 0;
  std::size_t cursor_ = 0;
  std::int64_t now_ns_ = 0;
};

}  // namespace numen::hal
