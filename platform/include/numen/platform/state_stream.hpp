#pragma once
/// @file state_stream.hpp
/// StateStream: state frames (state_frame.hpp) leaving the real-time loop for a viewer, a
/// recording or any renderer, without the loop ever waiting for them.
///
/// Mechanism: a pool of frame buffers, each of StateFrameLayout::max_frame_bytes(), allocated
/// once. The loop (publish()) takes a free buffer, encodes the period into it and queues its
/// index on the one record queue of the project (hal::AsyncRecordWriter, the queue the trace
/// writer and the bus recorder use); the writer's thread hands the encoded bytes to every
/// StateFrameSink, then returns the buffer to the free list (a second lock-free
/// single-producer/single-consumer queue, consumer → loop). No buffer is copied twice and
/// nothing is shared while in use: a buffer belongs to the loop while free-listed-and-taken,
/// to the consumer while queued.
///
/// Decimation: a run at 1 kHz shown at 60 Hz publishes the first period and then every period
/// whose simulated time reaches the next display instant of the grid t₀ + j/display_rate_hz
/// (t₀: the first period's time); a grid instant more than one interval behind is skipped,
/// so the display rate holds on average for any dt and never bursts. What the skipped periods
/// saw is not lost: a frame's sample_faults are the OR of the periods' since the previous frame,
/// and its kFrameBusDown is set when any of them had the bus down (each device's: device 0's in
/// the header, the loop's other devices' in their extra_device items).
/// Periods not published are counted (decimated). A period that is due but finds no free
/// buffer (the sinks are slower than the display rate) is dropped and counted (dropped);
/// under FullQueuePolicy::kWait (offline runs with a recording, no deadline) the loop instead
/// waits for a buffer.
///
/// Threads: publish() belongs to the loop thread; start(), stop() and the destructor to the
/// setup thread. The sinks run on the stream's thread (SCHED_OTHER, never the loop's).

#include <array>
#include <atomic>
#include <boost/lockfree/spsc_queue.hpp>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include "numen/hal/transport/async_record_writer.hpp"
#include "numen/platform/state_frame.hpp"

namespace numen::platform {

/// Consumer of encoded frames (a recording file, a WebSocket server). Called on the stream's
/// thread, never on the loop; must not keep `frame` after returning.
class StateFrameSink {
 public:
  virtual ~StateFrameSink() = default;
  /// Takes one encoded frame; false on a failure (counted as a sink error; the frame still
  /// reaches the other sinks).
  virtual bool write_frame(std::span<const std::byte> frame) noexcept = 0;
  /// Pushes buffered output out; false on failure (counted).
  virtual bool flush() noexcept { return true; }
};

/// Creation settings of a StateStream (checked by its constructor).
struct StateStreamSettings {
  /// Frames per second of simulated time, > 0 (60: a display). +infinity publishes every period.
  double display_rate_hz = 60.0;
  /// Frame buffers in the pool, >= 2. At 60 Hz the default 16 lets the sinks stall 250 ms.
  std::size_t pool_frames = 16;
  /// How often the stream's thread looks for frames when idle, ns, > 0.
  std::int64_t poll_period_ns = 2'000'000;
  /// kDrop (paced runs: a busy sink costs frames, never time) or kWait (offline runs: every
  /// due frame reaches the sinks).
  hal::FullQueuePolicy full_queue = hal::FullQueuePolicy::kDrop;
};

/// Counters of a StateStream since construction (relaxed atomics; each consistent on its own).
/// Once stopped: periods = published + decimated + dropped + encode_failures, and every
/// published frame was handed to each sink (sink_errors counts refusals).
struct StateStreamCounters {
  std::uint64_t periods = 0;          ///< publish() calls.
  std::uint64_t published = 0;        ///< Frames queued for the sinks.
  std::uint64_t decimated = 0;        ///< Periods skipped by the display rate.
  std::uint64_t dropped = 0;          ///< Due frames lost: no free buffer (kDrop).
  std::uint64_t waits = 0;            ///< kWait: due frames that waited for a buffer.
  std::uint64_t encode_failures = 0;  ///< Data not matching the layout (cannot happen in a run).
  std::uint64_t delivered = 0;        ///< Frames handed to the sinks.
  std::uint64_t sink_errors = 0;      ///< Frames some sink refused, plus failed flushes (each once,
                                      ///< however many sinks failed).
  std::uint64_t bytes = 0;            ///< Bytes of the frames delivered.
};

/// Owner of the frame pool, of the queue and of the thread feeding the sinks.
class StateStream final : private hal::RecordSink<std::uint32_t> {
 public:
  /// Allocates the pool. `sinks` are not owned and must outlive the stream. Throws
  /// std::invalid_argument naming the setting: display_rate_hz not > 0, pool_frames < 2,
  /// poll_period_ns not > 0.
  StateStream(const StateFrameLayout& layout, std::vector<StateFrameSink*> sinks,
              const StateStreamSettings& settings = {});
  /// stop().
  ~StateStream() override;
  StateStream(const StateStream&) = delete;
  StateStream& operator=(const StateStream&) = delete;

  /// Starts the thread that feeds the sinks (SCHED_OTHER; then `on_thread_start`, e.g. an
  /// affinity). Start it before the loop thread is made real-time.
  void start(std::function<void()> on_thread_start = {});
  /// Stops the thread after it has delivered every queued frame, flushes the sinks.
  /// Idempotent.
  void stop();

  /// The loop's side, once per period after core::step: publishes the period when the display
  /// rate says so (see the file comment). `report`, `axis_torques` and `figures.bus_down` are
  /// device 0's, `extra_devices` the loop's other devices' (layout().num_extra_devices of them,
  /// at most kMaxLoopDevices − 1; encode_state_frame()). Returns true when a frame was queued.
  /// noexcept, no allocation, no lock; never blocks under kDrop.
  bool publish(const core::Data& data, const PeriodReport& report,
               std::span<const double> axis_torques, const StateFrameFigures& figures,
               std::span<const FrameDeviceInput> extra_devices = {}) noexcept;

  /// Counters (see StateStreamCounters).
  StateStreamCounters counters() const noexcept;
  /// The layout frames are encoded with.
  const StateFrameLayout& layout() const noexcept { return layout_; }
  /// The settings.
  const StateStreamSettings& settings() const noexcept { return settings_; }

 private:
  hal::SinkResult write(const std::uint32_t& slot) noexcept override;
  bool flush() noexcept override;
  bool take_buffer(std::uint32_t& slot) noexcept;

  StateFrameLayout layout_;
  StateStreamSettings settings_;
  std::vector<StateFrameSink*> sinks_;
  std::size_t frame_capacity_ = 0;
  std::vector<std::byte> pool_;                 // pool_frames × frame_capacity_
  std::vector<std::uint32_t> frame_bytes_;      // bytes of the frame in each buffer
  boost::lockfree::spsc_queue<std::uint32_t> free_;  // consumer → loop
  hal::AsyncRecordWriter<std::uint32_t> queue_;      // loop → consumer
  std::uint32_t loop_slot_ = 0;   // a buffer the loop took but did not queue
  bool have_loop_slot_ = false;
  bool have_published_ = false;
  std::int64_t first_ns_ = 0;     // time of the first published period (the grid's origin)
  std::int64_t grid_index_ = 0;   // j of the next due instant t0 + j/rate
  std::int64_t next_due_ns_ = 0;  // that instant, ns
  double interval_s_ = 0.0;       // 1/display_rate_hz; 0: every period
  hal::FaultMask pending_sample_faults_ = 0;  // OR of the periods' since the last frame
  bool pending_bus_down_ = false;              // a period since the last frame had its bus down
  // The same for the loop's other devices, and their reports and inputs as encoded (fixed:
  // nothing is allocated in a period).
  std::array<hal::FaultMask, kMaxLoopDevices> extra_pending_faults_{};
  std::array<bool, kMaxLoopDevices> extra_pending_bus_down_{};
  std::array<PeriodReport, kMaxLoopDevices> extra_reports_{};
  std::array<FrameDeviceInput, kMaxLoopDevices> extra_inputs_{};
  std::atomic<std::uint64_t> periods_{0}, published_{0}, decimated_{0}, dropped_{0},
      encode_failures_{0}, delivered_{0}, bytes_{0};  // waits, sink errors: queue_'s counters
};

}  // namespace numen::platform
