/// @file emcy.cpp
/// EMCY write message codec and the CiA 301 emergency error code table (§7.2.7).

#include "numen/hal/canopen/emcy.hpp"


namespace numen::hal {
namespace {

// Exact codes of CiA 301 table "Emergency error codes" (monitoring, 0x81xx and 0x82xx).
struct ExactCode {
  std::uint16_t code;
  const char* text;
};
constexpr ExactCode kExactCodes[] = {
    {0x8110, "CAN overrun (objects lost)"},
    {0x8120, "CAN in error passive mode"},
    {0x8130, "life guard error or heartbeat error"},
    {0x8140, "recovered from bus off"},
    {0x8150, "CAN-ID collision"},
    {0x8210, "PDO not processed due to length error"},
    {0x8220, "PDO length exceeded"},
    {0x8230, "DAM MPDO not processed, destination object not available"},
    {0x8240, "unexpected SYNC data length"},
    {0x8250, "RPDO timeout"},
};

// Sub-classes (high byte) of the same table.
struct SubClass {
  std::uint8_t high_byte;
  const char* text;
};
constexpr SubClass kSubClasses[] = {
    {0x21, "current, device input side"},
    {0x22, "current inside the device"},
    {0x23, "current, device output side"},
    {0x31, "mains voltage"},
    {0x32, "voltage inside the device"},
    {0x33, "output voltage"},
    {0x41, "ambient temperature"},
    {0x42, "device temperature"},
    {0x61, "internal software"},
    {0x62, "user software"},
    {0x63, "data set"},
    {0x81, "communication"},
    {0x82, "protocol error"},
};

}  // namespace

const char* to_string(EmcyDecodeStatus status) noexcept {
  switch (status) {
    case EmcyDecodeStatus::kOk:
      return "ok";
    case EmcyDecodeStatus::kWrongId:
      return "wrong COB-ID";
    case EmcyDecodeStatus::kNotDataFrame:
      return "not a classic 11-bit data frame";
    case EmcyDecodeStatus::kWrongLength:
      return "wrong length";
  }
  return "unknown";
}

bool encode_emcy(const EmcyMessage& msg, std::int64_t timestamp_ns, CanFrame& out) noexcept {
  if (msg.node_id == 0 || msg.node_id > kMaxNodeId) return false;
  CanFrame f;
  f.id = emcy_cob_id(msg.node_id);
  f.len = kEmcyLen;
  f.data[0] = static_cast<std::uint8_t>(msg.error_code);
  f.data[1] = static_cast<std::uint8_t>(msg.error_code >> 8);
  f.data[2] = msg.error_register;
  for (std::size_t i = 0; i < kEmcyManufacturerLen; ++i) f.data[3 + i] = msg.manufacturer[i];
  f.timestamp_ns = timestamp_ns;
  out = f;
  return true;
}

EmcyDecodeStatus decode_emcy(const CanFrame& frame, EmcyMessage& out) noexcept {
  if (!is_standard_frame(frame) || frame.id <= kEmcyBaseCobId ||
      frame.id > kEmcyBaseCobId + kMaxNodeId) {
    return EmcyDecodeStatus::kWrongId;
  }
  if (!is_classic_data_frame(frame)) return EmcyDecodeStatus::kNotDataFrame;
  if (frame.len != kEmcyLen) return EmcyDecodeStatus::kWrongLength;
  out.node_id = static_cast<std::uint8_t>(frame.id - kEmcyBaseCobId);
  out.error_code = static_cast<std::uint16_t>(frame.data[0] | (frame.data[1] << 8));
  out.error_register = frame.data[2];
  for (std::size_t i = 0; i < kEmcyManufacturerLen; ++i) out.manufacturer[i] = frame.data[3 + i];
  return EmcyDecodeStatus::kOk;
}

const char* error_register_bit_name(unsigned bit) noexcept {
  switch (bit) {
    case 0:
      return "generic error";
    case 1:
      return "current";
    case 2:
      return "voltage";
    case 3:
      return "temperature";
    case 4:
      return "communication error";
    case 5:
      return "device profile specific";
    case 6:
      return "reserved";
    case 7:
      return "manufacturer specific";
    default:
      return "invalid bit";
  }
}

const char* to_string(EmcyErrorClass error_class) noexcept {
  switch (error_class) {
    case EmcyErrorClass::kErrorReset:
      return "error reset or no error";
    case EmcyErrorClass::kGeneric:
      return "generic error";
    case EmcyErrorClass::kCurrent:
      return "current";
    case EmcyErrorClass::kVoltage:
      return "voltage";
    case EmcyErrorClass::kTemperature:
      return "temperature";
    case EmcyErrorClass::kDeviceHardware:
      return "device hardware";
    case EmcyErrorClass::kDeviceSoftware:
      return "device software";
    case EmcyErrorClass::kAdditionalModules:
      return "additional modules";
    case EmcyErrorClass::kMonitoring:
      return "monitoring";
    case EmcyErrorClass::kExternal:
      return "external error";
    case EmcyErrorClass::kAdditionalFunctions:
      return "additional functions";
    case EmcyErrorClass::kDeviceSpecific:
      return "device specific";
    case EmcyErrorClass::kReserved:
      return "reserved";
  }
  return "unknown";
}

EmcyErrorClass emcy_error_class(std::uint16_t code) noexcept {
  const unsigned high_byte = code >> 8;
  switch (high_byte >> 4) {
    case 0x0:
      return high_byte == 0 ? EmcyErrorClass::kErrorReset : EmcyErrorClass::kReserved;
    case 0x1:
      return EmcyErrorClass::kGeneric;
    case 0x2:
      return EmcyErrorClass::kCurrent;
    case 0x3:
      return EmcyErrorClass::kVoltage;
    case 0x4:
      return EmcyErrorClass::kTemperature;
    case 0x5:
      return EmcyErrorClass::kDeviceHardware;
    case 0x6:
      return EmcyErrorClass::kDeviceSoftware;
    case 0x7:
      return EmcyErrorClass::kAdditionalModules;
    case 0x8:
      return EmcyErrorClass::kMonitoring;
    case 0x9:
      return EmcyErrorClass::kExternal;
    case 0xF:
      if (high_byte == 0xF0) return EmcyErrorClass::kAdditionalFunctions;
      if (high_byte == 0xFF) return EmcyErrorClass::kDeviceSpecific;
      return EmcyErrorClass::kReserved;
    default:
      return EmcyErrorClass::kReserved;  // 0xA–0xE
  }
}

const char* describe_emcy_code(std::uint16_t code) noexcept {
  for (const ExactCode& e : kExactCodes) {
    if (e.code == code) return e.text;
  }
  const auto high_byte = static_cast<std::uint8_t>(code >> 8);
  for (const SubClass& s : kSubClasses) {
    if (s.high_byte == high_byte) return s.text;
  }
  return to_string(emcy_error_class(code));
}

namespace {

/// CiA 402 (IEC 61800-7-201) error codes of a drive (object 0x603F, EMCY), by code.
constexpr ExactCode kCia402Codes[] = {
    {0x2110, "short circuit/earth leakage (input)"},
    {0x2120, "earth leakage (input)"},
    {0x2121, "earth leakage phase L1"},
    {0x2122, "earth leakage phase L2"},
    {0x2123, "earth leakage phase L3"},
    {0x2130, "short circuit (input)"},
    {0x2131, "short circuit phases L1-L2"},
    {0x2132, "short circuit phases L2-L3"},
    {0x2133, "short circuit phases L3-L1"},
    {0x2211, "internal current no. 1"},
    {0x2212, "internal current no. 2"},
    {0x2213, "over-current in ramp function"},
    {0x2214, "over-current in the sequence"},
    {0x2220, "continuous over current (device internal)"},
    {0x2221, "continuous over current no. 1"},
    {0x2222, "continuous over current no. 2"},
    {0x2230, "short circuit/earth leakage (device internal)"},
    {0x2240, "earth leakage (device internal)"},
    {0x2250, "short circuit (device internal)"},
    {0x2310, "continuous over current (motor side)"},
    {0x2311, "continuous over current (motor side) no. 1"},
    {0x2312, "continuous over current (motor side) no. 2"},
    {0x2320, "short circuit/earth leakage (motor side)"},
    {0x2330, "earth leakage (motor side)"},
    {0x2331, "earth leakage phase U"},
    {0x2332, "earth leakage phase V"},
    {0x2333, "earth leakage phase W"},
    {0x2340, "short circuit (motor side)"},
    {0x2341, "short circuit phases U-V"},
    {0x2342, "short circuit phases V-W"},
    {0x2343, "short circuit phases W-U"},
    {0x3110, "mains over-voltage"},
    {0x3111, "mains over-voltage phase L1"},
    {0x3112, "mains over-voltage phase L2"},
    {0x3113, "mains over-voltage phase L3"},
    {0x3120, "mains under-voltage"},
    {0x3121, "mains under-voltage phase L1"},
    {0x3122, "mains under-voltage phase L2"},
    {0x3123, "mains under-voltage phase L3"},
    {0x3130, "phase failure"},
    {0x3131, "phase failure L1"},
    {0x3132, "phase failure L2"},
    {0x3133, "phase failure L3"},
    {0x3134, "phase sequence"},
    {0x3140, "mains frequency"},
    {0x3141, "mains frequency too high"},
    {0x3142, "mains frequency too low"},
    {0x3210, "DC link over-voltage"},
    {0x3211, "DC link over-voltage no. 1"},
    {0x3212, "DC link over-voltage no. 2"},
    {0x3220, "DC link under-voltage"},
    {0x3221, "DC link under-voltage no. 1"},
    {0x3222, "DC link under-voltage no. 2"},
    {0x3230, "load error"},
    {0x3310, "output over-voltage"},
    {0x3311, "output over-voltage phase U"},
    {0x3312, "output over-voltage phase V"},
    {0x3313, "output over-voltage phase W"},
    {0x3320, "armature circuit"},
    {0x3321, "armature circuit interrupted"},
    {0x3330, "field circuit"},
    {0x3331, "field circuit interrupted"},
    {0x4110, "ambient temperature too high"},
    {0x4120, "ambient temperature too low"},
    {0x4130, "supply air temperature"},
    {0x4140, "air outlet temperature"},
    {0x4210, "device temperature too high"},
    {0x4220, "device temperature too low"},
    {0x4300, "drive temperature"},
    {0x4310, "drive temperature too high"},
    {0x4320, "drive temperature too low"},
    {0x4400, "supply temperature"},
    {0x4410, "supply temperature too high"},
    {0x4420, "supply temperature too low"},
    {0x5100, "supply"},
    {0x5110, "supply low voltage"},
    {0x5111, "supply low voltage U1 (±15 V)"},
    {0x5112, "supply low voltage U2 (+24 V)"},
    {0x5113, "supply low voltage U3 (+5 V)"},
    {0x5120, "supply intermediate circuit"},
    {0x5200, "control"},
    {0x5210, "control measurement circuit"},
    {0x5220, "control computing circuit"},
    {0x5300, "operating unit"},
    {0x5400, "power section"},
    {0x5410, "output stages"},
    {0x5420, "chopper"},
    {0x5430, "input stages"},
    {0x5440, "contacts"},
    {0x5450, "fuses"},
    {0x5451, "fuse S1 (L1)"},
    {0x5452, "fuse S2 (L2)"},
    {0x5453, "fuse S3 (L3)"},
    {0x5500, "data storage"},
    {0x5510, "data storage RAM"},
    {0x5520, "data storage EPROM"},
    {0x5530, "data storage EEPROM"},
    {0x6010, "software reset (watchdog)"},
    {0x6310, "loss of parameters"},
    {0x6320, "parameter error"},
    {0x7100, "power"},
    {0x7110, "brake chopper"},
    {0x7111, "brake chopper failure"},
    {0x7112, "brake chopper over current"},
    {0x7113, "brake chopper protective circuit"},
    {0x7120, "motor"},
    {0x7121, "motor blocked"},
    {0x7122, "motor error or commutation malfunction"},
    {0x7123, "motor tilted"},
    {0x7200, "measurement circuit"},
    {0x7300, "sensor"},
    {0x7301, "tacho fault"},
    {0x7302, "tacho wrong polarity"},
    {0x7303, "resolver 1 fault"},
    {0x7304, "resolver 2 fault"},
    {0x7305, "incremental sensor 1 fault"},
    {0x7306, "incremental sensor 2 fault"},
    {0x7307, "incremental sensor 3 fault"},
    {0x7310, "speed sensor"},
    {0x7320, "position sensor"},
    {0x7400, "computation circuit"},
    {0x7500, "communication"},
    {0x7510, "serial interface no. 1"},
    {0x7520, "serial interface no. 2"},
    {0x7600, "data storage (external)"},
    {0x8300, "torque control"},
    {0x8311, "excess torque"},
    {0x8312, "difficult start-up"},
    {0x8313, "standstill torque"},
    {0x8321, "insufficient torque"},
    {0x8331, "torque fault"},
    {0x8400, "velocity speed controller"},
    {0x8500, "position controller"},
    {0x8600, "positioning controller"},
    {0x8611, "following error"},
    {0x8612, "reference limit"},
    {0x8700, "sync controller"},
    {0x8800, "winding controller"},
    {0xF001, "deceleration"},
    {0xF002, "sub-synchronous run"},
    {0xF003, "stroke operation"},
    {0xF004, "control"},
};

}  // namespace

const char* describe_cia402_emcy_code(std::uint16_t code) noexcept {
  for (const ExactCode& c : kCia402Codes) {
    if (c.code == code) return c.text;
  }
  if (code >= 0x6301 && code <= 0x630F) return "data set error";  // data set no. 1–15
  return nullptr;
}

const char* describe_emcy_code(std::uint16_t code, std::uint16_t profile) noexcept {
  if (profile == 402) {
    if (const char* t = describe_cia402_emcy_code(code)) return t;
  }
  return describe_emcy_code(code);
}

}  // namespace numen::hal
