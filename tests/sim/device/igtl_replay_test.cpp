/// @file igtl_replay_test.cpp
/// `numen igtl-replay` (sim/device/igtl_replay.hpp) read by the library's decoder through the
/// tracker's receiver on loopback: message k is the trajectory's tip at k·dt + the bus latency
/// in the tracker's frame and units, stamped k·dt after the first; a replay told to stop early
/// closes the connection.

#include "numen/sim/device/igtl_replay.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <limits>
#include <memory>
#include <stdexcept>
#include <thread>
#include <utility>

#include "numen/hal/igtl/igtl_tracker_client.hpp"
#include "numen/sim/device/simulated_instrument.hpp"
#include "numen/sim/input/input_error.hpp"

namespace {

const numen::sim::Scene& igtl_replay_test_scene() {
  static const numen::sim::Scene s =
      numen::sim::load_scene(std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/tracker.toml");
  return s;
}

// `scene` replayed with `rs` (an ephemeral port) to a receiver that reads it to its end; the
// replay's result in `result`.
std::unique_ptr<numen::hal::IgtlTrackerClient> igtl_replay_test_read(
    const numen::sim::Scene& scene, numen::sim::IgtlReplaySettings rs,
    numen::sim::IgtlReplayResult& result) {
  rs.port = 0;
  numen::sim::IgtlReplayServer server(scene, rs);
  EXPECT_NE(server.port(), 0);
  std::thread serving([&] { result = server.serve(); });
  numen::hal::IgtlTrackerClientSettings cs;
  cs.port = server.port();
  cs.device_name = scene.igtl->device_name;
  cs.reconnect = false;
  auto client = std::make_unique<numen::hal::IgtlTrackerClient>(cs);
  for (int i = 0; i < 5000 && !client->ended(); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  serving.join();
  return client;
}

}  // namespace

TEST(IgtlReplay, MessageKIsTheTrackedTipAtItsSyncInTheTrackersFrame) {
  const numen::sim::Scene& scene = igtl_replay_test_scene();
  numen::sim::IgtlReplaySettings rs;
  rs.duration_s = 0.049;  // 50 messages
  rs.disconnect_after = -1;
  numen::sim::IgtlReplayResult result;
  const std::unique_ptr<numen::hal::IgtlTrackerClient> reader =
      igtl_replay_test_read(scene, rs, result);
  numen::hal::IgtlTrackerClient& client = *reader;
  EXPECT_TRUE(result.client_connected);
  EXPECT_EQ(result.messages_sent, 50);
  EXPECT_EQ(client.counters().poses, 50u);
  EXPECT_EQ(client.counters().faults_total(), 0u);
  const numen::sim::SimulatedInstrument instrument(scene.device, scene.trajectory);
  const numen::sim::IgtlTrackerScene& t = *scene.igtl;
  std::int64_t first = 0;
  for (int k = 0; k < 50; ++k) {
    const numen::hal::IgtlPose* p = client.front();
    ASSERT_NE(p, nullptr);
    if (k == 0) first = p->stamp_ns;
    EXPECT_EQ(p->stamp_ns - first, k * 1'000'000) << k;
    // Back into the world: registration · marker · calibration = the tip; · tool_offset = the
    // controlled frame the simulated instrument reports.
    const numen::core::Quat mq(p->rotation);
    const numen::core::Vec3 mp = p->translation * t.metres_per_unit;
    const numen::core::Quat tip_q = t.registration.orientation * mq * t.calibration.orientation;
    const numen::core::Vec3 tip_p =
        t.registration.position + t.registration.orientation * (mp + mq * t.calibration.position);
    const numen::core::Pose want =
        instrument.controlled_pose_at(k * 1'000'000 + scene.bus.latency_ns);
    const numen::core::Vec3 c_p = tip_p + tip_q * scene.device.tool_offset.position;
    EXPECT_LT((c_p - want.position).norm(), 1e-6) << k;  // float32 millimetres at ~1 m
    EXPECT_LT(tip_q.angularDistance(want.orientation), 1e-6) << k;
    client.pop();
  }
}

TEST(IgtlReplay, ASceneWithoutATrackerOrWithARegistrationReadAtStartIsRefused) {
  const numen::sim::Scene scene =
      numen::sim::load_scene(std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/mouse.toml");
  numen::sim::IgtlReplaySettings rs;
  rs.port = 0;
  EXPECT_THROW(numen::sim::IgtlReplayServer(scene, rs), numen::sim::InputError);
  // A registration read from a TRANSFORM: the replay has no value to place the tool with.
  numen::sim::Scene named =
      numen::sim::load_scene(std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/tracker.toml");
  named.igtl->registration_name = "TrackerToScene";
  try {
    numen::sim::IgtlReplayServer server(named, rs);
    ADD_FAILURE() << "replayed without a registration";
  } catch (const numen::sim::InputError& e) {
    EXPECT_EQ(e.key(), "device.igtl.registration");
    EXPECT_NE(std::string(e.what()).find("TrackerToScene"), std::string::npos) << e.what();
  }
}

// A stall (issue 70's tracker that loses its marker): from 0.02 s nothing for 0.2 s of wall
// time, and the poses of that stretch never sent; the next is stamped where the tracker's clock
// went on (0.22 s after the first). A stall's bad time or length is refused.
TEST(IgtlReplay, AStallLeavesAGapInTheStreamItsStampsAndWallTime) {
  const numen::sim::Scene& scene = igtl_replay_test_scene();
  numen::sim::IgtlReplaySettings rs;
  rs.duration_s = 0.249;  // 250 messages of the trajectory, 200 of them in the stall
  rs.stall_at_s = 0.02;
  rs.stall_s = 0.2;
  numen::sim::IgtlReplayResult result;
  const auto t0 = std::chrono::steady_clock::now();
  const std::unique_ptr<numen::hal::IgtlTrackerClient> reader =
      igtl_replay_test_read(scene, rs, result);
  numen::hal::IgtlTrackerClient& client = *reader;
  EXPECT_GE(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 0.2);
  EXPECT_EQ(result.messages_sent, 50);
  ASSERT_EQ(client.counters().poses, 50u);
  std::int64_t first = 0;
  for (int k = 0; k < 50; ++k) {
    const numen::hal::IgtlPose* p = client.front();
    ASSERT_NE(p, nullptr);
    if (k == 0) first = p->stamp_ns;
    EXPECT_EQ(p->stamp_ns - first, (k < 20 ? k : k + 200) * 1'000'000) << k;
    client.pop();
  }
  for (const auto& [at, length] : {std::pair{-1.0, 1.0}, std::pair{0.0, -1.0},
                                   std::pair{0.0, std::numeric_limits<double>::infinity()}}) {
    numen::sim::IgtlReplaySettings bad;
    bad.port = 0;
    bad.stall_at_s = at;
    bad.stall_s = length;
    EXPECT_THROW(numen::sim::IgtlReplayServer(scene, bad), std::invalid_argument) << at << " " << length;
  }
}
