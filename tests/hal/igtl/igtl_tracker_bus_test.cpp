/// @file igtl_tracker_bus_test.cpp
/// The OpenIGTLink tracker as a pose tracker's encoders (hal/igtl/igtl_tracker_bus.hpp) against
/// a loopback server: a TRANSFORM becomes the six TPDOs that put the tracked frame at
/// registration · marker · calibration; following the tracker takes the poses by their stamps;
/// the paced period neither allocates nor waits.

#include "numen/hal/igtl/igtl_tracker_bus.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <initializer_list>
#include <thread>

#include "alloc_counter.hpp"
#include "igtl_test_server.hpp"
#include "numen/hal/canopen/canopen.hpp"
#include "numen/hal/device/axis.hpp"
#include "numen/hal/device/kinematics_factory.hpp"
#include "numen/hal/igtl/igtl_pack.hpp"

namespace {

numen::hal::DeviceConfig igtl_bus_test_config() {
  numen::hal::DeviceConfig c = numen::hal::make_default_pose_tracker_config(1);
  c.tool_offset.position = numen::core::Vec3(0.0, 0.0, -0.04);
  return c;
}

numen::hal::IgtlTrackerSettings igtl_bus_test_settings(std::uint16_t port, bool follow) {
  numen::hal::IgtlTrackerSettings s;
  s.client.port = port;
  s.client.device_name = "StylusToTracker";
  s.metres_per_unit = 1e-3;
  s.calibration.position = numen::core::Vec3(0.0, 0.0, 0.15);
  s.registration.position = numen::core::Vec3(0.1, -0.2, 0.9);
  s.registration.orientation =
      numen::core::Quat(Eigen::AngleAxisd(0.785398, numen::core::Vec3::UnitZ()));
  s.wait_for_tracker = follow;
  s.wait_timeout_ns = 2'000'000'000;
  return s;
}

// The tracked frame (the tip) the six TPDOs of one SYNC put in the world.
numen::core::Pose igtl_bus_test_tip(numen::hal::IgtlTrackerBus& bus,
                                    const numen::hal::DeviceConfig& config) {
  numen::hal::AxisVector q = numen::hal::AxisVector::Zero(6);
  numen::hal::CanFrame f;
  int n = 0;
  while (bus.read(f) == numen::hal::IoStatus::kOk) {
    for (std::size_t i = 0; i < config.axes.size(); ++i) {
      std::int32_t counts = 0;
      if (numen::hal::decode_position_pdo(f, config.axes[i].encoder_cob_id, counts) ==
          numen::hal::DecodeStatus::kOk) {
        q(static_cast<Eigen::Index>(i)) = numen::hal::counts_to_value(config.axes[i], counts);
        ++n;
      }
    }
  }
  EXPECT_EQ(n, 6);
  const numen::core::Pose c = numen::hal::make_kinematics(config)->forward(q);
  numen::core::Pose tip;
  tip.orientation = c.orientation * config.tool_offset.orientation.conjugate();
  tip.position = c.position - tip.orientation * config.tool_offset.position;
  return tip;
}

// What `periods` paced periods of `buses` (each a SYNC every 0.1 ms of bus time, its TPDOs read)
// did: frames read, the longest period (wall), allocations on this thread.
struct IgtlBusTestPaced {
  std::uint64_t frames = 0;
  std::int64_t longest_ns = 0;
  std::int64_t allocations = 0;
};

IgtlBusTestPaced igtl_bus_test_paced_periods(
    std::initializer_list<numen::hal::IgtlTrackerBus*> buses, std::int64_t periods) {
  IgtlBusTestPaced out;
  numen::hal::CanFrame f;
  numen::test::AllocationGuard guard;
  for (std::int64_t k = 0; k < periods; ++k) {
    const auto a = std::chrono::steady_clock::now();
    for (numen::hal::IgtlTrackerBus* bus : buses) {
      bus->set_time_ns(k * 100'000);
      bus->write(numen::hal::make_sync(k * 100'000));
      while (bus->read(f) == numen::hal::IoStatus::kOk) ++out.frames;
    }
    out.longest_ns = std::max<std::int64_t>(
        out.longest_ns, std::chrono::duration_cast<std::chrono::nanoseconds>(
                            std::chrono::steady_clock::now() - a).count());
  }
  out.allocations = guard.count();
  return out;
}

}  // namespace

TEST(IgtlTrackerBus, ATransformBecomesTheEncoderFramesOfTheTrackedFrame) {
  namespace hal = numen::hal;
  const numen::core::Quat mq(Eigen::AngleAxisd(0.4, numen::core::Vec3(0.2, -1.0, 0.5).normalized()));
  const numen::core::Vec3 mp(-120.0, 250.0, -820.0);  // mm, in the tracker's frame
  numen::test::IgtlTestServer server(
      {hal::pack_igtl_transform("StylusToTracker", 5'000'000'000, mq.toRotationMatrix(), mp)},
      true);  // then the stream ends: the follower does not wait for a later pose
  const hal::DeviceConfig config = igtl_bus_test_config();
  const hal::IgtlTrackerSettings s = igtl_bus_test_settings(server.port(), true);
  hal::IgtlTrackerBus bus(config, hal::make_kinematics(config), s);
  bus.set_time_ns(0);
  ASSERT_EQ(bus.write(hal::make_sync(0)), hal::IoStatus::kOk);
  const numen::core::Pose tip = igtl_bus_test_tip(bus, config);
  // tip = registration · marker · calibration, to the encoders' 1 µm / 1 µrad.
  const numen::core::Quat want_q = s.registration.orientation * mq * s.calibration.orientation;
  const numen::core::Vec3 want_p =
      s.registration.position + s.registration.orientation * (mp * 1e-3 + mq * s.calibration.position);
  EXPECT_LT((tip.position - want_p).norm(), 3e-6);
  EXPECT_LT(tip.orientation.angularDistance(want_q), 1e-5);
  EXPECT_LT((bus.last_pose().position - want_p).norm(), 1e-6);  // float32 of the message
  EXPECT_EQ(bus.tracker_counters().poses_taken, 1u);
  EXPECT_EQ(bus.tracker_counters().wait_timeouts, 0u);
  EXPECT_EQ(bus.latency_ns().size(), 1u);
}

TEST(IgtlTrackerBus, APositionOrAQtransIsTheTrackedFrameOfItsTransform) {
  namespace hal = numen::hal;
  const numen::core::Quat mq(
      Eigen::AngleAxisd(2.5, numen::core::Vec3(0.6, 0.3, -0.7).normalized()));
  const numen::core::Vec3 mp(80.0, -140.0, -905.0);  // mm
  const hal::DeviceConfig config = igtl_bus_test_config();
  const std::string sent[] = {
      hal::pack_igtl_transform("StylusToTracker", 5'000'000'000, mq.toRotationMatrix(), mp),
      hal::pack_igtl_position("StylusToTracker", 5'000'000'000, mq, mp),
      hal::pack_igtl_position("StylusToTracker", 5'000'000'000, mq, mp, true),
      hal::pack_igtl_qtrans("StylusToTracker", 5'000'000'000, mq, mp)};
  std::vector<numen::core::Pose> tips;
  for (const std::string& m : sent) {
    numen::test::IgtlTestServer server({m}, true);
    hal::IgtlTrackerBus bus(config, hal::make_kinematics(config),
                            igtl_bus_test_settings(server.port(), true));
    bus.set_time_ns(0);
    ASSERT_EQ(bus.write(hal::make_sync(0)), hal::IoStatus::kOk);
    tips.push_back(igtl_bus_test_tip(bus, config));
    EXPECT_EQ(bus.tracker_counters().poses_taken, 1u);
    EXPECT_EQ(bus.client().counters().faults_total(), 0u);
  }
  // The same encoder frames to a count: 1 µm, 1 µrad (float32 matrix and quaternion differ in
  // their last bits only).
  for (std::size_t k = 1; k < tips.size(); ++k) {
    EXPECT_LT((tips[k].position - tips[0].position).norm(), 3e-6) << k;
    EXPECT_LT(tips[k].orientation.angularDistance(tips[0].orientation), 1e-5) << k;
  }
}

TEST(IgtlTrackerBus, TwoToolsOnOneConnectionEachFeedTheirOwnBus) {
  namespace hal = numen::hal;
  // PLUS-like: per frame (1 ms apart) one message of each tool, the pointer's as a POSITION,
  // and the pointer appears from frame 1 on.
  const std::int64_t t0 = 1'700'000'000'000'000'000;
  const numen::core::Quat pq(Eigen::AngleAxisd(0.5, numen::core::Vec3::UnitX()));
  std::vector<std::string> sent;
  for (int k = 0; k < 5; ++k) {
    sent.push_back(hal::pack_igtl_transform("StylusToTracker", t0 + k * 1'000'000,
                                            numen::core::Mat3::Identity(),
                                            numen::core::Vec3(10.0 * k, 0.0, -800.0)));
    if (k > 0)
      sent.push_back(hal::pack_igtl_position("PointerToTracker", t0 + k * 1'000'000, pq,
                                             numen::core::Vec3(0.0, -20.0 * k, -700.0)));
  }
  numen::test::IgtlTestServer server(sent, true);
  const hal::DeviceConfig config = igtl_bus_test_config();
  hal::IgtlTrackerSettings s = igtl_bus_test_settings(server.port(), true);
  s.registration = numen::core::Pose{};
  s.calibration = numen::core::Pose{};
  s.client.more_device_names = {"PointerToTracker"};
  const std::shared_ptr<hal::IgtlTrackerClient> client = hal::make_igtl_tracker_client(s);
  EXPECT_EQ(client->tool_count(), 2u);
  hal::IgtlTrackerBus stylus(config, hal::make_kinematics(config), s, client, 0);
  hal::IgtlTrackerBus pointer(config, hal::make_kinematics(config), s, client, 1);
  EXPECT_THROW(hal::IgtlTrackerBus(config, hal::make_kinematics(config), s, client, 2),
               std::invalid_argument);
  for (int k = 0; k < 5; ++k) {  // the loop's order: one bus, then the other, each period
    for (hal::IgtlTrackerBus* bus : {&stylus, &pointer}) {
      bus->set_time_ns(k * 1'000'000);
      bus->write(hal::make_sync(k * 1'000'000));
    }
    EXPECT_NEAR(igtl_bus_test_tip(stylus, config).position.x(), 0.01 * k, 2e-6) << k;
    if (k == 0) {  // the pointer's first pose is stamped 1 ms after the connection's first
      hal::CanFrame f;
      EXPECT_EQ(pointer.read(f), hal::IoStatus::kWouldBlock);
      continue;
    }
    const numen::core::Pose tip = igtl_bus_test_tip(pointer, config);
    EXPECT_NEAR(tip.position.y(), -0.02 * k, 2e-6) << k;
    EXPECT_LT(tip.orientation.angularDistance(pq), 1e-5) << k;
  }
  EXPECT_EQ(stylus.tracker_counters().poses_taken, 5u);
  EXPECT_EQ(pointer.tracker_counters().poses_taken, 4u);
  EXPECT_EQ(pointer.tracker_counters().syncs_without_pose, 1u);
  EXPECT_EQ(stylus.tracker_counters().wait_timeouts + pointer.tracker_counters().wait_timeouts, 0u);
  const hal::IgtlClientCounters c = client->counters();
  EXPECT_EQ(c.tool_poses[0], 5u);
  EXPECT_EQ(c.tool_poses[1], 4u);
  EXPECT_EQ(c.other_devices, 0u);
}

TEST(IgtlTrackerBus, FollowingTheTrackerTakesEachPoseAtItsStamp) {
  namespace hal = numen::hal;
  std::vector<std::string> poses;
  const std::int64_t t0 = 1'700'000'000'000'000'000;
  for (int k = 0; k < 5; ++k)
    poses.push_back(hal::pack_igtl_transform("StylusToTracker", t0 + k * 1'000'000,
                                             numen::core::Mat3::Identity(),
                                             numen::core::Vec3(10.0 * k, 0.0, -800.0)));
  numen::test::IgtlTestServer server(poses, true);
  const hal::DeviceConfig config = igtl_bus_test_config();
  hal::IgtlTrackerSettings s = igtl_bus_test_settings(server.port(), true);
  s.registration = numen::core::Pose{};
  s.calibration = numen::core::Pose{};
  hal::IgtlTrackerBus bus(config, hal::make_kinematics(config), s);
  for (int k = 0; k < 5; ++k) {
    bus.set_time_ns(k * 1'000'000);
    bus.write(hal::make_sync(k * 1'000'000));
    const numen::core::Pose tip = igtl_bus_test_tip(bus, config);
    EXPECT_NEAR(tip.position.x(), 0.01 * k, 2e-6) << "period " << k;
  }
  // After the last pose the stream ends: the SYNC takes nothing new and does not wait.
  bus.set_time_ns(5'000'000);
  bus.write(hal::make_sync(5'000'000));
  EXPECT_NEAR(igtl_bus_test_tip(bus, config).position.x(), 0.04, 2e-6);
  EXPECT_EQ(bus.tracker_counters().poses_taken, 5u);
  EXPECT_EQ(bus.tracker_counters().poses_superseded, 0u);
  EXPECT_EQ(bus.tracker_counters().wait_timeouts, 0u);
}

TEST(IgtlTrackerBus, NoPoseNoFramesAndTheStateSaysTheServerIsGone) {
  namespace hal = numen::hal;
  const hal::DeviceConfig config = igtl_bus_test_config();
  hal::IgtlTrackerSettings s = igtl_bus_test_settings(numen::test::IgtlTestServer::closed_port(), true);
  hal::IgtlTrackerBus bus(config, hal::make_kinematics(config), s);
  bus.set_time_ns(0);
  bus.write(hal::make_sync(0));  // waits for nothing: the receiver ended at the refusal
  hal::CanFrame f;
  EXPECT_EQ(bus.read(f), hal::IoStatus::kWouldBlock);
  EXPECT_EQ(bus.tracker_counters().syncs_without_pose, 1u);
  EXPECT_EQ(bus.state(), hal::BusState::kBusOff);
  EXPECT_GE(bus.client().counters().connect_failures, 1u);
}

TEST(IgtlTrackerBus, ASilentServerIsWaitedForOnceNotEveryPeriod) {
  namespace hal = numen::hal;
  numen::test::IgtlTestServer server({});  // accepts, then sends nothing
  const hal::DeviceConfig config = igtl_bus_test_config();
  hal::IgtlTrackerSettings s = igtl_bus_test_settings(server.port(), true);
  s.wait_timeout_ns = 50'000'000;
  hal::IgtlTrackerBus bus(config, hal::make_kinematics(config), s);
  const auto t0 = std::chrono::steady_clock::now();
  for (std::int64_t k = 0; k < 100; ++k) {
    bus.set_time_ns(k * 1'000'000);
    bus.write(hal::make_sync(k * 1'000'000));
  }
  const double waited_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  // One wait of 50 ms, then the SYNCs go on without one until a pose comes (not 100 × 50 ms).
  EXPECT_EQ(bus.tracker_counters().wait_timeouts, 1u);
  EXPECT_EQ(bus.tracker_counters().syncs_without_pose, 100u);
  EXPECT_LT(waited_s, 1.0);
}

TEST(IgtlTrackerBus, ThePacedPeriodNeitherAllocatesNorWaits) {
  namespace hal = numen::hal;
  std::vector<std::string> poses;
  for (int k = 0; k < 3000; ++k)
    poses.push_back(hal::pack_igtl_transform("StylusToTracker", 0, numen::core::Mat3::Identity(),
                                             numen::core::Vec3(0.01 * k, 0.0, -800.0)));
  numen::test::IgtlTestServer server(poses);
  const hal::DeviceConfig config = igtl_bus_test_config();
  hal::IgtlTrackerBus bus(config, hal::make_kinematics(config),
                          igtl_bus_test_settings(server.port(), false));
  for (int i = 0; i < 5000 && bus.client().counters().poses == 0; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  ASSERT_GT(bus.client().counters().poses, 0u);
  const IgtlBusTestPaced r = igtl_bus_test_paced_periods({&bus}, 2000);
  EXPECT_EQ(r.allocations, 0);
  EXPECT_GT(r.frames, 0u);
  EXPECT_GT(bus.tracker_counters().poses_taken, 0u);
  // Never the 2 s wait of a follower: a period takes what is there (a generous bound for a
  // loaded CI machine).
  EXPECT_LT(r.longest_ns, 200'000'000);
}

TEST(IgtlTrackerBus, TwoToolsPacedPeriodsNeitherAllocateNorWait) {
  namespace hal = numen::hal;
  std::vector<std::string> poses;  // both tools flood one connection, interleaved
  for (int k = 0; k < 3000; ++k) {
    poses.push_back(hal::pack_igtl_transform("StylusToTracker", 0, numen::core::Mat3::Identity(),
                                             numen::core::Vec3(0.01 * k, 0.0, -800.0)));
    poses.push_back(hal::pack_igtl_qtrans("PointerToTracker", 0, numen::core::Quat::Identity(),
                                          numen::core::Vec3(0.0, 0.01 * k, -700.0)));
  }
  numen::test::IgtlTestServer server(poses);
  const hal::DeviceConfig config = igtl_bus_test_config();
  hal::IgtlTrackerSettings s = igtl_bus_test_settings(server.port(), false);
  s.client.more_device_names = {"PointerToTracker"};
  const std::shared_ptr<hal::IgtlTrackerClient> client = hal::make_igtl_tracker_client(s);
  hal::IgtlTrackerBus stylus(config, hal::make_kinematics(config), s, client, 0);
  hal::IgtlTrackerBus pointer(config, hal::make_kinematics(config), s, client, 1);
  for (int i = 0; i < 5000 && (client->counters().tool_poses[0] == 0 ||
                               client->counters().tool_poses[1] == 0); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  ASSERT_GT(client->counters().tool_poses[1], 0u);
  const IgtlBusTestPaced r = igtl_bus_test_paced_periods({&stylus, &pointer}, 2000);
  EXPECT_EQ(r.allocations, 0);
  EXPECT_GT(r.frames, 0u);
  EXPECT_GT(stylus.tracker_counters().poses_taken, 0u);
  EXPECT_GT(pointer.tracker_counters().poses_taken, 0u);
  EXPECT_LT(r.longest_ns, 200'000'000);  // never a follower's 2 s wait (a loaded machine's bound)
}

// The bus's state is the connection's: kOk while connected, kBusOff once it is lost (here the
// server closes after its message and the follower does not reconnect), so that the run's
// frames (kFrameBusDown) and its bus error periods show a lost tracker.
TEST(IgtlTrackerBus, TheStateIsOkWhileConnectedAndBusOffOnceTheConnectionIsLost) {
  namespace hal = numen::hal;
  const hal::DeviceConfig config = igtl_bus_test_config();
  const std::string pose = hal::pack_igtl_transform("StylusToTracker", 1'000'000'000,
                                                    numen::core::Mat3::Identity(),
                                                    numen::core::Vec3(1.0, 2.0, 3.0));
  {
    numen::test::IgtlTestServer server({pose});  // keeps the connection open
    hal::IgtlTrackerBus bus(config, hal::make_kinematics(config), igtl_bus_test_settings(server.port(), true));
    for (int i = 0; i < 5000 && !bus.client().connected(); ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    ASSERT_TRUE(bus.client().connected());
    EXPECT_EQ(bus.state(), hal::BusState::kOk);
  }
  numen::test::IgtlTestServer server({pose}, true);  // closes once it has sent
  hal::IgtlTrackerBus bus(config, hal::make_kinematics(config), igtl_bus_test_settings(server.port(), true));
  for (int i = 0; i < 5000 && !bus.client().ended(); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  ASSERT_TRUE(bus.client().ended());
  EXPECT_EQ(bus.client().counters().connects, 1u);
  EXPECT_EQ(bus.state(), hal::BusState::kBusOff);
}

// registration = "TrackerToScene": the registration is that TRANSFORM, read at start (its
// translation in the tool's units), and the tool's poses are placed with it as with a fixed one.
TEST(IgtlTrackerBus, TheRegistrationIsReadFromItsNamedTransformAtStart) {
  namespace hal = numen::hal;
  const numen::core::Quat rq(Eigen::AngleAxisd(0.785398, numen::core::Vec3::UnitZ()));
  const numen::core::Quat mq(Eigen::AngleAxisd(0.4, numen::core::Vec3(0.2, -1.0, 0.5).normalized()));
  const numen::core::Vec3 mp(-120.0, 250.0, -820.0);  // mm
  numen::test::IgtlTestServer server(
      {hal::pack_igtl_transform("TrackerToScene", 4'000'000'000, rq.toRotationMatrix(),
                                numen::core::Vec3(100.0, -200.0, 900.0)),
       hal::pack_igtl_transform("StylusToTracker", 5'000'000'000, mq.toRotationMatrix(), mp)},
      true);
  const hal::DeviceConfig config = igtl_bus_test_config();
  hal::IgtlTrackerSettings s = igtl_bus_test_settings(server.port(), true);
  const numen::core::Pose fixed = s.registration;  // what the message says, as a fixed transform
  s.registration = numen::core::Pose{};
  s.client.registration_name = "TrackerToScene";
  hal::IgtlTrackerBus bus(config, hal::make_kinematics(config), s);
  EXPECT_LT((bus.settings().registration.position - fixed.position).norm(), 1e-9);
  EXPECT_LT(bus.settings().registration.orientation.angularDistance(fixed.orientation), 1e-6);
  EXPECT_EQ(bus.client().counters().other_devices, 0u);  // the registration is not another tool
  bus.set_time_ns(0);
  ASSERT_EQ(bus.write(hal::make_sync(0)), hal::IoStatus::kOk);
  const numen::core::Pose tip = igtl_bus_test_tip(bus, config);
  const numen::core::Vec3 want_p =
      fixed.position + fixed.orientation * (mp * 1e-3 + mq * s.calibration.position);
  EXPECT_LT((tip.position - want_p).norm(), 3e-6);
}

// A registration never sent: the construction waits at most registration_wait_ns and says so.
TEST(IgtlTrackerBus, ARegistrationNeverSentIsSaidAfterABoundedWait) {
  namespace hal = numen::hal;
  numen::test::IgtlTestServer server({hal::pack_igtl_transform(
      "StylusToTracker", 5'000'000'000, numen::core::Mat3::Identity(), numen::core::Vec3::Zero())});
  const hal::DeviceConfig config = igtl_bus_test_config();
  hal::IgtlTrackerSettings s = igtl_bus_test_settings(server.port(), false);
  s.client.registration_name = "TrackerToScene";
  s.registration_wait_ns = 200'000'000;
  try {
    hal::IgtlTrackerBus bus(config, hal::make_kinematics(config), s);
    ADD_FAILURE() << "made without its registration";
  } catch (const hal::IgtlRegistrationMissing& e) {
    EXPECT_NE(std::string(e.what()).find("no TRANSFORM 'TrackerToScene' (the registration) from 127.0.0.1:" +
                                         std::to_string(server.port()) + " within 0.2 s"),
              std::string::npos)
        << e.what();
  }
  // No server at all: said at once (the follower's receiver ends at the refusal).
  s = igtl_bus_test_settings(numen::test::IgtlTestServer::closed_port(), true);
  s.client.registration_name = "TrackerToScene";
  try {
    hal::IgtlTrackerBus bus(config, hal::make_kinematics(config), s);
    ADD_FAILURE() << "made without its registration";
  } catch (const hal::IgtlRegistrationMissing& e) {
    EXPECT_NE(std::string(e.what()).find(": never connected"), std::string::npos) << e.what();
  }
}
