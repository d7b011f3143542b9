/// @file igtl_world_server_test.cpp
/// The world out over OpenIGTLink (sim/view/igtl_world_server.hpp) on loopback (an ephemeral
/// port), read back by the tracker's receiver (the library's decoder): the TRANSFORMs of the
/// god-object and of its target are the trace's poses at the frames' times; a client that
/// connects late gets the frames from then on, one that leaves is dropped.

#include "numen/sim/view/igtl_world_server.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <map>
#include <memory>
#include <thread>

#include "numen/hal/igtl/igtl_tracker_client.hpp"
#include "numen/sim/run/run.hpp"
#include "numen/sim/scene/scene.hpp"

namespace {

std::unique_ptr<numen::hal::IgtlTrackerClient> igtl_world_test_client(std::uint16_t port,
                                                                       const char* name) {
  numen::hal::IgtlTrackerClientSettings s;
  s.port = port;
  s.device_name = name;
  s.queue_poses = 4096;
  s.wait_when_full = true;
  s.reconnect = false;
  return std::make_unique<numen::hal::IgtlTrackerClient>(s);
}

// Polls `done` every ms for at most 5 s.
template <typename F>
bool igtl_world_test_wait(F done) {
  for (int i = 0; i < 5000 && !done(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  return done();
}

}  // namespace

TEST(IgtlWorldServer, TheTransformsReadBackAreTheTracesPosesAndLateClientsJoin) {
  const numen::sim::Scene scene =
      numen::sim::load_scene(std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/tracker.toml");
  ASSERT_EQ(scene.model.bodies[0].name, "stylus");
  numen::sim::IgtlWorldSettings ws;
  ws.port = 0;
  numen::sim::IgtlWorldServer server({"stylus"}, ws);
  auto body = igtl_world_test_client(server.port(), "stylus");
  auto target = igtl_world_test_client(server.port(), "stylus_target");
  ASSERT_TRUE(igtl_world_test_wait([&] { return server.accept_clients() == 2; }));
  constexpr int kPeriods = 2000;
  numen::sim::SceneRunner runner(scene, kPeriods);
  runner.stream_view("", {&server}, 100.0, true);  // every 10th period, offline: none dropped
  std::unique_ptr<numen::hal::IgtlTrackerClient> late;
  for (int k = 0; k < kPeriods; ++k) {
    if (k == kPeriods / 2) {  // connected (the listener's backlog): the next frame accepts it
      late = igtl_world_test_client(server.port(), "stylus");
      ASSERT_TRUE(igtl_world_test_wait([&] { return late->connected(); }));
    }
    if (k == 3 * kPeriods / 4) {
      ASSERT_TRUE(igtl_world_test_wait([&] { return late->counters().poses > 0; }));
      late.reset();  // it leaves mid-run
    }
    runner.period();
  }
  runner.finish();
  EXPECT_EQ(server.counters().clients_total, 3u);
  EXPECT_EQ(server.counters().clients_gone, 1u);
  EXPECT_EQ(server.counters().frames_skipped, 0u);
  // Every frame's two TRANSFORMs, each equal to the trace's pose at the frame's time.
  const std::uint64_t frames = server.counters().frames;
  ASSERT_TRUE(igtl_world_test_wait([&] { return body->counters().poses >= frames; }));
  ASSERT_TRUE(igtl_world_test_wait([&] { return target->counters().poses >= frames; }));
  std::map<std::int64_t, const numen::sim::TraceRecord*> at;  // µs of simulated time
  for (const numen::sim::TraceRecord& r : runner.trace().records())
    at[std::llround(r.time_s * 1e6)] = &r;
  int compared = 0;
  for (auto* c : {body.get(), target.get()}) {
    for (const numen::hal::IgtlPose* p = c->front(); p != nullptr; c->pop(), p = c->front()) {
      const auto r = at.find(std::llround(static_cast<double>(p->stamp_ns) * 1e-3));
      ASSERT_NE(r, at.end()) << p->stamp_ns;
      const numen::core::Pose& want = c == body.get() ? r->second->tool : r->second->target;
      EXPECT_LT((p->translation * 1e-3 - want.position).norm(), 1e-6) << p->stamp_ns;  // mm
      EXPECT_LT(numen::core::Quat(p->rotation).angularDistance(want.orientation), 1e-5);
      ++compared;
    }
  }
  EXPECT_EQ(compared, 2 * static_cast<int>(server.counters().frames));
  EXPECT_GE(server.counters().frames, 200u);
}
