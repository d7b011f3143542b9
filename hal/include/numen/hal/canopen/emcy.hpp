#pragma once
/// @file emcy.hpp
/// CANopen emergency object (EMCY), CiA 301 §7.2.7:
///  - the EMCY write message, COB-ID 0x080 + node id (node 1–127; 0x080 itself is SYNC),
///    8 bytes: byte 0–1 emergency error code (u16 little endian), byte 2 error register
///    (object 1001h), bytes 3–7 manufacturer-specific error code;
///  - the error code classes of CiA 301 §7.2.7 (table "Emergency error codes") and the
///    error register bits (object 1001h, §7.5.2.2) as static strings;
///  - EmcyLog<K>, a fixed-capacity ring of the last K emergencies for reporting.
/// CiA 402 drive error codes (0x2xxx–0x7xxx, 0x8xxx) fall in the same classes.
/// Pure protocol logic: no I/O; every function and member is noexcept and allocation free.
/// See docs/protocol.md.

#include <array>
#include <cstddef>
#include <cstdint>

#include "numen/hal/transport/can_frame.hpp"
#include "numen/hal/canopen/canopen.hpp"

namespace numen::hal {

/// Base COB-ID of the EMCY write message (0x080 + node id; CiA 301 §7.2.7 and predefined
/// connection set). 0x080 itself (node 0) is the SYNC object.
inline constexpr std::uint32_t kEmcyBaseCobId = 0x080;
/// Payload length of the EMCY write message, bytes (CiA 301: always 8).
inline constexpr std::uint8_t kEmcyLen = 8;
/// Number of manufacturer-specific bytes in an EMCY message (bytes 3–7).
inline constexpr std::size_t kEmcyManufacturerLen = 5;

/// EMCY COB-ID of a node: 0x080 + node_id (node_id 1–127).
constexpr std::uint32_t emcy_cob_id(std::uint8_t node_id) noexcept {
  return kEmcyBaseCobId + node_id;
}

/// One EMCY write message, decoded.
struct EmcyMessage {
  /// Producing node, 1–127 (from the COB-ID).
  std::uint8_t node_id = 0;
  /// Emergency error code (CiA 301 table "Emergency error codes"; CiA 402 for drives).
  std::uint16_t error_code = 0;
  /// Error register, object 1001h (ErrorRegisterBit).
  std::uint8_t error_register = 0;
  /// Manufacturer-specific error code, bytes 3–7 as sent.
  std::array<std::uint8_t, kEmcyManufacturerLen> manufacturer{};
};

/// Outcome of decoding an EMCY message (decode_emcy()).
enum class EmcyDecodeStatus : std::uint8_t {
  kOk,            ///< Decoded.
  kWrongId,       ///< COB-ID is not 0x081–0x0FF: not an EMCY message (0x080 is SYNC).
  kNotDataFrame,  ///< EMCY COB-ID but remote or CAN FD frame. (Error reports and 29-bit
                  ///< frames are not on it: kWrongId.)
  kWrongLength,   ///< Payload length is not 8 (a length-0 frame is not a valid EMCY).
};

/// Short English name of an EmcyDecodeStatus (static string).
const char* to_string(EmcyDecodeStatus status) noexcept;

/// Builds the EMCY write message of `msg.node_id` (1–127) stamped `timestamp_ns`: COB-ID
/// 0x080 + node id, 8 bytes {code LSB, code MSB, register, manufacturer[0..4]}. Returns false
/// and leaves `out` unchanged if the node id is 0 or above 127.
/// Example: node 2, code 0x8130, register 0x11 -> id 0x082, data 30 81 11 00 00 00 00 00.
bool encode_emcy(const EmcyMessage& msg, std::int64_t timestamp_ns, CanFrame& out) noexcept;

/// Decodes an EMCY write message into `out` (unchanged unless kOk). Checks, in order:
/// COB-ID 0x081–0x0FF (kWrongId); 11-bit classic data frame (kNotDataFrame); length exactly
/// 8 (kWrongLength).
EmcyDecodeStatus decode_emcy(const CanFrame& frame, EmcyMessage& out) noexcept;

/// Bits of the error register, object 1001h (CiA 301 §7.5.2.2). Bit 0 is set whenever any
/// error is present.
struct ErrorRegisterBit {
  static constexpr std::uint8_t kGeneric = 1u << 0;        ///< Generic error.
  static constexpr std::uint8_t kCurrent = 1u << 1;        ///< Current.
  static constexpr std::uint8_t kVoltage = 1u << 2;        ///< Voltage.
  static constexpr std::uint8_t kTemperature = 1u << 3;    ///< Temperature.
  static constexpr std::uint8_t kCommunication = 1u << 4;  ///< Communication error
                                                           ///< (overrun, error state).
  static constexpr std::uint8_t kDeviceProfile = 1u << 5;  ///< Device profile specific.
  static constexpr std::uint8_t kReserved = 1u << 6;       ///< Reserved (always 0).
  static constexpr std::uint8_t kManufacturer = 1u << 7;   ///< Manufacturer specific.
};

/// Name of error register bit `bit` (0–7), e.g. "temperature" for bit 3 (static string);
/// "invalid bit" for bit > 7.
const char* error_register_bit_name(unsigned bit) noexcept;

/// Error code class: the high byte / high nibble of an emergency error code (CiA 301
/// §7.2.7, table "Emergency error codes").
enum class EmcyErrorClass : std::uint8_t {
  kErrorReset,           ///< 0x00xx: error reset or no error (not a fault).
  kGeneric,              ///< 0x1xxx: generic error.
  kCurrent,              ///< 0x2xxx: current.
  kVoltage,              ///< 0x3xxx: voltage.
  kTemperature,          ///< 0x4xxx: temperature.
  kDeviceHardware,       ///< 0x5xxx: device hardware.
  kDeviceSoftware,       ///< 0x6xxx: device software.
  kAdditionalModules,    ///< 0x7xxx: additional modules.
  kMonitoring,           ///< 0x8xxx: monitoring (communication, protocol; CiA 402 control).
  kExternal,             ///< 0x9xxx: external error.
  kAdditionalFunctions,  ///< 0xF0xx: additional functions.
  kDeviceSpecific,       ///< 0xFFxx: device specific.
  kReserved,             ///< 0x01xx–0x0Fxx, 0xAxxx–0xExxx, 0xF1xx–0xFExx: not assigned.
};

/// Short English name of an EmcyErrorClass (static string), e.g. "voltage".
const char* to_string(EmcyErrorClass error_class) noexcept;

/// The class of emergency error code `code`.
EmcyErrorClass emcy_error_class(std::uint16_t code) noexcept;

/// The most specific entry of the CiA 301 emergency error code table for `code` (static
/// string): an exact code (0x8110–0x8150, 0x8210–0x8250), else its sub-class (0x21xx,
/// 0x22xx, 0x23xx, 0x31xx–0x33xx, 0x41xx, 0x42xx, 0x61xx–0x63xx, 0x81xx, 0x82xx), else its
/// class. Examples: 0x8130 "life guard error or heartbeat error"; 0x3210 "voltage inside the
/// device"; 0x0000 "error reset or no error".
const char* describe_emcy_code(std::uint16_t code) noexcept;

/// The name CiA 402 (IEC 61800-7-201, drive error codes, object 0x603F) gives `code` (static
/// string), e.g. 0x2310 "continuous over current (motor side)", 0x7121 "motor blocked",
/// 0x8611 "following error", 0x3210 "DC link over-voltage"; nullptr if CiA 402 does not
/// define it.
const char* describe_cia402_emcy_code(std::uint16_t code) noexcept;

/// The name of `code` for a node of device profile `profile` (the low word of its 0x1000
/// device type): a CiA 402 drive's code by the CiA 402 table when it has it, else (and for
/// any other profile) describe_emcy_code(code).
const char* describe_emcy_code(std::uint16_t code, std::uint16_t profile) noexcept;

/// True if `code` is in the error reset / no error class 0x00xx (CiA 301: the producer sends
/// it when an error has gone away).
constexpr bool is_error_reset(std::uint16_t code) noexcept { return (code & 0xFF00u) == 0; }

/// True if `msg` says the node is in error: a code outside 0x00xx, or an error reset whose
/// error register is still non-zero (CiA 301: after an error reset the producer sends the
/// current register, so other errors are still active). An error reset with register 0 is
/// the node reporting that it is free of errors.
constexpr bool emcy_reports_fault(const EmcyMessage& msg) noexcept {
  return !is_error_reset(msg.error_code) || msg.error_register != 0;
}

/// One logged emergency.
struct EmcyRecord {
  EmcyMessage message;            ///< The decoded message (node, code, register, manufacturer).
  std::int64_t timestamp_ns = 0;  ///< Receive time, ns (CanFrame::timestamp_ns).
};

/// Counters of an EmcyLog since construction.
struct EmcyLogCounters {
  std::uint64_t received = 0;      ///< Valid EMCY messages recorded.
  std::uint64_t faults = 0;        ///< Of which emcy_reports_fault() was true.
  std::uint64_t resets = 0;        ///< Of which emcy_reports_fault() was false (all clear).
  std::uint64_t overwritten = 0;   ///< Records pushed out of the full ring.
  std::uint64_t wrong_length = 0;  ///< Frames on an EMCY COB-ID with length != 8.
  std::uint64_t not_data = 0;      ///< Remote / FD frames on an EMCY COB-ID.
};

/// Default capacity of an EmcyLog (records).
inline constexpr std::size_t kDefaultEmcyLogCapacity = 32;

/// The last K emergencies received, in a fixed ring (the oldest is overwritten). All members
/// are noexcept and allocation free.
template <std::size_t K = kDefaultEmcyLogCapacity>
class EmcyLog {
  static_assert(K >= 1, "EmcyLog capacity must be at least 1");

 public:
  /// Decodes `frame` and records it, stamped with the frame's timestamp. Frames outside
  /// 0x081–0x0FF return kWrongId and are not counted; malformed EMCY frames are counted by
  /// reason and not recorded.
  EmcyDecodeStatus on_frame(const CanFrame& frame) noexcept {
    EmcyMessage msg;
    const EmcyDecodeStatus s = decode_emcy(frame, msg);
    if (s == EmcyDecodeStatus::kOk) {
      record(msg, frame.timestamp_ns);
    } else if (s == EmcyDecodeStatus::kWrongLength) {
      ++counters_.wrong_length;
    } else if (s == EmcyDecodeStatus::kNotDataFrame) {
      ++counters_.not_data;
    }
    return s;
  }

  /// Records `msg` received at `timestamp_ns`.
  void record(const EmcyMessage& msg, std::int64_t timestamp_ns) noexcept {
    if (size_ == K) {
      ++counters_.overwritten;
    } else {
      ++size_;
    }
    records_[head_] = EmcyRecord{msg, timestamp_ns};
    head_ = (head_ + 1) % K;
    ++counters_.received;
    if (emcy_reports_fault(msg)) {
      ++counters_.faults;
    } else {
      ++counters_.resets;
    }
  }

  /// Records held, <= K.
  std::size_t size() const noexcept { return size_; }
  /// Capacity K.
  static constexpr std::size_t capacity() noexcept { return K; }
  /// Record `i` counted from the oldest held (0) to the newest (size() - 1); nullptr if
  /// i >= size().
  const EmcyRecord* at(std::size_t i) const noexcept {
    if (i >= size_) return nullptr;
    return &records_[(head_ + K - size_ + i) % K];
  }
  /// The newest record, or nullptr if none.
  const EmcyRecord* newest() const noexcept { return size_ == 0 ? nullptr : at(size_ - 1); }
  /// Counters.
  const EmcyLogCounters& counters() const noexcept { return counters_; }
  /// Forgets every record; the counters keep counting (a controller comparing
  /// counters().faults with an earlier value is not fooled by a clear()).
  void clear() noexcept {
    size_ = 0;
    head_ = 0;
  }

 private:
  std::array<EmcyRecord, K> records_{};
  std::size_t head_ = 0;  // where the next record goes
  std::size_t size_ = 0;
  EmcyLogCounters counters_;
};

}  // namespace numen::hal
