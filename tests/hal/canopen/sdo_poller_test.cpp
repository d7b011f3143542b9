// Tests of hal/canopen/sdo_poller: periodic reads against the emulated nodes over SimBus, one
// transfer per node at a time, at their rate; a refused read and a silent node counted; no
// allocation while it runs.
#include "numen/hal/canopen/sdo_poller.hpp"

#include <gtest/gtest.h>

#include <stdexcept>

#include "alloc_counter.hpp"
#include "numen/hal/emulation/device_emulator.hpp"
#include "numen/hal/transport/sim_bus.hpp"
#include "test_constants.hpp"

namespace {

using namespace numen::hal;

using numen::test::kMs;

struct PollerRig {
  DeviceEmulator emulator{make_default_trocar_config(1)};
  SimBus bus{SimBusSettings{}};
  std::int64_t t = 0;
  PollerRig() { emulator.tick(0, bus.device()); }  // boot-ups: pre-operational, SDO allowed
  void period(SdoPoller& p) {
    t += kMs;
    bus.set_time_ns(t);
    p.begin_period(t, bus.controller());
    emulator.poll(bus.device());
    CanFrame f;
    while (bus.controller().read(f) == IoStatus::kOk) (void)p.on_frame(f);
    p.update(t);
  }
};

TEST(SdoPoller, ReadsEachObjectAtItsRateOneTransferPerNode) {
  PollerRig rig;
  const PeriodicRead reads[] = {{1, {0x1001, 0}, 10}, {1, {0x1018, 2}, 10}, {4, {0x1018, 4}, 5}};
  SdoPoller p(reads, 50 * kMs);
  {
    numen::test::AllocationGuard guard;
    for (int k = 0; k < 100; ++k) rig.period(p);
    EXPECT_EQ(guard.count(), 0);
  }
  const auto r = p.results();
  // Node 1's two reads share its channel: the second waits one period behind the first.
  EXPECT_EQ(r[0].reads, 10u);
  EXPECT_EQ(r[1].reads, 10u);
  EXPECT_EQ(r[2].reads, 20u);
  EXPECT_EQ(r[0].value, 0u);  // no error
  EXPECT_EQ(r[0].size, 1);
  EXPECT_EQ(r[1].value, 0x402u);  // a drive node's product code
  EXPECT_EQ(r[2].value, 4u);      // node 4's serial number
  EXPECT_EQ(p.counters().completed, 40u);
  EXPECT_EQ(p.counters().aborted + p.counters().timeouts, 0u);
}

TEST(SdoPoller, LiveStatuswordFollowsTheDrive) {
  PollerRig rig;
  const PeriodicRead reads[] = {{1, {0x6041, 0}, 1}};
  SdoPoller p(reads, 50 * kMs);
  CanFrame f;
  encode_nmt(NmtCommand::kStartRemoteNode, 0, rig.t, f);
  (void)rig.bus.controller().write(f);
  for (int k = 0; k < 5; ++k) {
    (void)rig.bus.controller().write(make_sync(rig.t));  // the drive steps: switch on disabled
    rig.period(p);
  }
  EXPECT_EQ(p.results()[0].value, rig.emulator.drive(0)->statusword());
  EXPECT_EQ(p.results()[0].value & 0x4Fu, 0x40u);  // switch on disabled
}

TEST(SdoPoller, RefusedAndUnansweredReadsAreCounted) {
  PollerRig rig;
  const PeriodicRead reads[] = {{4, {0x6041, 0}, 2}, {9, {0x1001, 0}, 100}};  // no drive; no node
  SdoPoller p(reads, 10 * kMs);
  for (int k = 0; k < 30; ++k) rig.period(p);
  EXPECT_EQ(p.results()[0].aborts, 15u);
  EXPECT_EQ(p.results()[0].last_abort, SdoAbort::kNoObject);
  EXPECT_EQ(p.results()[1].aborts, 1u);  // timed out after 10 ms, next due at period 101
  EXPECT_EQ(p.results()[1].last_abort, SdoAbort::kTimeout);
  EXPECT_EQ(p.counters().timeouts, 1u);
  EXPECT_EQ(p.counters().aborted, 15u);
  const PeriodicRead bad_node[] = {{0, {0x1001, 0}, 1}};
  EXPECT_THROW(SdoPoller(bad_node, kMs), std::invalid_argument);
  const PeriodicRead bad_rate[] = {{1, {0x1001, 0}, 0}};
  EXPECT_THROW(SdoPoller(bad_rate, kMs), std::invalid_argument);
  EXPECT_THROW(SdoPoller(reads, 0), std::invalid_argument);
}

}  // namespace
