// Tests of numen/hal/canopen/pdo_mapping.hpp: byte-exact packing, sign extension, length and range
// errors, setup validation, the mapping parameter words (CiA 301 §7.4.8) and agreement with
// the fixed codecs of canopen.hpp.
#include "numen/hal/canopen/pdo_mapping.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "alloc_counter.hpp"
#include "numen/hal/canopen/canopen.hpp"
#include "numen/hal/transport/splitmix64.hpp"

namespace {

using namespace numen::hal;

std::vector<std::uint8_t> payload(const CanFrame& f) {
  return std::vector<std::uint8_t>(f.data.begin(), f.data.begin() + f.len);
}

CanFrame frame_of(std::vector<std::uint8_t> bytes) {
  CanFrame f;
  f.id = 0x181;
  f.len = static_cast<std::uint8_t>(bytes.size());
  for (std::size_t i = 0; i < bytes.size(); ++i) f.data[i] = bytes[i];
  return f;
}

// What the constructor's message says, or "" if it does not throw.
std::string setup_error(std::initializer_list<PdoEntry> entries) {
  try {
    PdoMapping m(entries, "test");
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

TEST(PdoMapping, DriveRpdoControlwordAndTargetTorqueBytes) {
  const PdoMapping m = drive_rpdo_mapping();
  ASSERT_EQ(m.size(), 2u);
  EXPECT_EQ(m.length(), 4);
  CanFrame f;
  f.id = 0x201;
  f.data.fill(0xAA);
  const std::array<std::int64_t, 2> v = {0x000F, -123};
  ASSERT_EQ(m.pack(v, f), PdoStatus::kOk);
  EXPECT_EQ(payload(f), (std::vector<std::uint8_t>{0x0F, 0x00, 0x85, 0xFF}));
  EXPECT_EQ(f.id, 0x201u);  // left to the caller
  for (std::size_t i = 4; i < 8; ++i) EXPECT_EQ(f.data[i], 0) << i;
  // The documented worked example: enable operation, 12.5 % = 125 per mille.
  const std::array<std::int64_t, 2> w = {0x000F, 125};
  ASSERT_EQ(m.pack(w, f), PdoStatus::kOk);
  EXPECT_EQ(payload(f), (std::vector<std::uint8_t>{0x0F, 0x00, 0x7D, 0x00}));
}

TEST(PdoMapping, DriveTpdoStatuswordUnsignedTorqueSigned) {
  const PdoMapping m = drive_tpdo_mapping();
  std::array<std::int64_t, 2> v{};
  ASSERT_EQ(m.unpack(frame_of({0x37, 0x16, 0x85, 0xFF}), v), PdoStatus::kOk);
  EXPECT_EQ(v[0], 0x1637);  // statusword, UNSIGNED16
  EXPECT_EQ(v[1], -123);    // torque actual value, INTEGER16
  ASSERT_EQ(m.unpack(frame_of({0xFF, 0xFF, 0x00, 0x80}), v), PdoStatus::kOk);
  EXPECT_EQ(v[0], 0xFFFF);  // zero extended
  EXPECT_EQ(v[1], -32768);
}

TEST(PdoMapping, SignednessOfThe32BitPositionValue) {
  const PdoMapping s = encoder_tpdo_mapping();
  const PdoMapping u({PdoObject::kPositionValueUnsigned});
  std::array<std::int64_t, 1> v{};
  const CanFrame f = frame_of({0xFE, 0xFF, 0xFF, 0xFF});
  ASSERT_EQ(s.unpack(f, v), PdoStatus::kOk);
  EXPECT_EQ(v[0], -2);
  ASSERT_EQ(u.unpack(f, v), PdoStatus::kOk);
  EXPECT_EQ(v[0], 4294967294);
  ASSERT_EQ(s.unpack(frame_of({0x78, 0x56, 0x34, 0x12}), v), PdoStatus::kOk);
  EXPECT_EQ(v[0], 0x12345678);
}

TEST(PdoMapping, AgreesWithTheFixedCanopenCodecs) {
  const PdoMapping enc = encoder_tpdo_mapping();
  for (std::int32_t c : {0, 1, -1, 123456, -987654, std::numeric_limits<std::int32_t>::min(),
                         std::numeric_limits<std::int32_t>::max()}) {
    std::array<std::int64_t, 1> v{};
    ASSERT_EQ(enc.unpack(encode_position_pdo(0x181, c, 0), v), PdoStatus::kOk);
    EXPECT_EQ(v[0], c);
    CanFrame f;
    f.id = 0x181;
    const std::array<std::int64_t, 1> in = {c};
    ASSERT_EQ(enc.pack(in, f), PdoStatus::kOk);
    std::int32_t back = 0;
    ASSERT_EQ(decode_position_pdo(f, 0x181, back), DecodeStatus::kOk);
    EXPECT_EQ(back, c);
  }
}

TEST(PdoMapping, MixedWidthsAreLaidOutInOrderLittleEndian) {
  const PdoMapping m({PdoObject::kModesOfOperation, PdoObject::kPositionActualValue,
                      PdoObject::kStatusword, PdoObject::kModesOfOperationDisplay});
  EXPECT_EQ(m.length(), 8);
  EXPECT_EQ(m.offset(0), 0);
  EXPECT_EQ(m.offset(1), 1);
  EXPECT_EQ(m.offset(2), 5);
  EXPECT_EQ(m.offset(3), 7);
  CanFrame f;
  const std::array<std::int64_t, 4> v = {10, -2, 0x0237, -1};
  ASSERT_EQ(m.pack(v, f), PdoStatus::kOk);
  EXPECT_EQ(payload(f),
            (std::vector<std::uint8_t>{0x0A, 0xFE, 0xFF, 0xFF, 0xFF, 0x37, 0x02, 0xFF}));
  std::array<std::int64_t, 4> back{};
  ASSERT_EQ(m.unpack(f, back), PdoStatus::kOk);
  EXPECT_EQ(back, v);
}

TEST(PdoMapping, RandomValuesRoundTripAtEveryWidth) {
  const PdoMapping m({{0x2000, 1, 8, false},
                      {0x2000, 2, 8, true},
                      {0x2000, 3, 16, false},
                      {0x2000, 4, 16, true},
                      {0x2000, 5, 8, true}});
  const PdoMapping w({{0x2001, 1, 32, false}, {0x2001, 2, 32, true}});
  SplitMix64 rng(42);
  for (int i = 0; i < 20000; ++i) {
    const std::uint64_t r = rng.next();
    const std::array<std::int64_t, 5> v = {
        static_cast<std::int64_t>(r & 0xFF), static_cast<std::int8_t>(r >> 8),
        static_cast<std::int64_t>((r >> 16) & 0xFFFF), static_cast<std::int16_t>(r >> 32),
        static_cast<std::int8_t>(r >> 48)};
    CanFrame f;
    ASSERT_EQ(m.pack(v, f), PdoStatus::kOk);
    ASSERT_EQ(f.len, 7);
    std::array<std::int64_t, 5> back{};
    ASSERT_EQ(m.unpack(f, back), PdoStatus::kOk);
    ASSERT_EQ(back, v);
    const std::array<std::int64_t, 2> x = {static_cast<std::int64_t>(r & 0xFFFFFFFFu),
                                           static_cast<std::int32_t>(r >> 32)};
    ASSERT_EQ(w.pack(x, f), PdoStatus::kOk);
    std::array<std::int64_t, 2> xb{};
    ASSERT_EQ(w.unpack(f, xb), PdoStatus::kOk);
    ASSERT_EQ(xb, x);
  }
}

TEST(PdoMapping, WrongLengthIsAMalformedPdoAndValuesAreKept) {
  const PdoMapping m = drive_tpdo_mapping();
  std::array<std::int64_t, 2> v = {7, 8};
  for (std::uint8_t len : {0, 1, 2, 3, 5, 6, 7, 8}) {
    CanFrame f = frame_of({1, 2, 3, 4, 5, 6, 7, 8});
    f.len = len;
    EXPECT_EQ(m.unpack(f, v), PdoStatus::kWrongLength) << int(len);
    EXPECT_EQ(v[0], 7);
    EXPECT_EQ(v[1], 8);
  }
}

TEST(PdoMapping, RemoteErrorExtendedAndFdFramesAreNotPdos) {
  const PdoMapping m = drive_tpdo_mapping();
  std::array<std::int64_t, 2> v = {7, 8};
  for (std::uint8_t flag :
       {CanFlag::kRemote, CanFlag::kErrorFrame, CanFlag::kExtendedId, CanFlag::kFd}) {
    CanFrame f = frame_of({0x37, 0x02, 0, 0});
    f.flags = flag;
    EXPECT_EQ(m.unpack(f, v), PdoStatus::kNotDataFrame) << int(flag);
  }
  EXPECT_EQ(v[0], 7);
}

TEST(PdoMapping, PackRejectsValuesThatDoNotFit) {
  const PdoMapping m = drive_rpdo_mapping();
  CanFrame f = frame_of({9, 9, 9});
  const CanFrame before = f;
  struct Case {
    std::int64_t cw, torque;
    PdoStatus status;
  };
  const Case cases[] = {
      {0xFFFF, 32767, PdoStatus::kOk},           {0, -32768, PdoStatus::kOk},
      {0x10000, 0, PdoStatus::kValueOutOfRange}, {-1, 0, PdoStatus::kValueOutOfRange},
      {0, 32768, PdoStatus::kValueOutOfRange},   {0, -32769, PdoStatus::kValueOutOfRange},
  };
  for (const Case& c : cases) {
    CanFrame g = f;
    const std::array<std::int64_t, 2> v = {c.cw, c.torque};
    EXPECT_EQ(m.pack(v, g), c.status) << c.cw << " " << c.torque;
    if (c.status != PdoStatus::kOk) {
      EXPECT_EQ(payload(g), payload(before));
    }
  }
  const PdoMapping u32({PdoObject::kPositionValueUnsigned});
  const PdoMapping i8({PdoObject::kModesOfOperation});
  const std::array<std::int64_t, 1> big = {4294967295};
  const std::array<std::int64_t, 1> too_big = {4294967296};
  const std::array<std::int64_t, 1> m129 = {-129};
  EXPECT_EQ(u32.pack(big, f), PdoStatus::kOk);
  EXPECT_EQ(u32.pack(too_big, f), PdoStatus::kValueOutOfRange);
  EXPECT_EQ(i8.pack(m129, f), PdoStatus::kValueOutOfRange);
}

TEST(PdoMapping, ValueCountMustMatch) {
  const PdoMapping m = drive_rpdo_mapping();
  CanFrame f = frame_of({0x0F, 0, 0, 0});
  const std::array<std::int64_t, 1> one = {1};
  const std::array<std::int64_t, 3> three = {1, 2, 3};
  EXPECT_EQ(m.pack(one, f), PdoStatus::kWrongValueCount);
  EXPECT_EQ(m.pack(three, f), PdoStatus::kWrongValueCount);
  std::array<std::int64_t, 3> out{};
  EXPECT_EQ(m.unpack(f, out), PdoStatus::kWrongValueCount);
  PdoValues all{};
  EXPECT_EQ(m.unpack(f, std::span<std::int64_t>(all).first(m.size())), PdoStatus::kOk);
  EXPECT_EQ(all[0], 0x0F);
  EXPECT_STREQ(to_string(PdoStatus::kWrongLength), "wrong length");
}

TEST(PdoMapping, SetupValidationNamesTheEntry) {
  EXPECT_EQ(setup_error({PdoObject::kControlword}), "");
  EXPECT_NE(setup_error({}).find("no mapped objects"), std::string::npos);
  const std::string bits = setup_error({PdoObject::kControlword, {0x6071, 0, 12, true}});
  EXPECT_NE(bits.find("'test' entry 2 (0x6071:00)"), std::string::npos) << bits;
  EXPECT_NE(bits.find("bit length 12"), std::string::npos) << bits;
  const std::string zero = setup_error({{0x0000, 0, 8, false}});
  EXPECT_NE(zero.find("entry 1 (0x0000:00): index 0"), std::string::npos) << zero;
  const std::string dup = setup_error({PdoObject::kStatusword, PdoObject::kStatusword});
  EXPECT_NE(dup.find("entry 2 (0x6041:00): object already mapped as entry 1"), std::string::npos)
      << dup;
  const std::string over = setup_error(
      {PdoObject::kPositionActualValue, PdoObject::kPositionValue, PdoObject::kStatusword});
  EXPECT_NE(over.find("entry 3 (0x6041:00): mapping reaches 80 bits"), std::string::npos) << over;
  std::vector<PdoEntry> nine;
  for (std::uint8_t i = 0; i < 9; ++i) nine.push_back({0x2000, i, 8, false});
  std::string many;
  try {
    PdoMapping m(nine, "nine");
  } catch (const std::invalid_argument& e) {
    many = e.what();
  }
  EXPECT_NE(many.find("'nine' entry 9 (0x2000:08): more than 8"), std::string::npos) << many;
  // Eight bytes exactly is fine.
  EXPECT_EQ(setup_error({PdoObject::kPositionActualValue, PdoObject::kPositionValue}), "");
}

TEST(PdoMapping, MappingParameterWords) {
  EXPECT_EQ(mapping_entry_value(PdoObject::kControlword), 0x60400010u);
  EXPECT_EQ(mapping_entry_value(PdoObject::kTargetTorque), 0x60710010u);
  EXPECT_EQ(mapping_entry_value(PdoObject::kPositionValue), 0x60040020u);
  EXPECT_EQ(mapping_entry_value(PdoObject::kModesOfOperation), 0x60600008u);
  const PdoEntry e = mapping_entry_from_value(0x60770010u, true);
  EXPECT_EQ(e.index, 0x6077);
  EXPECT_EQ(e.subindex, 0);
  EXPECT_EQ(e.bit_length, 16);
  EXPECT_TRUE(e.is_signed);
  EXPECT_TRUE(same_object(e, PdoObject::kTorqueActualValue));
  const auto rp = drive_rpdo_mapping().mapping_parameter();
  EXPECT_EQ(rp[0], 0x60400010u);
  EXPECT_EQ(rp[1], 0x60710010u);
  EXPECT_EQ(rp[2], 0u);
  const auto tp = drive_tpdo_mapping().mapping_parameter();
  EXPECT_EQ(tp[0], 0x60410010u);
  EXPECT_EQ(tp[1], 0x60770010u);
  EXPECT_EQ(encoder_tpdo_mapping().mapping_parameter()[0], 0x60040020u);
}

TEST(PdoMapping, StandardObjectTypes) {
  EXPECT_FALSE(PdoObject::kControlword.is_signed);
  EXPECT_FALSE(PdoObject::kStatusword.is_signed);
  EXPECT_TRUE(PdoObject::kTargetTorque.is_signed);
  EXPECT_TRUE(PdoObject::kTorqueActualValue.is_signed);
  EXPECT_TRUE(PdoObject::kPositionActualValue.is_signed);
  EXPECT_EQ(PdoObject::kPositionActualValue.bit_length, 32);
  EXPECT_EQ(PdoObject::kModesOfOperationDisplay.index, 0x6061);
  EXPECT_EQ(PdoObject::kModesOfOperationDisplay.bit_length, 8);
  EXPECT_EQ(encoder_tpdo_mapping().length(), 4);
  EXPECT_EQ(drive_tpdo_mapping().length(), 4);
}

TEST(PdoMapping, PackAndUnpackDoNotAllocate) {
  const PdoMapping rp = drive_rpdo_mapping();
  const PdoMapping tp = drive_tpdo_mapping();
  std::int64_t sum = 0;
  numen::test::AllocationGuard guard;
  for (int i = 0; i < 10000; ++i) {
    CanFrame f;
    const std::array<std::int64_t, 2> v = {0x000F, i % 2000 - 1000};
    (void)rp.pack(v, f);
    std::array<std::int64_t, 2> back{};
    (void)tp.unpack(f, back);
    f.len = static_cast<std::uint8_t>(i % 9);
    (void)tp.unpack(f, back);  // wrong lengths too
    sum += back[1];
  }
  EXPECT_EQ(guard.count(), 0);
  EXPECT_NE(sum, 0);
}

}  // namespace

TEST(PdoMapping, KnownObjectsAreFoundByTheirMappingEntry) {
  numen::hal::PdoEntry e;
  ASSERT_TRUE(numen::hal::find_known_pdo_object(0x60710010u, e));
  EXPECT_EQ(e.index, 0x6071);
  EXPECT_TRUE(e.is_signed);
  ASSERT_TRUE(numen::hal::find_known_pdo_object(0x60410010u, e));
  EXPECT_FALSE(e.is_signed);
  ASSERT_TRUE(numen::hal::find_known_pdo_object(0x60040020u, e));
  EXPECT_TRUE(e.is_signed);  // read as int32
  const numen::hal::PdoEntry before = e;
  EXPECT_FALSE(numen::hal::find_known_pdo_object(0x60710020u, e));  // wrong bit length
  EXPECT_FALSE(numen::hal::find_known_pdo_object(0x60720010u, e));  // max torque: not mapped
  EXPECT_EQ(e.index, before.index);
  const numen::hal::PdoMapping m = numen::hal::drive_rpdo_mapping();
  EXPECT_EQ(numen::hal::find_mapped(m.entries(), numen::hal::PdoObject::kTargetTorque), 1);
  EXPECT_EQ(numen::hal::find_mapped(m.entries(), numen::hal::PdoObject::kStatusword), -1);
}
