#include "numen/hal/input/relative_pose_integrator.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

#include "alloc_counter.hpp"

namespace numen::hal {
namespace relative_pose_integrator_test {  // named: the unity build shares a TU with other test files

using core::Quat;
using core::Vec3;

constexpr double kSx = 1e-4;    // m per REL_X count
constexpr double kSy = -2e-4;   // m per REL_Y count
constexpr double kSz = 3e-3;    // m per REL_WHEEL detent
constexpr double kSyaw = 0.05;  // rad per REL_HWHEEL detent

RelativePoseIntegratorSettings mouse_settings() {
  RelativePoseIntegratorSettings s;
  s.axes = {{REL_X, PoseDof::kX, kSx},
            {REL_Y, PoseDof::kY, kSy},
            {REL_WHEEL, PoseDof::kZ, kSz},
            {REL_HWHEEL, PoseDof::kYaw, kSyaw}};
  return s;
}

// Sends one report: the given events then SYN_REPORT, all stamped t_ns.
struct Feeder {
  RelativePoseIntegrator& in;
  std::int64_t t_ns = 0;
  void ev(std::uint16_t type, std::uint16_t code, std::int32_t value) {
    in.feed(InputEvent{t_ns, type, code, value});
  }
  void rel(std::uint16_t code, std::int32_t v) { ev(EV_REL, code, v); }
  void key(std::uint16_t code, std::int32_t v) { ev(EV_KEY, code, v); }
  void syn() { ev(EV_SYN, SYN_REPORT, 0); }
  void move(std::int32_t dx, std::int32_t dy) {
    rel(REL_X, dx);
    rel(REL_Y, dy);
    syn();
  }
  void press() {
    key(BTN_LEFT, 1);
    syn();
  }
  void release() {
    key(BTN_LEFT, 0);
    syn();
  }
};

void expect_position(const RelativePoseIntegrator& in, const Vec3& p) {
  EXPECT_NEAR(in.target().position.x(), p.x(), 1e-15);
  EXPECT_NEAR(in.target().position.y(), p.y(), 1e-15);
  EXPECT_NEAR(in.target().position.z(), p.z(), 1e-15);
}

double angle_between(const Quat& a, const Quat& b) { return a.angularDistance(b); }

TEST(RelativePoseIntegrator, StartsAtTheInitialPoseReleased) {
  RelativePoseIntegratorSettings s = mouse_settings();
  s.initial_pose.position = Vec3(0.1, -0.2, 0.05);
  s.initial_pose.orientation = Quat(2.0, 0.0, 0.0, 0.0);  // normalised by the constructor
  RelativePoseIntegrator in(s);
  expect_position(in, Vec3(0.1, -0.2, 0.05));
  EXPECT_DOUBLE_EQ(in.target().orientation.w(), 1.0);
  EXPECT_FALSE(in.engaged());
  EXPECT_EQ(in.counters().events, 0u);
}

TEST(RelativePoseIntegrator, AppliesAReportOnlyAtSynReportAsCountsTimesScale) {
  RelativePoseIntegrator in(mouse_settings());
  Feeder f{in};
  f.press();
  ASSERT_TRUE(in.engaged());
  f.t_ns = 5'000'000;
  f.rel(REL_X, 7);
  f.rel(REL_Y, -3);
  f.rel(REL_X, 5);  // two REL_X in one report add
  f.rel(REL_WHEEL, 2);
  expect_position(in, Vec3::Zero());  // nothing before SYN_REPORT
  f.syn();
  expect_position(in, Vec3(12 * kSx, -3 * kSy, 2 * kSz));
  EXPECT_EQ(in.last_report_ns(), 5'000'000);
  f.move(-20, 10);
  expect_position(in, Vec3(-8 * kSx, 7 * kSy, 2 * kSz));
  EXPECT_EQ(in.counters().reports, 3u);
  EXPECT_EQ(in.counters().moving_reports, 2u);
}

TEST(RelativePoseIntegrator, HoldClutchIgnoresMotionWhileReleased) {
  RelativePoseIntegrator in(mouse_settings());
  Feeder f{in};
  f.move(100, 100);  // released from the start
  expect_position(in, Vec3::Zero());
  f.press();
  f.move(10, 0);
  f.release();
  f.move(50, 50);  // indexing: hand repositioned, tool stays
  f.move(-30, 0);
  f.press();
  f.move(10, 0);
  expect_position(in, Vec3(20 * kSx, 0, 0));
  EXPECT_EQ(in.counters().ignored_reports, 3u);
  EXPECT_EQ(in.counters().moving_reports, 2u);
}

TEST(RelativePoseIntegrator, AReportThatChangesTheClutchMovesNothing) {
  RelativePoseIntegrator in(mouse_settings());
  Feeder f{in};
  // Press and motion in one report, in both orders.
  f.rel(REL_X, 10);
  f.key(BTN_LEFT, 1);
  f.syn();
  expect_position(in, Vec3::Zero());
  EXPECT_TRUE(in.engaged());
  f.move(1, 0);
  // Release and motion in one report.
  f.key(BTN_LEFT, 0);
  f.rel(REL_X, 10);
  f.syn();
  expect_position(in, Vec3(kSx, 0, 0));
  EXPECT_FALSE(in.engaged());
  // Press and release inside one report: the clutch ends released, nothing moves.
  f.key(BTN_LEFT, 1);
  f.rel(REL_X, 10);
  f.key(BTN_LEFT, 0);
  f.syn();
  expect_position(in, Vec3(kSx, 0, 0));
  EXPECT_FALSE(in.engaged());
  EXPECT_EQ(in.counters().ignored_reports, 3u);
}

TEST(RelativePoseIntegrator, ToggleClutchTogglesOnPressesOnly) {
  RelativePoseIntegratorSettings s = mouse_settings();
  s.clutch_mode = ClutchMode::kToggle;
  s.clutch_key = BTN_MIDDLE;
  RelativePoseIntegrator in(s);
  Feeder f{in};
  f.key(BTN_MIDDLE, 1);
  f.syn();
  EXPECT_TRUE(in.engaged());
  f.key(BTN_MIDDLE, 0);  // release: stays engaged
  f.syn();
  EXPECT_TRUE(in.engaged());
  f.move(4, 0);
  f.key(BTN_MIDDLE, 2);  // autorepeat: no toggle
  f.syn();
  f.move(4, 0);
  f.key(BTN_LEFT, 1);  // not the clutch key: ignored
  f.syn();
  EXPECT_TRUE(in.engaged());
  f.key(BTN_MIDDLE, 1);
  f.key(BTN_MIDDLE, 0);
  f.syn();
  EXPECT_FALSE(in.engaged());
  f.move(100, 0);
  expect_position(in, Vec3(8 * kSx, 0, 0));
  EXPECT_EQ(in.counters().other_events, 1u);  // the BTN_LEFT
}

TEST(RelativePoseIntegrator, NoClutchModeIsAlwaysEngaged) {
  RelativePoseIntegratorSettings s = mouse_settings();
  s.clutch_mode = ClutchMode::kNone;
  RelativePoseIntegrator in(s);
  Feeder f{in};
  EXPECT_TRUE(in.engaged());
  f.move(3, 0);
  f.release();
  f.move(3, 0);
  expect_position(in, Vec3(6 * kSx, 0, 0));
}

TEST(RelativePoseIntegrator, SynDroppedDiscardsUpToAndIncludingTheNextReport) {
  RelativePoseIntegrator in(mouse_settings());
  Feeder f{in};
  f.press();
  f.move(10, 0);
  f.rel(REL_X, 5);  // pending, then lost
  f.ev(EV_SYN, SYN_DROPPED, 0);
  EXPECT_TRUE(in.dropping());
  f.rel(REL_X, 50);    // after the drop: discarded
  f.key(BTN_LEFT, 1);  // discarded too
  f.syn();             // ends the drop, applies nothing
  EXPECT_FALSE(in.dropping());
  expect_position(in, Vec3(10 * kSx, 0, 0));
  EXPECT_EQ(in.counters().dropped, 1u);
  EXPECT_EQ(in.counters().discarded_events, 5u);  // REL_X 5, SYN_DROPPED, REL_X, KEY, SYN
  // The key state is unknown after a drop: disengaged until the key is seen pressed.
  EXPECT_FALSE(in.engaged());
  f.move(7, 0);
  expect_position(in, Vec3(10 * kSx, 0, 0));
  f.release();
  f.press();
  f.move(7, 0);
  expect_position(in, Vec3(17 * kSx, 0, 0));
}

TEST(RelativePoseIntegrator, DropPendingThenSyncedKeyReengagesAfterTheResync) {
  RelativePoseIntegrator in(mouse_settings());
  Feeder f{in};
  f.press();
  f.rel(REL_X, 9);
  in.drop_pending();            // libevdev: LIBEVDEV_READ_STATUS_SYNC
  EXPECT_FALSE(in.dropping());  // unlike SYN_DROPPED, later events are kept
  EXPECT_FALSE(in.engaged());
  f.syn();                   // the sync events' SYN_REPORT (no key change)
  in.sync_clutch_key(true);  // libevdev's re-read state: still held
  EXPECT_TRUE(in.engaged());
  f.move(4, 0);
  expect_position(in, Vec3(4 * kSx, 0, 0));
  EXPECT_EQ(in.counters().dropped, 1u);
  EXPECT_EQ(in.counters().discarded_events, 1u);
  in.sync_clutch_key(false);
  EXPECT_FALSE(in.engaged());
}

TEST(RelativePoseIntegrator, WorkspaceClampsAndLeavesTheWallAtOnce) {
  RelativePoseIntegratorSettings s = mouse_settings();
  s.workspace_min = Vec3(-0.01, -std::numeric_limits<double>::infinity(), 0.0);
  s.workspace_max = Vec3(0.01, std::numeric_limits<double>::infinity(), 0.02);
  RelativePoseIntegrator in(s);
  Feeder f{in};
  f.press();
  f.move(80, 0);
  expect_position(in, Vec3(0.008, 0, 0));
  EXPECT_EQ(in.counters().clamped_reports, 0u);
  f.move(80, 0);  // would be 0.016
  expect_position(in, Vec3(0.01, 0, 0));
  EXPECT_EQ(in.counters().clamped_reports, 1u);
  f.move(-10, 0);  // motion past the wall was not stored
  expect_position(in, Vec3(0.01 - 10 * kSx, 0, 0));
  f.rel(REL_WHEEL, -1);  // z below 0
  f.rel(REL_Y, 100000);  // y unbounded
  f.syn();
  expect_position(in, Vec3(0.01 - 10 * kSx, 100000 * kSy, 0.0));
  EXPECT_EQ(in.counters().clamped_reports, 2u);
}

TEST(RelativePoseIntegrator, WorldFrameAddsInWorldAxesToolFrameInToolAxes) {
  RelativePoseIntegratorSettings s = mouse_settings();
  s.clutch_mode = ClutchMode::kNone;
  // Tool yawed +90°: tool x = world y, tool y = world −x.
  s.initial_pose.orientation = Quat(Eigen::AngleAxisd(std::numbers::pi / 2, Vec3::UnitZ()));
  RelativePoseIntegrator world(s);
  s.frame = MotionFrame::kTool;
  RelativePoseIntegrator tool(s);
  Feeder fw{world};
  Feeder ft{tool};
  fw.move(10, 0);
  ft.move(10, 0);
  expect_position(world, Vec3(10 * kSx, 0, 0));
  EXPECT_NEAR(tool.target().position.x(), 0.0, 1e-15);
  EXPECT_NEAR(tool.target().position.y(), 10 * kSx, 1e-15);

  // Rotations: a roll (about x) after the yaw. World: q = Rx q0; tool: q = q0 Rx.
  RelativePoseIntegratorSettings r = s;
  r.axes = {{REL_RX, PoseDof::kRoll, 0.01}};
  r.frame = MotionFrame::kWorld;
  RelativePoseIntegrator rw(r);
  r.frame = MotionFrame::kTool;
  RelativePoseIntegrator rt(r);
  Feeder{rw}.rel(REL_RX, 30);
  Feeder{rw}.syn();
  Feeder{rt}.rel(REL_RX, 30);
  Feeder{rt}.syn();
  const Quat q0 = s.initial_pose.orientation;
  const Quat rx(Eigen::AngleAxisd(0.3, Vec3::UnitX()));
  EXPECT_LT(angle_between(rw.target().orientation, rx * q0), 1e-12);
  EXPECT_LT(angle_between(rt.target().orientation, q0 * rx), 1e-12);
  EXPECT_GT(angle_between(rw.target().orientation, rt.target().orientation), 0.1);
  // The tool frame's roll turns about the tool's x = world y.
  EXPECT_LT(
      angle_between(rt.target().orientation, Quat(Eigen::AngleAxisd(0.3, Vec3::UnitY())) * q0),
      1e-12);
}

TEST(RelativePoseIntegrator, ToolFrameTranslationUsesTheOrientationAtTheReportStart) {
  RelativePoseIntegratorSettings s;
  s.clutch_mode = ClutchMode::kNone;
  s.frame = MotionFrame::kTool;
  s.axes = {{REL_X, PoseDof::kX, 0.001}, {REL_RZ, PoseDof::kYaw, std::numbers::pi / 200}};
  RelativePoseIntegrator in(s);
  Feeder f{in};
  f.rel(REL_RZ, 100);  // +90° yaw in the same report as the translation
  f.rel(REL_X, 10);
  f.syn();
  expect_position(in, Vec3(0.01, 0, 0));  // moved along the old tool x
  f.move(10, 0);
  EXPECT_NEAR(in.target().position.x(), 0.01, 1e-15);
  EXPECT_NEAR(in.target().position.y(), 0.01, 1e-15);
}

TEST(RelativePoseIntegrator, RotationIncrementIsTheExponentialOfTheRotationVector) {
  RelativePoseIntegratorSettings s;
  s.clutch_mode = ClutchMode::kNone;
  s.axes = {{REL_RX, PoseDof::kRoll, 0.01},
            {REL_RY, PoseDof::kPitch, 0.01},
            {REL_RZ, PoseDof::kYaw, 0.01}};
  RelativePoseIntegrator a(s);
  RelativePoseIntegrator b(s);
  Feeder fa{a};
  Feeder fb{b};
  fa.rel(REL_RX, 30);
  fa.rel(REL_RY, -40);
  fa.rel(REL_RZ, 120);
  fa.syn();
  fb.rel(REL_RZ, 120);  // another order within the report: same result
  fb.rel(REL_RX, 30);
  fb.rel(REL_RY, -40);
  fb.syn();
  const Vec3 rv(0.3, -0.4, 1.2);
  const Quat expected(Eigen::AngleAxisd(rv.norm(), rv.normalized()));
  EXPECT_LT(angle_between(a.target().orientation, expected), 1e-12);
  EXPECT_LT(angle_between(b.target().orientation, expected), 1e-12);
  EXPECT_NEAR(a.target().orientation.norm(), 1.0, 1e-15);
}

TEST(RelativePoseIntegrator, TwistIsThePoseChangeOverThePeriod) {
  RelativePoseIntegratorSettings s = mouse_settings();
  s.clutch_mode = ClutchMode::kNone;
  RelativePoseIntegrator in(s);
  Feeder f{in};
  in.end_period(0);
  EXPECT_EQ(in.twist().linear, Vec3::Zero());
  f.move(10, 5);  // 1 mm in x, −1 mm in y
  f.rel(REL_HWHEEL, 2);
  f.syn();                   // 0.1 rad yaw
  in.end_period(1'000'000);  // 1 ms
  EXPECT_NEAR(in.twist().linear.x(), 1.0, 1e-9);
  EXPECT_NEAR(in.twist().linear.y(), -1.0, 1e-9);
  EXPECT_NEAR(in.twist().linear.z(), 0.0, 1e-12);
  EXPECT_NEAR(in.twist().angular.z(), 100.0, 1e-6);  // 0.1 rad / 1 ms
  EXPECT_NEAR(in.twist().angular.head<2>().norm(), 0.0, 1e-9);
  in.end_period(2'000'000);  // no motion in the second period
  EXPECT_NEAR(in.twist().linear.norm(), 0.0, 1e-12);
  EXPECT_NEAR(in.twist().angular.norm(), 0.0, 1e-9);
}

TEST(RelativePoseIntegrator, CountsUnmappedAndOtherEvents) {
  RelativePoseIntegratorSettings s = mouse_settings();
  s.axes = {{REL_X, PoseDof::kX, kSx}};
  RelativePoseIntegrator in(s);
  Feeder f{in};
  f.press();
  f.rel(REL_Y, 10);              // not mapped
  f.rel(REL_WHEEL_HI_RES, 120);  // not mapped
  f.ev(EV_MSC, MSC_SCAN, 90001);
  f.key(BTN_RIGHT, 1);
  f.ev(EV_SYN, SYN_MT_REPORT, 0);
  f.syn();
  expect_position(in, Vec3::Zero());
  EXPECT_EQ(in.counters().unmapped_events, 2u);
  EXPECT_EQ(in.counters().other_events, 3u);
  EXPECT_EQ(in.counters().events, 8u);
  EXPECT_EQ(in.counters().ignored_reports, 0u);  // nothing mapped moved
}

TEST(RelativePoseIntegrator, ResetMovesTheTargetAndKeepsTheClutch) {
  RelativePoseIntegrator in(mouse_settings());
  Feeder f{in};
  f.press();
  f.move(10, 0);
  f.rel(REL_X, 99);  // pending: dropped by reset
  core::Pose p;
  p.position = Vec3(0.2, 0.9, 0.0);  // y outside the default ±0.5 box: clamped
  in.reset(p);
  expect_position(in, Vec3(0.2, 0.5, 0.0));
  f.syn();
  expect_position(in, Vec3(0.2, 0.5, 0.0));
  EXPECT_TRUE(in.engaged());
  f.move(-10, 0);
  expect_position(in, Vec3(0.2 - 10 * kSx, 0.5, 0.0));
}

TEST(RelativePoseIntegrator, RejectsBadSettingsNamingTheField) {
  auto message = [](const RelativePoseIntegratorSettings& s) -> std::string {
    try {
      RelativePoseIntegrator in(s);
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "";
  };
  RelativePoseIntegratorSettings s = mouse_settings();
  s.axes[1].code = REL_MAX + 1;
  EXPECT_NE(message(s).find("axes[1].code"), std::string::npos) << message(s);
  s = mouse_settings();
  s.axes[2].scale = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(message(s).find("axes[2].scale"), std::string::npos) << message(s);
  s = mouse_settings();
  s.axes.assign(kMaxRelAxisMappings + 1, RelAxisMapping{});
  EXPECT_NE(message(s).find("axes: 17 mappings"), std::string::npos) << message(s);
  s = mouse_settings();
  s.clutch_key = KEY_MAX + 1;
  EXPECT_NE(message(s).find("clutch_key"), std::string::npos) << message(s);
  s = mouse_settings();
  s.workspace_min.y() = 0.6;
  EXPECT_NE(message(s).find("workspace_min[1]"), std::string::npos) << message(s);
  s = mouse_settings();
  s.workspace_max.z() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(message(s).find("workspace_max[2]: NaN"), std::string::npos) << message(s);
  s = mouse_settings();
  s.initial_pose.position.x() = 1.0;
  EXPECT_NE(message(s).find("initial_pose.position[0]"), std::string::npos) << message(s);
  s = mouse_settings();
  s.initial_pose.orientation = Quat(0, 0, 0, 0);
  EXPECT_NE(message(s).find("initial_pose.orientation"), std::string::npos) << message(s);
  EXPECT_EQ(message(mouse_settings()), "");
}

TEST(RelativePoseIntegrator, FeedAndEndPeriodDoNotAllocate) {
  RelativePoseIntegratorSettings s = mouse_settings();
  s.axes.push_back({REL_RX, PoseDof::kRoll, 0.01});
  RelativePoseIntegrator in(s);
  Feeder f{in};
  test::AllocationGuard guard;
  for (int period = 0; period < 1000; ++period) {
    f.t_ns = period * 1'000'000LL;
    if (period % 100 == 0) f.press();
    f.rel(REL_X, 1);
    f.rel(REL_Y, -1);
    f.rel(REL_RX, 1);
    f.rel(REL_HWHEEL, 1);
    f.syn();
    if (period % 100 == 50) f.release();
    if (period % 250 == 7) f.ev(EV_SYN, SYN_DROPPED, 0);
    in.end_period(f.t_ns);
  }
  EXPECT_EQ(guard.count(), 0);
  EXPECT_GT(in.counters().moving_reports, 0u);
}

}  // namespace relative_pose_integrator_test
}  // namespace numen::hal
