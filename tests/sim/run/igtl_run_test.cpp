/// @file igtl_run_test.cpp
/// `numen run --bus igtl` (sim/run/igtl_run.hpp) on loopback: the shipped tracker scene's motion
/// replayed as an OpenIGTLink server (numen igtl-replay, sim/device/igtl_replay.hpp, an
/// ephemeral port) drives the god-object as the simulated bus does, to the encoders'
/// quantisation; a server that goes away mid-run, a tool never sent and a scene without a
/// tracker are said in the summary and fail the run.

#include "numen/sim/run/igtl_run.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "temp_dir.hpp"
#include "numen/sim/device/igtl_replay.hpp"
#include "numen/sim/input/input_error.hpp"
#include "numen/sim/run/run.hpp"
#include "numen/sim/run/run_verdict.hpp"
#include "numen/sim/scene/scene.hpp"

namespace {

const numen::sim::Scene& igtl_run_test_scene() {
  static const numen::sim::Scene s =
      numen::sim::load_scene(std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/tracker.toml");
  return s;
}

/// A replay of `scene` on an ephemeral loopback port, served in a thread.
class IgtlRunTestReplay {
 public:
  IgtlRunTestReplay(const numen::sim::Scene& scene, numen::sim::IgtlReplaySettings s)
      : server_(scene, with_port_zero(s)), thread_([this] { result_ = server_.serve(&stop_); }) {}
  ~IgtlRunTestReplay() {
    stop_ = true;
    thread_.join();
  }
  std::string spec() const { return "igtl:127.0.0.1:" + std::to_string(server_.port()); }

 private:
  static numen::sim::IgtlReplaySettings with_port_zero(numen::sim::IgtlReplaySettings s) {
    s.port = 0;
    s.accept_timeout_s = 10.0;
    return s;
  }
  numen::sim::IgtlReplayServer server_;
  std::atomic<bool> stop_{false};
  numen::sim::IgtlReplayResult result_;
  std::thread thread_;
};

// `scene` run for `duration_s` on --bus igtl against a replay of `played` (offline: following).
numen::sim::RunSummary igtl_run_test_against(const numen::sim::Scene& scene,
                                             const numen::sim::Scene& played,
                                             const numen::sim::IgtlReplaySettings& rs,
                                             double duration_s) {
  IgtlRunTestReplay replay(played, rs);
  numen::sim::RunOptions o;
  o.bus.spec = replay.spec();
  o.duration_s = duration_s;
  return numen::sim::run_scene(scene, o);
}

/// The shipped tracker scene's text, its files ("../data/...", relative to the shipped scene's
/// folder) made absolute, so that an edited copy loads from another folder.
std::string igtl_run_test_tracker_text() {
  std::ifstream in(std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/tracker.toml");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("\"../"), std::string::npos);
  for (auto p = text.find("\"../"); p != std::string::npos; p = text.find("\"../", p))
    text.replace(p, 4, "\"" + std::string(NUMEN_SOURCE_DIR) + "/sim/");
  return text;
}

bool igtl_run_test_says(const numen::sim::RunSummary& s, const std::string& what) {
  return std::any_of(s.exit_reasons.begin(), s.exit_reasons.end(),
                     [&](const std::string& r) { return r.find(what) != std::string::npos; });
}

}  // namespace

TEST(IgtlRun, TheReplayedTrackerDrivesTheGodObjectAsTheSimulatedBusDoes) {
  const numen::sim::Scene& scene = igtl_run_test_scene();
  constexpr int kPeriods = 10000;  // 10 s of the recording: it goes into the tissue at 8.6 s
  std::vector<numen::core::Vec3> sim_p, net_p;
  numen::sim::RunSummary sim_s, net_s;
  {
    numen::sim::SceneRunner runner(scene);
    for (int k = 0; k < kPeriods; ++k) {
      runner.period();
      sim_p.push_back(runner.data().bodies[0].position);
    }
    sim_s = runner.summary();
  }
  {
    numen::sim::IgtlReplaySettings rs;
    rs.duration_s = kPeriods * scene.model.dt;
    IgtlRunTestReplay replay(scene, rs);
    numen::sim::BusChoice bus;
    bus.spec = replay.spec();
    numen::sim::SceneRunner runner(scene, 0, bus);
    for (int k = 0; k < kPeriods; ++k) {
      runner.period();
      net_p.push_back(runner.data().bodies[0].position);
    }
    runner.finish();
    net_s = runner.summary();
  }
  // Every pose came, none was refused, dropped or waited for in vain.
  EXPECT_EQ(net_s.igtl_poses_taken, kPeriods);
  EXPECT_EQ(net_s.igtl_faults, 0);
  EXPECT_EQ(net_s.igtl_dropped, 0);
  EXPECT_EQ(net_s.igtl_wait_timeouts, 0);
  EXPECT_EQ(net_s.invalid_periods, sim_s.invalid_periods);
  EXPECT_EQ(net_s.rejected_samples, 0);
  // The god-object's path: the same to the encoders' quantisation (1 µm, 1 µrad: a count that
  // a float32 message rounds the other way, carried by the dynamics).
  double worst = 0.0;
  for (int k = 0; k < kPeriods; ++k)
    worst = std::max(worst, (net_p[static_cast<std::size_t>(k)] - sim_p[static_cast<std::size_t>(k)]).norm());
  EXPECT_LT(worst, 20e-6);
  EXPECT_GT((sim_p.back() - sim_p.front()).norm(), 1e-3);  // it moved
  // The run's figures.
  EXPECT_GT(sim_s.target_penetration_max_mm, 0.5);  // the recording goes into the tissue
  EXPECT_NEAR(net_s.target_penetration_max_mm, sim_s.target_penetration_max_mm, 0.01);
  EXPECT_NEAR(net_s.tool_penetration_max_mm, sim_s.tool_penetration_max_mm, 0.01);
  EXPECT_NEAR(net_s.tracking_error_free_rms_mm, sim_s.tracking_error_free_rms_mm, 0.01);
  EXPECT_EQ(net_s.device_loop, "external");
}

// The multirate god-object (a [multirate] table: the scene loop every 10 ms) on the tracker bus:
// the device loop reads the tracker as the single-rate run does, with the same figures.
TEST(IgtlRun, AMultirateRunOnTheReplayedTrackerHasTheSimulatedBusFigures) {
  const numen::test::TempDir dir;
  std::string text = igtl_run_test_tracker_text();
  text += "\n[multirate]\nscene_dt = 0.01\nmargin = 0.005\n";
  const numen::sim::Scene scene = numen::sim::load_scene(dir.write("tracker_multirate.toml", text));
  ASSERT_TRUE(scene.multirate.has_value());
  numen::sim::RunOptions o;
  o.duration_s = 10.0;  // into the tissue at 8.6 s
  const numen::sim::RunSummary sim_s = numen::sim::run_scene(scene, o);
  numen::sim::IgtlReplaySettings rs;
  rs.duration_s = 10.0;
  const numen::sim::RunSummary net_s = igtl_run_test_against(scene, scene, rs, 10.0);
  EXPECT_TRUE(net_s.multirate.enabled);
  EXPECT_EQ(net_s.multirate.scene_steps, sim_s.multirate.scene_steps);
  EXPECT_EQ(net_s.igtl_poses_taken, net_s.steps);
  EXPECT_EQ(net_s.exit_status, 0) << net_s.exit_reasons.front();
  EXPECT_EQ(sim_s.exit_status, 0);
  EXPECT_GT(sim_s.target_penetration_max_mm, 0.5);
  EXPECT_NEAR(net_s.target_penetration_max_mm, sim_s.target_penetration_max_mm, 0.01);
  EXPECT_NEAR(net_s.tool_penetration_max_mm, sim_s.tool_penetration_max_mm, 0.01);
  EXPECT_NEAR(net_s.tracking_error_free_max_mm, sim_s.tracking_error_free_max_mm, 0.01);
}

// A live tracker that does not start where the scene's recording does (issue 70): the replay's
// recording moved 100 mm along x and turned 90° about z about the stylus's starting centre of
// mass (the scene's start, c0), so that the tracker's first pose puts the stylus 100 mm and 90°
// from where the scene puts it. The loop brings the god-object to that first pose
// (platform::ControlLoopSettings::place_at_first_sample) and the run goes on from there, its
// start-up and divergence bounds taken from there, said in a warning. Before, its springs
// pulled it across the gap in one swing and the run ended in its first period (exit 7,
// "diverged: body speed ... 14 above its limit 5").
TEST(IgtlRun, ATrackerThatStartsFarFromTheRecordingBringsTheToolThereInsteadOfDiverging) {
  const numen::test::TempDir dir;
  std::string text = igtl_run_test_tracker_text();
  const std::string manipulator = "manipulator = \"slave_right\"\n";
  const std::size_t at = text.rfind(manipulator);
  ASSERT_NE(at, std::string::npos);
  const numen::core::Vec3 c0 = igtl_run_test_scene().model.bodies[0].initial_pose.position;
  std::ostringstream placement;
  placement.precision(12);
  placement << "placement = { origin = [" << c0.x() << ", " << c0.y() << ", " << c0.z()
            << "], position = [" << c0.x() + 0.1 << ", " << c0.y() << ", " << c0.z()
            << "], orientation = [0.7071067811865476, 0.0, 0.0, 0.7071067811865476] }\n";
  text.insert(at + manipulator.size(), placement.str());
  const numen::sim::Scene played = numen::sim::load_scene(dir.write("tracker_moved.toml", text));
  numen::sim::IgtlReplaySettings rs;
  rs.duration_s = 2.0;
  const numen::sim::RunSummary s = igtl_run_test_against(igtl_run_test_scene(), played, rs, 2.0);
  for (const std::string& w : s.warnings) std::printf("[   info   ] %s\n", w.c_str());
  EXPECT_EQ(s.exit_status, 0) << (s.exit_reasons.empty() ? "" : s.exit_reasons.front());
  EXPECT_FALSE(s.divergence.latched) << s.divergence.cause << " " << s.divergence.value;
  EXPECT_EQ(s.steps, 2000);
  EXPECT_EQ(s.igtl_poses_taken, 2000);
  EXPECT_TRUE(std::any_of(s.warnings.begin(), s.warnings.end(), [](const std::string& w) {
    return w.find(
               "the live input's first sample (period 0) put the tool 100.0 mm and 90.0 deg "
               "from the scene's start: it was brought there") != std::string::npos;
  }));
}

// Issue 70: a live tracker that stalls for longer than the follower's wait (2 s) in following
// mode. The run raced on without it once the wait ran out, so the poses it sent when it came
// back were older than the run and stale until its clock caught up (a 2 s stall: invalid until
// 5.5 s; here, 2.5 s: to the run's end); then the target stepped to the resumed pose in one
// period (29 mm). Now the run keeps the tracker's pace while it is silent, the samples are valid
// again within a few periods of the stream resuming, the target glides to the resumed pose over
// the soft start (no step over a few mm a period), and the summary says the stall.
TEST(IgtlRun, ATrackerThatStallsIsTakenBackAtOnceAndTheTargetGlidesToItsPose) {
  const numen::sim::Scene& scene = igtl_run_test_scene();
  constexpr int kPeriods = 4000;
  numen::sim::IgtlReplaySettings rs;
  rs.duration_s = kPeriods * scene.model.dt;
  rs.paced = true;  // a live tracker: its clock is real time
  rs.stall_at_s = 0.5;
  rs.stall_s = 2.5;  // nothing from 0.5 s to 3.0 s
  IgtlRunTestReplay replay(scene, rs);
  numen::sim::BusChoice bus;
  bus.spec = replay.spec();
  numen::sim::SceneRunner runner(scene, 0, bus);
  int first_invalid = -1, valid_again = -1;
  double step_max_mm = 0.0, step_at_s = 0.0;
  numen::core::Vec3 last = numen::core::Vec3::Zero();
  for (int k = 0; k < kPeriods; ++k) {
    runner.period();
    const bool valid = runner.loop().last_report(0).sample_valid;
    if (!valid && first_invalid < 0) first_invalid = k;
    if (valid && first_invalid >= 0 && valid_again < 0) valid_again = k;
    const numen::core::Vec3 target = runner.data().target.position;
    if (k > 0 && (target - last).norm() * 1e3 > step_max_mm) {
      step_max_mm = (target - last).norm() * 1e3;
      step_at_s = k * scene.model.dt;
    }
    last = target;
  }
  runner.finish();
  const numen::sim::RunSummary s = runner.summary();
  for (const std::string& w : s.warnings) std::printf("[   info   ] %s\n", w.c_str());
  // Stale from max_sample_age (0.1 s) after the last pose before the stall ...
  EXPECT_NEAR(first_invalid, 600, 5);
  // ... valid again within a few periods of the resumption at 3.0 s (its first pose's stamp).
  EXPECT_GE(valid_again, 3000);
  EXPECT_LE(valid_again, 3005) << "valid again at period " << valid_again;
  // No step of the target: the largest move in one period is the glide's (a few mm), not the
  // gap the hand moved during the stall.
  EXPECT_LT(step_max_mm, 3.0) << "at " << step_at_s << " s";
  EXPECT_EQ(s.stale_stretches, 1);
  EXPECT_NEAR(s.stale_longest_s, 2.4, 0.01);
  EXPECT_NEAR(s.stale_longest_from_s, 0.6, 0.005);
  EXPECT_EQ(s.stale_rejoins, 1);
  EXPECT_GT(s.stale_rejoin_gap_mm, 10.0);  // the hand moved during the stall
  EXPECT_EQ(s.igtl_wait_timeouts, 1);
  EXPECT_TRUE(std::any_of(s.warnings.begin(), s.warnings.end(), [](const std::string& w) {
    return w.find("the device's samples went stale 1 time(s), 24") != std::string::npos &&
           w.find("the longest stretch 2.4") != std::string::npos &&
           w.find("the target was brought to the resumed pose over the soft start") !=
               std::string::npos;
  }));
  EXPECT_FALSE(s.divergence.latched);
}

TEST(IgtlRun, APositionOrQtransReplayDrivesTheGodObjectAsTheTransformOne) {
  const numen::sim::Scene& scene = igtl_run_test_scene();
  constexpr int kPeriods = 3000;
  std::vector<std::vector<numen::core::Vec3>> paths;
  for (const numen::sim::IgtlReplayMessage m :
       {numen::sim::IgtlReplayMessage::kTransform, numen::sim::IgtlReplayMessage::kPosition,
        numen::sim::IgtlReplayMessage::kQtrans}) {
    numen::sim::IgtlReplaySettings rs;
    rs.duration_s = kPeriods * scene.model.dt;
    rs.message = m;
    IgtlRunTestReplay replay(scene, rs);
    numen::sim::BusChoice bus;
    bus.spec = replay.spec();
    numen::sim::SceneRunner runner(scene, 0, bus);
    paths.emplace_back();
    for (int k = 0; k < kPeriods; ++k) {
      runner.period();
      paths.back().push_back(runner.data().bodies[0].position);
    }
    runner.finish();
    const numen::sim::RunSummary s = runner.summary();
    EXPECT_EQ(s.igtl_poses_taken, kPeriods) << static_cast<int>(m);
    EXPECT_EQ(s.igtl_faults, 0) << static_cast<int>(m);
    EXPECT_EQ(s.rejected_samples, 0) << static_cast<int>(m);
  }
  // The same god-object path: a float32 matrix and a float32 quaternion of one pose differ in
  // their last bits, an encoder count (1 um, 1 urad) at most.
  double worst = 0.0;
  for (std::size_t m = 1; m < paths.size(); ++m)
    for (int k = 0; k < kPeriods; ++k)
      worst = std::max(worst, (paths[m][static_cast<std::size_t>(k)] -
                               paths[0][static_cast<std::size_t>(k)]).norm());
  EXPECT_LT(worst, 5e-6);
}

TEST(IgtlRun, AServerThatGoesAwayMidRunIsSaidAndFailsTheRun) {
  const numen::sim::Scene& scene = igtl_run_test_scene();
  numen::sim::IgtlReplaySettings rs;
  rs.disconnect_after = 300;
  const numen::sim::RunSummary s = igtl_run_test_against(scene, scene, rs, 0.6);
  EXPECT_EQ(s.igtl_disconnects, 1);
  EXPECT_EQ(s.igtl_poses, 300);
  EXPECT_EQ(s.igtl_periods_after_end, 300);  // periods 300..599 found the stream ended
  EXPECT_GT(s.rejected_samples, 0);  // the last pose went stale after max_sample_age
  EXPECT_EQ(s.exit_status, numen::sim::code(numen::sim::ExitStatus::kSamplesRejected));
  EXPECT_TRUE(igtl_run_test_says(s, "the tracker's stream ended 300 periods before the run did"))
      << s.exit_reasons.front();
}

TEST(IgtlRun, AToolNeverSentIsNamedWithTheNamesThatWere) {
  numen::sim::Scene other = numen::sim::load_scene(std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/tracker.toml");
  other.igtl->device_name = "PointerToTracker";
  numen::sim::IgtlReplaySettings rs;
  rs.duration_s = 0.2;
  const numen::sim::RunSummary s = igtl_run_test_against(igtl_run_test_scene(), other, rs, 0.2);
  EXPECT_EQ(s.igtl_poses, 0);
  EXPECT_EQ(s.igtl_other_devices, 201);
  EXPECT_EQ(s.exit_status, numen::sim::code(numen::sim::ExitStatus::kSamplesRejected));
  EXPECT_TRUE(igtl_run_test_says(
      s, "'StylusToTracker' in 201 messages (device names sent: 'PointerToTracker')"));
  EXPECT_TRUE(
      igtl_run_test_says(s, "no pose (TRANSFORM, POSITION or QTRANS) of the tool 127.0.0.1:"));
}

TEST(IgtlRun, AServerThatNeverAnswersIsSaid) {
  numen::sim::RunOptions o;
  o.bus.spec = "igtl:127.0.0.1:1";  // a privileged port nobody listens on
  o.duration_s = 0.05;
  const numen::sim::RunSummary s = numen::sim::run_scene(igtl_run_test_scene(), o);
  EXPECT_EQ(s.igtl_connects, 0);
  EXPECT_GE(s.igtl_connect_failures, 1);
  EXPECT_EQ(s.exit_status, numen::sim::code(numen::sim::ExitStatus::kSamplesRejected));
  EXPECT_TRUE(igtl_run_test_says(s, "no connection to the OpenIGTLink server 127.0.0.1:1"));
}

TEST(IgtlRun, ASceneWithoutATrackerIsRefusedAtTheBusOption) {
  const numen::sim::Scene scene =
      numen::sim::load_scene(std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/mouse.toml");
  numen::sim::RunOptions o;
  o.bus.spec = "igtl:18944";
  try {
    numen::sim::run_scene(scene, o);
    FAIL() << "refused";
  } catch (const numen::sim::InputError& e) {
    EXPECT_EQ(e.key(), "--bus");
    EXPECT_NE(std::string(e.what()).find("[device.igtl]"), std::string::npos) << e.what();
  }
}

// A registration named in the scene that never comes (here: no server) fails the run's start
// with an error located at the scene's key.
TEST(IgtlRun, ARegistrationNeverSentIsAnErrorAtItsKey) {
  const numen::test::TempDir dir;
  std::string text = igtl_run_test_tracker_text();
  const auto at = text.find("registration = {");
  ASSERT_NE(at, std::string::npos);
  text.replace(at, text.find('\n', at) - at, "registration = \"TrackerToScene\"");
  const std::string file = dir.write("named.toml", text);
  const numen::sim::Scene scene = numen::sim::load_scene(file);
  numen::sim::RunOptions o;
  o.bus.spec = "igtl:127.0.0.1:1";  // a privileged port nobody listens on
  o.duration_s = 0.05;
  try {
    numen::sim::run_scene(scene, o);
    FAIL() << "ran without its registration";
  } catch (const numen::sim::InputError& e) {
    EXPECT_EQ(e.key(), "device.igtl.registration");
    EXPECT_EQ(e.file(), file);
    EXPECT_GT(e.line(), 0);
    EXPECT_NE(std::string(e.what()).find("no TRANSFORM 'TrackerToScene' (the registration) from "
                                         "127.0.0.1:1: never connected"),
              std::string::npos)
        << e.what();
  }
}
