// Tests of sim/bus_spec: parsing of `--bus` specs (every kind, and located errors for bad ones),
// the acceptance filters of each end of the link from the shipped default scene's device (the
// exact COB-ID sets of docs/protocol.md, docs/canopen.md, minimal and managed), opening a real port
// (a serial line on a pseudo-terminal; SocketCAN's error naming the interface where the host
// has no CAN) and wait_bus' timeout and readiness.
#include "numen/sim/input/bus_spec.hpp"

#include <fcntl.h>
#include <pty.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <set>
#include <stdexcept>
#include <string>

#include "numen/hal/features.hpp"
#include "numen/hal/transport/can_filter.hpp"
#include "numen/sim/scene/scene.hpp"
#include "build_features.hpp"
#include "lattice_scene.hpp"

namespace {

using numen::sim::BusKind;
using numen::sim::BusSpec;
using numen::sim::parse_bus_spec;

const numen::sim::Scene& bus_lattice_scene() {
  static const numen::sim::Scene s = numen::sim::load_scene(numen::test::lattice_scene_path());
  return s;
}

/// The COB-IDs of exact 11-bit data-frame filters; fails the test on any other kind of filter.
/// The 11-bit ids of `filters` that are exact (exact_standard_filter()); each id in `whole` must
/// instead come as the pair standard_id_filter() + extended_id_filter() (an encoder's COB-ID).
std::set<std::uint32_t> exact_ids(const std::vector<numen::hal::CanFilter>& filters,
                                  const std::set<std::uint32_t>& whole = {}) {
  std::set<std::uint32_t> ids;
  std::size_t pairs = 0;
  for (const numen::hal::CanFilter& f : filters) {
    const std::uint32_t id = f.id & numen::hal::kExtendedIdMask;
    if (whole.count(id) != 0) {
      const bool standard = f.id == numen::hal::standard_id_filter(id).id &&
                            f.mask == numen::hal::standard_id_filter(id).mask;
      const bool extended = f.id == numen::hal::extended_id_filter(id).id &&
                            f.mask == numen::hal::extended_id_filter(id).mask;
      EXPECT_TRUE(standard || extended) << std::hex << f.id << " mask " << f.mask;
      ++pairs;
      continue;
    }
    const numen::hal::CanFilter exact = numen::hal::exact_standard_filter(f.id);
    EXPECT_EQ(f.mask, exact.mask) << std::hex << f.id;
    EXPECT_EQ(f.id, exact.id);
    ids.insert(f.id);
  }
  EXPECT_EQ(pairs, 2 * whole.size()) << "each whole id: its 11-bit and its 29-bit filter";
  EXPECT_EQ(ids.size() + pairs, filters.size()) << "duplicate filters";
  for (const std::uint32_t id : whole) ids.insert(id);
  return ids;
}

const std::set<std::uint32_t> kEncoderIds = {0x181, 0x182, 0x183, 0x184, 0x185};

std::string error_of(const std::string& spec) {
  try {
    parse_bus_spec(spec);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

TEST(BusSpec, ParsesEveryKind) {
  EXPECT_EQ(parse_bus_spec("sim").kind, BusKind::kSim);
  EXPECT_FALSE(parse_bus_spec("sim").real());
  const BusSpec log = parse_bus_spec("log:runs/field.log");
  EXPECT_EQ(log.kind, BusKind::kLog);
  EXPECT_EQ(log.target, "runs/field.log");
  EXPECT_FALSE(log.real());
  const BusSpec can = parse_bus_spec("can:vcan0");
  EXPECT_EQ(can.kind, BusKind::kCan);
  EXPECT_EQ(can.target, "vcan0");
  EXPECT_TRUE(can.real());
  EXPECT_EQ(parse_bus_spec("can:abcdefghijklmno").target.size(), 15u);  // IFNAMSIZ − 1
  const BusSpec serial = parse_bus_spec("serial:/dev/ttyUSB0");
  EXPECT_EQ(serial.kind, BusKind::kSerial);
  EXPECT_EQ(serial.target, "/dev/ttyUSB0");
  EXPECT_EQ(serial.baud, 1'000'000u);
  EXPECT_TRUE(serial.real());
  const BusSpec fast = parse_bus_spec("serial:/dev/ttyS1@115200");
  EXPECT_EQ(fast.target, "/dev/ttyS1");
  EXPECT_EQ(fast.baud, 115200u);
  // Only the last '@' separates the speed: a path may hold one.
  const BusSpec at = parse_bus_spec("serial:/dev/serial/by-id/usb-x@y@9600");
  EXPECT_EQ(at.target, "/dev/serial/by-id/usb-x@y");
  EXPECT_EQ(at.baud, 9600u);
}

TEST(BusSpec, BadSpecsNameTheSpecAndTheProblem) {
  EXPECT_NE(error_of("can0").find("--bus 'can0': expected sim, log:FILE, can:IFACE"), std::string::npos);
  EXPECT_NE(error_of("").find("--bus ''"), std::string::npos);
  EXPECT_NE(error_of("SIM").find("expected"), std::string::npos);  // case matters
  EXPECT_NE(error_of("can:").find("nothing after the prefix"), std::string::npos);
  EXPECT_NE(error_of("log:").find("nothing after the prefix"), std::string::npos);
  EXPECT_NE(error_of("serial:").find("nothing after the prefix"), std::string::npos);
  EXPECT_NE(error_of("serial:@115200").find("nothing after the prefix"), std::string::npos);
  EXPECT_NE(error_of("can:abcdefghijklmnop").find("longer than 15 characters"), std::string::npos);
  EXPECT_NE(error_of("serial:/dev/ttyS0@").find("baud '' is not a decimal number"), std::string::npos);
  EXPECT_NE(error_of("serial:/dev/ttyS0@fast").find("baud 'fast'"), std::string::npos);
  EXPECT_NE(error_of("serial:/dev/ttyS0@115200x").find("baud '115200x'"), std::string::npos);
  EXPECT_NE(error_of("serial:/dev/ttyS0@-1").find("baud '-1'"), std::string::npos);
  EXPECT_NE(error_of("serial:/dev/ttyS0@99999999999").find("baud '99999999999'"), std::string::npos);
  if (numen::hal::kWithSerial) {  // the termios speeds belong to the serial backend
    EXPECT_NE(error_of("serial:/dev/ttyS0@12345").find("not a supported termios speed"), std::string::npos);
  }
}

TEST(BusSpec, ManagedFiltersAreExactlyTheIdsEachEndReads) {
  NUMEN_REQUIRE_ARTICULATION();
  const numen::hal::DeviceConfig& dev = bus_lattice_scene().device;
  ASSERT_TRUE(dev.canopen.managed);
  ASSERT_EQ(dev.axes.size(), 5u);
  // Controller: encoder TPDOs 0x181–0x185, drive TPDOs 0x281–0x283, heartbeats 0x701–0x705,
  // EMCY 0x081–0x085 (docs/canopen.md).
  // The encoders' COB-IDs pass whole (remote requests and 29-bit frames of their numbers are
  // counted by the controller, not filtered out unseen).
  const std::set<std::uint32_t> ctl = exact_ids(numen::sim::controller_filters(dev), kEncoderIds);
  // The shipped scene configures its nodes from DCFs: their SDO responses 0x581–0x585 too.
  const std::set<std::uint32_t> want_ctl = {0x181, 0x182, 0x183, 0x184, 0x185, 0x281, 0x282, 0x283,
                                            0x701, 0x702, 0x703, 0x704, 0x705, 0x081, 0x082, 0x083,
                                            0x084, 0x085, 0x581, 0x582, 0x583, 0x584, 0x585};
  EXPECT_EQ(ctl, want_ctl);
  // Device: SYNC, drive RPDOs 0x201–0x203, NMT, the controller's heartbeat (node 127), SDO
  // requests 0x601–0x605.
  const std::set<std::uint32_t> devf = exact_ids(numen::sim::device_filters(dev));
  const std::set<std::uint32_t> want_dev = {0x080, 0x201, 0x202, 0x203, 0x000, 0x77F,
                                            0x601, 0x602, 0x603, 0x604, 0x605};
  EXPECT_EQ(devf, want_dev);
}

TEST(BusSpec, MinimalProtocolFiltersOnlyTheEncodersAndTheTorques) {
  NUMEN_REQUIRE_ARTICULATION();
  numen::hal::DeviceConfig dev = bus_lattice_scene().device;
  dev.canopen.managed = false;
  EXPECT_EQ(exact_ids(numen::sim::controller_filters(dev), kEncoderIds),
            (std::set<std::uint32_t>{0x181, 0x182, 0x183, 0x184, 0x185}));
  EXPECT_EQ(exact_ids(numen::sim::device_filters(dev)),
            (std::set<std::uint32_t>{0x080, 0x201, 0x202, 0x203}));
}

TEST(BusSpec, OpenRealBusRefusesSimAndLogAndNamesAMissingPort) {
  EXPECT_THROW(numen::sim::open_real_bus(parse_bus_spec("sim"), {}), std::invalid_argument);
  EXPECT_THROW(numen::sim::open_real_bus(parse_bus_spec("log:x.log"), {}), std::invalid_argument);
  // Without the backend, std::invalid_argument (missing_backend()); either way the error names the port.
  try {
    numen::sim::open_real_bus(parse_bus_spec("serial:/nonexistent/tty"), {});
    FAIL() << "opened a missing tty";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/tty"), std::string::npos) << e.what();
    EXPECT_EQ(dynamic_cast<const std::invalid_argument*>(&e) != nullptr, !numen::hal::kWithSerial);
  }
  // No such interface (or, on a host without CAN, no PF_CAN at all): the error names it.
  try {
    numen::sim::open_real_bus(parse_bus_spec("can:nocan7"), {});
    FAIL() << "opened a missing CAN interface";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("nocan7"), std::string::npos) << e.what();
    EXPECT_EQ(dynamic_cast<const std::invalid_argument*>(&e) != nullptr, !numen::hal::kWithSocketCan);
  }
}

TEST(BusSpec, ABackendLeftOutIsAClearError) {
  const std::string can = numen::sim::missing_backend(parse_bus_spec("can:vcan0"));
  const std::string serial = numen::sim::missing_backend(parse_bus_spec("serial:/dev/ttyS0"));
  EXPECT_EQ(can.empty(), numen::hal::kWithSocketCan) << can;
  EXPECT_EQ(serial.empty(), numen::hal::kWithSerial) << serial;
  if (!can.empty()) {
    EXPECT_EQ(can, "bus 'can:vcan0' needs SocketCAN: this build has NUMEN_WITH_SOCKETCAN=OFF");
  }
  if (!serial.empty()) {
    EXPECT_EQ(serial,
              "bus 'serial:/dev/ttyS0' needs the serial backend: this build has NUMEN_WITH_SERIAL=OFF");
  }
  EXPECT_EQ(numen::sim::missing_backend(parse_bus_spec("sim")), "");
  EXPECT_EQ(numen::sim::missing_backend(parse_bus_spec("log:x.log")), "");
}

TEST(BusSpec, WaitBusTimesOutOnASilentLineAndWakesOnData) {
  NUMEN_REQUIRE_SERIAL();
  int master = -1, slave = -1;
  ASSERT_EQ(::openpty(&master, &slave, nullptr, nullptr, nullptr), 0);
  char name[256];
  ASSERT_EQ(::ttyname_r(slave, name, sizeof(name)), 0);
  const auto bus = numen::sim::open_real_bus(parse_bus_spec(std::string("serial:") + name), {});
  using clock = std::chrono::steady_clock;
  const auto t0 = clock::now();
  EXPECT_FALSE(numen::sim::wait_bus(*bus, 20'000'000));  // 20 ms, nothing sent
  EXPECT_GE(clock::now() - t0, std::chrono::milliseconds(19));
  const char byte = 0x00;  // a COBS delimiter: readable bytes, no frame
  ASSERT_EQ(::write(master, &byte, 1), 1);
  EXPECT_TRUE(numen::sim::wait_bus(*bus, 1'000'000'000));
  EXPECT_TRUE(numen::sim::wait_bus(*bus, 0));  // still readable until read
  ::close(master);
  ::close(slave);
}

}  // namespace

// igtl[:[HOST:]PORT]: the scene's OpenIGTLink tracker (docs/openigtlink.md), at the scene's
// server or this one; refused whole by a build without OpenIGTLink.
TEST(BusSpec, IgtlTakesAnOptionalHostAndPort) {
  const BusSpec plain = parse_bus_spec("igtl");
  EXPECT_EQ(plain.kind, numen::sim::BusKind::kIgtl);
  EXPECT_EQ(plain.igtl_port, 0);
  EXPECT_TRUE(plain.igtl_host.empty());
  EXPECT_FALSE(plain.real());
  const BusSpec port = parse_bus_spec("igtl:18945");
  EXPECT_EQ(port.igtl_port, 18945);
  EXPECT_TRUE(port.igtl_host.empty());
  const BusSpec both = parse_bus_spec("igtl:192.168.1.20:18944");
  EXPECT_EQ(both.igtl_host, "192.168.1.20");
  EXPECT_EQ(both.igtl_port, 18944);
  EXPECT_NE(error_of("igtl:0").find("--bus 'igtl:0': port '0' is not a TCP port"), std::string::npos);
  EXPECT_NE(error_of("igtl:65536").find("port '65536'"), std::string::npos);
  EXPECT_NE(error_of("igtl:host:").find("port ''"), std::string::npos);
  EXPECT_NE(error_of("igtl::18944").find("empty host"), std::string::npos);
  EXPECT_EQ(numen::sim::missing_backend(port).empty(), numen::hal::kWithOpenIgtLink)
      << numen::sim::missing_backend(port);
  if (!numen::hal::kWithOpenIgtLink) {
    EXPECT_EQ(numen::sim::missing_backend(port),
              "bus 'igtl' needs OpenIGTLink: this build has NUMEN_WITH_OPENIGTLINK=OFF");
  }
}

// Issue 66: "igtl:127.0.0.1:19098:5" was accepted (host "127.0.0.1:19098", port 5) and failed
// only at run time; the spec has one port, a host with a colon is an IPv6 address.
TEST(BusSpec, IgtlHostIsANameOrAnAddressRefusedAtParseOtherwise) {
  EXPECT_NE(error_of("igtl:127.0.0.1:19098:5")
                .find("--bus 'igtl:127.0.0.1:19098:5': host '127.0.0.1:19098' is not an IPv6 "
                      "address, and the spec has one port"),
            std::string::npos)
      << error_of("igtl:127.0.0.1:19098:5");
  EXPECT_NE(error_of("igtl:a b:18944").find("host 'a b' is not a host name"), std::string::npos);
  EXPECT_NE(error_of("igtl:[tracker]:18944").find("host '[tracker]'"), std::string::npos);
  EXPECT_EQ(parse_bus_spec("igtl:[::1]:18944").igtl_host, "::1");
  EXPECT_EQ(parse_bus_spec("igtl:::1:18944").igtl_host, "::1");
  EXPECT_EQ(parse_bus_spec("igtl:tracker-2.local:18944").igtl_host, "tracker-2.local");
  EXPECT_EQ(parse_bus_spec("igtl:[::1]:18944").igtl_port, 18944);
}
