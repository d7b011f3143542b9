/// @file igtl_tracker_client_test.cpp
/// The OpenIGTLink receiver (hal/igtl/igtl_tracker_client.hpp) against a loopback server
/// (support/igtl_test_server.hpp, an ephemeral port): bad input counted and located, a server
/// that never answers, one that goes away, a flood into a small queue (memory does not grow:
/// the newest poses are dropped and counted); POSITION and QTRANS poses among TRANSFORMs.

#include "numen/hal/igtl/igtl_tracker_client.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <cstring>
#include <limits>
#include <thread>

#include "igtl_test_server.hpp"
#include "numen/hal/igtl/igtl_pack.hpp"

namespace {

// Polls `done` every ms for at most 5 s (the tests never hang).
template <typename F>
bool igtl_client_test_wait(F done) {
  for (int i = 0; i < 5000; ++i) {
    if (done()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return done();
}

numen::hal::IgtlTrackerClientSettings igtl_client_test_settings(std::uint16_t port) {
  numen::hal::IgtlTrackerClientSettings s;
  s.host = "127.0.0.1";
  s.port = port;
  s.device_name = "StylusToTracker";
  s.reconnect = false;
  return s;
}

std::string igtl_client_test_transform(const char* name, double x, std::int64_t stamp_ns = 0) {
  return numen::hal::pack_igtl_transform(name, stamp_ns, numen::core::Mat3::Identity(),
                                         numen::core::Vec3(x, 0.0, 0.0));
}

}  // namespace

TEST(IgtlTrackerClient, BadInputIsCountedAndLocatedAndGoodPosesPass) {
  namespace hal = numen::hal;
  std::string crc = igtl_client_test_transform("StylusToTracker", 2.0);
  crc[hal::kIgtlHeaderBytes + 40] ^= 0x10;
  std::string unknown = igtl_client_test_transform("StylusToTracker", 3.0);
  std::memcpy(unknown.data() + hal::kIgtlTypeOffset, "WHATEVER\0\0\0\0", 12);
  numen::core::Mat3 nan_r = numen::core::Mat3::Identity();
  nan_r(0, 0) = std::numeric_limits<double>::quiet_NaN();
  const std::string nan = hal::pack_igtl_transform("StylusToTracker", 0, nan_r, numen::core::Vec3::Zero());
  const std::string skew = hal::pack_igtl_transform("StylusToTracker", 0, 2.0 * numen::core::Mat3::Identity(),
                                                    numen::core::Vec3::Zero());
  const std::string garbage(hal::kIgtlHeaderBytes, '\xff');  // version 0xFFFF: framing lost
  numen::test::IgtlTestServer server({igtl_client_test_transform("StylusToTracker", 1.0), crc,
                                      unknown, nan, skew,
                                      igtl_client_test_transform("PointerToTracker", 5.0),
                                      igtl_client_test_transform("StylusToTracker", 6.0), garbage},
                                     true);
  hal::IgtlTrackerClient client(igtl_client_test_settings(server.port()));
  ASSERT_TRUE(igtl_client_test_wait([&] { return client.ended(); }));
  const hal::IgtlClientCounters c = client.counters();
  EXPECT_EQ(c.messages, 8u);
  EXPECT_EQ(c.poses, 2u);
  EXPECT_EQ(c.other_devices, 1u);
  EXPECT_EQ(c.faults[static_cast<std::size_t>(hal::IgtlFault::kCrcMismatch)], 1u);
  EXPECT_EQ(c.faults[static_cast<std::size_t>(hal::IgtlFault::kUnknownType)], 1u);
  EXPECT_EQ(c.faults[static_cast<std::size_t>(hal::IgtlFault::kNonFinite)], 1u);
  EXPECT_EQ(c.faults[static_cast<std::size_t>(hal::IgtlFault::kNotRigid)], 1u);
  EXPECT_EQ(c.faults[static_cast<std::size_t>(hal::IgtlFault::kBadHeader)], 1u);
  EXPECT_EQ(c.faults_total(), 5u);
  EXPECT_EQ(c.disconnects, 1u);  // the garbage header: the connection is dropped
  // The two good poses, in order.
  const hal::IgtlPose* p = client.front();
  ASSERT_NE(p, nullptr);
  EXPECT_DOUBLE_EQ(p->translation.x(), 1.0);
  client.pop();
  p = client.front();
  ASSERT_NE(p, nullptr);
  EXPECT_DOUBLE_EQ(p->translation.x(), 6.0);
  client.pop();
  EXPECT_EQ(client.front(), nullptr);
  // Each fault located: type, device, message index, stream offset, field offset.
  const std::vector<hal::IgtlFaultRecord> records = client.fault_records();
  ASSERT_EQ(records.size(), 5u);
  const std::size_t message_bytes = hal::kIgtlHeaderBytes + hal::kIgtlTransformBodyBytes;
  EXPECT_EQ(records[0].fault, hal::IgtlFault::kCrcMismatch);
  EXPECT_EQ(records[0].type, "TRANSFORM");
  EXPECT_EQ(records[0].device_name, "StylusToTracker");
  EXPECT_EQ(records[0].message, 1u);
  EXPECT_EQ(records[0].stream_offset, message_bytes);
  EXPECT_EQ(records[0].byte_offset, hal::kIgtlCrcOffset);
  EXPECT_EQ(hal::describe(records[0]),
            "CRC mismatch: TRANSFORM 'StylusToTracker', message 1 at stream byte 106, field at byte 50");
  EXPECT_EQ(records[1].fault, hal::IgtlFault::kUnknownType);
  EXPECT_EQ(records[1].type, "WHATEVER");
  EXPECT_EQ(records[4].fault, hal::IgtlFault::kBadHeader);
  EXPECT_EQ(records[4].message, 7u);
  EXPECT_EQ(records[4].stream_offset, 7 * message_bytes);
  EXPECT_EQ(client.names_seen(), std::vector<std::string>{"PointerToTracker"});
}

TEST(IgtlTrackerClient, PositionAndQtransPosesPassAndTheirFaultsAreLocated) {
  namespace hal = numen::hal;
  const numen::core::Quat q(Eigen::AngleAxisd(0.3, numen::core::Vec3::UnitY()));
  const numen::core::Vec3 t(0.0, 0.0, -800.0);
  const auto at_x = [&](double x) { return numen::core::Vec3(x, t.y(), t.z()); };
  const std::string not_unit =
      hal::pack_igtl_position("StylusToTracker", 0, numen::core::Quat(0.9, 0.5, 0.0, 0.0), t);
  std::string position_only = hal::pack_igtl_position("StylusToTracker", 0, q, t);
  position_only.resize(hal::kIgtlHeaderBytes + 12);  // X Y Z: no orientation
  for (int i = 0; i < 8; ++i)
    position_only[hal::kIgtlBodySizeOffset + static_cast<std::size_t>(i)] = i == 7 ? 12 : 0;
  std::string version2 = hal::pack_igtl_position("StylusToTracker", 0, q, at_x(7.0));
  version2[1] = 2;  // OpenIGTLink 3's header version: its body is not read, its framing holds
  const std::vector<std::string> sent = {
      hal::pack_igtl_position("StylusToTracker", 0, q, at_x(1.0)),
      hal::pack_igtl_qtrans("StylusToTracker", 0, q, at_x(2.0)),
      hal::pack_igtl_position("StylusToTracker", 0, q, at_x(3.0), true),
      not_unit,
      position_only,
      hal::pack_igtl_qtrans("PointerToTracker", 0, q, at_x(5.0)),
      igtl_client_test_transform("StylusToTracker", 6.0),
      version2};
  numen::test::IgtlTestServer server(sent, true);
  hal::IgtlTrackerClient client(igtl_client_test_settings(server.port()));
  ASSERT_TRUE(igtl_client_test_wait([&] { return client.ended(); }));
  const hal::IgtlClientCounters c = client.counters();
  EXPECT_EQ(c.messages, 8u);
  EXPECT_EQ(c.poses, 4u);
  EXPECT_EQ(c.other_devices, 1u);
  EXPECT_EQ(c.faults[static_cast<std::size_t>(hal::IgtlFault::kNotUnitQuaternion)], 1u);
  EXPECT_EQ(c.faults[static_cast<std::size_t>(hal::IgtlFault::kBodySizeMismatch)], 1u);
  EXPECT_EQ(c.faults[static_cast<std::size_t>(hal::IgtlFault::kUnsupportedVersion)], 1u);
  EXPECT_EQ(c.faults_total(), 3u);
  EXPECT_EQ(c.disconnects, 1u);  // the server closed: the framing held across the sizes
  for (double x : {1.0, 2.0, 3.0, 6.0}) {
    const hal::IgtlPose* p = client.front();
    ASSERT_NE(p, nullptr) << x;
    EXPECT_NEAR(p->translation.x(), x, 1e-6);
    const numen::core::Mat3 want = x == 6.0 ? numen::core::Mat3::Identity() : q.toRotationMatrix();
    EXPECT_LT((p->rotation - want).cwiseAbs().maxCoeff(), 1e-6) << x;
    client.pop();
  }
  EXPECT_EQ(client.front(), nullptr);
  const std::vector<hal::IgtlFaultRecord> records = client.fault_records();
  ASSERT_EQ(records.size(), 3u);
  std::uint64_t at = 0;
  for (std::size_t k = 0; k < 3; ++k) at += sent[k].size();
  EXPECT_EQ(hal::describe(records[0]),
            "non-unit quaternion: POSITION 'StylusToTracker', message 3 at stream byte " +
                std::to_string(at) + ", field at byte 70");
  EXPECT_EQ(records[1].fault, hal::IgtlFault::kBodySizeMismatch);
  EXPECT_EQ(records[1].type, "POSITION");
  EXPECT_EQ(records[1].message, 4u);
  EXPECT_EQ(records[1].stream_offset, at + not_unit.size());
  EXPECT_EQ(records[1].byte_offset, hal::kIgtlBodySizeOffset);
  EXPECT_EQ(records[2].fault, hal::IgtlFault::kUnsupportedVersion);
  EXPECT_EQ(records[2].message, 7u);
  EXPECT_EQ(records[2].byte_offset, hal::kIgtlVersionOffset);
  EXPECT_EQ(client.names_seen(), std::vector<std::string>{"PointerToTracker"});
}

TEST(IgtlTrackerClient, AServerThatNeverAnswersIsCounted) {
  namespace hal = numen::hal;
  hal::IgtlTrackerClientSettings s = igtl_client_test_settings(numen::test::IgtlTestServer::closed_port());
  s.reconnect = true;
  s.reconnect_interval_ns = 5'000'000;
  hal::IgtlTrackerClient client(s);
  ASSERT_TRUE(igtl_client_test_wait([&] { return client.counters().connect_failures >= 3; }));
  EXPECT_FALSE(client.connected());
  EXPECT_EQ(client.counters().connects, 0u);
  EXPECT_EQ(client.front(), nullptr);
  client.stop();  // heard within the poll slice
  EXPECT_TRUE(client.ended());
}

TEST(IgtlTrackerClient, AServerThatGoesAwayIsCountedAndConnectedAgain) {
  namespace hal = numen::hal;
  numen::test::IgtlTestServer server({igtl_client_test_transform("StylusToTracker", 1.0)}, true);
  hal::IgtlTrackerClientSettings s = igtl_client_test_settings(server.port());
  s.reconnect = true;
  s.reconnect_interval_ns = 5'000'000;
  hal::IgtlTrackerClient client(s);
  ASSERT_TRUE(igtl_client_test_wait([&] { return client.counters().disconnects >= 1; }));
  EXPECT_EQ(client.counters().poses, 1u);
  // The server still listens (its backlog takes the connection): the client is back.
  ASSERT_TRUE(igtl_client_test_wait([&] { return client.counters().connects >= 2; }));
  client.stop();
  EXPECT_TRUE(client.ended());
}

TEST(IgtlTrackerClient, AFloodFillsTheQueueAndTheNewestAreDropped) {
  namespace hal = numen::hal;
  std::vector<std::string> flood;
  for (int i = 0; i < 2000; ++i)
    flood.push_back(igtl_client_test_transform("StylusToTracker", static_cast<double>(i)));
  numen::test::IgtlTestServer server(flood);
  hal::IgtlTrackerClientSettings s = igtl_client_test_settings(server.port());
  s.queue_poses = 16;
  hal::IgtlTrackerClient client(s);
  // A message is counted when its header is read, its pose after its body is decoded, and a
  // drop last: wait for all three, else the check can run between them (a race CI's ASan build
  // once lost). A client that loses or double-counts poses times out here.
  ASSERT_TRUE(igtl_client_test_wait([&] {
    const hal::IgtlClientCounters c = client.counters();
    return c.messages == 2000 && c.poses == 2000 && c.dropped_full == 2000u - 16u;
  }));
  EXPECT_EQ(client.counters().messages, 2000u);
  EXPECT_EQ(client.counters().poses, 2000u);
  EXPECT_EQ(client.counters().dropped_full, 2000u - 16u);
  // The queue holds the oldest 16, in order.
  for (int i = 0; i < 16; ++i) {
    const hal::IgtlPose* p = client.front();
    ASSERT_NE(p, nullptr);
    EXPECT_DOUBLE_EQ(p->translation.x(), static_cast<double>(i));
    client.pop();
  }
  EXPECT_EQ(client.front(), nullptr);
}

TEST(IgtlTrackerClient, SettingsAreChecked) {
  namespace hal = numen::hal;
  hal::IgtlTrackerClientSettings s;
  s.device_name = "";
  EXPECT_THROW(hal::IgtlTrackerClient{s}, std::invalid_argument);
  s.device_name = "ABCDEFGHIJKLMNOPQRSTU";  // 21 characters
  EXPECT_THROW(hal::IgtlTrackerClient{s}, std::invalid_argument);
  s.device_name = "Stylus";
  s.port = 0;
  EXPECT_THROW(hal::IgtlTrackerClient{s}, std::invalid_argument);
  s.port = numen::test::IgtlTestServer::closed_port();
  s.reconnect = false;
  s.more_device_names = {"Pointer", "Stylus"};  // two tools of one name
  EXPECT_THROW(hal::IgtlTrackerClient{s}, std::invalid_argument);
  s.more_device_names = {"A", "B", "C", "D"};  // five tools
  EXPECT_THROW(hal::IgtlTrackerClient{s}, std::invalid_argument);
  s.more_device_names = {"Pointer", ""};
  EXPECT_THROW(hal::IgtlTrackerClient{s}, std::invalid_argument);
  s.more_device_names = {"Pointer"};
  s.registration_name = "Pointer";  // a tool's name
  EXPECT_THROW(hal::IgtlTrackerClient{s}, std::invalid_argument);
  s.registration_name = "TrackerToScene";
  hal::IgtlTrackerClient two(s);
  EXPECT_EQ(two.tool_count(), 2u);
  EXPECT_EQ(two.front(1), nullptr);
  EXPECT_EQ(two.front(2), nullptr);  // no such tool: none, not a crash
}
