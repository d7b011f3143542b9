#include "numen/platform/state_stream.hpp"

#include <gtest/gtest.h>

#include <array>
#include <atomic>
#include <chrono>
#include <mutex>
#include <stdexcept>
#include <thread>
#include <vector>

#include "alloc_counter.hpp"
#include "free_bodies.hpp"
#include "numen/core/model.hpp"

namespace {

using numen::platform::StateFrameDecoder;
using numen::platform::StateFrameLayout;
using numen::platform::StateFrameView;
using numen::platform::StateStream;
using numen::platform::StateStreamSettings;

/// Keeps the period index and time of every frame it receives (checked as frames), optionally
/// slow or failing.
class RecordingSink final : public numen::platform::StateFrameSink {
 public:
  bool write_frame(std::span<const std::byte> frame) noexcept override {
    if (delay.count() > 0) std::this_thread::sleep_for(delay);
    StateFrameView v;
    const bool ok = StateFrameDecoder::decode(frame, v).ok();
    std::lock_guard<std::mutex> lock(mutex);
    if (ok) {
      periods.push_back(v.header().period);
      sample_faults.push_back(v.header().sample_faults);
      bus_down.push_back((v.header().flags & numen::platform::kFrameBusDown) != 0);
      if (v.header().num_extra_devices > 0) {
        const numen::platform::FrameDevice d = v.extra_device(0);
        second_faults.push_back(d.sample_faults);
        second_bus_down.push_back((d.flags & numen::platform::kFrameBusDown) != 0);
        second_force_y.push_back(d.feedback[1]);
      }
    }
    else ++malformed;
    return ok && !fail;
  }
  std::chrono::microseconds delay{0};
  bool fail = false;
  std::mutex mutex;
  std::vector<std::uint64_t> periods;
  std::vector<std::uint8_t> sample_faults;  // each frame's
  std::vector<bool> bus_down;               // each frame's kFrameBusDown
  // The loop's device 1 (frames with other devices): its sample faults, bus down, feedback's y.
  std::vector<std::uint8_t> second_faults;
  std::vector<bool> second_bus_down;
  std::vector<float> second_force_y;
  int malformed = 0;
};

struct Loop {
  numen::core::Model model = numen::test::free_bodies_model({"tool"});
  numen::core::Data data = numen::core::make_data(model);
  numen::platform::PeriodReport report;
  StateFrameLayout layout{1, 0, 0, 16};

  /// Publishes periods [0, n) of a run at 1 kHz; returns how many were queued.
  int run(StateStream& stream, int n) {
    int queued = 0;
    for (int k = 0; k < n; ++k) {
      data.time = k * model.dt;
      queued += stream.publish(data, report, {}, {static_cast<std::uint64_t>(k), 0.0, 0.0}) ? 1 : 0;
    }
    return queued;
  }
};

TEST(StateStream, DecimatesToTheDisplayRateAndCountsTheRest) {
  Loop loop;
  RecordingSink sink;
  StateStream stream(loop.layout, {&sink}, StateStreamSettings{60.0, 16, 1'000'000,
                                                                numen::hal::FullQueuePolicy::kWait});
  stream.start();
  loop.run(stream, 1000);  // 1 s at 1 kHz
  stream.stop();
  const auto c = stream.counters();
  EXPECT_EQ(c.periods, 1000u);
  EXPECT_EQ(c.published, 60u);  // t = 0, 17, 34, 50, ... ms: the 60 Hz grid, held on average
  EXPECT_EQ(c.decimated, 940u);
  EXPECT_EQ(c.dropped, 0u);
  EXPECT_EQ(c.delivered, 60u);
  ASSERT_EQ(sink.periods.size(), 60u);
  EXPECT_EQ(sink.periods[0], 0u);
  EXPECT_EQ(sink.periods[1], 17u);  // first grid instant at or after 16.67 ms
  EXPECT_EQ(sink.periods[3], 50u);
  for (std::size_t i = 1; i < sink.periods.size(); ++i) {
    const auto gap = sink.periods[i] - sink.periods[i - 1];
    EXPECT_TRUE(gap == 16 || gap == 17) << "frame " << i << " gap " << gap;
  }
  EXPECT_EQ(sink.malformed, 0);
}

// What the decimated periods saw reaches the next frame: its sample_faults are the OR of the
// periods' since the previous frame, its kFrameBusDown set when one of them had the bus down.
TEST(StateStream, AFramesSampleFaultsAndBusDownAreThoseOfThePeriodsSinceThePreviousFrame) {
  Loop loop;
  RecordingSink sink;
  StateStreamSettings every_10th;  // 100 Hz of a 1 kHz run, every frame delivered
  every_10th.display_rate_hz = 100.0;
  every_10th.full_queue = numen::hal::FullQueuePolicy::kWait;
  StateStream stream(loop.layout, {&sink}, every_10th);
  stream.start();
  for (int k = 0; k < 40; ++k) {  // frames at periods 0, 10, 20, 30
    loop.data.time = k * loop.model.dt;
    loop.report.sample_faults = k == 3 ? numen::hal::SampleFault::kJump
                                : k == 14 || k == 20 ? numen::hal::SampleFault::kStale
                                                     : numen::hal::SampleFault::kNone;
    numen::platform::StateFrameFigures figures{static_cast<std::uint64_t>(k), 0.0, 0.0};
    figures.bus_down = k == 25;
    stream.publish(loop.data, loop.report, {}, figures);
  }
  stream.stop();
  ASSERT_EQ(sink.periods, (std::vector<std::uint64_t>{0, 10, 20, 30}));
  EXPECT_EQ(sink.sample_faults, (std::vector<std::uint8_t>{0, numen::hal::SampleFault::kJump,
                                                           numen::hal::SampleFault::kStale, 0}));
  EXPECT_EQ(sink.bus_down, (std::vector<bool>{false, false, false, true}));
}

// Issue 70: the loop's other devices' sample faults and bus are kept between frames as device
// 0's are, each its own; the rest of their item is the published period's.
TEST(StateStream, EachOtherDevicesSampleFaultsAreThoseOfThePeriodsSinceThePreviousFrame) {
  Loop loop;
  loop.layout.num_extra_devices = 1;
  loop.layout.num_extra_axes = 1;
  RecordingSink sink;
  StateStreamSettings every_10th;
  every_10th.display_rate_hz = 100.0;
  every_10th.full_queue = numen::hal::FullQueuePolicy::kWait;
  StateStream stream(loop.layout, {&sink}, every_10th);
  stream.start();
  numen::platform::PeriodReport second;
  const std::array<double, 1> tau{0.5};
  for (int k = 0; k < 40; ++k) {  // frames at periods 0, 10, 20, 30
    loop.data.time = k * loop.model.dt;
    loop.report.sample_faults = k == 3 ? numen::hal::SampleFault::kJump : numen::hal::SampleFault::kNone;
    second.sample_faults = k == 14 ? numen::hal::SampleFault::kStale : numen::hal::SampleFault::kNone;
    second.feedback.force.y() = k;
    const std::array<numen::platform::FrameDeviceInput, 1> extra{{{&second, tau, k == 25}}};
    numen::platform::StateFrameFigures figures{static_cast<std::uint64_t>(k), 0.0, 0.0};
    stream.publish(loop.data, loop.report, {}, figures, extra);
  }
  stream.stop();
  ASSERT_EQ(sink.periods, (std::vector<std::uint64_t>{0, 10, 20, 30}));
  EXPECT_EQ(sink.sample_faults, (std::vector<std::uint8_t>{0, numen::hal::SampleFault::kJump, 0, 0}));
  EXPECT_EQ(sink.bus_down, (std::vector<bool>{false, false, false, false}));
  EXPECT_EQ(sink.second_faults, (std::vector<std::uint8_t>{0, 0, numen::hal::SampleFault::kStale, 0}));
  EXPECT_EQ(sink.second_bus_down, (std::vector<bool>{false, false, false, true}));
  EXPECT_EQ(sink.second_force_y, (std::vector<float>{0.0F, 10.0F, 20.0F, 30.0F}));
}

TEST(StateStream, WithoutAConsumerFramesAreDroppedAndCountedNeverWaitedFor) {
  Loop loop;
  RecordingSink sink;
  const double every_period = std::numeric_limits<double>::infinity();
  StateStream stream(loop.layout, {&sink}, StateStreamSettings{every_period, 4});
  // Not started: nobody frees a buffer. The loop keeps going and counts.
  EXPECT_EQ(loop.run(stream, 10), 4);
  auto c = stream.counters();
  EXPECT_EQ(c.published, 4u);
  EXPECT_EQ(c.dropped, 6u);
  EXPECT_EQ(c.decimated, 0u);
  stream.stop();  // the four queued frames reach the sink
  c = stream.counters();
  EXPECT_EQ(c.delivered, 4u);
  EXPECT_EQ(sink.periods, (std::vector<std::uint64_t>{0, 1, 2, 3}));
}

TEST(StateStream, ASlowSinkCostsFramesNotLoopTime) {
  Loop loop;
  RecordingSink sink;
  sink.delay = std::chrono::milliseconds(20);
  StateStream stream(loop.layout, {&sink},
                     StateStreamSettings{std::numeric_limits<double>::infinity(), 2});
  stream.start();
  loop.run(stream, 200);  // far faster than 20 ms a frame
  stream.stop();
  const auto c = stream.counters();
  EXPECT_GT(c.dropped, 0u);
  EXPECT_EQ(c.published + c.dropped, 200u);
  EXPECT_EQ(c.delivered, c.published);
  // What arrived is in order.
  for (std::size_t i = 1; i < sink.periods.size(); ++i) EXPECT_LT(sink.periods[i - 1], sink.periods[i]);
}

TEST(StateStream, WaitPolicyDeliversEveryDueFrame) {
  Loop loop;
  RecordingSink sink;
  sink.delay = std::chrono::microseconds(200);
  StateStream stream(loop.layout, {&sink},
                     StateStreamSettings{std::numeric_limits<double>::infinity(), 2, 100'000,
                                         numen::hal::FullQueuePolicy::kWait});
  stream.start();
  EXPECT_EQ(loop.run(stream, 100), 100);
  stream.stop();
  const auto c = stream.counters();
  EXPECT_EQ(c.dropped, 0u);
  EXPECT_GT(c.waits, 0u);
  EXPECT_EQ(sink.periods.size(), 100u);
}

TEST(StateStream, SinkFailuresAreCounted) {
  Loop loop;
  RecordingSink good, bad;
  bad.fail = true;
  StateStream stream(loop.layout, {&bad, &good},
                     StateStreamSettings{std::numeric_limits<double>::infinity(), 8});
  stream.start();
  loop.run(stream, 5);
  stream.stop();
  const auto c = stream.counters();
  EXPECT_EQ(c.sink_errors, c.delivered);
  EXPECT_EQ(good.periods.size(), c.delivered);  // one failing sink does not starve the others
}

TEST(StateStream, PublishDoesNotAllocate) {
  Loop loop;
  RecordingSink sink;
  StateStream stream(loop.layout, {&sink},
                     StateStreamSettings{std::numeric_limits<double>::infinity(), 16});
  stream.start();
  int queued = 0;
  {
    numen::test::AllocationGuard guard;
    queued = loop.run(stream, 500);
    EXPECT_EQ(guard.count(), 0);
  }
  stream.stop();
  EXPECT_GT(queued, 0);
}

TEST(StateStream, RefusesBadSettingsNamingThem) {
  const StateFrameLayout layout{1, 0, 0, 0};
  auto message = [&](StateStreamSettings s) {
    try {
      StateStream stream(layout, {}, s);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(message({0.0}).find("display_rate_hz must be > 0"), std::string::npos);
  EXPECT_NE(message({std::nan(""), 16}).find("display_rate_hz"), std::string::npos);
  EXPECT_NE(message({60.0, 1}).find("pool_frames must be >= 2"), std::string::npos);
  EXPECT_NE(message({60.0, 16, 0}).find("poll_period_ns must be > 0"), std::string::npos);
}

}  // namespace
