// Tests of numen/hal/canopen/cia402.hpp: the master driving the emulated drive, alone and in
// closed loop. The coding and the drive: cia402_test.cpp.
#include "numen/hal/canopen/cia402.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "alloc_counter.hpp"
#include "cia402_states.hpp"
#include "numen/hal/canopen/pdo_mapping.hpp"

namespace {

using namespace numen::hal;
using PS = PowerState;
using numen::test::kAllStates;

// ----------------------------------------------------------------------------------------------
// Master, alone and in closed loop with the emulated drive
// ----------------------------------------------------------------------------------------------

// One period of the loop: the master sees the statusword of the drive's last TPDO, the drive
// applies the RPDO the master sends. Returns the master's output.
Cia402MasterOutput period(Cia402Master& m, Cia402Drive& d, std::int16_t torque) {
  const Cia402MasterOutput out = m.update(d.statusword());
  d.step(out.controlword, (out.torque_allowed ? torque : std::int16_t{0}));
  return out;
}

TEST(Cia402Master, BringsTheDriveFromPowerUpToOperationEnabled) {
  Cia402DriveSettings ds;
  ds.init_periods = 2;
  Cia402Drive d(ds);
  Cia402Master m;
  m.request(Cia402Target::kEnabled);
  // init_periods + 1 periods of 0x0000 (the drive initialises, then transition 1 in the next
  // step), then shutdown, switch on, enable operation, each seen one period later; torque from
  // the period after enable operation: period init_periods + 5 = 7.
  const std::vector<std::uint16_t> expected_cw = {0x0000, 0x0000, 0x0000, 0x0006,
                                                  0x0007, 0x000F, 0x000F, 0x000F};
  for (std::size_t i = 0; i < expected_cw.size(); ++i) {
    const Cia402MasterOutput out = period(m, d, 125);
    EXPECT_EQ(out.controlword, expected_cw[i]) << "period " << i + 1;
    EXPECT_EQ(out.torque_allowed, i + 1 >= 7) << "period " << i + 1;
    EXPECT_EQ(out.at_target, i + 1 >= 7);
    EXPECT_EQ(d.applied_torque_per_mille(), i + 1 >= 7 ? 125 : 0) << "period " << i + 1;
    EXPECT_FALSE(out.fault || out.stuck);
  }
  EXPECT_EQ(m.last().state, PS::kOperationEnabled);
}

TEST(Cia402Master, DocumentedPowerUpFrames) {
  // The closed-loop table of docs/protocol.md: TPDO (statusword, torque actual value) received,
  // RPDO (controlword, target torque) sent, 12.5 % = 125 per mille requested throughout.
  using Bytes = std::vector<std::uint8_t>;
  const std::vector<std::pair<Bytes, Bytes>> expected = {
      {{0x10, 0x02, 0x00, 0x00}, {0x00, 0x00, 0x00, 0x00}},
      {{0x10, 0x02, 0x00, 0x00}, {0x00, 0x00, 0x00, 0x00}},
      {{0x50, 0x02, 0x00, 0x00}, {0x06, 0x00, 0x00, 0x00}},
      {{0x31, 0x02, 0x00, 0x00}, {0x07, 0x00, 0x00, 0x00}},
      {{0x33, 0x02, 0x00, 0x00}, {0x0F, 0x00, 0x00, 0x00}},
      {{0x37, 0x16, 0x00, 0x00}, {0x0F, 0x00, 0x7D, 0x00}},
      {{0x37, 0x16, 0x7D, 0x00}, {0x0F, 0x00, 0x7D, 0x00}},
  };
  const PdoMapping rpdo = drive_rpdo_mapping();
  const PdoMapping tpdo = drive_tpdo_mapping();
  Cia402Drive d;  // init_periods = 1
  Cia402Master m;
  m.request(Cia402Target::kEnabled);
  for (std::size_t i = 0; i < expected.size(); ++i) {
    CanFrame tx;
    const std::array<std::int64_t, 2> t = {d.statusword(), d.applied_torque_per_mille()};
    ASSERT_EQ(tpdo.pack(t, tx), PdoStatus::kOk);
    EXPECT_EQ(Bytes(tx.data.begin(), tx.data.begin() + tx.len), expected[i].first) << i + 1;
    std::array<std::int64_t, 2> got{};
    ASSERT_EQ(tpdo.unpack(tx, got), PdoStatus::kOk);
    const Cia402MasterOutput out = m.update(static_cast<std::uint16_t>(got[0]));
    CanFrame rx;
    const std::array<std::int64_t, 2> r = {out.controlword, out.torque_allowed ? 125 : 0};
    ASSERT_EQ(rpdo.pack(r, rx), PdoStatus::kOk);
    EXPECT_EQ(Bytes(rx.data.begin(), rx.data.begin() + rx.len), expected[i].second) << i + 1;
    std::array<std::int64_t, 2> cmd{};
    ASSERT_EQ(rpdo.unpack(rx, cmd), PdoStatus::kOk);
    d.step(static_cast<std::uint16_t>(cmd[0]), static_cast<std::int16_t>(cmd[1]));
  }
  EXPECT_EQ(d.applied_torque_per_mille(), 125);
}

TEST(Cia402Master, TorqueAllowedOnlyWhenEnabledAndTheStatuswordSaysOperationEnabled) {
  for (std::uint32_t w = 0; w <= 0xFFFF; ++w) {
    const auto sw = static_cast<std::uint16_t>(w);
    for (Cia402Target t :
         {Cia402Target::kEnabled, Cia402Target::kDisabled, Cia402Target::kQuickStop}) {
      Cia402Master m;
      m.request(t);
      const Cia402MasterOutput out = m.update(sw);
      const bool allowed =
          t == Cia402Target::kEnabled && decode_power_state(sw) == PS::kOperationEnabled;
      ASSERT_EQ(out.torque_allowed, allowed) << std::hex << w << " " << to_string(t);
    }
  }
}

TEST(Cia402Master, CommandsPerObservedState) {
  // One command per observed state (fresh master each time: no fault latched before).
  struct Row {
    Cia402Target target;
    PS state;
    std::uint16_t cw;
  };
  const Row rows[] = {
      {Cia402Target::kEnabled, PS::kNotReadyToSwitchOn, 0x0000},
      {Cia402Target::kEnabled, PS::kSwitchOnDisabled, 0x0006},
      {Cia402Target::kEnabled, PS::kReadyToSwitchOn, 0x0007},
      {Cia402Target::kEnabled, PS::kSwitchedOn, 0x000F},
      {Cia402Target::kEnabled, PS::kOperationEnabled, 0x000F},
      {Cia402Target::kEnabled, PS::kQuickStopActive, 0x0000},
      {Cia402Target::kEnabled, PS::kFaultReactionActive, 0x0000},
      {Cia402Target::kEnabled, PS::kFault, 0x0000},
  };
  for (const Row& r : rows) {
    Cia402Master m;
    m.request(r.target);
    EXPECT_EQ(m.update(power_state_bits(r.state) | 0x0210).controlword, r.cw) << to_string(r.state);
  }
  for (PS s : kAllStates) {
    Cia402Master dis;
    EXPECT_EQ(dis.update(power_state_bits(s)).controlword, 0x0000) << to_string(s);
    Cia402Master qs;
    qs.request(Cia402Target::kQuickStop);
    EXPECT_EQ(qs.update(power_state_bits(s)).controlword,
              s == PS::kFault || s == PS::kFaultReactionActive ? 0x0000 : 0x0002)
        << to_string(s);
  }
}

// Drive and master brought up together to operation enabled.
struct Loop {
  explicit Loop(Cia402DriveSettings ds = {}, Cia402MasterSettings ms = {}) : d(ds), m(ms) {
    m.request(Cia402Target::kEnabled);
    for (int i = 0; i < 20 && !m.last().torque_allowed; ++i) period(m, d, 0);
    EXPECT_TRUE(m.last().torque_allowed);
  }
  Cia402Drive d;
  Cia402Master m;
};

TEST(Cia402Master, FaultIsReportedTorqueZeroedAndNeverReArmedAutomatically) {
  Cia402DriveSettings ds;
  ds.fault_reaction_periods = 3;
  Loop l(ds);
  period(l.m, l.d, 400);
  ASSERT_EQ(l.d.applied_torque_per_mille(), 400);
  l.d.inject_fault(0x2310);
  for (int i = 0; i < 200; ++i) {
    const Cia402MasterOutput out = period(l.m, l.d, 400);
    ASSERT_TRUE(out.fault) << i;
    ASSERT_FALSE(out.torque_allowed) << i;
    ASSERT_EQ(out.controlword, 0x0000) << i;  // never a reset edge, never a power-up command
    ASSERT_FALSE(out.stuck) << i;             // a latched fault is not a stuck drive
    ASSERT_EQ(l.d.applied_torque_per_mille(), 0) << i;
  }
  EXPECT_EQ(l.d.state(), PS::kFault);
  EXPECT_EQ(l.m.counters().faults, 1u);
  EXPECT_EQ(l.m.counters().fault_resets, 0u);
  EXPECT_EQ(l.m.counters().dropouts, 1u);
}

TEST(Cia402Master, ExplicitReArmSendsOneRisingEdgeAndRecovers) {
  Cia402DriveSettings ds;
  ds.fault_reaction_periods = 0;
  Loop l(ds);
  l.d.inject_fault(0x2310);
  for (int i = 0; i < 5; ++i) period(l.m, l.d, 0);
  ASSERT_EQ(l.d.state(), PS::kFault);
  l.m.request_fault_reset();
  // 0x0000 then 0x0080 (rising edge, transition 15), then up again: 6, 7, F; torque after.
  const std::uint16_t expected_cw[] = {0x0000, 0x0080, 0x0006, 0x0007, 0x000F, 0x000F};
  for (std::size_t i = 0; i < std::size(expected_cw); ++i) {
    const Cia402MasterOutput out = period(l.m, l.d, 200);
    EXPECT_EQ(out.controlword, expected_cw[i]) << i;
    EXPECT_EQ(out.fault, i < 2) << i;
    EXPECT_EQ(out.torque_allowed, i == 5) << i;
  }
  EXPECT_EQ(l.d.applied_torque_per_mille(), 200);
  EXPECT_EQ(l.d.counters().fault_resets, 1u);
  EXPECT_EQ(l.m.counters().fault_resets, 1u);
  EXPECT_EQ(l.d.error_code(), 0);
}

TEST(Cia402Master, ReArmDuringFaultReactionWaitsForFault) {
  Cia402DriveSettings ds;
  ds.fault_reaction_periods = 4;
  Loop l(ds);
  l.d.inject_fault(0x2310);
  period(l.m, l.d, 0);  // fault seen (reaction active)
  l.m.request_fault_reset();
  std::vector<std::uint16_t> sent;
  for (int i = 0; i < 12; ++i) sent.push_back(period(l.m, l.d, 0).controlword);
  // Zeros until the drive is in fault, then exactly one 0 → 0x80 edge.
  int edges = 0;
  for (std::size_t i = 1; i < sent.size(); ++i) {
    if ((sent[i] & 0x80) != 0 && (sent[i - 1] & 0x80) == 0) ++edges;
  }
  EXPECT_EQ(edges, 1);
  EXPECT_EQ(l.d.counters().fault_resets, 1u);
  EXPECT_TRUE(l.m.last().torque_allowed);
}

TEST(Cia402Master, ResetRefusedByThePersistentFaultIsReportedStuckAndCanBeRetried) {
  Cia402DriveSettings ds;
  ds.fault_reaction_periods = 0;
  Cia402MasterSettings ms;
  ms.transition_timeout_periods = 5;
  Loop l(ds, ms);
  l.d.inject_fault(0x5114, true);
  for (int i = 0; i < 3; ++i) period(l.m, l.d, 0);
  l.m.request_fault_reset();
  // 0x0000, then 0x0080 held while waiting; stuck when the state has not changed for 5 periods
  // since the reset started; then bit 7 falls again.
  std::vector<Cia402MasterOutput> outs;
  for (int i = 0; i < 8; ++i) outs.push_back(period(l.m, l.d, 0));
  EXPECT_EQ(outs[0].controlword, 0x0000);
  for (int i = 1; i < 5; ++i) {
    EXPECT_EQ(outs[static_cast<std::size_t>(i)].controlword, 0x0080) << i;
    EXPECT_FALSE(outs[static_cast<std::size_t>(i)].stuck) << i;
  }
  EXPECT_TRUE(outs[5].stuck);
  EXPECT_EQ(outs[5].controlword, 0x0000);
  EXPECT_TRUE(outs[7].fault && outs[7].stuck);
  EXPECT_EQ(outs[7].controlword, 0x0000);
  EXPECT_EQ(l.m.counters().stuck, 1u);
  EXPECT_EQ(l.d.state(), PS::kFault);
  // Cause removed, re-arm again: a new edge, and the drive comes back.
  l.d.clear_fault_condition();
  l.m.request_fault_reset();
  for (int i = 0; i < 8; ++i) period(l.m, l.d, 0);
  EXPECT_TRUE(l.m.last().torque_allowed);
  EXPECT_FALSE(l.m.last().stuck);
  EXPECT_EQ(l.m.counters().fault_resets, 2u);
}

TEST(Cia402Master, FaultClearedBehindTheMastersBackStaysLatched) {
  Cia402DriveSettings ds;
  ds.fault_reaction_periods = 0;
  Loop l(ds);
  l.d.inject_fault(0x2310);
  for (int i = 0; i < 3; ++i) period(l.m, l.d, 0);
  l.d.step(0x0080, 0);  // someone else resets the drive (e.g. its local panel)
  ASSERT_EQ(l.d.state(), PS::kSwitchOnDisabled);
  for (int i = 0; i < 20; ++i) {
    const Cia402MasterOutput out = period(l.m, l.d, 0);
    ASSERT_TRUE(out.fault);
    ASSERT_EQ(out.controlword, 0x0000);  // the master does not bring it up by itself
  }
  EXPECT_EQ(l.d.state(), PS::kSwitchOnDisabled);
  l.m.request_fault_reset();  // nothing to reset in the drive: only the latch is cleared
  for (int i = 0; i < 4; ++i) period(l.m, l.d, 0);
  EXPECT_TRUE(l.m.last().torque_allowed);
  EXPECT_EQ(l.m.counters().fault_resets, 0u);
}

TEST(Cia402Master, QuickStopAndBack) {
  for (std::int16_t option : {std::int16_t{2}, std::int16_t{6}}) {
    Cia402DriveSettings ds;
    ds.quick_stop_option_code = option;
    ds.quick_stop_periods = 3;
    Loop l(ds);
    l.m.request(Cia402Target::kQuickStop);
    Cia402MasterOutput out = period(l.m, l.d, 300);
    EXPECT_EQ(out.controlword, 0x0002);
    EXPECT_FALSE(out.torque_allowed);  // the drive still reports operation enabled
    EXPECT_EQ(l.d.state(), PS::kQuickStopActive);
    EXPECT_EQ(l.d.applied_torque_per_mille(), 0);
    for (int i = 0; i < 10; ++i) {
      out = period(l.m, l.d, 300);
      EXPECT_TRUE(out.at_target) << option;
      EXPECT_FALSE(out.torque_allowed || out.stuck);
    }
    EXPECT_EQ(l.d.state(), option >= 5 ? PS::kQuickStopActive : PS::kSwitchOnDisabled);
    l.m.request(Cia402Target::kEnabled);
    for (int i = 0; i < 6; ++i) period(l.m, l.d, 300);
    EXPECT_TRUE(l.m.last().torque_allowed) << option;
    EXPECT_EQ(l.d.applied_torque_per_mille(), 300);
  }
}

TEST(Cia402Master, DisableIsTheSafeState) {
  Loop l;
  l.m.request(Cia402Target::kDisabled);
  const Cia402MasterOutput out = period(l.m, l.d, 300);
  EXPECT_EQ(out.controlword, 0x0000);
  EXPECT_FALSE(out.torque_allowed);
  EXPECT_EQ(l.d.state(), PS::kSwitchOnDisabled);  // transition 9
  EXPECT_EQ(l.d.applied_torque_per_mille(), 0);
  EXPECT_TRUE(period(l.m, l.d, 300).at_target);
  EXPECT_EQ(l.m.counters().dropouts, 0u);  // a requested disable is not a dropout
}

TEST(Cia402Master, StuckDriveIsReportedAfterTheTimeout) {
  Cia402MasterSettings ms;
  ms.transition_timeout_periods = 5;
  Cia402Master m(ms);
  m.request(Cia402Target::kEnabled);
  // The drive stays in switch on disabled whatever is sent: the sixth update in the same state
  // (5 periods after the first shutdown) reports stuck, once.
  for (int i = 1; i <= 5; ++i) {
    const Cia402MasterOutput out = m.update(0x0250);
    EXPECT_EQ(out.controlword, 0x0006);
    EXPECT_FALSE(out.stuck) << i;
  }
  EXPECT_TRUE(m.update(0x0250).stuck);
  for (int i = 0; i < 10; ++i) EXPECT_TRUE(m.update(0x0250).stuck);
  EXPECT_EQ(m.counters().stuck, 1u);
  // The state changes: the report clears and the timer restarts.
  EXPECT_FALSE(m.update(0x0231).stuck);
  for (int i = 0; i < 4; ++i) EXPECT_FALSE(m.update(0x0231).stuck);
  EXPECT_TRUE(m.update(0x0231).stuck);
  EXPECT_EQ(m.counters().stuck, 2u);
  // At the target nothing is awaited: never stuck.
  for (int i = 0; i < 20; ++i) EXPECT_FALSE(m.update(0x0237).stuck);
}

TEST(Cia402Master, DriveUnderLocalControlIsStuckInClosedLoop) {
  Cia402DriveSettings ds;
  ds.remote = false;
  Cia402Drive d(ds);
  Cia402MasterSettings ms;
  ms.transition_timeout_periods = 10;
  Cia402Master m(ms);
  m.request(Cia402Target::kEnabled);
  int first_stuck = -1;
  for (int i = 1; i <= 40 && first_stuck < 0; ++i) {
    if (period(m, d, 0).stuck) first_stuck = i;
  }
  // Periods 1–2 not ready (init 1 + transition), switch on disabled seen from period 3: stuck at
  // period 3 + 10.
  EXPECT_EQ(first_stuck, 13);
  EXPECT_EQ(m.last().state, PS::kSwitchOnDisabled);
}

TEST(Cia402Master, ChangingTheTargetRestartsTheTimer) {
  Cia402MasterSettings ms;
  ms.transition_timeout_periods = 3;
  Cia402Master m(ms);
  m.request(Cia402Target::kEnabled);
  for (int i = 0; i < 4; ++i) m.update(0x0250);
  EXPECT_TRUE(m.last().stuck);
  m.request(Cia402Target::kDisabled);
  EXPECT_FALSE(m.update(0x0250).stuck);  // switch on disabled is the disabled target
  m.request(Cia402Target::kEnabled);
  m.request(Cia402Target::kEnabled);  // same target: no restart
  for (int i = 0; i < 3; ++i) EXPECT_FALSE(m.update(0x0250).stuck) << i;
  EXPECT_TRUE(m.update(0x0250).stuck);
}

TEST(Cia402Master, CorruptedStatuswordRepeatsTheLastCommandWithoutTorque) {
  Loop l;
  const Cia402MasterOutput bad = l.m.update(0x0001);  // matches no state
  EXPECT_EQ(bad.state, PS::kUnknown);
  EXPECT_FALSE(bad.torque_allowed);
  EXPECT_EQ(bad.controlword, 0x000F);
  EXPECT_EQ(l.m.counters().invalid_statuswords, 1u);
  EXPECT_TRUE(l.m.update(0x1637).torque_allowed);
  EXPECT_EQ(l.m.counters().dropouts, 0u);
}

TEST(Cia402Master, SettingsAreValidated) {
  Cia402MasterSettings ms;
  ms.transition_timeout_periods = 2;
  try {
    Cia402Master m(ms);
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("transition_timeout_periods"), std::string::npos);
  }
  ms.transition_timeout_periods = 3;
  EXPECT_NO_THROW(Cia402Master{ms});
}

TEST(Cia402Master, PerPeriodCallsDoNotAllocate) {
  Cia402DriveSettings ds;
  ds.fault_reaction_periods = 2;
  ds.quick_stop_option_code = 6;
  Cia402Drive d(ds);
  Cia402MasterSettings ms;
  ms.transition_timeout_periods = 20;
  Cia402Master m(ms);
  std::uint64_t enabled_periods = 0;
  numen::test::AllocationGuard guard;
  m.request(Cia402Target::kEnabled);
  for (int i = 0; i < 10000; ++i) {
    if (i % 1000 == 500) d.inject_fault(static_cast<std::uint16_t>(0x2300 + i % 7));
    if (i % 1000 == 600) m.request_fault_reset();
    if (i % 1000 == 800) m.request(Cia402Target::kQuickStop);
    if (i % 1000 == 850) m.request(Cia402Target::kEnabled);
    const Cia402MasterOutput out = period(m, d, static_cast<std::int16_t>(i % 2000 - 1000));
    if (out.torque_allowed) ++enabled_periods;
    (void)decode_statusword(d.statusword());
    (void)decode_controlword(out.controlword);
  }
  EXPECT_EQ(guard.count(), 0);
  EXPECT_EQ(m.counters().faults, 10u);
  EXPECT_EQ(d.counters().fault_resets, 10u);
  EXPECT_GT(enabled_periods, 8000u);
}

}  // namespace
