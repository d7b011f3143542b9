// Tests of numen/hal/canopen/cia402.hpp: statusword and controlword coding against the CiA 402-2 tables
// (written here independently, as bit-pattern strings) and the emulated drive's transitions 0–16
// over every state × controlword. The master: cia402_master_test.cpp.
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
// Oracle: the standard's tables as bit-pattern strings ('0', '1', 'x'/'X', most significant bit
// first, spaces ignored).
// ----------------------------------------------------------------------------------------------

struct Pattern {
  std::uint16_t mask = 0;
  std::uint16_t value = 0;
  bool matches(std::uint16_t w) const { return (w & mask) == value; }
};

Pattern parse(const char* text, std::initializer_list<int> bits) {
  // `bits`: the bit number of each pattern character, in order.
  Pattern p;
  auto bit = bits.begin();
  for (const char* c = text; *c != '\0'; ++c) {
    if (*c == ' ') continue;
    EXPECT_NE(bit, bits.end()) << text;
    const auto m = static_cast<std::uint16_t>(1u << *bit);
    if (*c == '0' || *c == '1') p.mask |= m;
    if (*c == '1') p.value |= m;
    ++bit;
  }
  EXPECT_EQ(bit, bits.end()) << text;
  return p;
}

const std::initializer_list<int> kAll16 = {15, 14, 13, 12, 11, 10, 9, 8, 7, 6, 5, 4, 3, 2, 1, 0};

// CiA 402-2 statusword state coding.
struct StateRow {
  const char* bits;
  PS state;
};
const StateRow kStateTable[] = {
    {"xxxx xxxx x0xx 0000", PS::kNotReadyToSwitchOn},
    {"xxxx xxxx x1xx 0000", PS::kSwitchOnDisabled},
    {"xxxx xxxx x01x 0001", PS::kReadyToSwitchOn},
    {"xxxx xxxx x01x 0011", PS::kSwitchedOn},
    {"xxxx xxxx x01x 0111", PS::kOperationEnabled},
    {"xxxx xxxx x00x 0111", PS::kQuickStopActive},
    {"xxxx xxxx x0xx 1111", PS::kFaultReactionActive},
    {"xxxx xxxx x0xx 1000", PS::kFault},
};

// CiA 402-2 command coding over bits 7 (fault reset), 3, 2, 1, 0. '^' in bit 7 = rising edge.
enum class Cmd {
  kShutdown,
  kSwitchOn,
  kSwitchOnEnable,
  kDisableVoltage,
  kQuickStop,
  kDisableOperation,
  kEnableOperation,
  kFaultReset
};
struct CommandRow {
  const char* bits;  // fault reset, enable operation, quick stop, enable voltage, switch on
  Cmd cmd;
};
const CommandRow kCommandTable[] = {
    {"0 X 1 1 0", Cmd::kShutdown},        {"0 0 1 1 1", Cmd::kSwitchOn},
    {"0 1 1 1 1", Cmd::kSwitchOnEnable},  {"0 X X 0 X", Cmd::kDisableVoltage},
    {"0 X 0 1 X", Cmd::kQuickStop},       {"0 0 1 1 1", Cmd::kDisableOperation},
    {"0 1 1 1 1", Cmd::kEnableOperation}, {"X X X X X", Cmd::kFaultReset},
};
const std::initializer_list<int> kCommandBits = {7, 3, 2, 1, 0};

bool command_matches(Cmd cmd, std::uint16_t cw, std::uint16_t previous_cw) {
  if (cmd == Cmd::kFaultReset) return (cw & 0x80) != 0 && (previous_cw & 0x80) == 0;
  for (const CommandRow& r : kCommandTable) {
    if (r.cmd == cmd) return parse(r.bits, kCommandBits).matches(cw);
  }
  return false;
}

// CiA 402-2 state transitions with a command (0, 1, 13, 14 and the automatic 12 are automatic).
struct TransitionRow {
  const char* number;
  PS from;
  Cmd cmd;
  PS to;
  bool only_quick_stop_option_5_to_8 = false;
};
const TransitionRow kTransitions[] = {
    {"2", PS::kSwitchOnDisabled, Cmd::kShutdown, PS::kReadyToSwitchOn},
    {"3", PS::kReadyToSwitchOn, Cmd::kSwitchOn, PS::kSwitchedOn},
    {"3+4", PS::kReadyToSwitchOn, Cmd::kSwitchOnEnable, PS::kOperationEnabled},
    {"4", PS::kSwitchedOn, Cmd::kEnableOperation, PS::kOperationEnabled},
    {"5", PS::kOperationEnabled, Cmd::kDisableOperation, PS::kSwitchedOn},
    {"6", PS::kSwitchedOn, Cmd::kShutdown, PS::kReadyToSwitchOn},
    {"7", PS::kReadyToSwitchOn, Cmd::kQuickStop, PS::kSwitchOnDisabled},
    {"7", PS::kReadyToSwitchOn, Cmd::kDisableVoltage, PS::kSwitchOnDisabled},
    {"8", PS::kOperationEnabled, Cmd::kShutdown, PS::kReadyToSwitchOn},
    {"9", PS::kOperationEnabled, Cmd::kDisableVoltage, PS::kSwitchOnDisabled},
    {"10", PS::kSwitchedOn, Cmd::kDisableVoltage, PS::kSwitchOnDisabled},
    {"10", PS::kSwitchedOn, Cmd::kQuickStop, PS::kSwitchOnDisabled},
    {"11", PS::kOperationEnabled, Cmd::kQuickStop, PS::kQuickStopActive},
    {"12", PS::kQuickStopActive, Cmd::kDisableVoltage, PS::kSwitchOnDisabled},
    {"15", PS::kFault, Cmd::kFaultReset, PS::kSwitchOnDisabled},
    {"16", PS::kQuickStopActive, Cmd::kEnableOperation, PS::kOperationEnabled, true},
};

// Expected state after one step in `from` with `cw` (previous controlword `prev`), or `from`.
PS expected_next(PS from, std::uint16_t cw, std::uint16_t prev, std::int16_t qs_option,
                 std::string* which) {
  for (const TransitionRow& t : kTransitions) {
    if (t.from != from || !command_matches(t.cmd, cw, prev)) continue;
    if (t.only_quick_stop_option_5_to_8 && qs_option < 5) continue;
    *which = t.number;
    return t.to;
  }
  *which = "none";
  return from;
}

// A drive brought into `state` through the standard's own commands. Timers are long so no
// automatic transition fires during the step under test. The last controlword has bit 7 = 0.
Cia402Drive drive_in(PS state, std::int16_t qs_option) {
  Cia402DriveSettings s;
  s.init_periods = state == PS::kNotReadyToSwitchOn ? 1000 : 1;
  s.fault_reaction_periods = state == PS::kFaultReactionActive ? 1000 : 0;
  s.quick_stop_option_code = qs_option;
  s.quick_stop_periods = 1000;
  Cia402Drive d(s);
  if (state == PS::kNotReadyToSwitchOn) return d;
  if (state == PS::kFaultReactionActive || state == PS::kFault) {
    d.inject_fault(0x2310);
    if (state == PS::kFault) d.step(0x0000, 0);
    return d;
  }
  d.step(0x0000, 0);
  d.step(0x0000, 0);  // transition 1
  if (state == PS::kSwitchOnDisabled) return d;
  d.step(0x0006, 0);
  if (state == PS::kReadyToSwitchOn) return d;
  d.step(0x0007, 0);
  if (state == PS::kSwitchedOn) return d;
  d.step(0x000F, 0);
  if (state == PS::kOperationEnabled) return d;
  d.step(0x0002, 0);  // kQuickStopActive
  return d;
}

// ----------------------------------------------------------------------------------------------
// Statusword and controlword coding
// ----------------------------------------------------------------------------------------------

TEST(Cia402Coding, StateMasksAreTheStandardOnes) {
  // The rows whose quick stop bit is x use mask 0x004F, the others 0x006F.
  for (const StateRow& r : kStateTable) {
    const Pattern p = parse(r.bits, kAll16);
    const bool qs_dont_care = (p.mask & StatuswordBit::kQuickStop) == 0;
    EXPECT_EQ(p.mask, qs_dont_care ? kStateMaskWithoutQuickStop : kStateMaskWithQuickStop)
        << r.bits;
    EXPECT_EQ(power_state_bits(r.state), p.value) << r.bits;
  }
}

TEST(Cia402Coding, EveryStatuswordDecodesToItsTableRowOrUnknown) {
  // All 65536 statuswords: every don't-care bit varied.
  std::array<int, 9> per_state{};
  for (std::uint32_t w = 0; w <= 0xFFFF; ++w) {
    const auto sw = static_cast<std::uint16_t>(w);
    PS expected = PS::kUnknown;
    int rows = 0;
    for (const StateRow& r : kStateTable) {
      if (parse(r.bits, kAll16).matches(sw)) {
        expected = r.state;
        ++rows;
      }
    }
    ASSERT_LE(rows, 1) << "rows overlap at 0x" << std::hex << w;
    ASSERT_EQ(decode_power_state(sw), expected) << "statusword 0x" << std::hex << w;
    ++per_state[static_cast<std::size_t>(expected)];
  }
  // 5 bits fixed by the 0x4F rows (2^11 statuswords each), 6 by the 0x6F rows (2^10 each).
  EXPECT_EQ(per_state[static_cast<std::size_t>(PS::kNotReadyToSwitchOn)], 2048);
  EXPECT_EQ(per_state[static_cast<std::size_t>(PS::kFault)], 2048);
  EXPECT_EQ(per_state[static_cast<std::size_t>(PS::kOperationEnabled)], 1024);
  EXPECT_EQ(per_state[static_cast<std::size_t>(PS::kQuickStopActive)], 1024);
  EXPECT_EQ(per_state[static_cast<std::size_t>(PS::kUnknown)], 65536 - 4 * 2048 - 4 * 1024);
}

TEST(Cia402Coding, TypicalDriveStatuswords) {
  // Values real drives report (voltage enabled, remote set).
  EXPECT_EQ(decode_power_state(0x0250), PS::kSwitchOnDisabled);
  EXPECT_EQ(decode_power_state(0x0231), PS::kReadyToSwitchOn);
  EXPECT_EQ(decode_power_state(0x0233), PS::kSwitchedOn);
  EXPECT_EQ(decode_power_state(0x0237), PS::kOperationEnabled);
  EXPECT_EQ(decode_power_state(0x0217), PS::kQuickStopActive);
  EXPECT_EQ(decode_power_state(0x021F), PS::kFaultReactionActive);
  EXPECT_EQ(decode_power_state(0x0218), PS::kFault);
  EXPECT_EQ(decode_power_state(0x0001), PS::kUnknown);  // ready bit without quick stop bit
  EXPECT_EQ(decode_power_state(0x0041), PS::kUnknown);  // switch on disabled + ready
}

TEST(Cia402Coding, StatuswordFlags) {
  const Statusword s = decode_statusword(0x1E37 | 0x0080);
  EXPECT_EQ(s.state, PS::kOperationEnabled);
  EXPECT_TRUE(s.voltage_enabled);
  EXPECT_TRUE(s.warning);
  EXPECT_TRUE(s.remote);
  EXPECT_TRUE(s.target_reached);
  EXPECT_TRUE(s.internal_limit_active);
  EXPECT_TRUE(s.drive_follows_command);
  const Statusword z = decode_statusword(0x0027);
  EXPECT_EQ(z.state, PS::kOperationEnabled);
  EXPECT_FALSE(z.voltage_enabled || z.warning || z.remote || z.target_reached ||
               z.internal_limit_active || z.drive_follows_command);
  // One bit at a time.
  EXPECT_TRUE(decode_statusword(1u << 4).voltage_enabled);
  EXPECT_TRUE(decode_statusword(1u << 7).warning);
  EXPECT_TRUE(decode_statusword(1u << 9).remote);
  EXPECT_TRUE(decode_statusword(1u << 10).target_reached);
  EXPECT_TRUE(decode_statusword(1u << 11).internal_limit_active);
  EXPECT_TRUE(decode_statusword(1u << 12).drive_follows_command);
  EXPECT_FALSE(decode_statusword(1u << 8).remote);
}

TEST(Cia402Coding, EveryControlwordIsExactlyOneCommand) {
  for (std::uint32_t w = 0; w <= 0xFFFF; ++w) {
    const auto cw = static_cast<std::uint16_t>(w);
    const ControlCommand got = decode_controlword(cw);
    // Oracle rows; switch on / disable operation and enable operation / switch on + enable
    // operation share their bits.
    int distinct = 0;
    ControlCommand expected = ControlCommand::kFaultReset;
    auto row = [&](const char* bits) { return parse(bits, kCommandBits).matches(cw); };
    if ((cw & 0x80) != 0) {
      ++distinct;
    }
    if (row("0 X 1 1 0")) ++distinct, expected = ControlCommand::kShutdown;
    if (row("0 0 1 1 1")) ++distinct, expected = ControlCommand::kSwitchOn;
    if (row("0 1 1 1 1")) ++distinct, expected = ControlCommand::kEnableOperation;
    if (row("0 X X 0 X")) ++distinct, expected = ControlCommand::kDisableVoltage;
    if (row("0 X 0 1 X")) ++distinct, expected = ControlCommand::kQuickStop;
    ASSERT_EQ(distinct, 1) << "controlword 0x" << std::hex << w;
    ASSERT_EQ(got, expected) << "controlword 0x" << std::hex << w;
  }
}

TEST(Cia402Coding, NamedControlwordsCarryTheirCommands) {
  EXPECT_EQ(decode_controlword(Controlword::kShutdown), ControlCommand::kShutdown);
  EXPECT_EQ(decode_controlword(Controlword::kSwitchOn), ControlCommand::kSwitchOn);
  EXPECT_EQ(decode_controlword(Controlword::kDisableOperation), ControlCommand::kSwitchOn);
  EXPECT_EQ(decode_controlword(Controlword::kSwitchOnEnableOperation),
            ControlCommand::kEnableOperation);
  EXPECT_EQ(decode_controlword(Controlword::kEnableOperation), ControlCommand::kEnableOperation);
  EXPECT_EQ(decode_controlword(Controlword::kDisableVoltage), ControlCommand::kDisableVoltage);
  EXPECT_EQ(decode_controlword(Controlword::kQuickStop), ControlCommand::kQuickStop);
  EXPECT_EQ(decode_controlword(Controlword::kFaultReset), ControlCommand::kFaultReset);
  EXPECT_EQ(Controlword::kShutdown, 0x0006);
  EXPECT_EQ(Controlword::kSwitchOn, 0x0007);
  EXPECT_EQ(Controlword::kEnableOperation, 0x000F);
  EXPECT_EQ(Controlword::kQuickStop, 0x0002);
  EXPECT_EQ(Controlword::kFaultReset, 0x0080);
  EXPECT_STREQ(to_string(PS::kQuickStopActive), "quick stop active");
  EXPECT_STREQ(to_string(ControlCommand::kShutdown), "shutdown");
  EXPECT_STREQ(to_string(Cia402Target::kEnabled), "enabled");
}

// ----------------------------------------------------------------------------------------------
// Drive emulator
// ----------------------------------------------------------------------------------------------

TEST(Cia402Drive, HelperReachesEveryState) {
  for (PS s : kAllStates) {
    EXPECT_EQ(drive_in(s, 6).state(), s) << to_string(s);
    EXPECT_EQ(decode_power_state(drive_in(s, 2).statusword()), s) << to_string(s);
  }
}

TEST(Cia402Drive, EveryStateTimesEveryControlwordFollowsTheTransitionTable) {
  // States × controlwords 0x000–0x1FF (bits 0–8: the command bits, the mode-specific bits 4–6
  // and halt) × previous bit 7 low / high × quick stop option codes 2 (transit to switch on
  // disabled) and 6 (stay in quick stop active).
  int transitions_seen = 0;
  for (std::int16_t qs_option : {std::int16_t{2}, std::int16_t{6}}) {
    for (PS from : kAllStates) {
      for (bool prev_high : {false, true}) {
        Cia402Drive base = drive_in(from, qs_option);
        std::uint16_t prev = 0x0000;
        if (prev_high) {
          // Bit 7 high for a step without leaving the state: in fault, with a persistent cause.
          if (from == PS::kFault) base.inject_fault(0x2310, true);
          base.step(0x0080, 0);
          if (from == PS::kFault) base.clear_fault_condition();
          prev = 0x0080;
          ASSERT_EQ(base.state(), from) << to_string(from);
        }
        for (std::uint16_t cw = 0; cw < 0x200; ++cw) {
          Cia402Drive d = base;
          d.step(cw, 0);
          std::string which;
          const PS expected = expected_next(from, cw, prev, qs_option, &which);
          ASSERT_EQ(d.state(), expected) << "from " << to_string(from) << ", controlword 0x"
                                         << std::hex << cw << ", previous 0x" << prev << std::dec
                                         << ", option " << qs_option << ", transition " << which;
          ASSERT_EQ(decode_power_state(d.statusword()), expected);
          if (expected != from) ++transitions_seen;
        }
      }
    }
  }
  EXPECT_GT(transitions_seen, 1000);  // the table is exercised, not just "no transition"
}

TEST(Cia402Drive, PowerUpPerformsTransitions0And1) {
  Cia402DriveSettings s;
  s.init_periods = 3;
  Cia402Drive d(s);
  EXPECT_EQ(d.state(), PS::kNotReadyToSwitchOn);  // transition 0 at construction
  EXPECT_EQ(d.statusword(), 0x0210);              // voltage enabled, remote
  for (int i = 0; i < 3; ++i) {
    d.step(Controlword::kShutdown, 0);  // ignored while initialising
    EXPECT_EQ(d.state(), PS::kNotReadyToSwitchOn) << i;
  }
  d.step(0x0000, 0);  // transition 1
  EXPECT_EQ(d.state(), PS::kSwitchOnDisabled);
  EXPECT_EQ(d.statusword(), 0x0250);
  EXPECT_EQ(d.counters().transitions, 1u);
}

TEST(Cia402Drive, TypicalStatuswordsOnTheWayUp) {
  Cia402Drive d;
  d.step(0, 0);
  d.step(0, 0);
  EXPECT_EQ(d.statusword(), 0x0250);
  d.step(Controlword::kShutdown, 0);
  EXPECT_EQ(d.statusword(), 0x0231);
  d.step(Controlword::kSwitchOn, 0);
  EXPECT_EQ(d.statusword(), 0x0233);
  d.step(Controlword::kEnableOperation, 100);
  // Operation enabled, following the target torque (bit 12), target reached (bit 10).
  EXPECT_EQ(d.statusword(), 0x1637);
  EXPECT_EQ(d.applied_torque_per_mille(), 100);
}

TEST(Cia402Drive, SwitchOnPlusEnableOperationDoesThreeAndFourInOneStep) {
  Cia402Drive d = drive_in(PS::kReadyToSwitchOn, 2);
  d.step(Controlword::kSwitchOnEnableOperation, 321);
  EXPECT_EQ(d.state(), PS::kOperationEnabled);
  EXPECT_EQ(d.applied_torque_per_mille(), 321);
}

TEST(Cia402Drive, TorqueIsAppliedOnlyInOperationEnabled) {
  for (PS s : kAllStates) {
    Cia402Drive d = drive_in(s, 6);
    // The holding command of each state (no transition), with a torque request.
    const std::uint16_t hold = s == PS::kOperationEnabled  ? Controlword::kEnableOperation
                               : s == PS::kQuickStopActive ? Controlword::kQuickStop
                               : s == PS::kReadyToSwitchOn ? Controlword::kShutdown
                               : s == PS::kSwitchedOn      ? Controlword::kSwitchOn
                                                           : Controlword::kDisableVoltage;
    d.step(hold, 500);
    ASSERT_EQ(d.state(), s);
    EXPECT_EQ(d.applied_torque_per_mille(), s == PS::kOperationEnabled ? 500 : 0) << to_string(s);
    EXPECT_EQ((d.statusword() & StatuswordBit::kDriveFollowsCommand) != 0,
              s == PS::kOperationEnabled);
  }
}

TEST(Cia402Drive, TorqueClippedAtMaxTorqueReportsInternalLimit) {
  Cia402DriveSettings s;
  s.max_torque_per_mille = 800;
  Cia402Drive d(s);
  for (std::uint16_t cw : {0x0, 0x0, 0x6, 0x7, 0xF}) d.step(cw, 0);
  ASSERT_EQ(d.state(), PS::kOperationEnabled);
  d.step(0xF, 1500);
  EXPECT_EQ(d.applied_torque_per_mille(), 800);
  EXPECT_TRUE(decode_statusword(d.statusword()).internal_limit_active);
  EXPECT_FALSE(decode_statusword(d.statusword()).target_reached);
  d.step(0xF, -32768);
  EXPECT_EQ(d.applied_torque_per_mille(), -800);
  d.step(0xF, -799);
  EXPECT_EQ(d.applied_torque_per_mille(), -799);
  EXPECT_FALSE(decode_statusword(d.statusword()).internal_limit_active);
  EXPECT_TRUE(decode_statusword(d.statusword()).target_reached);
  EXPECT_EQ(d.counters().torque_limited, 2u);
}

TEST(Cia402Drive, HaltAndOtherModesApplyNoTorque) {
  Cia402Drive d = drive_in(PS::kOperationEnabled, 2);
  d.step(Controlword::kEnableOperation | ControlwordBit::kHalt, 400);
  EXPECT_EQ(d.state(), PS::kOperationEnabled);
  EXPECT_EQ(d.applied_torque_per_mille(), 0);
  EXPECT_TRUE(decode_statusword(d.statusword()).target_reached);
  d.set_modes_of_operation(9);  // cyclic synchronous velocity: target torque not used
  EXPECT_EQ(d.modes_of_operation_display(), 9);
  d.step(Controlword::kEnableOperation, 400);
  EXPECT_EQ(d.applied_torque_per_mille(), 0);
  EXPECT_FALSE(decode_statusword(d.statusword()).drive_follows_command);
  d.set_modes_of_operation(kModeCyclicSynchronousTorque);
  d.step(Controlword::kEnableOperation, 400);
  EXPECT_EQ(d.applied_torque_per_mille(), 400);
}

TEST(Cia402Drive, FaultReactionThenFaultThenResetOnRisingEdge) {
  Cia402DriveSettings s;
  s.fault_reaction_periods = 2;
  Cia402Drive d(s);
  for (std::uint16_t cw : {0x0, 0x0, 0x6, 0x7, 0xF}) d.step(cw, 0);
  d.step(0xF, 300);
  ASSERT_EQ(d.applied_torque_per_mille(), 300);
  d.inject_fault(0x3210);  // transition 13
  EXPECT_EQ(d.state(), PS::kFaultReactionActive);
  EXPECT_EQ(d.statusword() & 0x4F, 0x0F);
  EXPECT_EQ(d.applied_torque_per_mille(), 0);
  EXPECT_EQ(d.error_code(), 0x3210);
  d.inject_fault(0x4310);  // a second fault keeps the first code
  EXPECT_EQ(d.error_code(), 0x3210);
  EXPECT_EQ(d.counters().faults, 1u);
  for (int i = 0; i < 2; ++i) {
    d.step(0x0080, 300);  // commands, the reset edge included, are ignored during the reaction
    EXPECT_EQ(d.state(), PS::kFaultReactionActive) << i;
    EXPECT_EQ(d.applied_torque_per_mille(), 0);
  }
  d.step(0x0080, 300);  // transition 14; bit 7 already high: no edge
  EXPECT_EQ(d.state(), PS::kFault);
  EXPECT_EQ(d.statusword(), 0x0218);
  d.step(0x0080, 0);
  EXPECT_EQ(d.state(), PS::kFault);  // still no edge
  d.step(0x000F, 0);
  EXPECT_EQ(d.state(), PS::kFault);  // enable operation does nothing in fault
  d.step(0x0080, 0);                 // rising edge: transition 15
  EXPECT_EQ(d.state(), PS::kSwitchOnDisabled);
  EXPECT_EQ(d.error_code(), 0);
  EXPECT_EQ(d.counters().fault_resets, 1u);
}

TEST(Cia402Drive, PersistentFaultRefusesResetUntilItsCauseIsGone) {
  Cia402DriveSettings s;
  s.fault_reaction_periods = 0;
  Cia402Drive d(s);
  d.inject_fault(0x7500, true);
  d.step(0x0000, 0);
  ASSERT_EQ(d.state(), PS::kFault);
  d.step(0x0080, 0);
  EXPECT_EQ(d.state(), PS::kFault);
  d.clear_fault_condition();
  d.step(0x0080, 0);  // bit 7 still high: no new edge
  EXPECT_EQ(d.state(), PS::kFault);
  d.step(0x0000, 0);
  d.step(0x0080, 0);
  EXPECT_EQ(d.state(), PS::kSwitchOnDisabled);
}

TEST(Cia402Drive, QuickStopOptionCodes) {
  // 0: disable drive function — switch on disabled at the next step.
  {
    Cia402DriveSettings s;
    s.quick_stop_option_code = 0;
    s.quick_stop_periods = 50;  // not used by code 0
    Cia402Drive d(s);
    for (std::uint16_t cw : {0x0, 0x0, 0x6, 0x7, 0xF, 0x2}) d.step(cw, 100);
    EXPECT_EQ(d.state(), PS::kQuickStopActive);
    EXPECT_EQ(d.applied_torque_per_mille(), 0);
    d.step(0x2, 100);
    EXPECT_EQ(d.state(), PS::kSwitchOnDisabled);
  }
  // 2: stop for quick_stop_periods, then transition 12; enable operation does not return.
  {
    Cia402DriveSettings s;
    s.quick_stop_option_code = 2;
    s.quick_stop_periods = 3;
    Cia402Drive d(s);
    for (std::uint16_t cw : {0x0, 0x0, 0x6, 0x7, 0xF, 0x2}) d.step(cw, 100);
    EXPECT_EQ(d.statusword(), 0x0217);
    d.step(0xF, 100);  // transition 16 is not allowed with code 2
    d.step(0x2, 100);
    d.step(0x2, 100);
    EXPECT_EQ(d.state(), PS::kQuickStopActive);
    d.step(0x2, 100);
    EXPECT_EQ(d.state(), PS::kSwitchOnDisabled);
  }
  // 6: stop, then stay in quick stop active; enable operation returns (transition 16).
  {
    Cia402DriveSettings s;
    s.quick_stop_option_code = 6;
    s.quick_stop_periods = 2;
    Cia402Drive d(s);
    for (std::uint16_t cw : {0x0, 0x0, 0x6, 0x7, 0xF, 0x2}) d.step(cw, 100);
    for (int i = 0; i < 20; ++i) d.step(0x2, 100);
    EXPECT_EQ(d.state(), PS::kQuickStopActive);
    d.step(0xF, 100);
    EXPECT_EQ(d.state(), PS::kOperationEnabled);
    EXPECT_EQ(d.applied_torque_per_mille(), 100);
  }
}

TEST(Cia402Drive, LocalControlIgnoresTheControlword) {
  Cia402DriveSettings s;
  s.remote = false;
  Cia402Drive d(s);
  for (std::uint16_t cw : {0x0, 0x0, 0x6, 0x7, 0xF}) d.step(cw, 100);
  EXPECT_EQ(d.state(), PS::kSwitchOnDisabled);  // only the automatic transition 1
  EXPECT_FALSE(decode_statusword(d.statusword()).remote);
}

TEST(Cia402Drive, WarningBitDoesNotChangeTheState) {
  Cia402Drive d = drive_in(PS::kOperationEnabled, 2);
  d.set_warning(true);
  d.step(0xF, 10);
  EXPECT_TRUE(decode_statusword(d.statusword()).warning);
  EXPECT_EQ(decode_power_state(d.statusword()), PS::kOperationEnabled);
  EXPECT_EQ(d.applied_torque_per_mille(), 10);
}

TEST(Cia402Drive, SettingsAreValidated) {
  Cia402DriveSettings s;
  s.quick_stop_option_code = 9;
  try {
    Cia402Drive d(s);
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("quick_stop_option_code"), std::string::npos);
  }
  s.quick_stop_option_code = -1;
  EXPECT_THROW(Cia402Drive{s}, std::invalid_argument);
  s.quick_stop_option_code = 8;
  s.max_torque_per_mille = 0;
  try {
    Cia402Drive d(s);
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("max_torque_per_mille"), std::string::npos);
  }
}

}  // namespace
