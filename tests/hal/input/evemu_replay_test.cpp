#include "numen/hal/input/evemu_replay.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <iterator>
#include <limits>
#include <stdexcept>
#include <string>

#include "alloc_counter.hpp"
#include "numen/hal/input/evemu_log.hpp"

namespace numen::hal {
namespace {

using core::Vec3;

constexpr double kSx = 1e-4;
constexpr double kSy = -1e-4;
constexpr double kSz = 2e-3;
constexpr double kSyaw = 0.05;

RelativePoseIntegratorSettings mouse_settings() {
  RelativePoseIntegratorSettings s;
  s.axes = {{REL_X, PoseDof::kX, kSx},
            {REL_Y, PoseDof::kY, kSy},
            {REL_WHEEL, PoseDof::kZ, kSz},
            {REL_HWHEEL, PoseDof::kYaw, kSyaw}};
  return s;
}

std::vector<InputEvent> recording() {
  return load_evemu_recording(std::string(NUMEN_TEST_DATA_DIR) + "/mouse_clutch.evemu");
}

TEST(EvemuReplay, EventsAreDueAtTheOffsetPlusTheirRecordedTime) {
  const std::int64_t offset = 5'000'000'000;
  EvemuReplay replay({{1000, EV_REL, REL_X, 1},
                      {11000, EV_SYN, SYN_REPORT, 0},
                      {6000, EV_REL, REL_X, 2} /* out of order */,
                      {31000, EV_SYN, SYN_REPORT, 0}},
                     offset);
  EXPECT_EQ(replay.span_ns(), 30000);
  InputEvent e;
  replay.set_time_ns(offset - 1);
  EXPECT_FALSE(replay.read(e));
  replay.set_time_ns(offset);
  ASSERT_TRUE(replay.read(e));
  EXPECT_EQ(e.time_ns, offset);
  EXPECT_EQ(e.value, 1);
  EXPECT_FALSE(replay.read(e));
  EXPECT_EQ(replay.next_due_ns(), offset + 10000);
  replay.set_time_ns(offset + 10000);
  ASSERT_TRUE(replay.read(e));
  EXPECT_EQ(e.type, EV_SYN);
  // The out-of-order event is due right after its predecessor, not earlier.
  ASSERT_TRUE(replay.read(e));
  EXPECT_EQ(e.time_ns, offset + 10000);
  EXPECT_EQ(e.value, 2);
  EXPECT_FALSE(replay.read(e));
  replay.set_time_ns(offset + 30000);
  ASSERT_TRUE(replay.read(e));
  EXPECT_TRUE(replay.finished());
  EXPECT_FALSE(replay.read(e));
}

TEST(EvemuReplay, RejectsAnOffsetThatOverflows) {
  EXPECT_THROW(EvemuReplay({{0, EV_SYN, SYN_REPORT, 0}, {1000, EV_SYN, SYN_REPORT, 0}},
                           std::numeric_limits<std::int64_t>::max() - 10),
               std::invalid_argument);
}

// The shipped recording (tests/data/mouse_clutch.evemu) replayed through the integrator at
// 1 kHz; the expected poses are the hand-made sums of the counts moved with the clutch held,
// times the scales (the comments of the recording's generator list the reports).
TEST(EvemuReplay, IntegratedPoseFollowsTheRecordingsClutchedMotion) {
  RelativePoseIntegrator in(mouse_settings());
  EvemuReplay replay(recording(), 1'000'000'000);
  struct Check {
    std::int64_t t_ms;  // replay time since the first event
    Vec3 p;
    bool engaged;
  };
  const Check checks[] = {
      {5, Vec3::Zero(), false},                    // REL 5,-3 while released: ignored
      {15, Vec3::Zero(), true},                    // BTN_LEFT pressed
      {25, Vec3(10 * kSx, 4 * kSy, 0), true},      // REL 10,4
      {35, Vec3(17 * kSx, 4 * kSy, 0), true},      // REL_X 7
      {45, Vec3(17 * kSx, 4 * kSy, kSz), true},    // wheel +1
      {55, Vec3(17 * kSx, 4 * kSy, kSz), false},   // release in the same report as -2,-1
      {65, Vec3(17 * kSx, 4 * kSy, kSz), false},   // REL_X 100 released
      {75, Vec3(17 * kSx, 4 * kSy, kSz), true},    // pressed again
      {85, Vec3(17 * kSx, 4 * kSy, kSz), false},   // SYN_DROPPED: REL_X 3 and 50 lost
      {95, Vec3(17 * kSx, 4 * kSy, kSz), false},   // REL_Y 6 after the drop: disengaged
      {115, Vec3(17 * kSx, 4 * kSy, kSz), true},   // release, press
      {125, Vec3(17 * kSx, 10 * kSy, kSz), true},  // REL_Y 6
      {135, Vec3(17 * kSx, 10 * kSy, kSz), true},  // horizontal wheel: yaw only
  };
  std::size_t next = 0;
  for (std::int64_t t_ms = 0; t_ms <= 140; ++t_ms) {
    const std::int64_t now = 1'000'000'000 + t_ms * 1'000'000;
    replay.set_time_ns(now);
    replay.feed(in);
    in.end_period(now);
    if (next < std::size(checks) && checks[next].t_ms == t_ms) {
      const Check& c = checks[next++];
      EXPECT_NEAR((in.target().position - c.p).norm(), 0.0, 1e-15) << "t = " << t_ms << " ms";
      EXPECT_EQ(in.engaged(), c.engaged) << "t = " << t_ms << " ms";
    }
  }
  EXPECT_EQ(next, std::size(checks));
  EXPECT_TRUE(replay.finished());
  const double yaw = 2.0 * std::atan2(in.target().orientation.z(), in.target().orientation.w());
  EXPECT_NEAR(yaw, kSyaw, 1e-15);
  EXPECT_EQ(in.counters().events, 39u);
  EXPECT_EQ(in.counters().dropped, 1u);
  EXPECT_EQ(in.counters().discarded_events, 4u);  // REL_X 3, SYN_DROPPED, REL_X 50, SYN
  EXPECT_EQ(in.counters().ignored_reports, 4u);   // t = 0, 50, 60, 90 ms
  EXPECT_EQ(in.counters().moving_reports, 5u);
  EXPECT_EQ(in.counters().other_events, 5u);  // MSC_SCAN
  EXPECT_EQ(in.last_report_ns(), 1'000'000'000 + 130'000'000);
}

TEST(EvemuReplay, FeedDoesNotAllocate) {
  RelativePoseIntegrator in(mouse_settings());
  EvemuReplay replay(recording());
  test::AllocationGuard guard;
  std::size_t fed = 0;
  for (std::int64_t t = 0; t <= 200'000'000; t += 1'000'000) {
    replay.set_time_ns(t);
    fed += replay.feed(in);
    in.end_period(t);
  }
  EXPECT_EQ(guard.count(), 0);
  EXPECT_EQ(fed, 39u);
}

}  // namespace
}  // namespace numen::hal
