// Tests of numen/hal/canopen/heartbeat.hpp: heartbeat frames, producer timing, consumer timeout
// semantics and the monitor (CiA 301 §7.2.8.3.2).
#include "numen/hal/canopen/heartbeat.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <limits>
#include <stdexcept>
#include <vector>

#include "alloc_counter.hpp"
#include "numen/hal/canopen/nmt.hpp"
#include "numen/hal/transport/sim_bus.hpp"
#include "numen/hal/transport/splitmix64.hpp"
#include "test_constants.hpp"

namespace {

using namespace numen::hal;

using numen::test::kMs;

CanFrame heartbeat(std::uint8_t node, NmtState state, std::int64_t t) {
  CanFrame f;
  EXPECT_TRUE(encode_heartbeat(node, state, t, f));
  return f;
}

// ---------------------------------------------------------------------------------------------
// Frames

TEST(Heartbeat, FramesAreByteExact) {
  const CanFrame op = heartbeat(3, NmtState::kOperational, 42);
  EXPECT_EQ(op.id, 0x703u);
  EXPECT_EQ(op.flags, 0);
  EXPECT_EQ(op.len, 1);
  EXPECT_EQ(op.data[0], 0x05);
  EXPECT_EQ(op.timestamp_ns, 42);
  EXPECT_EQ(heartbeat(127, NmtState::kPreOperational, 0).id, 0x77Fu);
  EXPECT_EQ(heartbeat(127, NmtState::kPreOperational, 0).data[0], 0x7F);
  EXPECT_EQ(heartbeat(1, NmtState::kStopped, 0).data[0], 0x04);
  const CanFrame boot = heartbeat(1, NmtState::kBootUp, 0);
  EXPECT_EQ(boot.id, 0x701u);
  EXPECT_EQ(boot.data[0], 0x00);
  EXPECT_EQ(heartbeat_ms_to_ns(100), 100 * kMs);
  CanFrame f;
  f.id = 0x55;
  EXPECT_FALSE(encode_heartbeat(0, NmtState::kOperational, 0, f));
  EXPECT_FALSE(encode_heartbeat(128, NmtState::kOperational, 0, f));
  EXPECT_FALSE(encode_heartbeat(1, static_cast<NmtState>(0x85), 0, f));
  EXPECT_EQ(f.id, 0x55u);
}

TEST(Heartbeat, DecodeRoundTripAndRejections) {
  for (int node = 1; node <= 127; ++node) {
    std::uint8_t id = 0;
    NmtState s = NmtState::kBootUp;
    ASSERT_EQ(
        decode_heartbeat(heartbeat(static_cast<std::uint8_t>(node), NmtState::kStopped, 0), id, s),
        HeartbeatDecodeStatus::kOk);
    EXPECT_EQ(id, node);
    EXPECT_EQ(s, NmtState::kStopped);
  }
  auto status = [](const CanFrame& f) {
    std::uint8_t id = 99;
    NmtState s = NmtState::kStopped;
    const HeartbeatDecodeStatus r = decode_heartbeat(f, id, s);
    if (r != HeartbeatDecodeStatus::kOk) {
      EXPECT_EQ(id, 99);
      EXPECT_EQ(s, NmtState::kStopped);
    }
    return r;
  };
  CanFrame f = heartbeat(3, NmtState::kOperational, 0);
  f.id = 0x700;  // node 0
  EXPECT_EQ(status(f), HeartbeatDecodeStatus::kWrongId);
  f.id = 0x780;
  EXPECT_EQ(status(f), HeartbeatDecodeStatus::kWrongId);
  f.id = 0x183;
  EXPECT_EQ(status(f), HeartbeatDecodeStatus::kWrongId);
  for (std::uint8_t len : {0, 2, 8}) {
    f = heartbeat(3, NmtState::kOperational, 0);
    f.len = len;
    EXPECT_EQ(status(f), HeartbeatDecodeStatus::kWrongLength);
  }
  for (std::uint8_t flag : {CanFlag::kRemote, CanFlag::kFd}) {
    f = heartbeat(3, NmtState::kOperational, 0);
    f.flags = flag;
    EXPECT_EQ(status(f), HeartbeatDecodeStatus::kNotDataFrame);
  }
  // A 29-bit frame 0x00000703 and an error report whose class bits read 0x703 are not on
  // node 3's heartbeat COB-ID (can_frame.hpp, frame acceptance).
  for (std::uint8_t flag : {CanFlag::kExtendedId, CanFlag::kErrorFrame}) {
    f = heartbeat(3, NmtState::kOperational, 0);
    f.flags = flag;
    EXPECT_EQ(status(f), HeartbeatDecodeStatus::kWrongId);
  }
  // Node-guarding style toggle bit, and bytes that are no NMT state.
  for (std::uint8_t b : {0x85, 0x01, 0x7E, 0xFF}) {
    f = heartbeat(3, NmtState::kOperational, 0);
    f.data[0] = b;
    EXPECT_EQ(status(f), HeartbeatDecodeStatus::kUnknownState);
  }
}

// ---------------------------------------------------------------------------------------------
// Producer

TEST(HeartbeatProducer, FramesOnAFixedGridWithoutDrift) {
  // Heartbeat every 100 ms, polled by a 333.333 µs control loop that does not divide it:
  // frame k is sent at the first poll at or after t0 + k·100 ms, for 1000 periods (100 s).
  const std::int64_t period = 100 * kMs;
  const std::int64_t dt = 333'333;
  const std::int64_t t0 = 12'345;
  HeartbeatProducer p(4, period);
  p.start(t0);
  std::vector<std::int64_t> sent;
  CanFrame f;
  for (std::int64_t t = t0; t <= t0 + 1000 * period + dt; t += dt) {
    if (p.poll(t, NmtState::kOperational, f)) {
      sent.push_back(t);
      EXPECT_EQ(f.id, 0x704u);
      EXPECT_EQ(f.data[0], 0x05);
      EXPECT_EQ(f.timestamp_ns, t);
    }
  }
  ASSERT_EQ(sent.size(), 1000u);
  for (std::size_t k = 0; k < sent.size(); ++k) {
    const std::int64_t due = t0 + static_cast<std::int64_t>(k + 1) * period;
    EXPECT_GE(sent[k], due) << k;
    EXPECT_LT(sent[k] - due, dt) << k;  // never more than one poll late, also at k = 999
  }
  EXPECT_EQ(p.sent(), 1000u);
  EXPECT_EQ(p.skipped(), 0u);
}

TEST(HeartbeatProducer, LatePollSendsOnceAndKeepsTheGrid) {
  HeartbeatProducer p(1, 10 * kMs);
  CanFrame f;
  EXPECT_FALSE(p.poll(50 * kMs, NmtState::kOperational, f));  // not started
  p.start(0);
  EXPECT_FALSE(p.poll(10 * kMs - 1, NmtState::kOperational, f));
  EXPECT_TRUE(p.poll(35 * kMs, NmtState::kOperational, f));  // due 10, 20, 30 passed
  EXPECT_EQ(p.skipped(), 2u);
  EXPECT_EQ(p.next_due_ns(), 40 * kMs);
  EXPECT_FALSE(p.poll(36 * kMs, NmtState::kOperational, f));
  EXPECT_FALSE(p.poll(1 * kMs, NmtState::kOperational, f));  // time went back: nothing
  EXPECT_EQ(p.next_due_ns(), 40 * kMs);
  EXPECT_TRUE(p.poll(40 * kMs, NmtState::kOperational, f));  // exactly on the grid
  EXPECT_EQ(p.sent(), 2u);
  // A run-time period change counts from the last heartbeat.
  EXPECT_TRUE(p.set_period(5 * kMs));
  EXPECT_EQ(p.next_due_ns(), 45 * kMs);
  EXPECT_FALSE(p.set_period(-1));
  EXPECT_EQ(p.period_ns(), 5 * kMs);
  // Disabled and stopped.
  EXPECT_TRUE(p.set_period(0));
  EXPECT_FALSE(p.poll(1000 * kMs, NmtState::kOperational, f));
  EXPECT_TRUE(p.set_period(5 * kMs));
  p.stop();
  EXPECT_FALSE(p.poll(1000 * kMs, NmtState::kOperational, f));
  EXPECT_EQ(p.sent(), 2u);
  // Invalid state: nothing sent, nothing scheduled.
  p.start(0);
  f.id = 0x1;
  EXPECT_FALSE(p.poll(5 * kMs, static_cast<NmtState>(0x33), f));
  EXPECT_EQ(f.id, 0x1u);
  EXPECT_TRUE(p.poll(5 * kMs, NmtState::kStopped, f));
  EXPECT_EQ(f.data[0], 0x04);
}

TEST(HeartbeatProducer, ConstructorChecks) {
  EXPECT_THROW(HeartbeatProducer(0, kMs), std::invalid_argument);
  EXPECT_THROW(HeartbeatProducer(128, kMs), std::invalid_argument);
  EXPECT_THROW(HeartbeatProducer(1, -1), std::invalid_argument);
  HeartbeatProducer disabled(1, 0);
  disabled.start(0);
  CanFrame f;
  EXPECT_FALSE(disabled.poll(std::numeric_limits<std::int64_t>::max(), NmtState::kOperational, f));
}

// ---------------------------------------------------------------------------------------------
// Consumer

TEST(HeartbeatConsumer, WaitingUntilTheFirstHeartbeat) {
  HeartbeatConsumer c(2, 150 * kMs);
  EXPECT_EQ(c.status(), HeartbeatStatus::kWaiting);
  EXPECT_EQ(c.poll(10'000 * kMs), HeartbeatStatus::kWaiting);  // never heard: not lost
  EXPECT_FALSE(c.heard());
  // A boot-up message while waiting is expected (the node powers up); no monitoring yet.
  EXPECT_EQ(c.on_frame(heartbeat(2, NmtState::kBootUp, 10'000 * kMs)), HeartbeatDecodeStatus::kOk);
  EXPECT_EQ(c.status(), HeartbeatStatus::kWaiting);
  EXPECT_TRUE(c.heard());
  EXPECT_EQ(c.last_state(), NmtState::kBootUp);
  EXPECT_EQ(c.poll(20'000 * kMs), HeartbeatStatus::kWaiting);
  EXPECT_EQ(c.on_frame(heartbeat(2, NmtState::kPreOperational, 20'000 * kMs)),
            HeartbeatDecodeStatus::kOk);
  EXPECT_EQ(c.status(), HeartbeatStatus::kAlive);
  EXPECT_EQ(c.last_state(), NmtState::kPreOperational);
  EXPECT_EQ(c.last_heard_ns(), 20'000 * kMs);
  EXPECT_EQ(c.counters().boot_ups, 1u);
  EXPECT_EQ(c.counters().heartbeats, 1u);
  EXPECT_EQ(c.counters().faults(), 0u);
  EXPECT_EQ(c.last_fault().kind, HeartbeatStatus::kWaiting);
}

TEST(HeartbeatConsumer, LostExactlyAtTheTimeoutThenRecovered) {
  const std::int64_t timeout = 150 * kMs;
  const std::int64_t t1 = 5'000 * kMs + 17;
  HeartbeatConsumer c(2, timeout);
  c.on_frame(heartbeat(2, NmtState::kOperational, t1));
  EXPECT_EQ(c.poll(t1 + timeout - 1), HeartbeatStatus::kAlive);  // one ns before: alive
  EXPECT_FALSE(c.faulted());
  EXPECT_EQ(c.poll(t1 + timeout), HeartbeatStatus::kLost);  // exactly at the timeout: lost
  EXPECT_TRUE(c.faulted());
  EXPECT_EQ(c.last_fault().kind, HeartbeatStatus::kLost);
  EXPECT_EQ(c.last_fault().node_id, 2);
  EXPECT_EQ(c.last_fault().last_heard_ns, t1);
  EXPECT_EQ(c.last_fault().deadline_ns, t1 + timeout);
  EXPECT_EQ(c.last_fault().detected_ns, t1 + timeout);
  // Further polls keep it lost and do not count the loss again.
  EXPECT_EQ(c.poll(t1 + 10 * timeout), HeartbeatStatus::kLost);
  EXPECT_EQ(c.counters().losses, 1u);
  EXPECT_EQ(c.last_fault().detected_ns, t1 + timeout);
  // The next heartbeat revives it; the loss stays on record.
  const std::int64_t t2 = t1 + 11 * timeout;
  c.on_frame(heartbeat(2, NmtState::kOperational, t2));
  EXPECT_EQ(c.status(), HeartbeatStatus::kAlive);
  EXPECT_EQ(c.counters().recoveries, 1u);
  EXPECT_EQ(c.counters().faults(), 1u);
  EXPECT_EQ(c.last_fault().last_heard_ns, t1);
  EXPECT_EQ(c.poll(t2 + timeout - 1), HeartbeatStatus::kAlive);
  EXPECT_EQ(c.poll(t2 + timeout), HeartbeatStatus::kLost);
  EXPECT_EQ(c.counters().losses, 2u);
}

TEST(HeartbeatConsumer, LateHeartbeatRevealsTheLossWithoutAPoll) {
  const std::int64_t timeout = 100 * kMs;
  HeartbeatConsumer c(6, timeout);
  c.on_frame(heartbeat(6, NmtState::kOperational, 0));
  c.on_frame(heartbeat(6, NmtState::kOperational, timeout - 1));  // in time
  EXPECT_EQ(c.counters().losses, 0u);
  // Silence of exactly the timeout, no poll in between: the loss is still recorded.
  c.on_frame(heartbeat(6, NmtState::kOperational, 2 * timeout - 1));
  EXPECT_EQ(c.status(), HeartbeatStatus::kAlive);
  EXPECT_EQ(c.counters().losses, 1u);
  EXPECT_EQ(c.counters().recoveries, 1u);
  EXPECT_EQ(c.last_fault().last_heard_ns, timeout - 1);
  EXPECT_EQ(c.last_fault().deadline_ns, 2 * timeout - 1);
  EXPECT_EQ(c.last_fault().detected_ns, 2 * timeout - 1);
}

TEST(HeartbeatConsumer, LossCountDependsOnTimestampsNotOnPolling) {
  // Random heartbeat gaps around the timeout; three consumers see the same frames, one
  // polled every 0.25 ms, one at random instants, one never. All count the same losses,
  // equal to the number of gaps >= timeout.
  const std::int64_t timeout = 20 * kMs;
  numen::hal::SplitMix64 rng(7);
  HeartbeatConsumer dense(9, timeout), sparse(9, timeout), never(9, timeout);
  std::int64_t t = 0;
  std::uint64_t gaps_over = 0;
  std::int64_t next_sparse = 0;
  for (int k = 0; k < 2000; ++k) {
    const std::int64_t gap = 10 * kMs + static_cast<std::int64_t>(rng.next() % (20 * kMs));
    const std::int64_t next = t + gap;
    if (k > 0 && gap >= timeout) ++gaps_over;
    if (k > 0) {
      for (std::int64_t p = t; p < next; p += 250'000) dense.poll(p);
      while (next_sparse < next) {
        sparse.poll(next_sparse);
        next_sparse += static_cast<std::int64_t>(rng.next() % (60 * kMs));
      }
    }
    t = next;
    const CanFrame f = heartbeat(9, NmtState::kOperational, t);
    dense.on_frame(f);
    sparse.on_frame(f);
    never.on_frame(f);
  }
  ASSERT_GT(gaps_over, 100u);
  EXPECT_EQ(dense.counters().losses, gaps_over);
  EXPECT_EQ(sparse.counters().losses, gaps_over);
  EXPECT_EQ(never.counters().losses, gaps_over);
}

TEST(HeartbeatConsumer, UnexpectedBootUpIsAFault) {
  HeartbeatConsumer c(4, 100 * kMs);
  c.on_frame(heartbeat(4, NmtState::kBootUp, 0));  // expected boot-up
  c.on_frame(heartbeat(4, NmtState::kOperational, 50 * kMs));
  ASSERT_EQ(c.status(), HeartbeatStatus::kAlive);
  c.on_frame(heartbeat(4, NmtState::kBootUp, 120 * kMs));  // the node reset
  EXPECT_EQ(c.status(), HeartbeatStatus::kBootedUnexpectedly);
  EXPECT_TRUE(c.faulted());
  EXPECT_EQ(c.last_state(), NmtState::kBootUp);
  EXPECT_EQ(c.last_fault().kind, HeartbeatStatus::kBootedUnexpectedly);
  EXPECT_EQ(c.last_fault().last_heard_ns, 50 * kMs);
  EXPECT_EQ(c.last_fault().detected_ns, 120 * kMs);
  EXPECT_EQ(c.counters().unexpected_boot_ups, 1u);
  EXPECT_EQ(c.counters().losses, 0u);
  // Monitoring waits for the next heartbeat: no loss on top of the reset.
  EXPECT_EQ(c.poll(10'000 * kMs), HeartbeatStatus::kBootedUnexpectedly);
  c.on_frame(heartbeat(4, NmtState::kPreOperational, 10'001 * kMs));
  EXPECT_EQ(c.status(), HeartbeatStatus::kAlive);
  EXPECT_EQ(c.last_state(), NmtState::kPreOperational);  // a reset node is not operational
  // A boot-up while lost: the loss, then the reset.
  EXPECT_EQ(c.poll(10'200 * kMs), HeartbeatStatus::kLost);
  c.on_frame(heartbeat(4, NmtState::kBootUp, 10'300 * kMs));
  EXPECT_EQ(c.status(), HeartbeatStatus::kBootedUnexpectedly);
  EXPECT_EQ(c.counters().faults(), 3u);
  // A boot-up after a silence longer than the timeout that no poll saw: both recorded.
  HeartbeatConsumer d(4, 100 * kMs);
  d.on_frame(heartbeat(4, NmtState::kOperational, 0));
  d.on_frame(heartbeat(4, NmtState::kBootUp, 500 * kMs));
  EXPECT_EQ(d.counters().losses, 1u);
  EXPECT_EQ(d.counters().unexpected_boot_ups, 1u);
  EXPECT_EQ(d.status(), HeartbeatStatus::kBootedUnexpectedly);
}

TEST(HeartbeatConsumer, BootUpAnsweringTheMastersResetIsNotAFault) {
  HeartbeatConsumer c(4, 100 * kMs);
  c.on_frame(heartbeat(4, NmtState::kBootUp, 0));
  c.on_frame(heartbeat(4, NmtState::kPreOperational, 50 * kMs));
  ASSERT_EQ(c.status(), HeartbeatStatus::kAlive);
  c.expect_boot_up();  // the master sent NMT reset communication
  EXPECT_EQ(c.status(), HeartbeatStatus::kWaiting);
  EXPECT_EQ(c.poll(1'000 * kMs), HeartbeatStatus::kWaiting);  // no loss while waiting
  c.on_frame(heartbeat(4, NmtState::kBootUp, 1'010 * kMs));
  EXPECT_EQ(c.status(), HeartbeatStatus::kWaiting);
  EXPECT_EQ(c.counters().faults(), 0u);
  EXPECT_EQ(c.counters().boot_ups, 2u);
  c.on_frame(heartbeat(4, NmtState::kPreOperational, 1'020 * kMs));
  EXPECT_EQ(c.status(), HeartbeatStatus::kAlive);
  // Only the boot-up that answers the reset is expected: the next one is a fault again.
  c.on_frame(heartbeat(4, NmtState::kBootUp, 1'030 * kMs));
  EXPECT_EQ(c.status(), HeartbeatStatus::kBootedUnexpectedly);
  EXPECT_EQ(c.counters().unexpected_boot_ups, 1u);
  // A fault already reported is left as it is.
  c.expect_boot_up();
  EXPECT_EQ(c.status(), HeartbeatStatus::kBootedUnexpectedly);
}

TEST(HeartbeatConsumer, TimestampsOutOfOrder) {
  const std::int64_t timeout = 100 * kMs;
  HeartbeatConsumer c(5, timeout);
  c.on_frame(heartbeat(5, NmtState::kOperational, 1000 * kMs));
  // An older frame: counted, neither the deadline nor the state move back.
  c.on_frame(heartbeat(5, NmtState::kStopped, 950 * kMs));
  EXPECT_EQ(c.counters().out_of_order, 1u);
  EXPECT_EQ(c.last_heard_ns(), 1000 * kMs);
  EXPECT_EQ(c.last_state(), NmtState::kOperational);
  EXPECT_EQ(c.poll(950 * kMs + timeout), HeartbeatStatus::kAlive);
  EXPECT_EQ(c.poll(1000 * kMs + timeout - 1), HeartbeatStatus::kAlive);
  // A poll time before the last heartbeat counts as no time elapsed.
  EXPECT_EQ(c.poll(0), HeartbeatStatus::kAlive);
  EXPECT_EQ(c.poll(std::numeric_limits<std::int64_t>::min()), HeartbeatStatus::kAlive);
  // Same timestamp twice is not out of order.
  c.on_frame(heartbeat(5, NmtState::kOperational, 1000 * kMs));
  EXPECT_EQ(c.counters().out_of_order, 1u);
  // An out-of-order boot-up is still a reset of the node.
  c.on_frame(heartbeat(5, NmtState::kBootUp, 900 * kMs));
  EXPECT_EQ(c.status(), HeartbeatStatus::kBootedUnexpectedly);
  EXPECT_EQ(c.counters().out_of_order, 2u);
  EXPECT_EQ(c.last_heard_ns(), 1000 * kMs);
}

TEST(HeartbeatConsumer, ExtremeTimesDoNotOverflow) {
  HeartbeatConsumer c(1, std::numeric_limits<std::int64_t>::max());
  c.on_frame(heartbeat(1, NmtState::kOperational, std::numeric_limits<std::int64_t>::min()));
  EXPECT_EQ(c.poll(-2), HeartbeatStatus::kAlive);  // elapsed INT64_MAX - 1
  EXPECT_EQ(c.poll(std::numeric_limits<std::int64_t>::max()), HeartbeatStatus::kLost);
  EXPECT_EQ(c.last_fault().deadline_ns, -1);
  HeartbeatConsumer d(1, std::numeric_limits<std::int64_t>::max());
  d.on_frame(heartbeat(1, NmtState::kOperational, 10));
  EXPECT_EQ(d.poll(std::numeric_limits<std::int64_t>::max()), HeartbeatStatus::kAlive);
  EXPECT_EQ(d.poll(std::numeric_limits<std::int64_t>::max()), HeartbeatStatus::kAlive);
}

TEST(HeartbeatConsumer, MalformedFramesAreCountedAndIgnored) {
  HeartbeatConsumer c(3, 100 * kMs);
  c.on_frame(heartbeat(3, NmtState::kOperational, 0));
  CanFrame f = heartbeat(3, NmtState::kOperational, 90 * kMs);
  f.len = 0;
  EXPECT_EQ(c.on_frame(f), HeartbeatDecodeStatus::kWrongLength);
  f = heartbeat(3, NmtState::kOperational, 90 * kMs);
  f.flags = CanFlag::kRemote;  // a node-guarding request, not a heartbeat
  EXPECT_EQ(c.on_frame(f), HeartbeatDecodeStatus::kNotDataFrame);
  f = heartbeat(3, NmtState::kOperational, 90 * kMs);
  f.data[0] = 0x85;
  EXPECT_EQ(c.on_frame(f), HeartbeatDecodeStatus::kUnknownState);
  EXPECT_EQ(c.on_frame(heartbeat(4, NmtState::kOperational, 90 * kMs)),
            HeartbeatDecodeStatus::kWrongId);
  // None of them kept the node alive.
  EXPECT_EQ(c.poll(100 * kMs), HeartbeatStatus::kLost);
  EXPECT_EQ(c.counters().wrong_length, 1u);
  EXPECT_EQ(c.counters().not_data, 1u);
  EXPECT_EQ(c.counters().unknown_state, 1u);
  EXPECT_EQ(c.counters().heartbeats, 1u);
  // An unused slot takes nothing.
  HeartbeatConsumer unused;
  EXPECT_EQ(unused.on_frame(heartbeat(1, NmtState::kOperational, 0)),
            HeartbeatDecodeStatus::kWrongId);
  EXPECT_EQ(unused.poll(1'000'000 * kMs), HeartbeatStatus::kWaiting);
}

TEST(HeartbeatConsumer, ConstructorChecks) {
  EXPECT_THROW(HeartbeatConsumer(0, kMs), std::invalid_argument);
  EXPECT_THROW(HeartbeatConsumer(128, kMs), std::invalid_argument);
  EXPECT_THROW(HeartbeatConsumer(1, 0), std::invalid_argument);
  EXPECT_THROW(HeartbeatConsumer(1, -kMs), std::invalid_argument);
}

// ---------------------------------------------------------------------------------------------
// Monitor

TEST(HeartbeatMonitor, RoutesFramesToSeveralNodes) {
  HeartbeatMonitor<8> m;
  m.add(1, 100 * kMs);
  m.add(2, 100 * kMs);
  m.add(127, 300 * kMs);
  EXPECT_EQ(m.size(), 3u);
  EXPECT_FALSE(m.all_alive());
  EXPECT_EQ(m.find(5), nullptr);
  EXPECT_EQ(m.find(200), nullptr);
  EXPECT_EQ(m.on_frame(heartbeat(1, NmtState::kOperational, 0)), HeartbeatDecodeStatus::kOk);
  EXPECT_EQ(m.on_frame(heartbeat(2, NmtState::kOperational, 0)), HeartbeatDecodeStatus::kOk);
  EXPECT_EQ(m.on_frame(heartbeat(127, NmtState::kPreOperational, 0)), HeartbeatDecodeStatus::kOk);
  EXPECT_TRUE(m.all_alive());
  // Frames of other nodes and other objects are not routed.
  EXPECT_EQ(m.on_frame(heartbeat(5, NmtState::kOperational, 0)), HeartbeatDecodeStatus::kWrongId);
  CanFrame sync;
  EXPECT_EQ(m.on_frame(sync), HeartbeatDecodeStatus::kWrongId);
  EXPECT_EQ(m.unrouted(), 2u);
  // Node 1 keeps talking, node 2 falls silent, node 127 has a longer timeout.
  for (std::int64_t t = 50 * kMs; t <= 250 * kMs; t += 50 * kMs) {
    m.on_frame(heartbeat(1, NmtState::kOperational, t));
    m.poll(t);
  }
  EXPECT_EQ(m.find(1)->status(), HeartbeatStatus::kAlive);
  EXPECT_EQ(m.find(2)->status(), HeartbeatStatus::kLost);
  EXPECT_EQ(m.find(2)->last_fault().detected_ns, 100 * kMs);
  EXPECT_EQ(m.find(127)->status(), HeartbeatStatus::kAlive);
  EXPECT_EQ(m.find(127)->last_state(), NmtState::kPreOperational);
  EXPECT_TRUE(m.any_fault());
  EXPECT_FALSE(m.all_alive());
  EXPECT_EQ(m.fault_count(), 1u);
  m.poll(300 * kMs);
  EXPECT_EQ(m.find(127)->status(), HeartbeatStatus::kLost);
  EXPECT_EQ(m.fault_count(), 2u);
  // A recovered node clears any_fault() but not fault_count().
  m.on_frame(heartbeat(2, NmtState::kOperational, 300 * kMs));
  m.on_frame(heartbeat(127, NmtState::kOperational, 300 * kMs));
  EXPECT_FALSE(m.any_fault());
  EXPECT_TRUE(m.all_alive());
  EXPECT_EQ(m.fault_count(), 2u);
  ASSERT_EQ(m.consumers().size(), 3u);
  EXPECT_EQ(m.consumers()[2].node_id(), 127);
}

TEST(HeartbeatMonitor, AddChecks) {
  HeartbeatMonitor<8> m;
  EXPECT_EQ(m.capacity(), 8u);
  for (std::uint8_t n = 1; n <= 8; ++n) m.add(n, kMs);
  EXPECT_THROW(m.add(9, kMs), std::length_error);
  HeartbeatMonitor<> d;
  EXPECT_EQ(d.capacity(), kDefaultHeartbeatMonitorCapacity);
  d.add(3, kMs);
  EXPECT_THROW(d.add(3, kMs), std::invalid_argument);
  EXPECT_THROW(d.add(0, kMs), std::invalid_argument);
  EXPECT_THROW(d.add(4, 0), std::invalid_argument);
  EXPECT_EQ(d.size(), 1u);
}

// ---------------------------------------------------------------------------------------------
// End to end: a simulated node (NmtNodeModel + HeartbeatProducer) and the controller's
// monitor on a SimBus, 1 ms control period, 0.2 ms bus latency.

TEST(HeartbeatEndToEnd, BootStartLossResetOverSimBus) {
  SimBusSettings settings;
  settings.latency_ns = 200'000;
  SimBus bus(settings);
  const std::int64_t period = kMs;
  const std::int64_t hb_period = 20 * kMs;
  const std::int64_t hb_timeout = 50 * kMs;

  NmtNodeModel node(3);
  HeartbeatProducer producer(3, hb_period);
  bool node_powered = true;
  HeartbeatMonitor<8> monitor;
  monitor.add(3, hb_timeout);
  bool start_sent = false;
  std::int64_t lost_at = -1;
  std::int64_t boot_fault_at = -1;
  std::int64_t last_heartbeat_rx = -1;

  numen::test::AllocationGuard guard;
  for (std::int64_t k = 0; k < 1000; ++k) {
    const std::int64_t t = k * period;
    bus.set_time_ns(t);
    if (k == 400) node_powered = false;  // the node dies silently
    if (k == 600) {                      // ... and powers up again: a reset
      node_powered = true;
      node = NmtNodeModel(3);
      producer.stop();
    }
    // Device side.
    CanFrame f;
    if (node_powered) {
      while (bus.device().read(f) == IoStatus::kOk) node.on_frame(f);
      if (node.take_boot_up(t, f)) {
        EXPECT_EQ(bus.device().write(f), IoStatus::kOk);
        producer.start(t);
      }
      if (producer.poll(t, node.state(), f)) {
        EXPECT_EQ(bus.device().write(f), IoStatus::kOk);
      }
    }
    // Controller side.
    while (bus.controller().read(f) == IoStatus::kOk) {
      if (monitor.on_frame(f) == HeartbeatDecodeStatus::kOk && f.data[0] != 0) {
        last_heartbeat_rx = f.timestamp_ns;
      }
    }
    monitor.poll(t);
    const HeartbeatConsumer& c = *monitor.find(3);
    if (!start_sent && c.heard() && c.last_state() == NmtState::kBootUp) {
      ASSERT_TRUE(encode_nmt(NmtCommand::kStartRemoteNode, 3, t, f));
      EXPECT_EQ(bus.controller().write(f), IoStatus::kOk);
      start_sent = true;
    }
    if (lost_at < 0 && c.status() == HeartbeatStatus::kLost) lost_at = t;
    if (boot_fault_at < 0 && c.status() == HeartbeatStatus::kBootedUnexpectedly) boot_fault_at = t;
  }
  EXPECT_EQ(guard.count(), 0);

  // The node booted, was started and reported operational before it died.
  EXPECT_TRUE(start_sent);
  // Heartbeats at 20, 40, ... ms after the boot-up at 0; the last before k = 400 was sent at
  // 380 ms and received at 380.2 ms; lost at the first poll >= 380.2 + 50 ms.
  const HeartbeatConsumer& c = *monitor.find(3);
  EXPECT_EQ(lost_at, 431 * kMs);
  ASSERT_GE(c.counters().losses, 1u);
  // The reset node's boot-up (sent at 600 ms, received 600.2 ms, read at 601 ms) is a fault.
  EXPECT_EQ(boot_fault_at, 601 * kMs);
  EXPECT_EQ(c.counters().unexpected_boot_ups, 1u);
  EXPECT_EQ(c.counters().faults(), 2u);
  // After the reset the node is heard again, pre-operational (nobody restarted it).
  EXPECT_EQ(c.status(), HeartbeatStatus::kAlive);
  EXPECT_EQ(c.last_state(), NmtState::kPreOperational);
  EXPECT_EQ(last_heartbeat_rx, c.last_heard_ns());
}

}  // namespace
