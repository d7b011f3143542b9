// Tests of hal/canopen_master: the NMT start-up against the managed DeviceEmulator over SimBus
// (phases and exact periods, retries of lost commands, the start-up deadline), the routing of
// drive TPDOs, heartbeats and EMCYs, and the drive RPDOs (controlword + gated target torque).
#include "numen/hal/device/canopen_master.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <memory>
#include <string>

#include "alloc_counter.hpp"
#include "numen/hal/canopen/canopen.hpp"
#include "numen/hal/emulation/device_emulator.hpp"
#include "numen/hal/transport/sim_bus.hpp"
#include "test_constants.hpp"

namespace {

using numen::hal::CanFrame;
using numen::hal::CanopenMaster;
using numen::hal::Cia402Target;
using numen::hal::DeviceConfig;
using numen::hal::DeviceEmulator;
using numen::hal::IoStatus;
using numen::hal::NmtState;
using numen::hal::PowerState;
using numen::hal::SimBus;
using numen::hal::StartupPhase;

using numen::test::kMs;
constexpr std::int64_t kLatency = 100'000;
constexpr std::int64_t kPhase = 250'000;

DeviceConfig master_config() {
  DeviceConfig c = numen::hal::make_default_trocar_config(1);
  c.control_period_s = 1e-3;
  return c;
}

numen::hal::SimBusSettings bus_settings() {
  numen::hal::SimBusSettings s;
  s.latency_ns = kLatency;
  return s;
}

struct MasterRig {
  explicit MasterRig(const DeviceConfig& c = master_config())
      : cfg(c), emulator(c), master(c, kMs) {}
  DeviceConfig cfg;
  SimBus bus{bus_settings()};
  DeviceEmulator emulator;
  CanopenMaster master;
  std::array<std::int16_t, 8> torque{};
  std::int64_t k = 0;

  void period() {
    const std::int64_t t = k * kMs;
    ++k;
    bus.set_time_ns(t);
    bus.controller().write(numen::hal::make_sync(t));  // the loop's SYNC
    master.begin_period(t, bus.controller());
    bus.set_time_ns(t + kLatency);
    emulator.poll(bus.device());
    emulator.tick(t + kLatency, bus.device());
    bus.set_time_ns(t + kPhase);
    CanFrame f;
    while (bus.controller().read(f) == IoStatus::kOk) master.on_frame(f);
    master.update(t + kPhase);
    master.write_drive_rpdos(t + kPhase, torque, bus.controller());
  }
};

TEST(CanopenMaster, StartUpPhasesInExactPeriods) {
  MasterRig rig;
  EXPECT_EQ(rig.master.startup().phase, StartupPhase::kResetCommunication);
  rig.period();  // 0: reset communication sent, boot-ups read
  EXPECT_EQ(rig.master.startup().phase, StartupPhase::kStartNodes);
  EXPECT_EQ(rig.master.node_ids().size(), 5u);
  for (int a = 0; a < 5; ++a) EXPECT_EQ(rig.emulator.node_state(a), NmtState::kPreOperational);
  rig.period();  // 1: start remote node
  EXPECT_EQ(rig.master.startup().phase, StartupPhase::kWaitOperational);
  for (int a = 0; a < 5; ++a) EXPECT_EQ(rig.emulator.node_state(a), NmtState::kOperational);
  while (rig.k < 10) {
    rig.period();
    ASSERT_FALSE(rig.master.operational()) << rig.k;
  }
  rig.period();  // 10: the first heartbeats report operational
  EXPECT_TRUE(rig.master.operational());
  EXPECT_TRUE(rig.master.all_nodes_operational());
  EXPECT_EQ(rig.master.startup().done_period, 10u);
  EXPECT_EQ(rig.master.startup().began_ns, 0);
  EXPECT_EQ(rig.master.counters().nmt_sent, 2u);
  EXPECT_EQ(rig.master.counters().nmt_retries, 0u);
  // Drive TPDOs are read: switch on disabled; the master keeps the drives disabled.
  ASSERT_EQ(rig.master.num_drives(), 3u);
  EXPECT_EQ(rig.master.drive_outputs()[0].state, PowerState::kSwitchOnDisabled);
  EXPECT_EQ(rig.master.drive_statusword(0), 0x0250);
  // Enabled, the drives come up in 4 periods and take the target torque.
  rig.master.request_drives(Cia402Target::kEnabled);
  rig.torque[0] = 123;
  rig.torque[3] = 77;  // roll: no drive, never sent
  for (int i = 0; i < 5; ++i) rig.period();
  EXPECT_TRUE(rig.master.drive_outputs()[0].torque_allowed);
  EXPECT_EQ(rig.emulator.drive(0)->state(), PowerState::kOperationEnabled);
  EXPECT_EQ(rig.emulator.drive(0)->applied_torque_per_mille(), 123);
  EXPECT_EQ(rig.master.drive_torque_actual(0), 123);
  EXPECT_EQ(rig.emulator.drive(1)->applied_torque_per_mille(), 0);
  EXPECT_EQ(rig.emulator.counters().frames_malformed, 0u);
}

TEST(CanopenMaster, ALostStartCommandIsRepeatedToTheNodes) {
  MasterRig rig;
  rig.period();
  rig.emulator.kill(true);  // period 1: the start command is lost
  rig.period();
  rig.emulator.kill(false);
  while (rig.k < 80 && !rig.master.operational()) rig.period();
  // Retried 50 ms after the first start (period 51, to each node), heard operational at the
  // next heartbeat (60 ms).
  EXPECT_TRUE(rig.master.operational());
  EXPECT_EQ(rig.master.counters().nmt_retries, 5u);
  EXPECT_EQ(rig.master.startup().done_period, 60u);
}

TEST(CanopenMaster, ABootUpWhileStartingRestartsTheNodeWithoutAFault) {
  // The start command is lost, so the nodes heartbeat in pre-operational (alive) while the
  // master waits; then node 1 boots again (a late answer to a reset, or a node reset during
  // the start-up). The master starts it again at once and its consumer does not report a
  // reset fault; after the start-up, a boot-up is a fault.
  MasterRig rig;
  rig.period();
  rig.emulator.kill(true);  // period 1: the start command is lost
  rig.period();
  rig.emulator.kill(false);
  while (rig.k < 30) rig.period();
  ASSERT_EQ(rig.master.startup().phase, StartupPhase::kWaitOperational);
  ASSERT_EQ(rig.master.monitor().find(1)->status(), numen::hal::HeartbeatStatus::kAlive);
  CanFrame boot;
  ASSERT_TRUE(numen::hal::encode_heartbeat(1, NmtState::kBootUp, rig.k * kMs, boot));
  rig.bus.set_time_ns(rig.k * kMs);
  ASSERT_EQ(rig.bus.device().write(boot), IoStatus::kOk);
  const std::uint64_t retries = rig.master.counters().nmt_retries;
  rig.period();  // 30: the boot-up is read
  EXPECT_EQ(rig.master.monitor().find(1)->counters().unexpected_boot_ups, 0u);
  EXPECT_FALSE(rig.master.monitor().any_fault());
  rig.period();  // 31: node 1 is started again, before the 50 ms retry of the others
  EXPECT_EQ(rig.master.counters().nmt_retries, retries + 1);
  EXPECT_EQ(rig.emulator.node_state(0), NmtState::kOperational);
  while (rig.k < 80 && !rig.master.operational()) rig.period();
  ASSERT_TRUE(rig.master.operational());
  rig.bus.set_time_ns(rig.k * kMs);
  ASSERT_TRUE(numen::hal::encode_heartbeat(1, NmtState::kBootUp, rig.k * kMs, boot));
  ASSERT_EQ(rig.bus.device().write(boot), IoStatus::kOk);
  rig.period();
  EXPECT_EQ(rig.master.monitor().find(1)->counters().unexpected_boot_ups, 1u);
  EXPECT_TRUE(rig.master.monitor().any_fault());
}

TEST(CanopenMaster, StartUpFailsAtItsDeadlineNamingTheMissingNode) {
  DeviceConfig c = master_config();
  c.canopen.startup_timeout_ms = 20;
  MasterRig rig(c);
  rig.emulator.kill(true);
  for (int i = 0; i < 25; ++i) rig.period();
  EXPECT_EQ(rig.master.startup().phase, StartupPhase::kFailed);
  EXPECT_EQ(rig.master.startup().missing_node, 1);
  EXPECT_EQ(rig.master.startup().done_period, 20u);
  // Restarted with the device back: operational again.
  rig.emulator.power_cycle();
  rig.master.restart_startup();
  for (int i = 0; i < 20; ++i) rig.period();
  EXPECT_TRUE(rig.master.operational());
  EXPECT_EQ(rig.master.startup().attempts, 2u);
}

TEST(CanopenMaster, RoutesFramesAndCountsMalformedOnes) {
  MasterRig rig;
  CanFrame f;
  // A heartbeat before the node's post-reset boot-up is not given to the monitor.
  numen::hal::encode_heartbeat(1, NmtState::kOperational, 0, f);
  EXPECT_TRUE(rig.master.on_frame(f));
  EXPECT_EQ(rig.master.counters().frames_before_boot, 1u);
  EXPECT_FALSE(rig.master.monitor().find(1)->heard());
  // Another device's node.
  numen::hal::encode_heartbeat(40, NmtState::kOperational, 0, f);
  EXPECT_TRUE(rig.master.on_frame(f));
  EXPECT_EQ(rig.master.counters().unknown_nodes, 1u);
  // A drive TPDO of the wrong length.
  f = CanFrame{};
  f.id = 0x281;
  f.len = 3;
  EXPECT_TRUE(rig.master.on_frame(f));
  EXPECT_EQ(rig.master.counters().drive_tpdos_malformed, 1u);
  // EMCY goes to the log; an encoder TPDO is not the master's.
  numen::hal::EmcyMessage m;
  m.node_id = 2;
  m.error_code = 0x3210;
  numen::hal::encode_emcy(m, 5, f);
  EXPECT_TRUE(rig.master.on_frame(f));
  EXPECT_EQ(rig.master.emcy_log().newest()->message.error_code, 0x3210);
  EXPECT_FALSE(rig.master.on_frame(numen::hal::encode_position_pdo(0x181, 5, 0)));
  EXPECT_TRUE(rig.master.request_nmt(numen::hal::NmtCommand::kStopRemoteNode, 2));
  EXPECT_FALSE(rig.master.request_nmt(numen::hal::NmtCommand::kStartRemoteNode, 2));  // one queued
}

// Issue 17 #7: error reports and 29-bit frames whose numbers are a drive TPDO, heartbeat or
// EMCY COB-ID are not the master's; a CAN FD frame on the drive TPDO's id is malformed.
TEST(CanopenMaster, ErrorAndExtendedFramesAreNotCanopenTraffic) {
  MasterRig rig;
  for (std::uint32_t id : {0x281u, 0x701u, 0x082u}) {
    for (std::uint8_t flag : {numen::hal::CanFlag::kErrorFrame, numen::hal::CanFlag::kExtendedId}) {
      CanFrame f;
      f.id = id;
      f.flags = flag;
      f.len = 8;
      EXPECT_FALSE(rig.master.on_frame(f)) << std::hex << id << " flags " << int(flag);
    }
  }
  const auto& c = rig.master.counters();
  EXPECT_EQ(c.drive_tpdos_malformed, 0u);
  EXPECT_EQ(c.frames_before_boot, 0u);
  EXPECT_EQ(c.unknown_nodes, 0u);
  EXPECT_EQ(rig.master.emcy_log().counters().not_data, 0u);
  CanFrame fd;
  fd.id = 0x281;
  fd.flags = numen::hal::CanFlag::kFd;
  fd.len = 4;  // the drive TPDO's length (statusword + torque actual)
  EXPECT_TRUE(rig.master.on_frame(fd));
  EXPECT_EQ(rig.master.counters().drive_tpdos_malformed, 1u);
  EXPECT_EQ(rig.master.counters().drive_tpdos, 0u);
}

TEST(CanopenMaster, PeriodsDoNotAllocate) {
  MasterRig rig;
  numen::test::AllocationGuard guard;
  for (int i = 0; i < 50; ++i) rig.period();
  rig.master.request_drives(Cia402Target::kEnabled);
  for (int i = 0; i < 50; ++i) rig.period();
  rig.emulator.inject_drive_fault(0, 0x2310);
  for (int i = 0; i < 10; ++i) rig.period();
  EXPECT_EQ(guard.count(), 0);
  EXPECT_EQ(rig.master.drive_outputs()[0].fault, true);
  EXPECT_EQ(rig.master.emcy_log().counters().faults, 1u);
}

TEST(CanopenMaster, ConstructionErrors) {
  DeviceConfig c = master_config();
  c.canopen.managed = false;
  EXPECT_THROW(CanopenMaster(c, kMs), std::invalid_argument);
  EXPECT_THROW(CanopenMaster(master_config(), 0), std::invalid_argument);
}

// --- Configuration from DCFs (docs/sdo.md) ---------------------------------------

std::shared_ptr<const numen::hal::Dcf> shipped_dcf(const char* name, std::uint8_t node) {
  return std::make_shared<const numen::hal::Dcf>(numen::hal::parse_dcf_file(
      std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/devices/" + name, node));
}

/// The trainer with the shipped DCFs: drives on nodes 1–3, encoders on 4–5.
DeviceConfig config_with_dcfs() {
  DeviceConfig c = master_config();
  for (std::size_t i = 0; i < c.axes.size(); ++i) {
    numen::hal::CanopenAxisConfig& x = c.canopen.axes[i];
    x.dcf = shipped_dcf(c.axes[i].has_drive() ? "trocar_drive.dcf" : "encoder.dcf", x.node_id);
  }
  numen::hal::check_dcfs(c);
  return c;
}

TEST(CanopenMaster, StartUpConfiguresEveryNodeFromItsDcfBeforeStartingIt) {
  MasterRig rig(config_with_dcfs());
  rig.period();  // 0: reset communication, boot-ups: every node booted → configure
  EXPECT_EQ(rig.master.startup().phase, StartupPhase::kConfigure);
  std::size_t longest = 0;
  std::uint64_t transfers = 0;
  for (const std::uint8_t id : rig.master.node_ids()) {
    const numen::hal::NodeConfigurator* c = rig.master.configurator(id);
    ASSERT_NE(c, nullptr);
    longest = std::max(longest, c->plan().steps().size());
    transfers += c->plan().steps().size();
  }
  // One transfer per node and period, all nodes in parallel; no node is started meanwhile.
  while (rig.master.startup().phase == StartupPhase::kConfigure && rig.k < 500) {
    for (int a = 0; a < 5; ++a) ASSERT_EQ(rig.emulator.node_state(a), NmtState::kPreOperational);
    rig.period();
  }
  EXPECT_EQ(rig.master.startup().phase, StartupPhase::kStartNodes);
  EXPECT_EQ(static_cast<std::size_t>(rig.k), 1 + longest);
  EXPECT_EQ(rig.master.counters().configurations, 5u);
  EXPECT_EQ(rig.master.counters().sdo_requests, transfers);  // every transfer expedited
  EXPECT_EQ(rig.master.counters().sdo_responses, transfers);
  EXPECT_EQ(rig.master.startup().configure_ns, static_cast<std::int64_t>(longest) * kMs);
  while (!rig.master.operational() && rig.k < 500) rig.period();
  ASSERT_TRUE(rig.master.operational());
  EXPECT_EQ(rig.master.configuration_error(), "");
  // The configured drives run as before: enabled, they apply the torque.
  rig.master.request_drives(Cia402Target::kEnabled);
  rig.torque[1] = -321;
  for (int i = 0; i < 5; ++i) rig.period();
  EXPECT_EQ(rig.emulator.drive(1)->applied_torque_per_mille(), -321);
  EXPECT_EQ(rig.master.drive_torque_actual(1), -321);
  EXPECT_EQ(rig.emulator.counters().frames_malformed, 0u);
}

TEST(CanopenMaster, ADcfTheNodeDisagreesWithStopsTheStartUpWithALocatedError) {
  DeviceConfig c = config_with_dcfs();
  c.canopen.axes[0].dcf = shipped_dcf("encoder.dcf", 1);  // node 1 is a drive, not an encoder
  MasterRig rig(c);
  while (rig.master.startup().phase != StartupPhase::kFailed && rig.k < 500) rig.period();
  ASSERT_EQ(rig.master.startup().phase, StartupPhase::kFailed);
  EXPECT_TRUE(rig.master.startup().configuration_failed);
  EXPECT_EQ(rig.master.startup().missing_node, 1);
  const std::string e = rig.master.configuration_error();
  EXPECT_NE(e.find("/sim/scenes/devices/encoder.dcf:"), std::string::npos) << e;
  EXPECT_NE(e.find(": [1000] ParameterValue: node 1 0x1000:00 read back 0x00020192, the DCF "
                   "configures 0x00020196"),
            std::string::npos)
      << e;
  // Refused to start: no node is ever started.
  for (int i = 0; i < 100; ++i) rig.period();
  for (int a = 0; a < 5; ++a) EXPECT_EQ(rig.emulator.node_state(a), NmtState::kPreOperational);
  EXPECT_EQ(rig.master.counters().nmt_sent, 1u);  // the reset communication only
}

TEST(CanopenMaster, ANodeThatResetsWhileBeingConfiguredIsConfiguredAgain) {
  MasterRig rig(config_with_dcfs());
  for (int i = 0; i < 20; ++i) rig.period();
  ASSERT_EQ(rig.master.startup().phase, StartupPhase::kConfigure);
  rig.emulator.power_cycle();  // every node boots again: its configuration is gone
  while (!rig.master.operational() && rig.k < 500) rig.period();
  ASSERT_TRUE(rig.master.operational());
  EXPECT_GE(rig.master.counters().configurations, 5u);
  EXPECT_EQ(rig.master.monitor().consumers()[0].counters().faults(), 0u);
}

TEST(CanopenMaster, InLoopSdoReadsOnceOperationalWithoutAllocating) {
  DeviceConfig c = master_config();
  c.canopen.sdo_poll_period_ms = 20;
  MasterRig rig(c);
  ASSERT_NE(rig.master.sdo_poller(), nullptr);
  EXPECT_EQ(rig.master.sdo_poller()->reads().size(), 5u + 3u);  // 0x1001 per node, 0x6041 per drive
  numen::test::AllocationGuard guard;
  while (!rig.master.operational()) {
    ASSERT_EQ(rig.master.sdo_poller()->counters().started, 0u);  // nothing before operational
    rig.period();
  }
  rig.master.request_drives(Cia402Target::kEnabled);
  for (int i = 0; i < 200; ++i) rig.period();
  EXPECT_EQ(guard.count(), 0);
  const numen::hal::SdoPoller& p = *rig.master.sdo_poller();
  for (const numen::hal::PeriodicReadResult& r : p.results()) {
    EXPECT_EQ(r.reads, 10u);  // every 20 periods over 200
    EXPECT_EQ(r.aborts, 0u);
  }
  EXPECT_EQ(p.results()[5].value, rig.master.drive_statusword(0));  // operation enabled, by SDO too
  EXPECT_EQ(p.results()[0].value, 0u);                               // error register clear
  EXPECT_EQ(rig.emulator.counters().frames_malformed, 0u);
}

TEST(CanopenMaster, ConfigurationPeriodsDoNotAllocate) {
  MasterRig rig(config_with_dcfs());
  numen::test::AllocationGuard guard;
  while (!rig.master.operational() && rig.k < 500) rig.period();
  EXPECT_EQ(guard.count(), 0);
  EXPECT_TRUE(rig.master.operational());
}

}  // namespace
