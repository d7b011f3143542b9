// Tests of sim/pointer_path: a mouse recording replayed through the relative-pose integrator
// gives, at every control period, the target a live pointer read each period would give; the
// clutch stops motion; what is kept is the report poses only, whatever dt; sampling allocates
// nothing.
#include "numen/sim/input/pointer_path.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "alloc_counter.hpp"
#include "numen/hal/input/evemu_log.hpp"
#include "numen/hal/input/evemu_replay.hpp"
#include "test_constants.hpp"

namespace {

using numen::core::Vec3;
using numen::hal::InputEvent;
using numen::sim::PointerPath;
using numen::sim::Trajectory;

using numen::test::kMs;

numen::hal::RelativePoseIntegratorSettings mouse() {
  numen::hal::RelativePoseIntegratorSettings s;
  s.axes = {{REL_X, numen::hal::PoseDof::kX, 1e-4}, {REL_Y, numen::hal::PoseDof::kY, -1e-4}};
  s.initial_pose.position = Vec3(0.01, 0.02, 0.03);
  return s;
}

/// Reports every 8 ms from t0: button down at t0, then `n` reports of REL_X +dx, then up.
std::vector<InputEvent> drag(std::int64_t t0, int n, int dx) {
  std::vector<InputEvent> e;
  std::int64_t t = t0;
  e.push_back({t, EV_KEY, BTN_LEFT, 1});
  e.push_back({t, EV_SYN, SYN_REPORT, 0});
  for (int k = 0; k < n; ++k) {
    t += 8 * kMs;
    e.push_back({t, EV_REL, REL_X, dx});
    e.push_back({t, EV_SYN, SYN_REPORT, 0});
  }
  t += 8 * kMs;
  e.push_back({t, EV_KEY, BTN_LEFT, 0});
  e.push_back({t, EV_SYN, SYN_REPORT, 0});
  return e;
}

std::string shipped_recording() { return std::string(NUMEN_SOURCE_DIR) + "/sim/data/mouse_push.evemu"; }

TEST(PointerPath, HoldsEachReportsTargetUntilTheNext) {
  const PointerPath path(drag(1000, 3, 10), mouse());
  // The initial pose, then one pose per moving report (the button reports move nothing).
  ASSERT_EQ(path.size(), 4u);
  EXPECT_EQ(path.counters().moving_reports, 3u);
  EXPECT_DOUBLE_EQ(path.duration(), 32e-3);  // the first event (1000 ns) to the release
  EXPECT_EQ(path.evaluate(0.0).pose.position, Vec3(0.01, 0.02, 0.03));
  EXPECT_EQ(path.evaluate(0.007).pose.position, Vec3(0.01, 0.02, 0.03));  // before the 1st move
  EXPECT_NEAR(path.evaluate(0.008).pose.position.x(), 0.011, 1e-15);       // at the report
  EXPECT_NEAR(path.evaluate(0.0159).pose.position.x(), 0.011, 1e-15);      // held
  EXPECT_NEAR(path.evaluate(0.024).pose.position.x(), 0.013, 1e-15);
  EXPECT_NEAR(path.evaluate(10.0).pose.position.x(), 0.013, 1e-15);        // clamped to the end
  EXPECT_EQ(path.evaluate(std::numeric_limits<double>::quiet_NaN()).pose.position,
            Vec3(0.01, 0.02, 0.03));
}

TEST(PointerPath, MotionWithTheClutchReleasedMovesNothing) {
  std::vector<InputEvent> e;
  for (int k = 0; k < 5; ++k) {  // no button: the hand repositions the mouse
    e.push_back({k * 8 * kMs, EV_REL, REL_X, 50});
    e.push_back({k * 8 * kMs, EV_SYN, SYN_REPORT, 0});
  }
  const PointerPath path(e, mouse());
  EXPECT_EQ(path.size(), 1u);
  EXPECT_EQ(path.counters().ignored_reports, 5u);
  EXPECT_EQ(path.evaluate(0.05).pose.position, Vec3(0.01, 0.02, 0.03));
}

// The loop samples the trajectory at each period's time; a live EvdevPointer read once a
// period gives the integrator's target after the reports that arrived by then. Both must be
// the same pose, bit for bit, at every period (the shipped recording, dt = 1 ms and 0.3 ms).
TEST(PointerPath, SampledAtDtItIsTheTargetALivePointerGivesEachPeriod) {
  const std::vector<InputEvent> events = numen::hal::load_evemu_recording(shipped_recording());
  numen::hal::RelativePoseIntegratorSettings s = mouse();
  s.axes.push_back({REL_WHEEL, numen::hal::PoseDof::kZ, 2e-3});
  for (const double dt : {1e-3, 3e-4}) {
    const Trajectory traj = PointerPath(events, s).sample(dt);
    numen::hal::RelativePoseIntegrator live(s);
    numen::hal::EvemuReplay replay(events, 0);
    std::size_t moved = 0;
    for (std::size_t k = 0; k < traj.size(); ++k) {
      const double t = static_cast<double>(k) * dt;
      replay.set_time_ns(std::llround(t * 1e9));
      replay.feed(live);
      const auto got = traj.at(t).pose;
      ASSERT_EQ(got.position, live.target().position) << "dt " << dt << ", period " << k;
      ASSERT_EQ(got.orientation.coeffs(), live.target().orientation.coeffs()) << k;
      if (got.position != s.initial_pose.position) ++moved;
    }
    EXPECT_TRUE(replay.finished());
    EXPECT_GT(moved, traj.size() / 2) << "the recording moves the target for most of its span";
  }
}

// Issue 17 made memory independent of dt; a pointer trajectory keeps its report poses only.
TEST(PointerPath, KeepsTheReportPosesOnlyWhateverTheControlPeriod) {
  const PointerPath path(numen::hal::load_evemu_recording(shipped_recording()), mouse());
  const Trajectory coarse = path.sample(1e-3);
  const Trajectory fine = path.sample(1e-6);
  EXPECT_EQ(fine.size(), 1000 * (coarse.size() - 1) + 1);
  EXPECT_EQ(coarse.memory_bytes(), fine.memory_bytes());
  EXPECT_EQ(coarse.memory_bytes(), path.memory_bytes());
  EXPECT_LE(path.size(), 1 + path.counters().moving_reports);
  EXPECT_LT(path.memory_bytes(), 64u * 1024u);  // ~400 moving reports of 64 bytes
}

TEST(PointerPath, SamplingAllocatesNothing) {
  const Trajectory traj =
      PointerPath(numen::hal::load_evemu_recording(shipped_recording()), mouse()).sample(1e-3);
  double sink = 0.0;
  numen::test::AllocationGuard guard;
  for (double t = -0.1; t < traj.duration() + 0.1; t += 0.000731) {
    const auto s = traj.at(t);
    const auto tw = traj.twist_at(t);
    sink += s.pose.position.x() + tw.linear.x();
  }
  EXPECT_EQ(guard.count(), 0);
  EXPECT_TRUE(std::isfinite(sink));
}

TEST(PointerPath, BadSettingsAndJawAreRefused) {
  numen::hal::RelativePoseIntegratorSettings s = mouse();
  s.initial_pose.position.x() = 2.0;  // outside the ±0.5 m workspace
  EXPECT_THROW(PointerPath(drag(0, 1, 1), s), std::invalid_argument);
  EXPECT_THROW(PointerPath(drag(0, 1, 1), mouse(), std::nan("")), std::invalid_argument);
}

}  // namespace
