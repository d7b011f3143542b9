// Tests of hal/canopen/dcf_configuration: the CiA 301 write sequence a DCF gives, and
// NodeConfigurator against an emulated node over SimBus: the shipped DCF written and read back
// without allocating, a DCF that changes the node applied by it, a write the node refuses
// reported by its abort name at the DCF line, a read-back mismatch located, a silent node.
#include "numen/hal/canopen/dcf_configuration.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "alloc_counter.hpp"
#include "numen/hal/canopen/canopen.hpp"
#include "numen/hal/canopen/nmt.hpp"
#include "numen/hal/emulation/device_emulator.hpp"
#include "numen/hal/transport/sim_bus.hpp"
#include "test_constants.hpp"

namespace {

using numen::hal::CanFrame;
using numen::hal::ConfigurationStatus;
using numen::hal::ConfigurationStep;
using numen::hal::Dcf;
using numen::hal::DcfConfiguration;
using numen::hal::DeviceConfig;
using numen::hal::DeviceEmulator;
using numen::hal::IoStatus;
using numen::hal::NodeConfigurator;
using numen::hal::SdoAddress;
using numen::hal::SimBus;

using numen::test::kMs;

std::string shipped_text(const char* name) {
  std::ifstream in(std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/devices/" + name);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

/// `text` with the first occurrence of `from` replaced by `to` (which must exist).
std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return at == std::string::npos ? text : text.replace(at, from.size(), to);
}

/// The 1-based line of the first occurrence of `needle` in `text`.
int line_of(const std::string& text, const std::string& needle) {
  const auto at = text.find(needle);
  int line = 1;
  for (std::size_t i = 0; i < at; ++i) line += text[i] == '\n' ? 1 : 0;
  return line;
}

std::shared_ptr<const Dcf> dcf(const std::string& text, std::uint8_t node) {
  return std::make_shared<const Dcf>(numen::hal::parse_dcf_text(text, "node.dcf", node));
}

/// A default trocar instrument's emulator on SimBus, its nodes booted (pre-operational).
struct Node {
  DeviceConfig cfg = numen::hal::make_default_trocar_config(1);
  DeviceEmulator emulator{cfg};
  SimBus bus{numen::hal::SimBusSettings{}};
  std::int64_t t = 0;

  Node() { emulator.tick(0, bus.device()); }

  /// One period: the configurator's request out, the node's answer back. Returns false once
  /// the configurator is no longer running.
  bool period(NodeConfigurator& c) {
    t += kMs;
    bus.set_time_ns(t);
    CanFrame f;
    while (c.take_request(f, t)) (void)bus.controller().write(f);
    emulator.poll(bus.device());
    while (bus.controller().read(f) == IoStatus::kOk) (void)c.on_frame(f);
    c.poll(t);
    return c.status() == ConfigurationStatus::kRunning;
  }
  int run(NodeConfigurator& c, int max_periods = 1000) {
    c.start(t);
    int n = 0;
    while (n < max_periods && period(c)) ++n;
    return n;
  }
  std::uint32_t od(std::uint8_t node, SdoAddress a) const {
    std::uint32_t v = 0;
    EXPECT_TRUE(emulator.object_dictionary(node)->read_unsigned(a, v));
    return v;
  }
};

std::vector<std::string> write_addresses(const DcfConfiguration& plan) {
  std::vector<std::string> out;
  for (const ConfigurationStep& s : plan.steps()) {
    if (s.kind != ConfigurationStep::Kind::kWrite) break;
    char buf[32];
    std::snprintf(buf, sizeof buf, "%04X:%02X=%llX", s.address.index, s.address.subindex,
                  static_cast<unsigned long long>(s.value));
    out.emplace_back(buf);
  }
  return out;
}

TEST(DcfConfiguration, PdoSequenceOfCia301ThenObjectsThenReadBack) {
  const DcfConfiguration plan(dcf(shipped_text("trocar_drive.dcf"), 1));
  const std::vector<std::string> expected = {
      // RPDO1: disable, transmission type, mapping count 0, entries, count, enable.
      "1400:01=80000201", "1400:02=1", "1600:00=0", "1600:01=60400010", "1600:02=60710010",
      "1600:00=2", "1400:01=201",
      "1800:01=80000181", "1800:02=1", "1A00:00=0", "1A00:01=60040020", "1A00:00=1", "1800:01=181",
      "1801:01=80000281", "1801:02=1", "1A01:00=0", "1A01:01=60410010", "1A01:02=60770010",
      "1A01:00=2", "1801:01=281",
      // The other configured writable objects, in index order.
      "1005:00=80", "1016:01=7F001E", "1017:00=A", "6060:00=A", "6072:00=7D0"};
  EXPECT_EQ(write_addresses(plan), expected);
  EXPECT_EQ(plan.num_writes(), expected.size());
  // Every configured entry is read back, read-only ones (0x1000, 0x1018:1/2) included.
  std::size_t verifies = 0;
  for (const ConfigurationStep& s : plan.steps()) verifies += s.kind == ConfigurationStep::Kind::kVerify;
  EXPECT_EQ(verifies, 22u);
  EXPECT_EQ(plan.steps().back().address, (SdoAddress{0x6072, 0}));
}

TEST(DcfConfiguration, AMappingCountOfAStringTypeIsRefusedAtItsEntry) {
  // A fuzz finding: mapping entries configured under a count that is a VISIBLE_STRING gave
  // SDO steps of 0 bytes. The count is UNSIGNED8 (CiA 301); a non-numeric one is refused.
  const std::string text = replaced(
      shipped_text("trocar_drive.dcf"),
      "[1A00sub0]\nParameterName=Number of mapped objects\nObjectType=0x7\nDataType=0x0005",
      "[1A00sub0]\nParameterName=Number of mapped objects\nObjectType=0x7\nDataType=0x0009");
  try {
    const DcfConfiguration plan(dcf(text, 1));
    FAIL() << "accepted";
  } catch (const numen::hal::DcfError& e) {
    EXPECT_EQ(e.location().section, "1A00sub0");
    const std::string expected = "the mapping count [1A00sub0] has DataType 0x0009, not a numeric one";
    EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
  }
}

TEST(DcfConfiguration, ShippedDcfWrittenAndReadBackWithoutAllocating) {
  Node n;
  const DcfConfiguration plan(dcf(shipped_text("trocar_drive.dcf"), 1));
  NodeConfigurator c(plan, 1, 100 * kMs);
  int periods = 0;
  {
    numen::test::AllocationGuard guard;
    periods = n.run(c);
    EXPECT_EQ(guard.count(), 0);
  }
  EXPECT_EQ(c.status(), ConfigurationStatus::kDone) << c.error();
  EXPECT_EQ(static_cast<std::size_t>(periods) + 1, plan.steps().size());  // one transfer a period
  EXPECT_EQ(c.error(), "");
  EXPECT_EQ(n.od(1, {0x1800, 1}), 0x181u);
  EXPECT_EQ(n.od(1, {0x1A01, 2}), 0x60770010u);
  EXPECT_EQ(n.od(1, {0x6072, 0}), 2000u);
  EXPECT_EQ(n.emulator.drive(0)->settings().max_torque_per_mille, 2000);
}

TEST(DcfConfiguration, EmulatedNodeAppliesWhatTheDcfChanges) {
  Node n;
  // Drive TPDO2 with the mode display added, heartbeat 20 ms, max torque 1500 per mille.
  std::string text = shipped_text("trocar_drive.dcf");
  text = replaced(text, "[1A01sub0]\nParameterName=Number of mapped objects\nObjectType=0x7\nDataType=0x0005\nAccessType=rw\nDefaultValue=2\nParameterValue=2",
                  "[1A01sub0]\nParameterName=Number of mapped objects\nObjectType=0x7\nDataType=0x0005\nAccessType=rw\nDefaultValue=2\nParameterValue=3");
  text = replaced(text, "[1A01]\nParameterName=TPDO2 mapping parameter\nObjectType=0x9\nSubNumber=3",
                  "[1A01]\nParameterName=TPDO2 mapping parameter\nObjectType=0x9\nSubNumber=4");
  text += "\n[1A01sub3]\nDataType=0x0007\nAccessType=rw\nParameterValue=0x60610008\n";
  text = replaced(text, "DefaultValue=10\nParameterValue=10", "DefaultValue=10\nParameterValue=20");
  text = replaced(text, "ParameterValue=2000", "ParameterValue=1500");
  const DcfConfiguration plan(dcf(text, 1));
  NodeConfigurator c(plan, 1, 100 * kMs);
  n.run(c);
  ASSERT_EQ(c.status(), ConfigurationStatus::kDone) << c.error();
  EXPECT_EQ(n.emulator.drive(0)->settings().max_torque_per_mille, 1500);
  // Started and synchronised, the node sends its drive TPDO with 5 bytes now.
  CanFrame f;
  numen::hal::encode_nmt(numen::hal::NmtCommand::kStartRemoteNode, 1, n.t, f);
  (void)n.bus.controller().write(f);
  (void)n.bus.controller().write(numen::hal::make_sync(n.t));
  n.emulator.poll(n.bus.device());
  int drive_tpdos = 0;
  while (n.bus.controller().read(f) == IoStatus::kOk) {
    if (f.id == 0x281) {
      ++drive_tpdos;
      EXPECT_EQ(f.len, 5);
      EXPECT_EQ(f.data[4], 10);  // modes of operation display: cst
    }
  }
  EXPECT_EQ(drive_tpdos, 1);
  // Heartbeats every 20 ms (after the first, which the old grid point makes due at once).
  std::vector<std::int64_t> heartbeats;
  for (int k = 1; k <= 100; ++k) {
    n.emulator.tick(n.t + k * kMs, n.bus.device());
    while (n.bus.controller().read(f) == IoStatus::kOk)
      if (f.id == 0x701) heartbeats.push_back(n.t + k * kMs);
  }
  ASSERT_GE(heartbeats.size(), 5u);
  for (std::size_t i = 2; i < heartbeats.size(); ++i) EXPECT_EQ(heartbeats[i] - heartbeats[i - 1], 20 * kMs);
}

TEST(DcfConfiguration, RefusedWriteReportedByAbortNameAtItsLine) {
  Node n;
  // Max torque 0x6072 is no PDO object of the emulated drive.
  const std::string text = replaced(shipped_text("trocar_drive.dcf"), "ParameterValue=0x60710010",
                                    "ParameterValue=0x60720010");
  const DcfConfiguration plan(dcf(text, 1));
  NodeConfigurator c(plan, 1, 100 * kMs);
  n.run(c);
  ASSERT_EQ(c.status(), ConfigurationStatus::kFailed);
  EXPECT_EQ(c.abort_code(), numen::hal::SdoAbort::kNotMappable);
  const int line = line_of(text, "ParameterValue=0x60720010");
  EXPECT_EQ(c.error(), "node.dcf:" + std::to_string(line) +
                           ": [1600sub2] ParameterValue: node 1 refused writing 0x1600:02 = "
                           "0x60720010: object cannot be mapped to the PDO (0x06040041)");
}

TEST(DcfConfiguration, ReadBackMismatchLocated) {
  Node n;
  // The DCF describes an encoder (product 0x406) but node 1 is a drive (0x402).
  const std::string text = shipped_text("encoder.dcf");
  const DcfConfiguration plan(dcf(text, 1));
  NodeConfigurator c(plan, 1, 100 * kMs);
  n.run(c);
  ASSERT_EQ(c.status(), ConfigurationStatus::kFailed);
  EXPECT_EQ(c.abort_code(), 0u);
  const std::string err = c.error();
  // 0x1000 is the first value read back: device type 0x00020192 (402) against 0x00020196.
  const int line = line_of(text, "ParameterValue=0x00020196");
  EXPECT_EQ(err, "node.dcf:" + std::to_string(line) +
                     ": [1000] ParameterValue: node 1 0x1000:00 read back 0x00020192, the DCF "
                     "configures 0x00020196");
}

TEST(DcfConfiguration, ALostResponseIsTriedAgain) {
  Node n;
  const DcfConfiguration plan(dcf(shipped_text("encoder.dcf"), 4));
  NodeConfigurator c(plan, 4, 5 * kMs);
  c.start(n.t);
  for (int k = 0; k < 3; ++k) n.period(c);
  n.emulator.kill(true);  // the node misses a request (and so never answers it)
  n.period(c);
  n.emulator.kill(false);
  while (n.period(c)) {
  }
  EXPECT_EQ(c.status(), ConfigurationStatus::kDone) << c.error();
  EXPECT_EQ(c.retries(), 1u);
}

TEST(DcfConfiguration, SilentNodeTimesOut) {
  Node n;
  n.emulator.kill(true);
  const DcfConfiguration plan(dcf(shipped_text("encoder.dcf"), 4));
  NodeConfigurator c(plan, 4, 20 * kMs);
  const int periods = n.run(c);
  ASSERT_EQ(c.status(), ConfigurationStatus::kFailed);
  EXPECT_EQ(c.abort_code(), numen::hal::SdoAbort::kTimeout);
  EXPECT_EQ(c.retries(), static_cast<std::uint64_t>(numen::hal::kTimeoutRetries));  // tried 3 times
  // Each try: the request goes out the period after it starts, the 20 ms timeout runs from there.
  EXPECT_GE(periods, 3 * 20);
  EXPECT_LE(periods, 3 * 22);
  EXPECT_NE(c.error().find("node 4 writing 0x1800:01 = 0x80000184 failed: SDO protocol timed out"),
            std::string::npos)
      << c.error();
  EXPECT_NE(c.error().find("the node did not answer (3 tries)"), std::string::npos);
}

}  // namespace
