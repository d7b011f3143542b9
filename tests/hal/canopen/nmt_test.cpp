// Tests of numen/hal/canopen/nmt.hpp: NMT node control frames, decode rejections, NMT states and the
// slave-side state machine (CiA 301 §7.2.8.3.1, §7.3.2).
#include "numen/hal/canopen/nmt.hpp"

#include <gtest/gtest.h>

#include <cstring>
#include <stdexcept>
#include <string>

#include "alloc_counter.hpp"

namespace {

using namespace numen::hal;

constexpr NmtCommand kAllCommands[] = {NmtCommand::kStartRemoteNode, NmtCommand::kStopRemoteNode,
                                       NmtCommand::kEnterPreOperational, NmtCommand::kResetNode,
                                       NmtCommand::kResetCommunication};

CanFrame nmt_frame(std::uint8_t cs, std::uint8_t node, std::uint8_t len = 2) {
  CanFrame f;
  f.id = 0x000;
  f.len = len;
  f.data[0] = cs;
  f.data[1] = node;
  return f;
}

TEST(Nmt, CommandFramesAreByteExact) {
  struct Case {
    NmtCommand command;
    std::uint8_t node;
    std::uint8_t cs;
  };
  const Case cases[] = {
      {NmtCommand::kStartRemoteNode, 5, 0x01},      {NmtCommand::kStopRemoteNode, 5, 0x02},
      {NmtCommand::kEnterPreOperational, 5, 0x80},  {NmtCommand::kResetNode, 5, 0x81},
      {NmtCommand::kResetCommunication, 5, 0x82},   {NmtCommand::kStartRemoteNode, 0, 0x01},
      {NmtCommand::kResetCommunication, 127, 0x82},
  };
  for (const Case& c : cases) {
    CanFrame f;
    ASSERT_TRUE(encode_nmt(c.command, c.node, 777, f));
    EXPECT_EQ(f.id, 0x000u);
    EXPECT_EQ(f.flags, 0);
    EXPECT_EQ(f.len, 2);
    EXPECT_EQ(f.data[0], c.cs) << to_string(c.command);
    EXPECT_EQ(f.data[1], c.node);
    EXPECT_EQ(f.timestamp_ns, 777);
    EXPECT_EQ(check_frame(f), FrameError::kNone);
  }
}

TEST(Nmt, EncodeRefusesBadNodeIdAndCommand) {
  CanFrame f;
  f.id = 0x123;
  EXPECT_FALSE(encode_nmt(NmtCommand::kStartRemoteNode, 128, 0, f));
  EXPECT_FALSE(encode_nmt(NmtCommand::kStartRemoteNode, 255, 0, f));
  EXPECT_FALSE(encode_nmt(static_cast<NmtCommand>(0x03), 1, 0, f));
  EXPECT_EQ(f.id, 0x123u);  // unchanged
}

TEST(Nmt, DecodeRoundTripsEveryCommandAndNode) {
  for (NmtCommand c : kAllCommands) {
    for (int node = 0; node <= 127; ++node) {
      CanFrame f;
      ASSERT_TRUE(encode_nmt(c, static_cast<std::uint8_t>(node), 0, f));
      NmtMessage m;
      ASSERT_EQ(decode_nmt(f, m), NmtDecodeStatus::kOk);
      EXPECT_EQ(m.command, c);
      EXPECT_EQ(m.node_id, node);
    }
  }
}

TEST(Nmt, DecodeRejections) {
  const NmtMessage sentinel{NmtCommand::kResetNode, 99};
  auto expect = [&](const CanFrame& f, NmtDecodeStatus want) {
    NmtMessage m = sentinel;
    EXPECT_EQ(decode_nmt(f, m), want) << to_string(want);
    EXPECT_EQ(m.command, sentinel.command);
    EXPECT_EQ(m.node_id, sentinel.node_id);
  };
  CanFrame f = nmt_frame(0x01, 5);
  f.id = 0x001;
  expect(f, NmtDecodeStatus::kWrongId);
  f = nmt_frame(0x01, 5);
  f.id = 0x701;
  expect(f, NmtDecodeStatus::kWrongId);
  // Lengths other than 2.
  for (std::uint8_t len : {0, 1, 3, 8})
    expect(nmt_frame(0x01, 5, len), NmtDecodeStatus::kWrongLength);
  // Unknown command specifiers: every byte but the five.
  int unknown = 0;
  for (int cs = 0; cs < 256; ++cs) {
    NmtMessage m;
    const NmtDecodeStatus s = decode_nmt(nmt_frame(static_cast<std::uint8_t>(cs), 5), m);
    if (s == NmtDecodeStatus::kUnknownCommand) ++unknown;
    EXPECT_EQ(s == NmtDecodeStatus::kOk, is_nmt_command(static_cast<std::uint8_t>(cs)));
  }
  EXPECT_EQ(unknown, 256 - 5);
  // Node id above 127.
  expect(nmt_frame(0x01, 128), NmtDecodeStatus::kNodeIdOutOfRange);
  expect(nmt_frame(0x81, 255), NmtDecodeStatus::kNodeIdOutOfRange);
  // Remote request, CAN FD on COB-ID 0: not a CiA 301 NMT message.
  for (std::uint8_t flag : {CanFlag::kRemote, CanFlag::kFd}) {
    f = nmt_frame(0x01, 5);
    f.flags = flag;
    expect(f, NmtDecodeStatus::kNotDataFrame);
  }
  // 29-bit id 0 and an error report with class bits 0 are not on COB-ID 0 at all.
  for (std::uint8_t flag : {CanFlag::kExtendedId, CanFlag::kErrorFrame}) {
    f = nmt_frame(0x01, 5);
    f.flags = flag;
    expect(f, NmtDecodeStatus::kWrongId);
  }
  // The order of the checks: a remote frame of wrong length is "not a data frame".
  f = nmt_frame(0x01, 5, 0);
  f.flags = CanFlag::kRemote;
  expect(f, NmtDecodeStatus::kNotDataFrame);
}

TEST(Nmt, StatesAndNames) {
  EXPECT_EQ(static_cast<int>(NmtState::kBootUp), 0x00);
  EXPECT_EQ(static_cast<int>(NmtState::kStopped), 0x04);
  EXPECT_EQ(static_cast<int>(NmtState::kOperational), 0x05);
  EXPECT_EQ(static_cast<int>(NmtState::kPreOperational), 0x7F);
  EXPECT_STREQ(to_string(NmtState::kBootUp), "boot-up");
  EXPECT_STREQ(to_string(NmtState::kStopped), "stopped");
  EXPECT_STREQ(to_string(NmtState::kOperational), "operational");
  EXPECT_STREQ(to_string(NmtState::kPreOperational), "pre-operational");
  EXPECT_STREQ(to_string(static_cast<NmtState>(0x85)), "unknown");
  int states = 0;
  for (int v = 0; v < 256; ++v) states += is_nmt_state(static_cast<std::uint8_t>(v)) ? 1 : 0;
  EXPECT_EQ(states, 4);
  EXPECT_STREQ(to_string(NmtCommand::kStartRemoteNode), "start remote node");
  EXPECT_STREQ(to_string(NmtCommand::kResetCommunication), "reset communication");
  EXPECT_STREQ(to_string(NmtDecodeStatus::kNodeIdOutOfRange), "node id out of range");
}

TEST(Nmt, CommunicationObjectsPerState) {
  // CiA 301 §7.3.2.2: rows = state, columns = PDO SDO SYNC TIME EMCY NMT error-control.
  const CommObject objects[] = {CommObject::kPdo,         CommObject::kSdo,  CommObject::kSync,
                                CommObject::kTime,        CommObject::kEmcy, CommObject::kNmt,
                                CommObject::kErrorControl};
  struct Row {
    NmtState state;
    bool allowed[7];
  };
  const Row rows[] = {
      {NmtState::kBootUp, {false, false, false, false, false, false, true}},
      {NmtState::kPreOperational, {false, true, true, true, true, true, true}},
      {NmtState::kOperational, {true, true, true, true, true, true, true}},
      {NmtState::kStopped, {false, false, false, false, false, true, true}},
  };
  for (const Row& r : rows) {
    for (int i = 0; i < 7; ++i) {
      EXPECT_EQ(nmt_allows(r.state, objects[i]), r.allowed[i])
          << to_string(r.state) << " / " << to_string(objects[i]);
    }
  }
  EXPECT_FALSE(nmt_allows(static_cast<NmtState>(0x12), CommObject::kErrorControl));
}

TEST(NmtNodeModel, PowerOnBootUpThenPreOperational) {
  NmtNodeModel node(5);
  EXPECT_EQ(node.state(), NmtState::kBootUp);
  EXPECT_EQ(node.last_reset(), NmtReset::kPowerOn);
  EXPECT_TRUE(node.allows(CommObject::kErrorControl));
  EXPECT_FALSE(node.allows(CommObject::kSdo));
  // Initialisation is not left by a command (CiA 301 NMT state diagram).
  EXPECT_EQ(node.apply(NmtCommand::kStartRemoteNode), NmtApplyResult::kIgnoredInitialising);
  EXPECT_EQ(node.state(), NmtState::kBootUp);
  CanFrame boot;
  ASSERT_TRUE(node.take_boot_up(1'000, boot));
  EXPECT_EQ(boot.id, 0x705u);
  EXPECT_EQ(boot.len, 1);
  EXPECT_EQ(boot.data[0], 0x00);
  EXPECT_EQ(boot.timestamp_ns, 1'000);
  EXPECT_EQ(node.state(), NmtState::kPreOperational);
  CanFrame again;
  again.id = 0x3;
  EXPECT_FALSE(node.take_boot_up(2'000, again));  // one boot-up per initialisation
  EXPECT_EQ(again.id, 0x3u);
  EXPECT_EQ(node.counters().boot_ups, 1u);
  EXPECT_EQ(node.counters().ignored_initialising, 1u);
}

// Brings a fresh model to `state` through commands.
void drive_to(NmtNodeModel& node, NmtState state) {
  CanFrame boot;
  node.apply(NmtCommand::kResetCommunication);
  node.take_boot_up(0, boot);
  if (state == NmtState::kOperational) node.apply(NmtCommand::kStartRemoteNode);
  if (state == NmtState::kStopped) node.apply(NmtCommand::kStopRemoteNode);
  if (state == NmtState::kBootUp) node.apply(NmtCommand::kResetNode);
  ASSERT_EQ(node.state(), state);
}

TEST(NmtNodeModel, EveryTransitionOfTheStateDiagram) {
  // CiA 301 figure "NMT state diagram": (3)(6) start, (4)(7) enter pre-operational,
  // (5)(8) stop, (9)-(11) reset node, (12)-(14) reset communication.
  const NmtState from_states[] = {NmtState::kPreOperational, NmtState::kOperational,
                                  NmtState::kStopped};
  for (NmtState from : from_states) {
    for (NmtCommand c : kAllCommands) {
      NmtNodeModel node(9);
      drive_to(node, from);
      ASSERT_EQ(node.apply(c), NmtApplyResult::kApplied);
      NmtState want = NmtState::kBootUp;
      switch (c) {
        case NmtCommand::kStartRemoteNode:
          want = NmtState::kOperational;
          break;
        case NmtCommand::kStopRemoteNode:
          want = NmtState::kStopped;
          break;
        case NmtCommand::kEnterPreOperational:
          want = NmtState::kPreOperational;
          break;
        default:
          want = NmtState::kBootUp;
      }
      EXPECT_EQ(node.state(), want) << to_string(from) << " + " << to_string(c);
      if (c == NmtCommand::kResetNode) {
        EXPECT_EQ(node.last_reset(), NmtReset::kNode);
      }
      if (c == NmtCommand::kResetCommunication) {
        EXPECT_EQ(node.last_reset(), NmtReset::kCommunication);
      }
      // After a reset the boot-up message is pending again, then pre-operational.
      CanFrame boot;
      EXPECT_EQ(node.take_boot_up(5, boot), want == NmtState::kBootUp);
      if (want == NmtState::kBootUp) {
        EXPECT_EQ(boot.id, 0x709u);
        EXPECT_EQ(boot.data[0], 0x00);
        EXPECT_EQ(node.state(), NmtState::kPreOperational);
      }
    }
  }
}

TEST(NmtNodeModel, FramesAddressedToOthersAndBroadcast) {
  NmtNodeModel node(3);
  CanFrame f;
  node.take_boot_up(0, f);
  ASSERT_TRUE(encode_nmt(NmtCommand::kStartRemoteNode, 4, 0, f));
  EXPECT_EQ(node.on_frame(f), NmtApplyResult::kNotAddressed);
  EXPECT_EQ(node.state(), NmtState::kPreOperational);
  ASSERT_TRUE(encode_nmt(NmtCommand::kStartRemoteNode, 3, 0, f));
  EXPECT_EQ(node.on_frame(f), NmtApplyResult::kApplied);
  EXPECT_EQ(node.state(), NmtState::kOperational);
  EXPECT_TRUE(node.allows(CommObject::kPdo));
  ASSERT_TRUE(encode_nmt(NmtCommand::kStopRemoteNode, kNmtAllNodes, 0, f));
  EXPECT_EQ(node.on_frame(f), NmtApplyResult::kApplied);
  EXPECT_EQ(node.state(), NmtState::kStopped);
  EXPECT_FALSE(node.allows(CommObject::kSdo));
  EXPECT_FALSE(node.allows(CommObject::kEmcy));
  EXPECT_TRUE(node.allows(CommObject::kErrorControl));
  // Malformed NMT frames change nothing and are counted; other COB-IDs are ignored.
  EXPECT_EQ(node.on_frame(nmt_frame(0x01, 3, 3)), NmtApplyResult::kMalformed);
  EXPECT_EQ(node.on_frame(nmt_frame(0x07, 3)), NmtApplyResult::kMalformed);
  EXPECT_EQ(node.on_frame(nmt_frame(0x01, 200)), NmtApplyResult::kMalformed);
  CanFrame pdo = nmt_frame(0x01, 3);
  pdo.id = 0x203;
  EXPECT_EQ(node.on_frame(pdo), NmtApplyResult::kNotNmt);
  EXPECT_EQ(node.apply(static_cast<NmtCommand>(0x42)), NmtApplyResult::kMalformed);
  EXPECT_EQ(node.state(), NmtState::kStopped);
  EXPECT_EQ(node.counters().malformed, 4u);
  EXPECT_EQ(node.counters().not_addressed, 1u);
  EXPECT_EQ(node.counters().commands_applied, 2u);
  // Reset node by broadcast: boot-up again with the node's own COB-ID.
  ASSERT_TRUE(encode_nmt(NmtCommand::kResetNode, kNmtAllNodes, 0, f));
  EXPECT_EQ(node.on_frame(f), NmtApplyResult::kApplied);
  EXPECT_EQ(node.state(), NmtState::kBootUp);
  ASSERT_TRUE(node.take_boot_up(10, f));
  EXPECT_EQ(f.id, 0x703u);
  EXPECT_EQ(node.counters().resets, 1u);
  EXPECT_EQ(node.counters().boot_ups, 2u);
}

TEST(NmtNodeModel, ConstructorRejectsBadNodeId) {
  EXPECT_THROW(NmtNodeModel(0), std::invalid_argument);
  EXPECT_THROW(NmtNodeModel(128), std::invalid_argument);
  try {
    NmtNodeModel bad(200);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("200"), std::string::npos) << e.what();
  }
}

TEST(NmtNodeModel, PerPeriodCallsDoNotAllocate) {
  NmtNodeModel node(7);
  CanFrame frames[6];
  encode_nmt(NmtCommand::kStartRemoteNode, 7, 0, frames[0]);
  encode_nmt(NmtCommand::kStopRemoteNode, 0, 0, frames[1]);
  encode_nmt(NmtCommand::kEnterPreOperational, 7, 0, frames[2]);
  encode_nmt(NmtCommand::kResetCommunication, 7, 0, frames[3]);
  frames[4] = nmt_frame(0x99, 7);
  encode_nmt(NmtCommand::kResetNode, 8, 0, frames[5]);
  numen::test::AllocationGuard guard;
  std::uint64_t boots = 0;
  for (int k = 0; k < 10'000; ++k) {
    CanFrame out;
    if (node.take_boot_up(k, out)) ++boots;
    node.on_frame(frames[k % 6]);
    NmtMessage m;
    decode_nmt(frames[k % 6], m);
    encode_nmt(NmtCommand::kStartRemoteNode, static_cast<std::uint8_t>(k % 128), k, out);
    (void)to_string(node.state());
  }
  EXPECT_EQ(guard.count(), 0);
  EXPECT_GT(boots, 1000u);
}

}  // namespace
