// Tests of hal/nmt_master: the NMT master of one CAN network shared by several devices' CANopen
// masters. A command every device asks for all its nodes in one period is one broadcast; any
// other is node-addressed to the nodes asked for, so one device's commands never reach another
// device's nodes; the period's commands go out once every device has submitted; one controller
// heartbeat per network; with a minimal device's nodes on the network (a bystander) nothing is
// broadcast; the wirings one network cannot hold are refused; no allocation.
#include "numen/hal/device/nmt_master.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <stdexcept>
#include <vector>

#include "alloc_counter.hpp"
#include "numen/hal/canopen/heartbeat.hpp"
#include "numen/hal/device/device_config.hpp"
#include "numen/hal/transport/sim_bus.hpp"

namespace nmt_master_test {  // named: the unity build shares a TU with other test files

namespace hal = numen::hal;

/// A managed trocar instrument on nodes first_node .. first_node + 4.
hal::DeviceConfig managed_config(std::uint8_t first_node, const char* name) {
  hal::DeviceConfig c = hal::make_default_trocar_config(first_node);
  c.name = name;
  c.canopen.managed = true;
  c.control_period_s = 1e-3;
  return c;
}

/// Every frame the controller wrote, read on the device side at `t_ns`.
std::vector<hal::CanFrame> sent(hal::SimBus& bus, std::int64_t t_ns) {
  bus.set_time_ns(t_ns);
  std::vector<hal::CanFrame> out;
  hal::CanFrame f;
  while (bus.device().read(f) == hal::IoStatus::kOk) out.push_back(f);
  return out;
}

/// The NMT messages among `frames`, as (command, node) pairs.
std::vector<std::pair<int, int>> nmt_of(const std::vector<hal::CanFrame>& frames) {
  std::vector<std::pair<int, int>> out;
  for (const hal::CanFrame& f : frames) {
    hal::NmtMessage m;
    if (hal::decode_nmt(f, m) == hal::NmtDecodeStatus::kOk)
      out.emplace_back(static_cast<int>(m.command), static_cast<int>(m.node_id));
  }
  return out;
}

struct TwoDevices {
  TwoDevices()
      : left(managed_config(1, "left")),
        right(managed_config(11, "right")),
        d0(nmt.add_device(left)),
        d1(nmt.add_device(right)) {}
  hal::DeviceConfig left, right;
  hal::SimBus bus{hal::SimBusSettings{}};
  hal::NmtMaster nmt;
  int d0, d1;
};

constexpr int kReset = 0x82;
constexpr int kStart = 0x01;
constexpr int kStop = 0x02;

TEST(NmtMaster, ACommandEveryDeviceAsksForAllItsNodesIsOneBroadcast) {
  TwoDevices n;
  ASSERT_EQ(n.d0, 0);
  ASSERT_EQ(n.d1, 1);
  EXPECT_TRUE(n.nmt.request(0, hal::NmtCommand::kResetCommunication, hal::kNmtAllNodes));
  EXPECT_EQ(n.nmt.submit(0, 0, n.bus.controller()), hal::IoStatus::kOk);
  // Nothing goes out before the network's last device has submitted.
  EXPECT_TRUE(sent(n.bus, 0).empty());
  EXPECT_TRUE(n.nmt.request(1, hal::NmtCommand::kResetCommunication, hal::kNmtAllNodes));
  EXPECT_EQ(n.nmt.submit(1, 0, n.bus.controller()), hal::IoStatus::kOk);
  EXPECT_EQ(nmt_of(sent(n.bus, 0)), (std::vector<std::pair<int, int>>{{kReset, 0}}));
  EXPECT_EQ(n.nmt.broadcasts(), 1u);
  EXPECT_EQ(n.nmt.counters(0).nmt_sent, 1u);  // the broadcast carried both devices' command
  EXPECT_EQ(n.nmt.counters(1).nmt_sent, 1u);
  // The next period starts empty: nothing requested, nothing sent.
  n.nmt.submit(0, 1'000'000, n.bus.controller());
  n.nmt.submit(1, 1'000'000, n.bus.controller());
  EXPECT_TRUE(nmt_of(sent(n.bus, 1'000'000)).empty());
}

TEST(NmtMaster, OneDevicesCommandsGoToItsOwnNodesOnly) {
  TwoDevices n;
  // Device 1 reruns its start-up (a re-arm) while device 0 only repeats a start to its node 3,
  // then stops node 12 of device 1 twice: node-addressed, in the order first asked, once each.
  n.nmt.request(1, hal::NmtCommand::kResetCommunication, hal::kNmtAllNodes);
  n.nmt.request(0, hal::NmtCommand::kStartRemoteNode, 3);
  n.nmt.request(1, hal::NmtCommand::kStopRemoteNode, 12);
  n.nmt.request(1, hal::NmtCommand::kStopRemoteNode, 12);
  n.nmt.submit(1, 0, n.bus.controller());
  n.nmt.submit(0, 0, n.bus.controller());
  const std::vector<std::pair<int, int>> expected{{kReset, 11}, {kReset, 12}, {kReset, 13},
                                                  {kReset, 14}, {kReset, 15}, {kStart, 3},
                                                  {kStop, 12}};
  EXPECT_EQ(nmt_of(sent(n.bus, 0)), expected);
  EXPECT_EQ(n.nmt.broadcasts(), 0u);
  EXPECT_EQ(n.nmt.counters(0).nmt_sent, 1u);
  EXPECT_EQ(n.nmt.counters(1).nmt_sent, 6u);
  // A whole-device request alone on its network is a broadcast (a lone master's start-up).
  hal::NmtMaster alone;
  const hal::DeviceConfig c = managed_config(1, "alone");
  ASSERT_EQ(alone.add_device(c), 0);
  alone.request(0, hal::NmtCommand::kStartRemoteNode, hal::kNmtAllNodes);
  hal::SimBus bus{hal::SimBusSettings{}};
  alone.submit(0, 0, bus.controller());
  EXPECT_EQ(nmt_of(sent(bus, 0)), (std::vector<std::pair<int, int>>{{kStart, 0}}));
  // Bad requests are refused.
  EXPECT_FALSE(n.nmt.request(2, hal::NmtCommand::kStartRemoteNode, 1));
  EXPECT_FALSE(n.nmt.request(0, hal::NmtCommand::kStartRemoteNode, 128));
  EXPECT_FALSE(n.nmt.request(0, static_cast<hal::NmtCommand>(0x03), 1));
}

TEST(NmtMaster, OneControllerHeartbeatPerNetwork) {
  TwoDevices n;  // both: controller node 127, heartbeat every 10 ms
  int heartbeats = 0;
  for (std::int64_t k = 0; k <= 30; ++k) {
    const std::int64_t t = k * 1'000'000;
    n.nmt.submit(0, t, n.bus.controller());
    n.nmt.submit(1, t, n.bus.controller());
    for (const hal::CanFrame& f : sent(n.bus, t))
      if (f.id == hal::heartbeat_cob_id(127)) ++heartbeats;
  }
  EXPECT_EQ(heartbeats, 3);  // at 10, 20, 30 ms: once for the network, not once per device
  EXPECT_EQ(n.nmt.counters(0).heartbeats_sent, 3u);
  EXPECT_EQ(n.nmt.counters(1).heartbeats_sent, 3u);
}

TEST(NmtMaster, AFailedWriteReachesEveryDeviceItCarried) {
  hal::SimBusSettings s;
  s.capacity = 1;
  TwoDevices n;
  hal::SimBus full(s);
  hal::CanFrame f;
  ASSERT_EQ(full.controller().write(f), hal::IoStatus::kOk);  // the ring is full now
  n.nmt.request(0, hal::NmtCommand::kResetCommunication, hal::kNmtAllNodes);
  n.nmt.request(1, hal::NmtCommand::kResetCommunication, hal::kNmtAllNodes);
  EXPECT_EQ(n.nmt.submit(0, 0, full.controller()), hal::IoStatus::kOk);  // not sent yet
  EXPECT_EQ(n.nmt.submit(1, 0, full.controller()), hal::IoStatus::kWouldBlock);
  EXPECT_EQ(n.nmt.take_status(0), hal::IoStatus::kWouldBlock);  // device 0 learns it too
  EXPECT_EQ(n.nmt.take_status(0), hal::IoStatus::kOk);          // once
  EXPECT_EQ(n.nmt.take_status(1), hal::IoStatus::kWouldBlock);
  EXPECT_EQ(n.nmt.counters(0).write_would_block, 1u);
  EXPECT_EQ(n.nmt.counters(1).nmt_sent, 0u);
}

TEST(NmtMaster, RefusesDevicesOneNetworkCannotHold) {
  hal::NmtMaster nmt;
  ASSERT_EQ(nmt.add_device(managed_config(1, "left")), 0);
  // A node of another device, the controller's node id, another controller, a minimal device.
  EXPECT_THROW(nmt.add_device(managed_config(5, "overlap")), std::invalid_argument);
  hal::DeviceConfig other_controller = managed_config(11, "other");
  other_controller.canopen.controller_node_id = 100;
  EXPECT_THROW(nmt.add_device(other_controller), std::invalid_argument);
  hal::DeviceConfig slower = managed_config(11, "slower");
  slower.canopen.controller_heartbeat_period_ms = 20;
  slower.canopen.drive_heartbeat_timeout_ms = 100;
  EXPECT_THROW(nmt.add_device(slower), std::invalid_argument);
  hal::DeviceConfig minimal = managed_config(11, "minimal");
  minimal.canopen.managed = false;
  EXPECT_THROW(nmt.add_device(minimal), std::invalid_argument);
  try {
    nmt.add_device(managed_config(5, "overlap"));
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(),
                 "device 'overlap': node 5 is device 'left''s on this bus too (a node id once "
                 "per CAN network)");
  }
  // Refused devices left nothing behind: three more fit, then the network is full.
  EXPECT_EQ(nmt.num_devices(), 1);
  EXPECT_EQ(nmt.add_device(managed_config(11, "b")), 1);
  EXPECT_EQ(nmt.add_device(managed_config(21, "c")), 2);
  EXPECT_EQ(nmt.add_device(managed_config(31, "d")), 3);
  EXPECT_THROW(nmt.add_device(managed_config(41, "e")), std::invalid_argument);
}

TEST(NmtMaster, WithAMinimalDeviceOnTheNetworkNothingIsBroadcast) {
  // One managed device asks for the reset communication, then the start, of all its nodes —
  // alone on its network that is one broadcast each (its start-up's frames as a lone master
  // sends them). With a minimal device's self-starting nodes 11-15 on the network, node id 0
  // would reach them too: each command goes to nodes 1-5, addressed, and to nothing else.
  for (const bool bystander : {false, true}) {
    hal::NmtMaster nmt;
    hal::SimBus bus{hal::SimBusSettings{}};
    ASSERT_EQ(nmt.add_device(managed_config(1, "managed")), 0);
    if (bystander) {
      hal::DeviceConfig minimal = managed_config(11, "minimal");
      minimal.canopen.managed = false;
      nmt.add_bystander(minimal);
    }
    EXPECT_EQ(nmt.num_bystanders(), bystander ? 1 : 0);
    EXPECT_TRUE(nmt.request(0, hal::NmtCommand::kResetCommunication, hal::kNmtAllNodes));
    EXPECT_EQ(nmt.submit(0, 0, bus.controller()), hal::IoStatus::kOk);
    EXPECT_TRUE(nmt.request(0, hal::NmtCommand::kStartRemoteNode, hal::kNmtAllNodes));
    EXPECT_EQ(nmt.submit(0, 1'000'000, bus.controller()), hal::IoStatus::kOk);
    const std::vector<std::pair<int, int>> wire = nmt_of(sent(bus, 1'000'000));
    if (!bystander) {
      EXPECT_EQ(wire, (std::vector<std::pair<int, int>>{{kReset, 0}, {kStart, 0}}));
      EXPECT_EQ(nmt.broadcasts(), 2u);
      continue;
    }
    EXPECT_EQ(wire, (std::vector<std::pair<int, int>>{{kReset, 1}, {kReset, 2}, {kReset, 3},
                                                      {kReset, 4}, {kReset, 5}, {kStart, 1},
                                                      {kStart, 2}, {kStart, 3}, {kStart, 4},
                                                      {kStart, 5}}));
    EXPECT_EQ(nmt.broadcasts(), 0u);
    EXPECT_EQ(nmt.counters(0).nmt_sent, 10u);
  }
}

TEST(NmtMaster, RefusesBystandersItCannotHold) {
  // A managed device is not a bystander; bystanders count against the network's devices.
  hal::NmtMaster nmt;
  EXPECT_THROW(nmt.add_bystander(managed_config(1, "managed")), std::invalid_argument);
  hal::DeviceConfig minimal = managed_config(1, "minimal");
  minimal.canopen.managed = false;
  for (int i = 0; i < 3; ++i) nmt.add_bystander(minimal);
  EXPECT_EQ(nmt.add_device(managed_config(11, "last")), 0);
  EXPECT_THROW(nmt.add_bystander(minimal), std::invalid_argument);
  EXPECT_THROW(nmt.add_device(managed_config(21, "fifth")), std::invalid_argument);
  try {
    nmt.add_bystander(managed_config(21, "m"));
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "device 'm': a managed device is add_device()'s, not a bystander");
  }
}

TEST(NmtMaster, RequestsAndSubmitsNeverAllocate) {
  TwoDevices n;
  numen::test::AllocationGuard guard;
  for (std::int64_t k = 0; k < 50; ++k) {
    const std::int64_t t = k * 1'000'000;
    n.nmt.request(0, hal::NmtCommand::kStartRemoteNode, hal::kNmtAllNodes);
    n.nmt.request(1, hal::NmtCommand::kResetCommunication, static_cast<std::uint8_t>(11 + k % 5));
    n.nmt.submit(0, t, n.bus.controller());
    n.nmt.submit(1, t, n.bus.controller());
    (void)n.nmt.take_status(0);
    hal::CanFrame f;
    n.bus.set_time_ns(t);
    while (n.bus.device().read(f) == hal::IoStatus::kOk) {
    }
  }
  EXPECT_EQ(guard.count(), 0);
  // Device 1 never asked its nodes' start: device 0's goes to each of its 5 nodes.
  EXPECT_EQ(n.nmt.counters(0).nmt_sent, 250u);
  EXPECT_EQ(n.nmt.counters(1).nmt_sent, 50u);
  EXPECT_EQ(n.nmt.broadcasts(), 0u);
}

}  // namespace nmt_master_test
