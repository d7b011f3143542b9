// Tests of numen/hal/canopen/canopen.hpp: SYNC, position TPDO and torque RPDO layouts and checks.
#include "numen/hal/canopen/canopen.hpp"

#include <gtest/gtest.h>

#include <limits>

namespace {

using namespace numen::hal;

TEST(Canopen, SyncWithAndWithoutCounter) {
  CanFrame s = make_sync(123);
  EXPECT_EQ(s.id, 0x080u);
  EXPECT_EQ(s.len, 0);
  EXPECT_EQ(s.timestamp_ns, 123);
  EXPECT_TRUE(is_sync(s));
  s = make_sync(0, 17);
  EXPECT_EQ(s.len, 1);
  EXPECT_EQ(s.data[0], 17);
  EXPECT_TRUE(is_sync(s));
  s.len = 2;
  EXPECT_FALSE(is_sync(s));
  s.len = 0;
  s.flags = CanFlag::kRemote;
  EXPECT_FALSE(is_sync(s));
  // Not a SYNC either: a CAN FD frame on 0x080, a 29-bit 0x00000080, an error report whose
  // class bits read 0x080 (CAN_ERR_BUSERROR).
  for (std::uint8_t flag : {CanFlag::kFd, CanFlag::kExtendedId, CanFlag::kErrorFrame}) {
    s = make_sync(0, 3);
    s.flags = flag;
    EXPECT_FALSE(is_sync(s)) << int(flag);
  }
}

TEST(Canopen, DefaultCobIds) {
  EXPECT_EQ(encoder_tpdo_cob_id(1), 0x181u);
  EXPECT_EQ(encoder_tpdo_cob_id(127), 0x1FFu);
  EXPECT_EQ(drive_rpdo_cob_id(5), 0x205u);
}

TEST(Canopen, PositionPdoIsInt32LittleEndian) {
  const CanFrame f = encode_position_pdo(0x183, 0x12345678, 9);
  EXPECT_EQ(f.id, 0x183u);
  EXPECT_EQ(f.len, 4);
  EXPECT_EQ(f.data[0], 0x78);
  EXPECT_EQ(f.data[1], 0x56);
  EXPECT_EQ(f.data[2], 0x34);
  EXPECT_EQ(f.data[3], 0x12);
  EXPECT_EQ(f.timestamp_ns, 9);
  const CanFrame m = encode_position_pdo(0x183, -2, 0);
  EXPECT_EQ(m.data[0], 0xFE);
  EXPECT_EQ(m.data[3], 0xFF);
}

TEST(Canopen, PositionRoundTripIncludingExtremes) {
  for (std::int32_t v : {0, 1, -1, 123456, -987654, std::numeric_limits<std::int32_t>::min(),
                         std::numeric_limits<std::int32_t>::max()}) {
    std::int32_t out = 0;
    ASSERT_EQ(decode_position_pdo(encode_position_pdo(0x181, v, 0), 0x181, out), DecodeStatus::kOk);
    EXPECT_EQ(out, v);
  }
}

TEST(Canopen, PositionDecodeChecksIdFrameTypeAndLength) {
  CanFrame f = encode_position_pdo(0x181, 42, 0);
  std::int32_t out = 7;
  EXPECT_EQ(decode_position_pdo(f, 0x182, out), DecodeStatus::kWrongId);
  f.len = 3;
  EXPECT_EQ(decode_position_pdo(f, 0x181, out), DecodeStatus::kWrongLength);
  f.len = 8;
  EXPECT_EQ(decode_position_pdo(f, 0x181, out), DecodeStatus::kWrongLength);
  f.len = 4;
  f.flags = CanFlag::kRemote;
  EXPECT_EQ(decode_position_pdo(f, 0x181, out), DecodeStatus::kNotDataFrame);
  f.flags = CanFlag::kFd;  // a CAN FD frame on the classic COB-ID: ours, but wrong
  EXPECT_EQ(decode_position_pdo(f, 0x181, out), DecodeStatus::kNotDataFrame);
  // A 29-bit frame 0x00000181 is another identifier; an error report is no frame on the wire.
  f.flags = CanFlag::kExtendedId;
  EXPECT_EQ(decode_position_pdo(f, 0x181, out), DecodeStatus::kWrongId);
  f.flags = CanFlag::kErrorFrame;
  EXPECT_EQ(decode_position_pdo(f, 0x181, out), DecodeStatus::kWrongId);
  EXPECT_EQ(out, 7);  // untouched on failure
}

TEST(Canopen, TorquePdoIsInt16LittleEndian) {
  const CanFrame f = encode_torque_pdo(0x201, -1000, 5);
  EXPECT_EQ(f.len, 2);
  EXPECT_EQ(f.data[0], 0x18);  // -1000 = 0xFC18
  EXPECT_EQ(f.data[1], 0xFC);
  std::int16_t pm = 0;
  ASSERT_EQ(decode_torque_pdo(f, 0x201, pm), DecodeStatus::kOk);
  EXPECT_EQ(pm, -1000);
  CanFrame g = f;
  g.len = 4;
  EXPECT_EQ(decode_torque_pdo(g, 0x201, pm), DecodeStatus::kWrongLength);
  EXPECT_EQ(decode_torque_pdo(f, 0x202, pm), DecodeStatus::kWrongId);
  for (std::int16_t v : {std::numeric_limits<std::int16_t>::min(), std::int16_t{0},
                         std::numeric_limits<std::int16_t>::max()}) {
    ASSERT_EQ(decode_torque_pdo(encode_torque_pdo(0x201, v, 0), 0x201, pm), DecodeStatus::kOk);
    EXPECT_EQ(pm, v);
  }
}

}  // namespace
