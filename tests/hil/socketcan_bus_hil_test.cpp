// SocketCanBus on real virtual CAN interfaces, inside the qemu guest of tests/hil/run.sh
// (the build host's kernel has no CAN). The guest's /init creates:
//   vcan0: CAN FD capable (mtu 72), up;   vcan1: classic only (mtu 16), up.
// Tests that take an interface down, or delete it, use vcan1 and restore it before returning.
#include <gtest/gtest.h>
#include <linux/can/error.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

#include "alloc_counter.hpp"
#include "can_test_frames.hpp"
#include "numen/hal/transport/socketcan_bus.hpp"

namespace numen::hal {
namespace {

using test::error_frame;
using test::expect_same;
using test::make;
using test::mono_ns;

constexpr const char* kFdIf = "vcan0";
constexpr const char* kClassicIf = "vcan1";

// Sets or clears IFF_UP like `ip link set dev NAME up|down` (the guest runs as root).
void set_up(const char* name, bool up) {
  const int s = socket(AF_INET, SOCK_DGRAM, 0);
  ASSERT_GE(s, 0);
  ifreq req{};
  std::strncpy(req.ifr_name, name, IFNAMSIZ - 1);
  ASSERT_EQ(ioctl(s, SIOCGIFFLAGS, &req), 0) << std::strerror(errno);
  if (up) {
    req.ifr_flags = static_cast<short>(req.ifr_flags | IFF_UP);
  } else {
    req.ifr_flags = static_cast<short>(req.ifr_flags & ~IFF_UP);
  }
  ASSERT_EQ(ioctl(s, SIOCSIFFLAGS, &req), 0) << std::strerror(errno);
  close(s);
}

// Reads with wait_readable until `count` frames arrived or nothing came for `idle_ns`.
std::vector<CanFrame> drain(SocketCanBus& bus, std::size_t count, std::int64_t idle_ns) {
  std::vector<CanFrame> out;
  out.reserve(count);
  CanFrame f;
  while (out.size() < count) {
    const IoStatus s = bus.read(f);
    if (s == IoStatus::kOk) {
      out.push_back(f);
    } else if (s == IoStatus::kWouldBlock) {
      if (!bus.wait_readable(idle_ns)) break;
    } else {
      ADD_FAILURE() << "read error, errno " << bus.socketcan_counters().last_errno;
      break;
    }
  }
  return out;
}

TEST(SocketCanHil, OpensAnExistingInterfaceAndNamesAMissingOne) {
  SocketCanBus bus(kFdIf);
  EXPECT_TRUE(bus.is_open());
  EXPECT_EQ(bus.state(), BusState::kOk);
  EXPECT_FALSE(bus.link_down());
  try {
    SocketCanBus missing("vcan9");
    FAIL() << "vcan9 opened";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("'vcan9' does not exist"), std::string::npos) << e.what();
  }
}

TEST(SocketCanHil, ClassicAndFdFramesCrossByteExact) {
  SocketCanBus a(kFdIf);
  SocketCanBus b(kFdIf);
  std::vector<CanFrame> sent;
  for (std::uint8_t len = 0; len <= 8; ++len) sent.push_back(make(0x100 + len, 0, len, len));
  sent.push_back(make(0x7FF, CanFlag::kRemote, 5));
  sent.push_back(make(0x1FFFFFFF, CanFlag::kExtendedId, 8, 0xAA));
  sent.push_back(make(0x0ABCDEF, CanFlag::kExtendedId | CanFlag::kRemote, 0));
  for (std::uint8_t len : {0, 1, 8, 12, 16, 20, 24, 32, 48, 64}) {
    sent.push_back(make(0x200 + len, CanFlag::kFd, len, len));
  }
  sent.push_back(make(0x300, CanFlag::kFd | CanFlag::kBitRateSwitch, 64, 3));
  sent.push_back(make(0x301, CanFlag::kFd | CanFlag::kErrorStateIndicator, 12, 4));
  sent.push_back(
      make(0x1234567, CanFlag::kFd | CanFlag::kExtendedId | CanFlag::kBitRateSwitch, 48, 5));
  for (const CanFrame& f : sent) ASSERT_EQ(a.write(f), IoStatus::kOk) << std::hex << f.id;
  const std::vector<CanFrame> got = drain(b, sent.size() + 1, 200'000'000);
  ASSERT_EQ(got.size(), sent.size());
  for (std::size_t i = 0; i < sent.size(); ++i) expect_same(sent[i], got[i]);
  // The writer does not read its own frames (CAN_RAW_RECV_OWN_MSGS off).
  CanFrame f;
  EXPECT_EQ(a.read(f), IoStatus::kWouldBlock);
  EXPECT_EQ(a.counters().frames_tx, sent.size());
  EXPECT_EQ(b.counters().frames_rx, sent.size());
  EXPECT_EQ(b.counters().dropped, 0u);
  EXPECT_EQ(b.socketcan_counters().malformed_rx, 0u);
}

TEST(SocketCanHil, ReceiveOwnMessagesOption) {
  SocketCanOptions o;
  o.receive_own_messages = true;
  SocketCanBus a(kFdIf, {}, o);
  ASSERT_EQ(a.write(make(0x123, 0, 2)), IoStatus::kOk);
  const std::vector<CanFrame> got = drain(a, 1, 200'000'000);
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].id, 0x123u);
}

TEST(SocketCanHil, KernelFiltersKeepNonMatchingFramesOutUnderAFlood) {
  const std::array<CanFilter, 3> filters{
      exact_standard_filter(0x181),
      CanFilter{0x200, 0x780 | kFilterExtendedBit | kFilterRemoteBit},  // 0x200-0x27F data
      CanFilter{kFilterExtendedBit | 0x18FF0000u, kFilterExtendedBit | 0x1FFF0000u}};
  SocketCanBus a(kFdIf);
  SocketCanBus filtered(kFdIf, filters);
  SocketCanBus all(kFdIf);  // control: sees the whole flood
  std::size_t expected = 0;
  std::size_t sent = 0;
  std::vector<CanFrame> got_filtered;
  std::size_t got_all = 0;
  // Drains both readers often enough that no receive buffer overflows (~200 frames fit in the
  // default 208 KiB: the kernel accounts each CAN skb at ~1 KiB). The writer waits until the
  // control reader has every frame sent so far (up to 200 ms without one): vcan delivers through
  // the receive softirq, which a guest starved by its host defers, and 64 writes per drain would
  // otherwise pile up into one burst of many hundreds. The filters see the same flood. Once the
  // control reader has waited that long in vain (frames lost: the counts below say so), the
  // writer stops waiting, so a lossy bus fails the test in 200 ms, not in one wait per drain.
  bool frames_lost = false;
  const auto drain_now = [&] {
    CanFrame f;
    while (got_all < sent && !frames_lost) {
      if (all.read(f) == IoStatus::kOk) {
        ++got_all;
      } else if (!all.wait_readable(200'000'000)) {
        frames_lost = true;
      }
    }
    while (all.read(f) == IoStatus::kOk) ++got_all;
    while (filtered.read(f) == IoStatus::kOk) got_filtered.push_back(f);
  };
  // 20 rounds of every third 11-bit id, remote requests, and 29-bit ids in and near the range.
  for (int round = 0; round < 20; ++round) {
    for (std::uint32_t id = 0; id <= 0x7FF; id += 3) {
      const CanFrame f = (id % 7 == 0) ? make(id, CanFlag::kRemote, 1)
                         : (id % 5 == 0)
                             ? make(0x18FF0000u | (id & 0x1FF) << 7, CanFlag::kExtendedId, 8)
                         : (id % 11 == 0) ? make(0x18FE0000u | id, CanFlag::kExtendedId, 8)
                                          : make(id, round % 2 ? CanFlag::kFd : 0, 8);
      ASSERT_EQ(a.write(f), IoStatus::kOk);
      ++sent;
      if (passes(filters, f)) ++expected;
      if (sent % 64 == 0) drain_now();
    }
  }
  for (const CanFrame& f : drain(filtered, expected + 1, 200'000'000)) got_filtered.push_back(f);
  got_all += drain(all, sent + 1, 200'000'000).size();
  ASSERT_GT(expected, 100u);
  ASSERT_LT(expected, sent / 4);
  EXPECT_EQ(got_all, sent);
  EXPECT_EQ(got_filtered.size(), expected);
  for (const CanFrame& f : got_filtered) {
    ASSERT_TRUE(passes(filters, f)) << "filtered id " << std::hex << f.id << " flags " << +f.flags;
  }
  EXPECT_EQ(filtered.counters().dropped, 0u);
  EXPECT_EQ(all.counters().dropped, 0u);
}

TEST(SocketCanHil, EmptyFilterListPassesAllAndFiltersCanChange) {
  SocketCanBus a(kFdIf);
  SocketCanBus b(kFdIf);
  ASSERT_EQ(a.write(make(0x042, 0, 1)), IoStatus::kOk);
  EXPECT_EQ(drain(b, 2, 100'000'000).size(), 1u);
  const std::array<CanFilter, 1> only{exact_standard_filter(0x043)};
  b.set_filters(only);
  ASSERT_EQ(a.write(make(0x042, 0, 1)), IoStatus::kOk);
  ASSERT_EQ(a.write(make(0x043, 0, 1)), IoStatus::kOk);
  const std::vector<CanFrame> got = drain(b, 2, 100'000'000);
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].id, 0x043u);
  b.set_filters({});
  ASSERT_EQ(a.write(make(0x042, 0, 1)), IoStatus::kOk);
  EXPECT_EQ(drain(b, 2, 100'000'000).size(), 1u);
}

TEST(SocketCanHil, ReceiveTimestampsAreMonotonicAndRecent) {
  SocketCanBus a(kFdIf);
  SocketCanBus b(kFdIf);
  std::int64_t previous = 0;
  std::int64_t worst_backwards = 0;
  for (int i = 0; i < 200; ++i) {
    const std::int64_t before = mono_ns();
    ASSERT_EQ(a.write(make(0x100, 0, 1, static_cast<std::uint8_t>(i))), IoStatus::kOk);
    const std::vector<CanFrame> got = drain(b, 1, 200'000'000);
    const std::int64_t after = mono_ns();
    ASSERT_EQ(got.size(), 1u);
    const std::int64_t t = got[0].timestamp_ns;
    // Kernel receive time (SO_TIMESTAMPNS, CLOCK_REALTIME) mapped to CLOCK_MONOTONIC: after
    // the write started (slack: the two clocks are read a little apart, and an emulated CPU
    // can be preempted between them), before the read ended. In order, within the mapping's
    // own error: each read maps with the offset of its own pair of clock reads, and an emulated
    // vCPU preempted inside all three of a read's pairs moves that read's offset by up to the
    // preemption (CI once saw 394 us backwards under load).
    EXPECT_GE(t, before - 5'000'000) << i;
    EXPECT_LE(t, after) << i;
    EXPECT_GE(t, previous - 5'000'000) << i;
    worst_backwards = std::max(worst_backwards, previous - t);
    previous = t;
  }
  std::printf("HIL-METRIC timestamp_worst_backwards_ns=%lld\n",
              static_cast<long long>(worst_backwards));
  EXPECT_EQ(b.socketcan_counters().no_kernel_timestamp, 0u);
}

TEST(SocketCanHil, NonBlockingReadOnAnEmptyBusReturnsAtOnce) {
  const std::array<CanFilter, 1> silent{exact_standard_filter(0x7EE)};  // nobody sends it
  SocketCanBus b(kFdIf, silent);
  CanFrame f;
  std::int64_t worst = 0;
  const std::int64_t t0 = mono_ns();
  for (int i = 0; i < 1000; ++i) {
    const std::int64_t s = mono_ns();
    ASSERT_EQ(b.read(f), IoStatus::kWouldBlock);
    worst = std::max(worst, mono_ns() - s);
  }
  const std::int64_t total = mono_ns() - t0;
  // Emulated (TCG) syscalls take microseconds, a preempted vCPU some milliseconds; a read that
  // blocked would never return (the scenario's timeout fails it).
  EXPECT_LT(worst, 200'000'000) << "worst read " << worst << " ns";
  EXPECT_LT(total, 1'000'000'000) << "1000 reads took " << total << " ns";
  RecordProperty("empty_read_mean_ns", std::to_string(total / 1000));
  std::printf("HIL-METRIC empty_read_mean_ns=%lld worst_ns=%lld\n",
              static_cast<long long>(total / 1000), static_cast<long long>(worst));
}

TEST(SocketCanHil, ReceiveOverflowIsCountedAsDropped) {
  SocketCanOptions small;
  small.receive_buffer_bytes = 4096;  // the kernel doubles it: a handful of frames fit
  SocketCanBus a(kFdIf);
  SocketCanBus b(kFdIf, {}, small);
  constexpr int kFlood = 2000;
  for (int i = 0; i < kFlood; ++i) ASSERT_EQ(a.write(make(0x300, 0, 8)), IoStatus::kOk);
  const std::size_t kept = drain(b, kFlood + 1, 100'000'000).size();
  ASSERT_GT(kept, 0u);
  ASSERT_LT(kept, static_cast<std::size_t>(kFlood));
  // The running drop count (SO_RXQ_OVFL) rides on frames queued after the drops: one more.
  ASSERT_EQ(a.write(make(0x301, 0, 1)), IoStatus::kOk);
  const std::vector<CanFrame> marker = drain(b, 1, 200'000'000);
  ASSERT_EQ(marker.size(), 1u);
  EXPECT_EQ(marker[0].id, 0x301u);
  EXPECT_EQ(b.counters().dropped, kFlood - kept);
  EXPECT_EQ(b.counters().frames_rx, kept + 1);
  std::printf("HIL-METRIC overflow_kept=%zu dropped=%llu\n", kept,
              static_cast<unsigned long long>(b.counters().dropped));
}

TEST(SocketCanHil, InterfaceDownIsAnErrorAndUpRecovers) {
  SocketCanBus a(kClassicIf);
  SocketCanBus b(kClassicIf);
  ASSERT_EQ(a.write(make(0x100, 0, 1)), IoStatus::kOk);
  ASSERT_EQ(drain(b, 1, 200'000'000).size(), 1u);
  set_up(kClassicIf, false);
  EXPECT_EQ(a.write(make(0x101, 0, 1)), IoStatus::kError);
  EXPECT_TRUE(a.link_down());
  EXPECT_EQ(a.state(), BusState::kBusOff);
  EXPECT_EQ(a.controller_state(), BusState::kOk);
  EXPECT_EQ(a.socketcan_counters().last_errno, ENETDOWN);
  CanFrame f;
  EXPECT_EQ(b.read(f), IoStatus::kError);  // the socket's pending ENETDOWN
  EXPECT_TRUE(b.link_down());
  EXPECT_EQ(b.read(f), IoStatus::kError);  // still down: every call says so
  EXPECT_FALSE(b.refresh_link());
  EXPECT_FALSE(b.needs_reopen());
  set_up(kClassicIf, true);
  // The sockets stay bound across down/up: no reopen needed.
  EXPECT_EQ(a.write(make(0x102, 0, 1)), IoStatus::kOk);
  EXPECT_FALSE(a.link_down());
  const std::vector<CanFrame> got = drain(b, 1, 200'000'000);
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].id, 0x102u);
  EXPECT_FALSE(b.link_down());  // a frame received after the failure
  EXPECT_EQ(b.state(), BusState::kOk);
  EXPECT_EQ(a.socketcan_counters().link_down, 1u);
  EXPECT_EQ(b.socketcan_counters().link_down, 1u);
  // refresh_link() alone also sees the link come back.
  set_up(kClassicIf, false);
  EXPECT_FALSE(b.refresh_link());
  set_up(kClassicIf, true);
  EXPECT_TRUE(b.refresh_link());
  EXPECT_EQ(b.read(f), IoStatus::kWouldBlock);  // the stale ENETDOWN was cleared
  EXPECT_FALSE(b.link_down());
}

TEST(SocketCanHil, DeletedInterfaceNeedsReopen) {
  SocketCanBus a(kClassicIf);
  SocketCanBus b(kClassicIf);
  ASSERT_EQ(std::system("ip link del dev vcan1"), 0);
  CanFrame f;
  EXPECT_EQ(b.read(f), IoStatus::kError);  // ENODEV: unbound
  EXPECT_TRUE(b.needs_reopen());
  EXPECT_EQ(a.write(make(0x100, 0, 1)), IoStatus::kError);
  EXPECT_TRUE(a.link_down());
  EXPECT_THROW(b.reopen(), std::runtime_error);  // not there yet
  EXPECT_FALSE(b.is_open());
  // vcan's default MTU is CANFD_MTU: set it back to classic like /init did.
  ASSERT_EQ(std::system("ip link add dev vcan1 type vcan && ip link set dev vcan1 mtu 16 && "
                        "ip link set dev vcan1 up"),
            0);
  EXPECT_FALSE(a.refresh_link());  // up again, but this socket was unbound
  EXPECT_TRUE(a.needs_reopen());
  a.reopen();
  b.reopen();
  EXPECT_FALSE(a.link_down());
  ASSERT_EQ(a.write(make(0x103, 0, 1)), IoStatus::kOk);
  const std::vector<CanFrame> got = drain(b, 1, 200'000'000);
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].id, 0x103u);
  EXPECT_EQ(a.socketcan_counters().reopens, 1u);
  EXPECT_EQ(b.socketcan_counters().reopens, 1u);
}

TEST(SocketCanHil, MalformedFramesFromARawSocketAreSkippedAndCounted) {
  // The kernel passes an FD frame with a length that is no FD length (13) and an 11-bit
  // frame with bits above 0x7FF set: a raw socket sends them byte for byte.
  const int raw = socket(PF_CAN, SOCK_RAW, CAN_RAW);
  ASSERT_GE(raw, 0);
  const int on = 1;
  ASSERT_EQ(setsockopt(raw, SOL_CAN_RAW, CAN_RAW_FD_FRAMES, &on, sizeof(on)), 0);
  sockaddr_can addr{};
  addr.can_family = AF_CAN;
  addr.can_ifindex = static_cast<int>(if_nametoindex(kFdIf));
  ASSERT_EQ(bind(raw, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr)), 0);
  SocketCanBus b(kFdIf);
  canfd_frame bad{};
  bad.can_id = 0x120;
  bad.len = 13;
  ASSERT_EQ(send(raw, &bad, CANFD_MTU, 0), CANFD_MTU) << std::strerror(errno);
  bad.can_id = 0x900;  // 11-bit frame, bit 11 set
  bad.len = 1;
  ASSERT_EQ(send(raw, &bad, CAN_MTU, 0), CAN_MTU) << std::strerror(errno);
  canfd_frame good{};
  good.can_id = 0x121;
  good.len = 2;
  good.data[1] = 0x5A;
  ASSERT_EQ(send(raw, &good, CAN_MTU, 0), CAN_MTU) << std::strerror(errno);
  close(raw);
  const std::vector<CanFrame> got = drain(b, 3, 200'000'000);
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].id, 0x121u);
  EXPECT_EQ(got[0].data[1], 0x5A);
  EXPECT_EQ(b.socketcan_counters().malformed_rx, 2u);
  EXPECT_EQ(b.counters().errors, 0u);
}

TEST(SocketCanHil, FdFrameOnAClassicInterfaceIsAnError) {
  SocketCanBus a(kClassicIf);
  EXPECT_EQ(a.write(make(0x100, CanFlag::kFd, 12)), IoStatus::kError);
  EXPECT_EQ(a.socketcan_counters().last_errno, EINVAL);
  EXPECT_FALSE(a.link_down());
  EXPECT_EQ(a.write(make(0x100, 0, 8)), IoStatus::kOk);
}

TEST(SocketCanHil, InjectedErrorFramesDriveTheStateMachine) {
  SocketCanOptions inject;
  inject.allow_error_frame_write = true;
  SocketCanBus a(kFdIf, {}, inject);
  SocketCanBus b(kFdIf);
  SocketCanOptions deaf;
  deaf.error_classes = 0;
  SocketCanBus c(kFdIf, {}, deaf);
  SocketCanOptions bus_off_only;
  bus_off_only.error_classes = CAN_ERR_BUSOFF;
  SocketCanBus d(kFdIf, {}, bus_off_only);

  const auto step = [&](const CanFrame& e, BusState expected) {
    ASSERT_EQ(a.write(e), IoStatus::kOk);
    const std::vector<CanFrame> got = drain(b, 1, 200'000'000);
    ASSERT_EQ(got.size(), 1u);
    EXPECT_TRUE(got[0].error_frame());
    EXPECT_EQ(got[0].id, e.id);
    EXPECT_EQ(b.state(), expected);
  };
  step(error_frame(CAN_ERR_CRTL, CAN_ERR_CRTL_RX_WARNING), BusState::kErrorWarning);
  step(error_frame(CAN_ERR_CRTL, CAN_ERR_CRTL_TX_PASSIVE), BusState::kErrorPassive);
  step(error_frame(CAN_ERR_CRTL, CAN_ERR_CRTL_ACTIVE), BusState::kOk);
  step(error_frame(CAN_ERR_PROT | CAN_ERR_ACK), BusState::kOk);  // bus error: no state change
  step(error_frame(CAN_ERR_BUSOFF), BusState::kBusOff);
  EXPECT_EQ(b.write(make(0x080, 0, 0)), IoStatus::kError);  // refused while bus off
  EXPECT_FALSE(b.link_down());
  step(error_frame(CAN_ERR_RESTARTED), BusState::kOk);
  EXPECT_EQ(b.write(make(0x080, 0, 0)), IoStatus::kOk);
  EXPECT_EQ(b.socketcan_counters().error_frames, 6u);
  EXPECT_EQ(b.socketcan_counters().bus_off, 1u);
  EXPECT_EQ(b.socketcan_counters().restarts, 1u);
  // Subscriptions: c asked for no error class, d only for bus off.
  CanFrame f;
  const std::vector<CanFrame> c_got = drain(c, 10, 100'000'000);
  EXPECT_EQ(
      std::count_if(c_got.begin(), c_got.end(), [](const CanFrame& x) { return x.error_frame(); }),
      0);
  const std::vector<CanFrame> d_got = drain(d, 10, 100'000'000);
  ASSERT_EQ(d_got.size(), 2u);  // the bus-off report, and b's SYNC after the restart
  EXPECT_EQ(d_got[0].id, CAN_ERR_BUSOFF);
  EXPECT_EQ(d.state(), BusState::kBusOff);  // it never saw the restart it did not ask for
  (void)f;
}

TEST(SocketCanHil, ReadAndWriteDoNotAllocate) {
  SocketCanBus a(kFdIf);
  SocketCanBus b(kFdIf);
  CanFrame f;
  int read = 0;
  {
    numen::test::AllocationGuard guard;
    for (int i = 0; i < 64; ++i) {
      ASSERT_EQ(a.write(make(0x181, i % 2 ? CanFlag::kFd : 0, 8)), IoStatus::kOk);
      while (b.read(f) == IoStatus::kOk) ++read;
    }
    (void)b.state();
    (void)b.counters();
    EXPECT_EQ(guard.count(), 0);
  }
  read += static_cast<int>(drain(b, 64, 100'000'000).size());
  EXPECT_EQ(read, 64);
}

TEST(SocketCanHil, WaitReadableTimesOutThenSeesAFrame) {
  SocketCanBus a(kFdIf);
  SocketCanBus b(kFdIf);
  const std::int64_t t0 = mono_ns();
  EXPECT_FALSE(b.wait_readable(50'000'000));
  EXPECT_GE(mono_ns() - t0, 40'000'000);
  ASSERT_EQ(a.write(make(0x181, 0, 1)), IoStatus::kOk);
  EXPECT_TRUE(b.wait_readable(1'000'000'000));
}

}  // namespace
}  // namespace numen::hal
