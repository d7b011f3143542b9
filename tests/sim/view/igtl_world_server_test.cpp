/// @file igtl_world_server_test.cpp
/// The world out over OpenIGTLink (sim/view/igtl_world_server.hpp) on loopback (an ephemeral
/// port), read back by the tracker's receiver and a plain client (the library's decoders): the
/// TRANSFORMs of the god-object and of its target are the trace's poses at the frames' times; a
/// client that connects late gets the frames from then on, one that leaves is dropped; the
/// organs' POLYDATA are their (fine) surfaces at the frames' times, a late client gets the shapes
/// first; faults and events are STATUS and STRING messages; the server listens on IPv6 too.

#include "numen/sim/view/igtl_world_server.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <cmath>
#include <map>
#include <string>
#include <vector>
#include <memory>
#include <thread>

#include "build_features.hpp"
#include "fine_surface_organ.hpp"
#include "igtl_test_reader.hpp"
#include "numen/core/net_surface_map.hpp"
#include "numen/hal/device/safety_supervisor.hpp"
#include "numen/hal/device/sample_check.hpp"
#include "numen/hal/igtl/igtl_pack.hpp"
#include "numen/hal/igtl/igtl_tracker_client.hpp"
#include "numen/platform/state_frame.hpp"
#include "numen/sim/run/run.hpp"
#include "numen/sim/scene/scene.hpp"
#include "numen/sim/view/view_scene.hpp"

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
  numen::sim::IgtlWorldServer server(scene.model, ws);
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

TEST(IgtlWorldServer, PlusNamesAreSentAsFromToSceneAndBodiesTheyCannotNameAreRefused) {
  using numen::sim::IgtlNameStyle;
  using numen::sim::igtl_world_transform_name;
  EXPECT_EQ(igtl_world_transform_name("stylus", false, IgtlNameStyle::kNumen), "stylus");
  EXPECT_EQ(igtl_world_transform_name("stylus", true, IgtlNameStyle::kNumen), "stylus_target");
  EXPECT_EQ(igtl_world_transform_name("stylus", false, IgtlNameStyle::kPlus), "StylusToScene");
  EXPECT_EQ(igtl_world_transform_name("stylus", true, IgtlNameStyle::kPlus), "StylusTargetToScene");
  EXPECT_EQ(igtl_world_transform_name("tool", false, IgtlNameStyle::kPlus), "ToolToScene");
  EXPECT_EQ(igtl_world_transform_name("jaw_2", true, IgtlNameStyle::kPlus), "Jaw_2TargetToScene");
  const auto refused = [](const std::string& body, IgtlNameStyle style, const std::string& says) {
    try {
      (void)igtl_world_transform_name(body, true, style);
      ADD_FAILURE() << body << ": not refused";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(says), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("'" + body + "'"), std::string::npos) << e.what();
    }
  };
  refused("needle_driver", IgtlNameStyle::kPlus, "1 to 7 characters");  // 26 with TargetToScene
  refused("needle_driver_2", IgtlNameStyle::kNumen, "1 to 13 characters");
  refused("2arm", IgtlNameStyle::kPlus, "start with a letter");
  refused("goToX", IgtlNameStyle::kPlus, "finds 2 in 'GoToXTargetToScene'");
  refused("to_b", IgtlNameStyle::kPlus, "'To_bTargetToScene'");  // "To_": not lower case
  // The names a client receives: each TRANSFORM by its PLUS name, and no other.
  const numen::sim::Scene scene =
      numen::sim::load_scene(std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/tracker.toml");
  numen::sim::IgtlWorldSettings ws;
  ws.port = 0;
  ws.names = IgtlNameStyle::kPlus;
  numen::sim::IgtlWorldServer server(scene.model, ws);
  auto body = igtl_world_test_client(server.port(), "StylusToScene");
  auto target = igtl_world_test_client(server.port(), "StylusTargetToScene");
  ASSERT_TRUE(igtl_world_test_wait([&] { return server.accept_clients() == 2; }));
  constexpr int kPeriods = 500;
  numen::sim::SceneRunner runner(scene, kPeriods);
  runner.stream_view("", {&server}, 100.0, true);
  for (int k = 0; k < kPeriods; ++k) runner.period();
  runner.finish();
  const std::uint64_t frames = server.counters().frames;
  ASSERT_GE(frames, 40u);
  ASSERT_TRUE(igtl_world_test_wait([&] { return body->counters().poses >= frames; }));
  ASSERT_TRUE(igtl_world_test_wait([&] { return target->counters().poses >= frames; }));
  // A frame sends the body's TRANSFORM, then the target's: the body's client may have counted
  // its last pose while the last frame's other message is still on its way.
  ASSERT_TRUE(igtl_world_test_wait([&] { return body->counters().other_devices >= frames; }));
  ASSERT_TRUE(igtl_world_test_wait([&] { return target->counters().other_devices >= frames; }));
  EXPECT_EQ(body->names_seen(), std::vector<std::string>{"StylusTargetToScene"});
  EXPECT_EQ(target->names_seen(), std::vector<std::string>{"StylusToScene"});
  EXPECT_EQ(body->counters().other_devices, frames);  // the target's, one a frame
  // A scene whose body PLUS cannot name: refused at construction, naming it.
  numen::core::Model model = scene.model;
  model.bodies[0].name = "pointer";  // 7 characters: "PointerTargetToScene" is 20
  EXPECT_NO_THROW(numen::sim::IgtlWorldServer(model, ws));
  model.bodies[0].name = "stylus_2";
  EXPECT_THROW(numen::sim::IgtlWorldServer(model, ws), std::invalid_argument);
}

namespace {

// One frame of `data` (the frames the stream would send), with `report` and `figures`.
std::vector<std::byte> igtl_world_test_frame(const numen::platform::StateFrameLayout& layout,
                                             const numen::core::Data& data,
                                             const numen::platform::PeriodReport& report,
                                             const numen::platform::StateFrameFigures& figures) {
  std::vector<std::byte> frame(layout.max_frame_bytes());
  const std::vector<double> torques(layout.num_axes, 0.0);
  frame.resize(numen::platform::encode_state_frame(layout, data, report, torques, figures, frame));
  return frame;
}

// The messages of `reader` of type `type` and device `name`, decoded.
std::vector<numen::hal::IgtlUnpacked> igtl_world_test_of(const numen::test::IgtlTestReader& reader,
                                                         const std::string& type,
                                                         const std::string& name) {
  std::vector<numen::hal::IgtlUnpacked> out;
  for (const std::string& m : reader.messages())
    if (numen::test::IgtlTestReader::type_of(m) == type &&
        numen::test::IgtlTestReader::name_of(m) == name)
      out.push_back(numen::hal::unpack_igtl(std::span(
          reinterpret_cast<const std::uint8_t*>(m.data()), m.size())));
  return out;
}

// The STATUS messages `reader` has received.
int igtl_world_test_statuses(const numen::test::IgtlTestReader& reader) {
  int n = 0;
  for (const std::string& m : reader.messages())
    n += numen::test::IgtlTestReader::type_of(m) == "STATUS";
  return n;
}

// STATUS `m` has code `code`, subcode `subcode`, error name `name` and timestamp `t_ns`.
void igtl_world_test_expect(const numen::hal::IgtlUnpacked& m, int code, std::int64_t subcode,
                            const std::string& name, std::int64_t t_ns) {
  EXPECT_EQ(m.status_code, code) << m.text;
  EXPECT_EQ(m.status_subcode, subcode) << m.text;
  EXPECT_EQ(m.error_name, name) << m.text;
  EXPECT_EQ(m.timestamp_ns, t_ns) << m.text;
}

}  // namespace

// The organs out: each deformable's POLYDATA (the fine surface of the net that carries one, the
// net's own nodes and triangles of the other) at the frames due at the organ rate, its points
// the state's (fine) surface vertices at that frame's time in mm, its triangles the model's; a
// client that connects late gets the shapes first, at the frame it joins.
TEST(IgtlWorldServer, TheOrgansPolyDataIsTheirSurfaceAtTheFramesTimeAndLateClientsGetItFirst) {
  NUMEN_REQUIRE_DEFORMABLE();
  numen::sim::Scene scene =
      numen::sim::load_scene(std::string(NUMEN_TEST_DATA_DIR) + "/node_contacts.toml");
  numen::core::Model& model = scene.model;
  ASSERT_EQ(model.nets.size(), 2u);  // the organ (fine icosphere 3 mapped on it), the ball
  ASSERT_EQ(numen::test::map_fine_icosphere_onto_net(model, 0, 3), "");
  const numen::core::NetModel& organ = model.nets[0];
  const numen::core::NetModel& ball = model.nets[1];
  ASSERT_EQ(organ.surface_point_count, 642);
  ASSERT_EQ(ball.surface_point_count, 0);
  numen::sim::IgtlWorldSettings ws;
  ws.port = 0;
  ws.organ_rate_hz = 25.0;  // frames at 100 Hz: an organ update every 4th frame
  numen::sim::IgtlWorldServer server(model, ws);
  numen::test::IgtlTestReader early(server.port());
  ASSERT_TRUE(early.connected());
  std::unique_ptr<numen::test::IgtlTestReader> late;
  const numen::platform::StateFrameLayout layout = numen::sim::view_frame_layout(scene);
  numen::core::Data data = numen::core::make_data(model);
  std::map<std::int64_t, std::vector<numen::core::Vec3>> fine_at, ball_at;  // mm, by ns
  constexpr int kFrames = 20;
  for (int k = 0; k < kFrames; ++k) {
    data.time = 0.01 * k;
    for (int i = 0; i < model.num_nodes(); ++i)  // every node moved by up to 2 mm, differently each frame
      data.nodes[static_cast<std::size_t>(i)].position =
          model.node_rest[static_cast<std::size_t>(i)] +
          0.002 * numen::core::Vec3(std::sin(1.7 * i + k), std::cos(2.3 * i - k), std::sin(0.9 * i + 0.3 * k));
    const std::int64_t t_ns = std::llround(data.time * 1e9);
    std::vector<numen::core::Vec3> fine(642);
    ASSERT_EQ(numen::core::net_surface_positions(model, data, 0, fine), 642);
    for (numen::core::Vec3& p : fine) p *= 1e3;
    fine_at[t_ns] = fine;
    for (int i = 0; i < ball.node_count; ++i)
      ball_at[t_ns].push_back(1e3 * data.nodes[static_cast<std::size_t>(ball.node_begin + i)].position);
    if (k == 10) {  // t = 0.10 s: between the updates of 0.08 and 0.12 s
      late = std::make_unique<numen::test::IgtlTestReader>(server.port());
      ASSERT_TRUE(late->connected());
    }
    const std::vector<std::byte> frame = igtl_world_test_frame(layout, data, {}, {});
    ASSERT_FALSE(frame.empty());
    ASSERT_TRUE(server.write_frame(frame));
  }
  // Updates at 0, 0.04, ..., 0.16 s: five of each organ to the early client, and the late one's
  // shapes at 0.10 s then 0.12 and 0.16 s.
  const auto count_polydata = [](const numen::test::IgtlTestReader& r) {
    int n = 0;
    for (const std::string& m : r.messages()) n += numen::test::IgtlTestReader::type_of(m) == "POLYDATA";
    return n;
  };
  const auto flush = [&] { server.flush(); };
  ASSERT_TRUE(early.read_until([&] { return count_polydata(early) >= 10; }, flush));
  ASSERT_TRUE(late->read_until([&] { return count_polydata(*late) >= 6; }, flush));
  EXPECT_EQ(server.counters().polydata, 16u);
  // The late client's first message is a shape, at the frame it joined.
  ASSERT_FALSE(late->messages().empty());
  EXPECT_EQ(numen::test::IgtlTestReader::type_of(late->messages().front()), "POLYDATA");
  const std::vector<std::int64_t> early_times{0, 40'000'000, 80'000'000, 120'000'000, 160'000'000};
  const std::vector<std::int64_t> late_times{100'000'000, 120'000'000, 160'000'000};
  for (const auto* reader : {&early, late.get()}) {
    const auto& want_times = reader == &early ? early_times : late_times;
    for (const char* name : {"organ", "ball"}) {
      const std::vector<numen::hal::IgtlUnpacked> got = igtl_world_test_of(*reader, "POLYDATA", name);
      ASSERT_EQ(got.size(), want_times.size()) << name;
      const bool is_organ = std::string(name) == "organ";
      const numen::core::NetModel& net = is_organ ? organ : ball;
      for (std::size_t u = 0; u < got.size(); ++u) {
        const numen::hal::IgtlUnpacked& p = got[u];
        EXPECT_EQ(p.timestamp_ns, want_times[u]) << name;
        const auto& want = (is_organ ? fine_at : ball_at).at(p.timestamp_ns);
        ASSERT_EQ(p.points.size(), want.size()) << name;
        double worst = 0.0;
        for (std::size_t i = 0; i < want.size(); ++i) worst = std::max(worst, (p.points[i] - want[i]).norm());
        EXPECT_LT(worst, 1e-3) << name << " at " << p.timestamp_ns << " ns (mm)";  // 1 µm: float32
        ASSERT_EQ(p.triangles.size(),
                  static_cast<std::size_t>(is_organ ? net.surface_face_count : net.face_count));
        for (std::size_t t = 0; t < p.triangles.size(); ++t)
          for (int c = 0; c < 3; ++c)
            ASSERT_EQ(static_cast<int>(p.triangles[t][static_cast<std::size_t>(c)]),
                      is_organ ? model.net_surface_faces[static_cast<std::size_t>(net.surface_face_begin) + t][static_cast<std::size_t>(c)] -
                                     net.surface_point_begin
                               : model.net_faces[static_cast<std::size_t>(net.face_begin) + t][static_cast<std::size_t>(c)] -
                                     net.node_begin);
      }
    }
  }
}

// An organ given by its material (its contact_modulus) is sent with the tools' dimples drawn
// (view/tissue_dimple.hpp; docs/openigtlink.md, "The organs"): the probe's 4 mm sphere placed
// 1 mm into the organ's surface at one of its nodes, the organ's POLYDATA has that node 1 mm in
// and no point inside the sphere; the ball (per spring) is sent as its nodes are.
TEST(IgtlWorldServer, AnOrganGivenByItsMaterialIsSentWithTheToolsDimple) {
  NUMEN_REQUIRE_DEFORMABLE();
  numen::sim::Scene scene =
      numen::sim::load_scene(std::string(NUMEN_TEST_DATA_DIR) + "/node_contacts.toml");
  numen::core::Model& model = scene.model;
  ASSERT_EQ(model.nets.size(), 2u);
  model.nets[0].contact_modulus = 1.5e5;  // only the flag is read here
  const numen::core::NetModel& organ = model.nets[0];
  const numen::core::NetModel& ball = model.nets[1];
  const int probe = static_cast<int>(model.bodies.size()) - 1;
  ASSERT_EQ(model.bodies[static_cast<std::size_t>(probe)].name, "probe");
  const double r = model.body_spheres[static_cast<std::size_t>(model.bodies[static_cast<std::size_t>(probe)].sphere_begin)].radius;
  numen::core::Data data = numen::core::make_data(model);
  // The organ's node 0 at rest and its outward normal (from the organ's core: an icosphere).
  const numen::core::Vec3 core = data.bodies[static_cast<std::size_t>(organ.body)].position;
  const numen::core::Vec3 node = data.nodes[static_cast<std::size_t>(organ.node_begin)].position;
  const numen::core::Vec3 n = (node - core).normalized();
  const numen::core::Vec3 centre = node + (r - 0.001) * n;
  data.bodies[static_cast<std::size_t>(probe)].position = centre;
  data.bodies[static_cast<std::size_t>(probe)].orientation = numen::core::Quat::Identity();
  numen::sim::IgtlWorldSettings ws;
  ws.port = 0;
  numen::sim::IgtlWorldServer server(model, ws);
  numen::test::IgtlTestReader reader(server.port());
  ASSERT_TRUE(reader.connected());
  ASSERT_TRUE(server.write_frame(igtl_world_test_frame(numen::sim::view_frame_layout(scene), data, {}, {})));
  const auto flush = [&] { server.flush(); };
  ASSERT_TRUE(reader.read_until([&] { return igtl_world_test_of(reader, "POLYDATA", "ball").size() == 1; }, flush));
  const auto got = igtl_world_test_of(reader, "POLYDATA", "organ");
  ASSERT_EQ(got.size(), 1u);
  ASSERT_EQ(got[0].points.size(), static_cast<std::size_t>(organ.node_count));
  double inside = 0.0;
  for (const numen::core::Vec3& p : got[0].points) inside = std::max(inside, 1e3 * r - (p - 1e3 * centre).norm());
  const double moved = (got[0].points[0] - 1e3 * node).norm();
  std::printf("the organ's node under the probe moved %.4f mm in; deepest point inside the sphere %.2g mm\n",
              moved, inside);
  EXPECT_NEAR(moved, 1.0, 0.05) << "mm: the dimple under the sphere";
  EXPECT_LT(inside, 1e-3) << "mm";
  const auto balls = igtl_world_test_of(reader, "POLYDATA", "ball");
  for (int i = 0; i < ball.node_count; ++i)
    EXPECT_LT((balls[0].points[static_cast<std::size_t>(i)] -
               1e3 * data.nodes[static_cast<std::size_t>(ball.node_begin + i)].position).norm(), 1e-3);
}

// Issue 69: the suturing scene's thread is a POLYDATA named after it every frame: its segments + 1
// nodes (mm) at the frame's time as points and one LINES cell through them in order; once it
// broke, two (the pieces either side of the broken segment). The needle is its body's TRANSFORM.
TEST(IgtlWorldServer, TheThreadIsAPolylineEveryFrameBrokenInTwoAndTheNeedleItsBodysTransform) {
  NUMEN_REQUIRE_DEFORMABLE();
  const numen::sim::Scene scene =
      numen::sim::load_scene(std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/suturing.toml");
  const numen::core::Model& model = scene.model;
  ASSERT_EQ(model.threads.size(), 1u);
  ASSERT_EQ(model.needles.size(), 1u);
  const std::size_t nodes = static_cast<std::size_t>(model.threads[0].segments) + 1;  // 101
  numen::sim::IgtlWorldSettings ws;
  ws.port = 0;
  ws.organ_rate_hz = 0.0;  // the pad's shape once
  numen::sim::IgtlWorldServer server(model, ws);
  numen::test::IgtlTestReader reader(server.port());
  ASSERT_TRUE(reader.connected());
  numen::platform::StateFrameLayout layout = numen::sim::view_frame_layout(scene);
  layout.num_extra_devices = layout.num_extra_axes = 0;  // the left driver's device: not needed here
  ASSERT_EQ(layout.num_threads, 1u);
  ASSERT_EQ(layout.num_thread_nodes, nodes);
  numen::core::Data data = numen::core::make_data(model);
  std::map<std::int64_t, std::vector<numen::core::Vec3>> thread_at;  // mm, by ns
  constexpr int kFrames = 6;
  constexpr int kBroken = 40;  // broken from frame 3 on
  for (int k = 0; k < kFrames; ++k) {
    data.time = 0.01 * k;
    std::vector<numen::core::Vec3>& x = data.threads[0].position;
    ASSERT_EQ(x.size(), nodes);
    for (std::size_t i = 0; i < nodes; ++i)
      x[i] = numen::core::Vec3(0.001 * static_cast<double>(i), 0.002 * std::sin(0.3 * static_cast<double>(i) + k),
                               0.01 + 0.001 * k);
    data.threads[0].broken_segment = k >= 3 ? kBroken : -1;
    std::vector<numen::core::Vec3>& want = thread_at[std::llround(data.time * 1e9)];
    for (const numen::core::Vec3& p : x) want.push_back(1e3 * p);
    const std::vector<std::byte> frame = igtl_world_test_frame(layout, data, {}, {});
    ASSERT_FALSE(frame.empty());
    ASSERT_TRUE(server.write_frame(frame));
  }
  const auto count = [](const numen::test::IgtlTestReader& r, const std::string& name) {
    int n = 0;
    for (const std::string& m : r.messages())
      n += numen::test::IgtlTestReader::type_of(m) == "POLYDATA" && numen::test::IgtlTestReader::name_of(m) == name;
    return n;
  };
  ASSERT_TRUE(reader.read_until([&] { return count(reader, "suture") >= kFrames; }, [&] { server.flush(); }));
  const std::vector<numen::hal::IgtlUnpacked> got = igtl_world_test_of(reader, "POLYDATA", "suture");
  ASSERT_EQ(got.size(), static_cast<std::size_t>(kFrames));
  for (std::size_t u = 0; u < got.size(); ++u) {
    const numen::hal::IgtlUnpacked& p = got[u];
    EXPECT_EQ(p.timestamp_ns, static_cast<std::int64_t>(u) * 10'000'000);
    const std::vector<numen::core::Vec3>& want = thread_at.at(p.timestamp_ns);
    ASSERT_EQ(p.points.size(), nodes);
    double worst = 0.0;
    for (std::size_t i = 0; i < nodes; ++i) worst = std::max(worst, (p.points[i] - want[i]).norm());
    EXPECT_LT(worst, 1e-3) << "at " << p.timestamp_ns << " ns (mm)";  // 1 µm: float32
    EXPECT_TRUE(p.triangles.empty());
    if (u < 3) {  // whole: one polyline through every node in order
      ASSERT_EQ(p.lines.size(), 1u);
      ASSERT_EQ(p.lines[0].size(), nodes);
      for (std::size_t i = 0; i < nodes; ++i) EXPECT_EQ(p.lines[0][i], i);
    } else {  // broken at segment 40: nodes 0-40 and 41-100
      ASSERT_EQ(p.lines.size(), 2u);
      ASSERT_EQ(p.lines[0].size(), static_cast<std::size_t>(kBroken) + 1);
      ASSERT_EQ(p.lines[1].size(), nodes - kBroken - 1);
      EXPECT_EQ(p.lines[0].back(), static_cast<std::uint32_t>(kBroken));
      EXPECT_EQ(p.lines[1].front(), static_cast<std::uint32_t>(kBroken) + 1);
      EXPECT_EQ(p.lines[1].back(), nodes - 1);
    }
  }
  // The needle: its body's TRANSFORM every frame, at the body's pose (mm).
  const std::vector<numen::hal::IgtlUnpacked> needle = igtl_world_test_of(reader, "TRANSFORM", "needle");
  ASSERT_EQ(needle.size(), static_cast<std::size_t>(kFrames));
  const numen::core::Vec3 at = 1e3 * data.bodies[static_cast<std::size_t>(model.needles[0].body)].position;
  EXPECT_LT((needle.back().translation - at).norm(), 1e-3);
  // One organ (the pad) once, and the thread every frame.
  EXPECT_EQ(server.counters().polydata, 1u + kFrames);
}

// Organ rate 0: the shapes once per client (at its first frame), never again.
TEST(IgtlWorldServer, AnOrganRateOfZeroSendsTheShapeOncePerClient) {
  NUMEN_REQUIRE_DEFORMABLE();
  const numen::sim::Scene scene =
      numen::sim::load_scene(std::string(NUMEN_TEST_DATA_DIR) + "/node_contacts.toml");
  numen::sim::IgtlWorldSettings ws;
  ws.port = 0;
  ws.organ_rate_hz = 0.0;
  numen::sim::IgtlWorldServer server(scene.model, ws);
  numen::test::IgtlTestReader a(server.port());
  const numen::platform::StateFrameLayout layout = numen::sim::view_frame_layout(scene);
  numen::core::Data data = numen::core::make_data(scene.model);
  std::unique_ptr<numen::test::IgtlTestReader> b;
  for (int k = 0; k < 10; ++k) {
    data.time = 0.01 * k;
    if (k == 5) b = std::make_unique<numen::test::IgtlTestReader>(server.port());
    ASSERT_TRUE(server.write_frame(igtl_world_test_frame(layout, data, {}, {})));
  }
  const auto transforms = [](const numen::test::IgtlTestReader& r) {
    int n = 0;
    for (const std::string& m : r.messages()) n += numen::test::IgtlTestReader::type_of(m) == "TRANSFORM";
    return n;
  };
  const auto flush = [&] { server.flush(); };
  const int per_frame = static_cast<int>(scene.model.num_bodies());  // no targets: no device run
  ASSERT_TRUE(a.read_until([&] { return transforms(a) >= 10 * per_frame; }, flush));
  ASSERT_TRUE(b->read_until([&] { return transforms(*b) >= 5 * per_frame; }, flush));
  for (const char* name : {"organ", "ball"}) {
    const auto at_a = igtl_world_test_of(a, "POLYDATA", name);
    const auto at_b = igtl_world_test_of(*b, "POLYDATA", name);
    ASSERT_EQ(at_a.size(), 1u) << name;
    ASSERT_EQ(at_b.size(), 1u) << name;
    EXPECT_EQ(at_a[0].timestamp_ns, 0);
    EXPECT_EQ(at_b[0].timestamp_ns, 50'000'000);
  }
  EXPECT_EQ(server.counters().polydata, 4u);
}

// Faults and events: each change the frames show is a STATUS (code and subcode as
// docs/openigtlink.md says) and a STRING, at the frame that shows it; a grasp is a STRING; a
// client that connects gets the current state first.
TEST(IgtlWorldServer, FaultsRejectionsTheBusAndGraspsAreStatusAndStringMessages) {
  const numen::sim::Scene scene =
      numen::sim::load_scene(std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/tracker.toml");
  numen::sim::IgtlWorldSettings ws;
  ws.port = 0;
  numen::sim::IgtlWorldServer server(scene.model, ws);
  numen::test::IgtlTestReader early(server.port());
  const numen::platform::StateFrameLayout layout = numen::sim::view_frame_layout(scene);
  numen::core::Data data = numen::core::make_data(scene.model);
  const int held = data.held_body;
  ASSERT_EQ(held, 0);
  using numen::hal::FaultCause;
  using numen::hal::SampleFault;
  struct Step {
    numen::hal::FaultMask sample_faults;
    bool bus_down;
    FaultCause cause;
    int held;
  };
  const std::vector<Step> steps{
      {SampleFault::kNoData, false, FaultCause::kNone, 0},   // start: no sample yet (no event)
      {SampleFault::kNone, false, FaultCause::kNone, 0},     // valid (no event)
      {SampleFault::kStale, true, FaultCause::kNone, 0},     // stale, the tracker's connection lost
      {SampleFault::kStale, true, FaultCause::kEncoderTimeout, 0},  // the safe state latches
      {SampleFault::kStale, true, FaultCause::kEncoderTimeout, 0},  // nothing new
      {SampleFault::kNone, false, FaultCause::kNone, -1},    // all back; the tool released
      {SampleFault::kJump, false, FaultCause::kNone, -1},    // a jump rejected
  };
  std::unique_ptr<numen::test::IgtlTestReader> late;
  for (std::size_t k = 0; k < steps.size(); ++k) {
    data.time = 0.01 * static_cast<double>(k);
    data.held_body = steps[k].held;
    numen::platform::PeriodReport report;
    report.sample_faults = steps[k].sample_faults;
    report.fault_cause = steps[k].cause;
    numen::platform::StateFrameFigures figures;
    figures.bus_down = steps[k].bus_down;
    if (k == 4) late = std::make_unique<numen::test::IgtlTestReader>(server.port());
    ASSERT_TRUE(server.write_frame(igtl_world_test_frame(layout, data, report, figures)));
  }
  const auto flush = [&] { server.flush(); };
  // early: its intro (ok), then 2: rejected + bus down, 3: latched, 5: cleared, valid, bus up,
  // 6: rejected (jump).
  ASSERT_TRUE(early.read_until([&] { return igtl_world_test_statuses(early) >= 8; }, flush));
  const std::vector<numen::hal::IgtlUnpacked> s = igtl_world_test_of(early, "STATUS", "numen");
  ASSERT_EQ(s.size(), 8u);
  igtl_world_test_expect(s[0], 1, 0, "ok", 0);
  igtl_world_test_expect(s[1], 7, SampleFault::kStale, "samples rejected", 20'000'000);
  igtl_world_test_expect(s[2], 7, 0, "bus down", 20'000'000);
  igtl_world_test_expect(s[3], 3, static_cast<int>(FaultCause::kEncoderTimeout),
                         numen::hal::to_string(FaultCause::kEncoderTimeout), 30'000'000);
  igtl_world_test_expect(s[4], 1, 0, "safe state cleared", 50'000'000);
  igtl_world_test_expect(s[5], 1, 0, "samples valid", 50'000'000);
  igtl_world_test_expect(s[6], 1, 0, "bus up", 50'000'000);
  igtl_world_test_expect(s[7], 2, SampleFault::kJump, "samples rejected", 60'000'000);
  EXPECT_NE(s[1].text.find("stale"), std::string::npos) << s[1].text;
  EXPECT_NE(s[7].text.find("jump"), std::string::npos) << s[7].text;
  // The STRINGs say the same in words, and the release.
  const std::vector<numen::hal::IgtlUnpacked> w = igtl_world_test_of(early, "STRING", "numen_events");
  ASSERT_EQ(w.size(), 8u);  // seven events with a STATUS, and the release
  EXPECT_EQ(w[6].text, "the device released 'stylus' at t = 0.050 s");
  EXPECT_EQ(server.counters().events, 8u);
  // The late client (joined at 0.04 s, the safe state latched): the fault first.
  ASSERT_TRUE(late->read_until([&] { return igtl_world_test_statuses(*late) >= 5; }, flush));
  const std::vector<numen::hal::IgtlUnpacked> l = igtl_world_test_of(*late, "STATUS", "numen");
  ASSERT_EQ(l.size(), 5u);
  EXPECT_EQ(numen::test::IgtlTestReader::type_of(late->messages().front()), "STATUS");
  igtl_world_test_expect(l[0], 3, static_cast<int>(FaultCause::kEncoderTimeout),
                         numen::hal::to_string(FaultCause::kEncoderTimeout), 40'000'000);
}

// Listening on IPv6 ([::1]) and on "localhost" (127.0.0.1): a client of each gets the frames.
// Issue 70: the STATUS carried device 0's state alone. Each of the loop's other devices (here
// bimanual.toml's "right") has its STATUS under its own name, "numen_1": its samples rejected
// and valid again, its safe state latched and cleared, its bus; its STRINGs name it; a client
// that connects gets every device's state. Device 0's STATUS "numen" and its words are as ever.
TEST(IgtlWorldServer, EveryDevicesStateIsAStatusUnderItsOwnName) {
  NUMEN_REQUIRE_ARTICULATION();
  NUMEN_REQUIRE_DEFORMABLE();  // the bimanual scene's organs
  const numen::sim::Scene scene =
      numen::sim::load_scene(std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/bimanual.toml");
  ASSERT_EQ(scene.extra_devices.size(), 1u);
  EXPECT_EQ(numen::sim::igtl_world_status_name(0), "numen");
  EXPECT_EQ(numen::sim::igtl_world_status_name(1), "numen_1");
  numen::sim::IgtlWorldSettings ws;
  ws.port = 0;
  ws.device_names = {scene.device.name, scene.extra_devices[0].device.name};
  numen::sim::IgtlWorldServer server(scene.model, ws);
  numen::test::IgtlTestReader early(server.port());
  const numen::platform::StateFrameLayout layout = numen::sim::view_frame_layout(scene);
  ASSERT_EQ(layout.num_extra_devices, 1u);
  numen::core::Data data = numen::core::make_data(scene.model);
  using numen::hal::FaultCause;
  using numen::hal::SampleFault;
  struct Step {
    numen::hal::FaultMask second_faults;
    bool second_bus_down;
    FaultCause second_cause;
  };
  const std::vector<Step> steps{
      {SampleFault::kNone, false, FaultCause::kNone},                  // both valid (no event)
      {SampleFault::kStale, true, FaultCause::kNone},                  // device 1 stale, its bus down
      {SampleFault::kStale, true, FaultCause::kEncoderTimeout},        // its safe state latches
      {SampleFault::kStale, true, FaultCause::kEncoderTimeout},        // nothing new
      {SampleFault::kNone, false, FaultCause::kNone},                  // all back
  };
  std::unique_ptr<numen::test::IgtlTestReader> late;
  const std::vector<double> first_tau(layout.num_axes, 0.0), second_tau(layout.num_extra_axes, 0.0);
  for (std::size_t k = 0; k < steps.size(); ++k) {
    data.time = 0.01 * static_cast<double>(k);
    numen::platform::PeriodReport first, second;  // device 0 valid throughout
    second.sample_faults = steps[k].second_faults;
    second.fault_cause = steps[k].second_cause;
    const std::array<numen::platform::FrameDeviceInput, 1> extra{
        {{&second, second_tau, steps[k].second_bus_down}}};
    std::vector<std::byte> frame(layout.max_frame_bytes());
    frame.resize(numen::platform::encode_state_frame(layout, data, first, first_tau, {}, frame, extra));
    ASSERT_FALSE(frame.empty());
    if (k == 3) late = std::make_unique<numen::test::IgtlTestReader>(server.port());
    ASSERT_TRUE(server.write_frame(frame));
  }
  const auto flush = [&] { server.flush(); };
  // early: both intros (ok), then device 1's 1: rejected, bus down; 2: latched; 4: cleared,
  // valid, bus up.
  ASSERT_TRUE(early.read_until([&] { return igtl_world_test_statuses(early) >= 8; }, flush));
  const std::vector<numen::hal::IgtlUnpacked> zero = igtl_world_test_of(early, "STATUS", "numen");
  ASSERT_EQ(zero.size(), 1u);  // device 0: its intro, nothing changed
  EXPECT_EQ(zero[0].error_name, "ok");
  const std::vector<numen::hal::IgtlUnpacked> s = igtl_world_test_of(early, "STATUS", "numen_1");
  ASSERT_EQ(s.size(), 7u);
  igtl_world_test_expect(s[0], 1, 0, "ok", 0);
  igtl_world_test_expect(s[1], 7, SampleFault::kStale, "samples rejected", 10'000'000);
  igtl_world_test_expect(s[2], 7, 0, "bus down", 10'000'000);
  igtl_world_test_expect(s[3], 3, static_cast<int>(FaultCause::kEncoderTimeout),
                         numen::hal::to_string(FaultCause::kEncoderTimeout), 20'000'000);
  igtl_world_test_expect(s[4], 1, 0, "safe state cleared", 40'000'000);
  igtl_world_test_expect(s[5], 1, 0, "samples valid", 40'000'000);
  igtl_world_test_expect(s[6], 1, 0, "bus up", 40'000'000);
  const std::vector<numen::hal::IgtlUnpacked> w = igtl_world_test_of(early, "STRING", "numen_events");
  ASSERT_EQ(w.size(), 6u);
  EXPECT_EQ(w[0].text, "device 1 'right': its samples were rejected at t = 0.010 s (stale)");
  EXPECT_EQ(w[2].text, "device 1 'right' latched its safe state at t = 0.020 s: " +
                           std::string(numen::hal::to_string(FaultCause::kEncoderTimeout)));
  EXPECT_EQ(server.counters().events, 6u);
  // The late client (joined at 0.03 s): device 0's state, then device 1's latched fault.
  ASSERT_TRUE(late->read_until([&] { return igtl_world_test_statuses(*late) >= 5; }, flush));
  const std::vector<numen::hal::IgtlUnpacked> l0 = igtl_world_test_of(*late, "STATUS", "numen");
  const std::vector<numen::hal::IgtlUnpacked> l1 = igtl_world_test_of(*late, "STATUS", "numen_1");
  ASSERT_EQ(l0.size(), 1u);
  ASSERT_EQ(l1.size(), 4u);
  igtl_world_test_expect(l0[0], 1, 0, "ok", 30'000'000);
  igtl_world_test_expect(l1[0], 3, static_cast<int>(FaultCause::kEncoderTimeout),
                         numen::hal::to_string(FaultCause::kEncoderTimeout), 30'000'000);
  EXPECT_EQ(l1[0].text, "device 1 'right' is in its safe state: " +
                            std::string(numen::hal::to_string(FaultCause::kEncoderTimeout)));
}

TEST(IgtlWorldServer, ListensOnIpv6AndOnLocalhost) {
  const numen::sim::Scene scene =
      numen::sim::load_scene(std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/tracker.toml");
  const numen::platform::StateFrameLayout layout = numen::sim::view_frame_layout(scene);
  const numen::core::Data data = numen::core::make_data(scene.model);
  for (const char* host : {"localhost", "::1"}) {
    numen::sim::IgtlWorldSettings ws;
    ws.host = host;
    ws.port = 0;
    std::unique_ptr<numen::sim::IgtlWorldServer> server;
    try {
      server = std::make_unique<numen::sim::IgtlWorldServer>(scene.model, ws);
    } catch (const std::runtime_error& e) {  // a host without IPv6 (a container without ::1)
      if (std::string(host) == "::1") GTEST_SKIP() << e.what();
      throw;
    }
    numen::test::IgtlTestReader reader(server->port(), std::string(host) == "::1");
    ASSERT_TRUE(reader.connected()) << host;
    ASSERT_TRUE(server->write_frame(igtl_world_test_frame(layout, data, {}, {})));
    ASSERT_TRUE(reader.read_until([&] { return !igtl_world_test_of(reader, "TRANSFORM", "stylus").empty(); },
                                  [&] { server->flush(); }))
        << host;
  }
  // A host that is no address of this machine: the error names it.
  numen::sim::IgtlWorldSettings ws;
  ws.host = "192.0.2.1";  // TEST-NET-1 (RFC 5737): never local
  ws.port = 0;
  try {
    numen::sim::IgtlWorldServer server(scene.model, ws);
    ADD_FAILURE() << "listened on 192.0.2.1";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("--igtl: cannot listen on 192.0.2.1:0"), std::string::npos)
        << e.what();
  }
}
