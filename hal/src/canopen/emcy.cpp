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

}  // namespace numen::hal
