// Tests of sim/sdo_session: SDO transfers run to their end, the bus scan (boot-ups and
// heartbeats heard, identities read by SDO) against the emulated CANopen nodes of the default
// trocar instrument on a SimBus, the scan's table and JSON, and INDEX:SUB parsing.
#include "numen/sim/device/sdo_session.hpp"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <array>
#include <stdexcept>
#include <string>

#include "numen/hal/device/device_config.hpp"
#include "numen/hal/emulation/device_emulator.hpp"
#include "numen/hal/transport/sim_bus.hpp"

namespace {

namespace hal = numen::hal;
namespace sim = numen::sim;

/// The emulated device on the far end of a SimBus; "waiting" advances simulated time by the
/// wait (at most 1 ms per call) and lets the device read, answer and tick.
struct Bench {
  hal::DeviceConfig config = hal::make_default_trocar_config(1);
  hal::SimBus bus{hal::SimBusSettings{}};
  hal::DeviceEmulator emulator{config};
  std::int64_t t = 0;
  sim::BringUpLink link() {
    return sim::BringUpLink{&bus.controller(), [this] { return t; }, [this](std::int64_t ns) {
                              t += std::min<std::int64_t>(ns, 1'000'000);
                              bus.set_time_ns(t);
                              emulator.poll(bus.device());
                              emulator.tick(t, bus.device());
                            }};
  }
};

TEST(SdoSession, ATransferRunsToItsEndOrItsAbort) {
  Bench b;
  const sim::BringUpLink link = b.link();
  link.wait(1'000'000);  // boot-ups: the nodes take SDO
  hal::SdoClient client(2);
  std::array<std::uint8_t, 128> buf{};
  ASSERT_TRUE(client.start_upload({0x1008, 0}, buf, link.now_ns()));
  ASSERT_EQ(sim::run_sdo_transfer(link, client), hal::SdoStatus::kDone);
  const std::string name(buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(client.transferred()));
  EXPECT_NE(name.find("drive"), std::string::npos) << name;
  ASSERT_TRUE(client.start_upload({0x2345, 0}, buf, link.now_ns()));  // no such object
  EXPECT_EQ(sim::run_sdo_transfer(link, client), hal::SdoStatus::kAborted);
  EXPECT_EQ(client.abort_code(), hal::SdoAbort::kNoObject);
  hal::SdoClient absent(42, 20'000'000);  // no such node: the timeout ends it
  ASSERT_TRUE(absent.start_upload({0x1000, 0}, buf, link.now_ns()));
  EXPECT_EQ(sim::run_sdo_transfer(link, absent), hal::SdoStatus::kAborted);
  EXPECT_EQ(absent.abort_code(), hal::SdoAbort::kTimeout);
}

TEST(SdoSession, AScanFindsEveryNodeWithItsIdentity) {
  Bench b;
  sim::ScanSettings settings;
  settings.listen_ns = 100'000'000;  // heartbeats every 10 ms
  const std::vector<sim::ScannedNode> nodes = sim::scan_nodes(b.link(), settings);
  ASSERT_EQ(nodes.size(), b.config.canopen.axes.size());
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    const sim::ScannedNode& n = nodes[i];
    SCOPED_TRACE(int(n.node_id));
    EXPECT_EQ(n.node_id, b.config.canopen.axes[i].node_id);
    EXPECT_EQ(n.state, hal::NmtState::kPreOperational);  // the scan started nothing
    EXPECT_TRUE(n.answered);
    const bool drive = b.config.axes[i].has_drive();
    EXPECT_EQ(n.device_type & 0xFFFF, drive ? 402u : 406u);
    EXPECT_EQ(n.product_code, drive ? 0x402u : 0x406u);
    EXPECT_EQ(n.serial, n.node_id);
    EXPECT_NE(n.name.find(b.config.axes[i].name), std::string::npos) << n.name;
    EXPECT_EQ(n.software_version, "numen device emulator");
    EXPECT_TRUE(n.errors.empty()) << n.errors.front();
  }
  const std::string table = sim::format_scan_table(nodes);
  EXPECT_NE(table.find("pre-operational"), std::string::npos) << table;
  const auto j = nlohmann::json::parse(sim::format_scan_json(nodes));
  ASSERT_EQ(j["nodes"].size(), nodes.size());
  EXPECT_EQ(j["nodes"][0]["profile"], 402);
}

TEST(SdoSession, AScanOfASilentBusFindsNothingAndSaysSo) {
  hal::SimBus bus{hal::SimBusSettings{}};
  std::int64_t t = 0;
  const sim::BringUpLink link{&bus.controller(), [&] { return t; }, [&](std::int64_t ns) { t += ns; }};
  sim::ScanSettings settings;
  settings.listen_ns = 50'000'000;
  const auto nodes = sim::scan_nodes(link, settings);
  EXPECT_TRUE(nodes.empty());
  EXPECT_NE(sim::format_scan_table(nodes).find("no node heard"), std::string::npos);
}

TEST(SdoSession, AddressesAreCanopenHexNotation) {
  EXPECT_EQ(sim::parse_sdo_address("1018:01"), (hal::SdoAddress{0x1018, 0x01}));
  EXPECT_EQ(sim::parse_sdo_address("0x6060:0"), (hal::SdoAddress{0x6060, 0x00}));
  EXPECT_EQ(sim::parse_sdo_address("1A00:ff"), (hal::SdoAddress{0x1A00, 0xFF}));
  for (const char* bad : {"1018", "1018:", ":1", "10180:1", "1018:100", "x:1", "1018:1:2", "-1:0"}) {
    EXPECT_THROW(sim::parse_sdo_address(bad), std::invalid_argument) << bad;
  }
}

}  // namespace
