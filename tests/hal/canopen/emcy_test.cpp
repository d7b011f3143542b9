// Tests of numen/hal/canopen/emcy.hpp: EMCY layout, decode checks, the CiA 301 error code table,
// the error register bits and the EMCY log.
#include "numen/hal/canopen/emcy.hpp"

#include <gtest/gtest.h>

#include <cstring>
#include <initializer_list>

#include "alloc_counter.hpp"
#include "can_test_frames.hpp"

namespace {

using namespace numen::hal;

using numen::test::raw_frame;

TEST(Emcy, EncodeIsByteExact) {
  EmcyMessage m;
  m.node_id = 2;
  m.error_code = 0x8130;
  m.error_register = 0x11;
  CanFrame f;
  ASSERT_TRUE(encode_emcy(m, 55, f));
  EXPECT_EQ(f.id, 0x082u);
  EXPECT_EQ(f.flags, 0);
  ASSERT_EQ(f.len, 8);
  const std::uint8_t want[8] = {0x30, 0x81, 0x11, 0, 0, 0, 0, 0};
  EXPECT_EQ(std::memcmp(f.data.data(), want, 8), 0);
  EXPECT_EQ(f.timestamp_ns, 55);
  m.node_id = 127;
  m.manufacturer = {0xA1, 0xA2, 0xA3, 0xA4, 0xA5};
  ASSERT_TRUE(encode_emcy(m, 0, f));
  EXPECT_EQ(f.id, 0x0FFu);
  EXPECT_EQ(f.data[3], 0xA1);
  EXPECT_EQ(f.data[7], 0xA5);
  f.id = 0x42;
  m.node_id = 0;  // would be 0x080, the SYNC
  EXPECT_FALSE(encode_emcy(m, 0, f));
  m.node_id = 128;
  EXPECT_FALSE(encode_emcy(m, 0, f));
  EXPECT_EQ(f.id, 0x42u);
}

TEST(Emcy, DecodesRealWorldExamples) {
  EmcyMessage m;
  // Heartbeat consumer of node 10 lost its producer: 0x8130, register generic + communication.
  ASSERT_EQ(decode_emcy(raw_frame(0x08A, {0x30, 0x81, 0x11, 0, 0, 0, 0, 0}), m),
            EmcyDecodeStatus::kOk);
  EXPECT_EQ(m.node_id, 10);
  EXPECT_EQ(m.error_code, 0x8130);
  EXPECT_EQ(m.error_register, 0x11);
  EXPECT_EQ(emcy_error_class(m.error_code), EmcyErrorClass::kMonitoring);
  EXPECT_STREQ(describe_emcy_code(m.error_code), "life guard error or heartbeat error");
  EXPECT_TRUE(emcy_reports_fault(m));
  // CiA 402 drive on node 3: DC link over-voltage 0x3210, register generic + voltage, with
  // a manufacturer-specific value (e.g. the measured voltage).
  ASSERT_EQ(decode_emcy(raw_frame(0x083, {0x10, 0x32, 0x05, 0x2C, 0x01, 0x00, 0x00, 0x7E}), m),
            EmcyDecodeStatus::kOk);
  EXPECT_EQ(m.node_id, 3);
  EXPECT_EQ(m.error_code, 0x3210);
  EXPECT_EQ(m.error_register, ErrorRegisterBit::kGeneric | ErrorRegisterBit::kVoltage);
  EXPECT_EQ(m.manufacturer[0], 0x2C);
  EXPECT_EQ(m.manufacturer[1], 0x01);
  EXPECT_EQ(m.manufacturer[4], 0x7E);
  EXPECT_EQ(emcy_error_class(m.error_code), EmcyErrorClass::kVoltage);
  EXPECT_STREQ(to_string(emcy_error_class(m.error_code)), "voltage");
  EXPECT_STREQ(describe_emcy_code(m.error_code), "voltage inside the device");
  EXPECT_TRUE(emcy_reports_fault(m));
  // The same drive clears the error: 0x0000 with register 0 — not a fault.
  ASSERT_EQ(decode_emcy(raw_frame(0x083, {0, 0, 0, 0, 0, 0, 0, 0}), m), EmcyDecodeStatus::kOk);
  EXPECT_EQ(m.error_code, 0x0000);
  EXPECT_TRUE(is_error_reset(m.error_code));
  EXPECT_EQ(emcy_error_class(m.error_code), EmcyErrorClass::kErrorReset);
  EXPECT_STREQ(describe_emcy_code(m.error_code), "error reset or no error");
  EXPECT_FALSE(emcy_reports_fault(m));
  // Error reset of one error while another is still active (register still has bits).
  ASSERT_EQ(decode_emcy(raw_frame(0x083, {0, 0, 0x09, 0, 0, 0, 0, 0}), m), EmcyDecodeStatus::kOk);
  EXPECT_TRUE(is_error_reset(m.error_code));
  EXPECT_TRUE(emcy_reports_fault(m));
  // CiA 402 over-current on the output side, drive temperature.
  EXPECT_STREQ(describe_emcy_code(0x2310), "current, device output side");
  EXPECT_EQ(emcy_error_class(0x2310), EmcyErrorClass::kCurrent);
  EXPECT_STREQ(describe_emcy_code(0x4310), "temperature");
  EXPECT_STREQ(describe_emcy_code(0x4210), "device temperature");
}

TEST(Emcy, DecodeRejections) {
  const CanFrame good = raw_frame(0x085, {0x10, 0x32, 0x05, 0, 0, 0, 0, 0});
  auto status = [](const CanFrame& f) {
    EmcyMessage m;
    m.node_id = 77;
    const EmcyDecodeStatus s = decode_emcy(f, m);
    if (s != EmcyDecodeStatus::kOk) {
      EXPECT_EQ(m.node_id, 77);
    }
    return s;
  };
  EXPECT_EQ(status(good), EmcyDecodeStatus::kOk);
  CanFrame f = good;
  f.id = 0x080;  // SYNC, not node 0's EMCY
  EXPECT_EQ(status(f), EmcyDecodeStatus::kWrongId);
  f.id = 0x07F;
  EXPECT_EQ(status(f), EmcyDecodeStatus::kWrongId);
  f.id = 0x100;
  EXPECT_EQ(status(f), EmcyDecodeStatus::kWrongId);
  for (std::uint8_t len : {0, 1, 2, 7}) {
    f = good;
    f.len = len;
    EXPECT_EQ(status(f), EmcyDecodeStatus::kWrongLength) << int(len);
  }
  // A SYNC with a counter byte at 0x080 is still not an EMCY.
  EXPECT_EQ(status(raw_frame(0x080, {5})), EmcyDecodeStatus::kWrongId);
  for (std::uint8_t flag : {CanFlag::kRemote, CanFlag::kFd}) {
    f = good;
    f.flags = flag;
    EXPECT_EQ(status(f), EmcyDecodeStatus::kNotDataFrame);
  }
  // 29-bit frames and error reports are not on an EMCY COB-ID, whatever their number.
  for (std::uint8_t flag : {CanFlag::kExtendedId, CanFlag::kErrorFrame}) {
    f = good;
    f.flags = flag;
    EXPECT_EQ(status(f), EmcyDecodeStatus::kWrongId);
  }
  f = good;
  f.flags = CanFlag::kFd;
  f.len = 12;
  EXPECT_EQ(status(f), EmcyDecodeStatus::kNotDataFrame);
}

TEST(Emcy, ErrorCodeTable) {
  struct Case {
    std::uint16_t code;
    EmcyErrorClass cls;
    const char* text;
  };
  const Case cases[] = {
      {0x0000, EmcyErrorClass::kErrorReset, "error reset or no error"},
      {0x00FF, EmcyErrorClass::kErrorReset, "error reset or no error"},
      {0x0100, EmcyErrorClass::kReserved, "reserved"},
      {0x1000, EmcyErrorClass::kGeneric, "generic error"},
      {0x2000, EmcyErrorClass::kCurrent, "current"},
      {0x2120, EmcyErrorClass::kCurrent, "current, device input side"},
      {0x2200, EmcyErrorClass::kCurrent, "current inside the device"},
      {0x3100, EmcyErrorClass::kVoltage, "mains voltage"},
      {0x3300, EmcyErrorClass::kVoltage, "output voltage"},
      {0x4100, EmcyErrorClass::kTemperature, "ambient temperature"},
      {0x5000, EmcyErrorClass::kDeviceHardware, "device hardware"},
      {0x6000, EmcyErrorClass::kDeviceSoftware, "device software"},
      {0x6100, EmcyErrorClass::kDeviceSoftware, "internal software"},
      {0x6200, EmcyErrorClass::kDeviceSoftware, "user software"},
      {0x6320, EmcyErrorClass::kDeviceSoftware, "data set"},
      {0x7000, EmcyErrorClass::kAdditionalModules, "additional modules"},
      {0x8000, EmcyErrorClass::kMonitoring, "monitoring"},
      {0x8100, EmcyErrorClass::kMonitoring, "communication"},
      {0x8110, EmcyErrorClass::kMonitoring, "CAN overrun (objects lost)"},
      {0x8120, EmcyErrorClass::kMonitoring, "CAN in error passive mode"},
      {0x8140, EmcyErrorClass::kMonitoring, "recovered from bus off"},
      {0x8150, EmcyErrorClass::kMonitoring, "CAN-ID collision"},
      {0x8111, EmcyErrorClass::kMonitoring, "communication"},
      {0x8200, EmcyErrorClass::kMonitoring, "protocol error"},
      {0x8210, EmcyErrorClass::kMonitoring, "PDO not processed due to length error"},
      {0x8220, EmcyErrorClass::kMonitoring, "PDO length exceeded"},
      {0x8230, EmcyErrorClass::kMonitoring,
       "DAM MPDO not processed, destination object not available"},
      {0x8240, EmcyErrorClass::kMonitoring, "unexpected SYNC data length"},
      {0x8250, EmcyErrorClass::kMonitoring, "RPDO timeout"},
      {0x8611, EmcyErrorClass::kMonitoring, "monitoring"},  // CiA 402 following error
      {0x9000, EmcyErrorClass::kExternal, "external error"},
      {0xA000, EmcyErrorClass::kReserved, "reserved"},
      {0xE123, EmcyErrorClass::kReserved, "reserved"},
      {0xF000, EmcyErrorClass::kAdditionalFunctions, "additional functions"},
      {0xF100, EmcyErrorClass::kReserved, "reserved"},
      {0xFF00, EmcyErrorClass::kDeviceSpecific, "device specific"},
      {0xFFFF, EmcyErrorClass::kDeviceSpecific, "device specific"},
  };
  for (const Case& c : cases) {
    EXPECT_EQ(emcy_error_class(c.code), c.cls) << std::hex << c.code;
    EXPECT_STREQ(describe_emcy_code(c.code), c.text) << std::hex << c.code;
  }
  // Every code has a class and a description; the class follows the high nibble.
  for (unsigned code = 0; code <= 0xFFFF; ++code) {
    const auto c = static_cast<std::uint16_t>(code);
    ASSERT_NE(describe_emcy_code(c), nullptr);
    const unsigned nibble = code >> 12;
    const EmcyErrorClass cls = emcy_error_class(c);
    if (nibble >= 1 && nibble <= 9) {
      EXPECT_EQ(static_cast<unsigned>(cls), nibble) << std::hex << code;
    }
    EXPECT_EQ(is_error_reset(c), cls == EmcyErrorClass::kErrorReset);
  }
}

TEST(Emcy, Cia402DriveCodesByProfile) {
  // CiA 402 (IEC 61800-7-201) names of drive codes; the profile decides which table speaks.
  EXPECT_STREQ(describe_cia402_emcy_code(0x2310), "continuous over current (motor side)");
  EXPECT_STREQ(describe_cia402_emcy_code(0x3210), "DC link over-voltage");
  EXPECT_STREQ(describe_cia402_emcy_code(0x7121), "motor blocked");
  EXPECT_STREQ(describe_cia402_emcy_code(0x8611), "following error");
  EXPECT_STREQ(describe_cia402_emcy_code(0x630A), "data set error");
  EXPECT_EQ(describe_cia402_emcy_code(0x8130), nullptr);  // CiA 301's own
  EXPECT_EQ(describe_cia402_emcy_code(0x1000), nullptr);
  EXPECT_STREQ(describe_emcy_code(0x7121, 402), "motor blocked");
  EXPECT_STREQ(describe_emcy_code(0x7121, 406), describe_emcy_code(0x7121));
  EXPECT_STREQ(describe_emcy_code(0x8130, 402), "life guard error or heartbeat error");
  EXPECT_STREQ(describe_emcy_code(0x1000, 402), describe_emcy_code(0x1000));
}

TEST(Emcy, ErrorRegisterBits) {
  const char* want[8] = {"generic error",
                         "current",
                         "voltage",
                         "temperature",
                         "communication error",
                         "device profile specific",
                         "reserved",
                         "manufacturer specific"};
  for (unsigned b = 0; b < 8; ++b) EXPECT_STREQ(error_register_bit_name(b), want[b]);
  EXPECT_STREQ(error_register_bit_name(8), "invalid bit");
  EXPECT_EQ(ErrorRegisterBit::kGeneric, 0x01);
  EXPECT_EQ(ErrorRegisterBit::kCommunication, 0x10);
  EXPECT_EQ(ErrorRegisterBit::kManufacturer, 0x80);
}

TEST(EmcyLog, RingKeepsTheLastK) {
  EmcyLog<4> log;
  EXPECT_EQ(log.size(), 0u);
  EXPECT_EQ(log.newest(), nullptr);
  EXPECT_EQ(log.at(0), nullptr);
  for (int i = 0; i < 6; ++i) {
    EmcyMessage m;
    m.node_id = static_cast<std::uint8_t>(i + 1);
    m.error_code = static_cast<std::uint16_t>(i == 5 ? 0x0000 : 0x2310 + i);
    m.error_register = i == 5 ? 0 : 0x03;
    CanFrame f;
    ASSERT_TRUE(encode_emcy(m, 1000 + i, f));
    EXPECT_EQ(log.on_frame(f), EmcyDecodeStatus::kOk);
  }
  EXPECT_EQ(log.size(), 4u);
  EXPECT_EQ(log.capacity(), 4u);
  for (std::size_t i = 0; i < 4; ++i) {
    ASSERT_NE(log.at(i), nullptr);
    EXPECT_EQ(log.at(i)->message.node_id, i + 3);  // oldest kept is the third
    EXPECT_EQ(log.at(i)->timestamp_ns, static_cast<std::int64_t>(1002 + i));
  }
  EXPECT_EQ(log.at(4), nullptr);
  EXPECT_EQ(log.newest()->message.node_id, 6);
  EXPECT_EQ(log.newest()->message.error_code, 0x0000);
  EXPECT_EQ(log.at(0)->message.error_code, 0x2312);
  EXPECT_EQ(log.counters().received, 6u);
  EXPECT_EQ(log.counters().faults, 5u);
  EXPECT_EQ(log.counters().resets, 1u);
  EXPECT_EQ(log.counters().overwritten, 2u);
  // Malformed and foreign frames are counted (or not) and not recorded.
  EXPECT_EQ(log.on_frame(raw_frame(0x083, {})), EmcyDecodeStatus::kWrongLength);
  CanFrame rtr = raw_frame(0x083, {});
  rtr.flags = CanFlag::kRemote;
  EXPECT_EQ(log.on_frame(rtr), EmcyDecodeStatus::kNotDataFrame);
  EXPECT_EQ(log.on_frame(raw_frame(0x080, {})), EmcyDecodeStatus::kWrongId);
  EXPECT_EQ(log.counters().wrong_length, 1u);
  EXPECT_EQ(log.counters().not_data, 1u);
  EXPECT_EQ(log.newest()->message.node_id, 6);
  // clear() forgets the records, not the counts.
  log.clear();
  EXPECT_EQ(log.size(), 0u);
  EXPECT_EQ(log.counters().faults, 5u);
  log.record(EmcyMessage{9, 0x5000, 0x01, {}}, 7);
  EXPECT_EQ(log.size(), 1u);
  EXPECT_EQ(log.at(0)->message.node_id, 9);
}

TEST(EmcyLog, PerPeriodCallsDoNotAllocate) {
  EmcyLog<> log;
  const CanFrame frames[] = {
      raw_frame(0x08A, {0x30, 0x81, 0x11, 0, 0, 0, 0, 0}),
      raw_frame(0x083, {0x10, 0x32, 0x05, 0, 0, 0, 0, 0}),
      raw_frame(0x083, {0, 0, 0, 0, 0, 0, 0, 0}),
      raw_frame(0x083, {0x10, 0x32}),
      raw_frame(0x080, {}),
  };
  numen::test::AllocationGuard guard;
  std::size_t text = 0;
  for (int k = 0; k < 10'000; ++k) {
    const CanFrame& f = frames[k % 5];
    log.on_frame(f);
    EmcyMessage m;
    if (decode_emcy(f, m) == EmcyDecodeStatus::kOk) {
      text += std::strlen(describe_emcy_code(m.error_code));
      text += std::strlen(to_string(emcy_error_class(m.error_code)));
      text += std::strlen(error_register_bit_name(static_cast<unsigned>(k % 8)));
    }
    CanFrame out;
    encode_emcy(m, k, out);
  }
  EXPECT_EQ(guard.count(), 0);
  EXPECT_GT(text, 0u);
  EXPECT_EQ(log.counters().received, 6000u);
  EXPECT_EQ(log.counters().wrong_length, 2000u);
}

}  // namespace
