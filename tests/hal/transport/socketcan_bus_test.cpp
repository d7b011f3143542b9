// Host tests of SocketCanBus: the pure conversions (struct canfd_frame, kernel filters, error
// frames, timestamps), the setup errors, and the read/write paths over an adopted AF_UNIX
// datagram socketpair (this host's kernel has no CAN). The same paths on a real vcan interface
// are tested in the qemu hardware-in-the-loop suite (tests/hil/socketcan_bus_hil_test.cpp).
#include "numen/hal/transport/socketcan_bus.hpp"

#include <gtest/gtest.h>
#include <linux/can/error.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include <array>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

#include "alloc_counter.hpp"
#include "can_test_frames.hpp"

namespace numen::hal {
namespace {

using test::error_frame;
using test::expect_same;
using test::make;
using test::mono_ns;

// --- struct canfd_frame conversion -----------------------------------------------------------

TEST(SocketCanEncode, ClassicStandardFrameIsACanFrame) {
  const CanFrame f = make(0x181, 0, 4, 0x10);
  canfd_frame out;
  std::memset(&out, 0xAB, sizeof(out));
  ASSERT_EQ(encode_socketcan(f, out), CAN_MTU);
  EXPECT_EQ(out.can_id, 0x181u);
  EXPECT_EQ(out.len, 4);
  EXPECT_EQ(out.flags, 0);
  EXPECT_EQ(out.data[0], 0x10);
  EXPECT_EQ(out.data[3], 0x10 + 21);
  for (int i = 4; i < CANFD_MAX_DLEN; ++i) EXPECT_EQ(out.data[i], 0) << i;
  // The head of canfd_frame is a struct can_frame (the layout SocketCAN sends for CAN_MTU).
  can_frame classic;
  std::memcpy(&classic, &out, CAN_MTU);
  EXPECT_EQ(classic.can_id, 0x181u);
  EXPECT_EQ(classic.len, 4);
  EXPECT_EQ(classic.data[3], 0x10 + 21);
}

TEST(SocketCanEncode, ExtendedRemoteAndErrorFlagsGoIntoCanId) {
  canfd_frame out;
  ASSERT_EQ(encode_socketcan(make(0x1ABCDEF0, CanFlag::kExtendedId | CanFlag::kRemote, 3), out),
            CAN_MTU);
  EXPECT_EQ(out.can_id, CAN_EFF_FLAG | CAN_RTR_FLAG | 0x1ABCDEF0u);
  EXPECT_EQ(out.len, 3);
  EXPECT_EQ(out.data[0], 0);  // a remote request carries no data
  ASSERT_EQ(encode_socketcan(error_frame(CAN_ERR_CRTL, CAN_ERR_CRTL_TX_PASSIVE), out), CAN_MTU);
  EXPECT_EQ(out.can_id, CAN_ERR_FLAG | CAN_ERR_CRTL);
  EXPECT_EQ(out.data[1], CAN_ERR_CRTL_TX_PASSIVE);
}

TEST(SocketCanEncode, FdFrameIsCanfdFrameWithFlags) {
  const CanFrame f = make(0x7FF, CanFlag::kFd | CanFlag::kBitRateSwitch, 64, 3);
  canfd_frame out;
  ASSERT_EQ(encode_socketcan(f, out), CANFD_MTU);
  EXPECT_EQ(out.can_id, 0x7FFu);
  EXPECT_EQ(out.len, 64);
  EXPECT_EQ(out.flags, CANFD_BRS);  // FD-ness is the byte count
  EXPECT_EQ(0, std::memcmp(out.data, f.data.data(), 64));
  ASSERT_EQ(encode_socketcan(make(0x10, CanFlag::kFd | CanFlag::kErrorStateIndicator, 12), out),
            CANFD_MTU);
  EXPECT_EQ(out.flags, CANFD_ESI);
}

TEST(SocketCanEncode, WorkedExampleOfTheProtocolDoc) {
  // docs/transports.md, "SocketCAN transport": encoder TPDO 0x181 = 1000 counts, little endian.
  CanFrame tpdo;
  tpdo.id = 0x181;
  tpdo.len = 4;
  tpdo.data = {0xE8, 0x03, 0x00, 0x00};
  canfd_frame wire;
  ASSERT_EQ(encode_socketcan(tpdo, wire), 16u);
  const std::array<std::uint8_t, 16> expected{0x81, 0x01, 0x00, 0x00, 0x04, 0x00, 0x00, 0x00,
                                              0xE8, 0x03, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00};
  EXPECT_EQ(0, std::memcmp(&wire, expected.data(), expected.size()));
  // A kernel error report "controller error passive (tx)": can_id 0x20000004, data[1] 0x20.
  const std::array<std::uint8_t, 16> report{0x04, 0x00, 0x00, 0x20, 0x08, 0x00, 0x00, 0x00,
                                            0x00, 0x20, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00};
  canfd_frame in{};
  std::memcpy(&in, report.data(), report.size());
  CanFrame f;
  ASSERT_TRUE(decode_socketcan(in, CAN_MTU, f));
  EXPECT_EQ(f.flags, CanFlag::kErrorFrame);
  EXPECT_EQ(f.id, 0x4u);
  EXPECT_EQ(decode_error_frame(f).state, BusState::kErrorPassive);
}

TEST(SocketCanEncode, MalformedFramesGiveZeroBytes) {
  canfd_frame out;
  EXPECT_EQ(encode_socketcan(make(0x800, 0, 1), out), 0u);              // 11-bit overflow
  EXPECT_EQ(encode_socketcan(make(0x100, 0, 9), out), 0u);              // classic > 8
  EXPECT_EQ(encode_socketcan(make(0x100, CanFlag::kFd, 13), out), 0u);  // FD length 13
  EXPECT_EQ(encode_socketcan(make(0x100, CanFlag::kFd | CanFlag::kRemote, 0), out), 0u);
  EXPECT_EQ(encode_socketcan(make(0x100, CanFlag::kBitRateSwitch, 1), out), 0u);
}

TEST(SocketCanDecode, RoundTripsEveryKindOfFrame) {
  const std::vector<CanFrame> frames = {
      make(0x000, 0, 0),
      make(0x181, 0, 4),
      make(0x7FF, 0, 8),
      make(0x123, CanFlag::kRemote, 2),
      make(0x1FFFFFFF, CanFlag::kExtendedId, 8),
      make(0x00000001, CanFlag::kExtendedId | CanFlag::kRemote, 0),
      make(0x080, CanFlag::kFd, 0),
      make(0x201, CanFlag::kFd, 12),
      make(0x201, CanFlag::kFd | CanFlag::kBitRateSwitch | CanFlag::kErrorStateIndicator, 48),
      make(0x1234567, CanFlag::kFd | CanFlag::kExtendedId | CanFlag::kBitRateSwitch, 64),
      error_frame(CAN_ERR_BUSOFF),
  };
  for (const CanFrame& f : frames) {
    canfd_frame wire;
    const std::size_t n = encode_socketcan(f, wire);
    ASSERT_NE(n, 0u);
    CanFrame back;
    back.timestamp_ns = 42;
    ASSERT_TRUE(decode_socketcan(wire, n, back)) << std::hex << f.id;
    expect_same(f, back);
    EXPECT_EQ(back.timestamp_ns, 42);  // left to the caller
  }
}

TEST(SocketCanDecode, ByteCountTellsClassicFromFd) {
  canfd_frame wire{};
  wire.can_id = 0x181;
  wire.len = 8;
  wire.flags = CANFD_BRS;  // the __pad byte of a struct can_frame: no meaning there
  CanFrame f;
  ASSERT_TRUE(decode_socketcan(wire, CAN_MTU, f));
  EXPECT_EQ(f.flags, 0);
  ASSERT_TRUE(decode_socketcan(wire, CANFD_MTU, f));
  EXPECT_EQ(f.flags, CanFlag::kFd | CanFlag::kBitRateSwitch);
}

TEST(SocketCanDecode, RejectsWrongSizesAndMalformedFrames) {
  canfd_frame wire{};
  wire.can_id = 0x181;
  wire.len = 4;
  CanFrame f = make(0x55, 0, 1);
  for (std::size_t n : {0u, 1u, 8u, 15u, 17u, 64u, 71u, 73u}) {
    EXPECT_FALSE(decode_socketcan(wire, n, f)) << n;
  }
  wire.len = 9;  // classic longer than 8
  EXPECT_FALSE(decode_socketcan(wire, CAN_MTU, f));
  wire.len = 13;  // not an FD length
  EXPECT_FALSE(decode_socketcan(wire, CANFD_MTU, f));
  wire.len = 4;
  wire.can_id = 0x181 | CAN_RTR_FLAG;  // FD has no remote frames
  EXPECT_FALSE(decode_socketcan(wire, CANFD_MTU, f));
  wire.can_id = 0x800;  // 11-bit frame with bit 11 set
  EXPECT_FALSE(decode_socketcan(wire, CAN_MTU, f));
  EXPECT_EQ(f.id, 0x55u);  // untouched on rejection
}

// --- Kernel filters ---------------------------------------------------------------------------

TEST(SocketCanFilter, KernelFilterKeepsLayoutAndClearsBit29) {
  const can_filter k = to_kernel_filter(exact_standard_filter(0x181));
  EXPECT_EQ(k.can_id, 0x181u);
  EXPECT_EQ(k.can_mask, CAN_SFF_MASK | CAN_EFF_FLAG | CAN_RTR_FLAG);
  // Bit 29 would invert the filter (can_id) or make it an error-frame filter (can_mask).
  const can_filter odd =
      to_kernel_filter(CanFilter{0x181u | CAN_INV_FILTER, 0x7FFu | CAN_ERR_FLAG});
  EXPECT_EQ(odd.can_id, 0x181u);
  EXPECT_EQ(odd.can_mask, 0x7FFu);
}

TEST(SocketCanFilter, KernelMatchRuleAgreesWithCanFilterMatches) {
  // net/can/af_can.c delivers a frame to a filter when (can_id & mask) == (f.can_id & mask).
  const std::vector<CanFilter> filters = {exact_standard_filter(0x181), CanFilter{0x180, 0x780},
                                          CanFilter{0x80000000u | 0x100, 0xC00000FFu},
                                          CanFilter{0, 0}, CanFilter{0x40000000u, 0x40000000u}};
  const std::vector<CanFrame> frames = {make(0x181, 0, 1),
                                        make(0x182, 0, 1),
                                        make(0x181, CanFlag::kRemote, 0),
                                        make(0x181, CanFlag::kExtendedId, 1),
                                        make(0x1F00, CanFlag::kExtendedId, 1),
                                        make(0x100, CanFlag::kExtendedId | CanFlag::kRemote, 0),
                                        make(0x181, CanFlag::kFd, 12)};
  for (const CanFilter& filter : filters) {
    const can_filter k = to_kernel_filter(filter);
    for (const CanFrame& f : frames) {
      canfd_frame wire;
      ASSERT_NE(encode_socketcan(f, wire), 0u);
      const bool kernel = (wire.can_id & k.can_mask) == (k.can_id & k.can_mask);
      EXPECT_EQ(kernel, matches(filter, f)) << std::hex << filter.id << "/" << filter.mask
                                            << " frame " << f.id << " flags " << +f.flags;
    }
  }
}

// --- Error frames -> states -------------------------------------------------------------------

TEST(SocketCanErrorFrame, ControllerBitsMapToStates) {
  EXPECT_EQ(decode_error_frame(error_frame(CAN_ERR_CRTL, CAN_ERR_CRTL_RX_WARNING)).state,
            BusState::kErrorWarning);
  EXPECT_EQ(decode_error_frame(error_frame(CAN_ERR_CRTL, CAN_ERR_CRTL_TX_WARNING)).state,
            BusState::kErrorWarning);
  EXPECT_EQ(decode_error_frame(error_frame(CAN_ERR_CRTL, CAN_ERR_CRTL_RX_PASSIVE)).state,
            BusState::kErrorPassive);
  // can_change_state() sets both directions' bits: the worse one wins.
  const CanErrorReport both = decode_error_frame(
      error_frame(CAN_ERR_CRTL, CAN_ERR_CRTL_TX_PASSIVE | CAN_ERR_CRTL_RX_WARNING));
  EXPECT_TRUE(both.has_state);
  EXPECT_EQ(both.state, BusState::kErrorPassive);
  const CanErrorReport active = decode_error_frame(error_frame(CAN_ERR_CRTL, CAN_ERR_CRTL_ACTIVE));
  EXPECT_TRUE(active.has_state);
  EXPECT_EQ(active.state, BusState::kOk);
}

TEST(SocketCanErrorFrame, BusOffRestartOverflowAndCounters) {
  const CanErrorReport off = decode_error_frame(error_frame(CAN_ERR_BUSOFF));
  EXPECT_TRUE(off.bus_off);
  EXPECT_EQ(off.state, BusState::kBusOff);
  // Bus off outranks a controller bit in the same frame.
  EXPECT_EQ(
      decode_error_frame(error_frame(CAN_ERR_BUSOFF | CAN_ERR_CRTL, CAN_ERR_CRTL_TX_PASSIVE)).state,
      BusState::kBusOff);
  const CanErrorReport restarted = decode_error_frame(error_frame(CAN_ERR_RESTARTED));
  EXPECT_TRUE(restarted.restarted);
  EXPECT_TRUE(restarted.has_state);
  EXPECT_EQ(restarted.state, BusState::kOk);
  const CanErrorReport overflow =
      decode_error_frame(error_frame(CAN_ERR_CRTL, CAN_ERR_CRTL_RX_OVERFLOW));
  EXPECT_TRUE(overflow.controller_overflow);
  EXPECT_FALSE(overflow.has_state);  // an overflow alone says nothing about the state
  // Bus errors (protocol, ACK) carry no state.
  EXPECT_FALSE(decode_error_frame(error_frame(CAN_ERR_PROT | CAN_ERR_ACK)).has_state);
  CanFrame cnt = error_frame(CAN_ERR_CRTL | CAN_ERR_CNT, CAN_ERR_CRTL_TX_WARNING);
  cnt.data[6] = 100;
  cnt.data[7] = 7;
  const CanErrorReport c = decode_error_frame(cnt);
  EXPECT_TRUE(c.has_error_counters);
  EXPECT_EQ(c.tx_error_counter, 100);
  EXPECT_EQ(c.rx_error_counter, 7);
  // A data frame is not an error report even if its id has the same bits.
  EXPECT_FALSE(decode_error_frame(make(CAN_ERR_BUSOFF, 0, 8)).has_state);
}

// --- Timestamps -------------------------------------------------------------------------------

TEST(SocketCanTimestamp, RealtimeMapsToMonotonicAndIsCapped) {
  // Wall clock 1e18 ns when the monotonic clock reads 5e9: a frame 2 ms old.
  const std::int64_t real_now = 1'000'000'000'000'000'000;
  const std::int64_t mono_now = 5'000'000'000;
  EXPECT_EQ(realtime_to_monotonic_ns(real_now - 2'000'000, real_now, mono_now),
            mono_now - 2'000'000);
  // A receive time after "now" (wall clock stepped back in between) is capped at now.
  EXPECT_EQ(realtime_to_monotonic_ns(real_now + 1'000'000'000, real_now, mono_now), mono_now);
}

// --- Setup errors -----------------------------------------------------------------------------

TEST(SocketCanOpen, MissingInterfaceIsAClearError) {
  try {
    SocketCanBus bus("numen_nope0");
    FAIL() << "opened a missing interface";
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("'numen_nope0'"), std::string::npos) << what;
    EXPECT_NE(what.find("does not exist"), std::string::npos) << what;
    EXPECT_NE(what.find("No such device"), std::string::npos) << what;  // strerror(ENODEV)
  }
}

TEST(SocketCanOpen, BadArgumentsNameTheField) {
  SocketCanOptions o;
  o.write_attempts = 0;
  try {
    SocketCanBus bus("vcan0", {}, o);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("write_attempts"), std::string::npos);
  }
  o = SocketCanOptions{};
  o.error_classes = CAN_ERR_FLAG;
  EXPECT_THROW(SocketCanBus("vcan0", {}, o), std::invalid_argument);
  const std::vector<CanFilter> too_many(CAN_RAW_FILTER_MAX + 1);
  EXPECT_THROW(SocketCanBus("vcan0", too_many), std::invalid_argument);
  EXPECT_THROW(SocketCanBus("a_name_longer_than_15"), std::invalid_argument);
  EXPECT_THROW(SocketCanBus(""), std::invalid_argument);
}

TEST(SocketCanOpen, ClosedPortFails) {
  SocketCanBus bus;
  CanFrame f;
  EXPECT_EQ(bus.read(f), IoStatus::kError);
  EXPECT_EQ(bus.write(make(0x100, 0, 1)), IoStatus::kError);
  EXPECT_EQ(bus.counters().errors, 2u);
  EXPECT_FALSE(bus.wait_readable(0));
}

// --- read/write paths over an adopted datagram socketpair -------------------------------------

// One end adopted by a SocketCanBus, the other kept raw to play the kernel's CAN side.
class SocketCanPair : public ::testing::Test {
 protected:
  void SetUp() override { open_pair(SocketCanOptions{}); }
  void TearDown() override {
    if (peer_ >= 0) ::close(peer_);
  }
  void open_pair(const SocketCanOptions& options) {
    int sv[2];
    ASSERT_EQ(socketpair(AF_UNIX, SOCK_DGRAM, 0, sv), 0);
    if (peer_ >= 0) ::close(peer_);
    peer_ = sv[1];
    bus_.adopt(sv[0], "pair", options);
  }
  void peer_send(const CanFrame& f) {
    canfd_frame wire;
    const std::size_t n = encode_socketcan(f, wire);
    ASSERT_NE(n, 0u);
    ASSERT_EQ(send(peer_, &wire, n, 0), static_cast<ssize_t>(n));
  }
  SocketCanBus bus_;
  int peer_ = -1;
};

TEST_F(SocketCanPair, WriteSendsCanMtuOrCanfdMtuBytes) {
  const CanFrame classic = make(0x201, 0, 2, 9);
  ASSERT_EQ(bus_.write(classic), IoStatus::kOk);
  canfd_frame got{};
  ASSERT_EQ(recv(peer_, &got, sizeof(got), MSG_DONTWAIT), CAN_MTU);
  EXPECT_EQ(got.can_id, 0x201u);
  EXPECT_EQ(got.len, 2);
  EXPECT_EQ(got.data[1], 9 + 7);
  const CanFrame fd = make(0x1ABCDE, CanFlag::kFd | CanFlag::kExtendedId, 20, 4);
  ASSERT_EQ(bus_.write(fd), IoStatus::kOk);
  ASSERT_EQ(recv(peer_, &got, sizeof(got), MSG_DONTWAIT), CANFD_MTU);
  EXPECT_EQ(got.can_id, CAN_EFF_FLAG | 0x1ABCDEu);
  EXPECT_EQ(0, std::memcmp(got.data, fd.data.data(), 20));
  EXPECT_EQ(bus_.counters().frames_tx, 2u);
}

TEST_F(SocketCanPair, ReadReturnsFramesWithMonotonicReceiveTime) {
  const CanFrame fd = make(0x181, CanFlag::kFd | CanFlag::kBitRateSwitch, 64, 5);
  const std::int64_t before = mono_ns();
  peer_send(fd);
  peer_send(make(0x182, 0, 4, 6));
  CanFrame got;
  ASSERT_EQ(bus_.read(got), IoStatus::kOk);
  const std::int64_t after = mono_ns();
  expect_same(fd, got);
  // SO_TIMESTAMPNS (CLOCK_REALTIME) mapped onto CLOCK_MONOTONIC: between send and read, with
  // slack for the two clocks being read a few ns apart.
  EXPECT_GE(got.timestamp_ns, before - 1'000'000);
  EXPECT_LE(got.timestamp_ns, after);
  const std::int64_t first = got.timestamp_ns;
  ASSERT_EQ(bus_.read(got), IoStatus::kOk);
  EXPECT_EQ(got.id, 0x182u);
  EXPECT_GE(got.timestamp_ns, first);
  EXPECT_EQ(bus_.socketcan_counters().no_kernel_timestamp, 0u);
  EXPECT_EQ(bus_.read(got), IoStatus::kWouldBlock);
  EXPECT_EQ(got.id, 0x182u);  // unchanged
  EXPECT_EQ(bus_.counters().frames_rx, 2u);
}

TEST_F(SocketCanPair, MalformedDatagramsAreSkippedAndCounted) {
  const std::array<std::uint8_t, 5> junk{1, 2, 3, 4, 5};
  ASSERT_EQ(send(peer_, junk.data(), junk.size(), 0), 5);
  canfd_frame bad{};
  bad.can_id = 0x100;
  bad.len = 13;  // not an FD length
  ASSERT_EQ(send(peer_, &bad, CANFD_MTU, 0), CANFD_MTU);
  peer_send(make(0x183, 0, 1));
  CanFrame got;
  ASSERT_EQ(bus_.read(got), IoStatus::kOk);
  EXPECT_EQ(got.id, 0x183u);
  EXPECT_EQ(bus_.socketcan_counters().malformed_rx, 2u);
  EXPECT_EQ(bus_.counters().frames_rx, 1u);
  EXPECT_EQ(bus_.counters().errors, 0u);
}

TEST_F(SocketCanPair, ErrorFramesDriveStateAndAreReturned) {
  CanFrame got;
  peer_send(error_frame(CAN_ERR_CRTL, CAN_ERR_CRTL_TX_WARNING));
  ASSERT_EQ(bus_.read(got), IoStatus::kOk);
  EXPECT_TRUE(got.error_frame());
  EXPECT_EQ(got.id, CAN_ERR_CRTL);
  EXPECT_EQ(bus_.state(), BusState::kErrorWarning);
  peer_send(error_frame(CAN_ERR_CRTL, CAN_ERR_CRTL_RX_PASSIVE));
  ASSERT_EQ(bus_.read(got), IoStatus::kOk);
  EXPECT_EQ(bus_.state(), BusState::kErrorPassive);
  peer_send(error_frame(CAN_ERR_BUSOFF));
  ASSERT_EQ(bus_.read(got), IoStatus::kOk);
  EXPECT_EQ(bus_.state(), BusState::kBusOff);
  EXPECT_FALSE(bus_.link_down());  // a controller bus off, not an interface down
  // Bus off: nothing is queued for transmission.
  EXPECT_EQ(bus_.write(make(0x080, 0, 0)), IoStatus::kError);
  canfd_frame none;
  EXPECT_LT(recv(peer_, &none, sizeof(none), MSG_DONTWAIT), 0);
  peer_send(error_frame(CAN_ERR_RESTARTED));
  ASSERT_EQ(bus_.read(got), IoStatus::kOk);
  EXPECT_EQ(bus_.state(), BusState::kOk);
  EXPECT_EQ(bus_.write(make(0x080, 0, 0)), IoStatus::kOk);
  const SocketCanCounters& c = bus_.socketcan_counters();
  EXPECT_EQ(c.error_frames, 4u);
  EXPECT_EQ(c.bus_off, 1u);
  EXPECT_EQ(c.restarts, 1u);
  EXPECT_EQ(bus_.counters().frames_rx, 4u);
}

TEST_F(SocketCanPair, WriteRefusesWhatTheOptionsForbid) {
  EXPECT_EQ(bus_.write(make(0x800, 0, 1)), IoStatus::kError);  // malformed
  EXPECT_EQ(bus_.write(error_frame(CAN_ERR_BUSOFF)), IoStatus::kError);
  SocketCanOptions o;
  o.fd_frames = false;
  o.allow_error_frame_write = true;
  open_pair(o);
  EXPECT_EQ(bus_.write(make(0x100, CanFlag::kFd, 12)), IoStatus::kError);
  EXPECT_EQ(bus_.write(error_frame(CAN_ERR_BUSOFF)), IoStatus::kOk);
  EXPECT_EQ(bus_.counters().errors, 3u);
}

TEST_F(SocketCanPair, FullQueueGivesWouldBlockAfterRetries) {
  SocketCanOptions o;
  o.write_attempts = 4;
  open_pair(o);
  // The peer never reads: its receive queue (net.unix.max_dgram_qlen, or the buffer) fills.
  int accepted = 0;
  IoStatus s = IoStatus::kOk;
  while (accepted < 100000 && (s = bus_.write(make(0x181, CanFlag::kFd, 64))) == IoStatus::kOk) {
    ++accepted;
  }
  ASSERT_EQ(s, IoStatus::kWouldBlock);
  EXPECT_GT(accepted, 0);
  EXPECT_EQ(bus_.counters().tx_would_block, 1u);
  EXPECT_EQ(bus_.socketcan_counters().tx_retries, 3u);  // 4 attempts = 3 retries
  EXPECT_EQ(bus_.socketcan_counters().last_errno, EAGAIN);
  EXPECT_EQ(bus_.counters().frames_tx, static_cast<std::uint64_t>(accepted));
  // Draining one frame makes room again.
  canfd_frame got;
  ASSERT_EQ(recv(peer_, &got, sizeof(got), 0), CANFD_MTU);
  EXPECT_EQ(bus_.write(make(0x181, CanFlag::kFd, 64)), IoStatus::kOk);
}

TEST_F(SocketCanPair, PeerGoneIsAnErrorNotALinkDown) {
  ::close(peer_);
  peer_ = -1;
  EXPECT_EQ(bus_.write(make(0x181, 0, 1)), IoStatus::kError);
  EXPECT_NE(bus_.socketcan_counters().last_errno, 0);
  EXPECT_FALSE(bus_.link_down());
}

TEST_F(SocketCanPair, ReadAndWriteDoNotAllocate) {
  for (int i = 0; i < 8; ++i) peer_send(make(0x181 + i, i % 2 ? CanFlag::kFd : 0, 8));
  peer_send(error_frame(CAN_ERR_CRTL, CAN_ERR_CRTL_RX_WARNING));
  CanFrame got;
  numen::test::AllocationGuard guard;
  int read = 0;
  while (bus_.read(got) == IoStatus::kOk) ++read;
  for (int i = 0; i < 8; ++i) EXPECT_EQ(bus_.write(make(0x201, CanFlag::kFd, 16)), IoStatus::kOk);
  (void)bus_.state();
  (void)bus_.counters();
  EXPECT_EQ(guard.count(), 0);
  EXPECT_EQ(read, 9);
}

TEST_F(SocketCanPair, WaitReadableSeesAPendingFrameAndTimesOut) {
  const std::int64_t t0 = mono_ns();
  EXPECT_FALSE(bus_.wait_readable(20'000'000));
  EXPECT_GE(mono_ns() - t0, 15'000'000);
  peer_send(make(0x181, 0, 1));
  EXPECT_TRUE(bus_.wait_readable(1'000'000'000));
}

}  // namespace
}  // namespace numen::hal
