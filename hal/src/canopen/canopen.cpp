/// @file canopen.cpp
/// SYNC, encoder position TPDO and drive torque RPDO codecs (CiA 301, 406, 402).

#include "numen/hal/canopen/canopen.hpp"

namespace numen::hal {
namespace {

// Common checks of a PDO expected on `cob_id` with `len` bytes.
DecodeStatus check_pdo(const CanFrame& frame, std::uint32_t cob_id, std::uint8_t len) noexcept {
  if (!has_standard_id(frame, cob_id)) return DecodeStatus::kWrongId;
  if (!is_classic_data_frame(frame)) return DecodeStatus::kNotDataFrame;
  if (frame.len != len) return DecodeStatus::kWrongLength;
  return DecodeStatus::kOk;
}

}  // namespace

const char* to_string(DecodeStatus status) noexcept {
  switch (status) {
    case DecodeStatus::kOk:
      return "ok";
    case DecodeStatus::kWrongId:
      return "wrong COB-ID";
    case DecodeStatus::kWrongLength:
      return "wrong length";
    case DecodeStatus::kNotDataFrame:
      return "not a data frame";
  }
  return "unknown";
}

CanFrame make_sync(std::int64_t timestamp_ns, std::uint8_t counter) noexcept {
  CanFrame f;
  f.id = kSyncCobId;
  f.timestamp_ns = timestamp_ns;
  if (counter != 0) {
    f.len = 1;
    f.data[0] = counter;
  }
  return f;
}

bool is_sync(const CanFrame& frame) noexcept {
  return matches_classic_id(frame, kSyncCobId) && frame.len <= 1;
}

CanFrame encode_position_pdo(std::uint32_t cob_id, std::int32_t counts,
                             std::int64_t timestamp_ns) noexcept {
  CanFrame f;
  f.id = cob_id;
  f.len = kPositionPdoLen;
  const auto u = static_cast<std::uint32_t>(counts);
  f.data[0] = static_cast<std::uint8_t>(u);
  f.data[1] = static_cast<std::uint8_t>(u >> 8);
  f.data[2] = static_cast<std::uint8_t>(u >> 16);
  f.data[3] = static_cast<std::uint8_t>(u >> 24);
  f.timestamp_ns = timestamp_ns;
  return f;
}

DecodeStatus decode_position_pdo(const CanFrame& frame, std::uint32_t cob_id,
                                 std::int32_t& counts) noexcept {
  const DecodeStatus s = check_pdo(frame, cob_id, kPositionPdoLen);
  if (s != DecodeStatus::kOk) return s;
  const std::uint32_t u = static_cast<std::uint32_t>(frame.data[0]) |
                          (static_cast<std::uint32_t>(frame.data[1]) << 8) |
                          (static_cast<std::uint32_t>(frame.data[2]) << 16) |
                          (static_cast<std::uint32_t>(frame.data[3]) << 24);
  counts = static_cast<std::int32_t>(u);  // two's complement (C++20)
  return DecodeStatus::kOk;
}

CanFrame encode_torque_pdo(std::uint32_t cob_id, std::int16_t per_mille,
                           std::int64_t timestamp_ns) noexcept {
  CanFrame f;
  f.id = cob_id;
  f.len = kTorquePdoLen;
  const auto u = static_cast<std::uint16_t>(per_mille);
  f.data[0] = static_cast<std::uint8_t>(u);
  f.data[1] = static_cast<std::uint8_t>(u >> 8);
  f.timestamp_ns = timestamp_ns;
  return f;
}

DecodeStatus decode_torque_pdo(const CanFrame& frame, std::uint32_t cob_id,
                               std::int16_t& per_mille) noexcept {
  const DecodeStatus s = check_pdo(frame, cob_id, kTorquePdoLen);
  if (s != DecodeStatus::kOk) return s;
  const auto u = static_cast<std::uint16_t>(frame.data[0] | (frame.data[1] << 8));
  per_mille = static_cast<std::int16_t>(u);
  return DecodeStatus::kOk;
}

}  // namespace numen::hal
