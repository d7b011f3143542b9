/// @file sdo.cpp
/// SDO frames (CiA 301 §7.2.4.3) and the client's state machine. Byte 0 of every frame is the
/// command byte: the command specifier in bits 7–5, then per service
///   initiate download / upload response: bits 3–2 n (bytes of 4–7 without data, when e and s),
///                                        bit 1 e (expedited), bit 0 s (size indicated);
///   download segment request / upload segment response: bit 4 t (toggle), bits 3–1 n (bytes
///                                        of 1–7 without data), bit 0 c (last segment);
///   download segment response / upload segment request: bit 4 t;
/// bytes 1–2 the index (little endian) and byte 3 the sub-index in initiate frames and aborts;
/// bytes 4–7 expedited data, the size (s set), or the abort code (little endian).

#include "numen/hal/canopen/sdo.hpp"

#include <algorithm>
#include <cstdio>

namespace numen::hal {
namespace {

// Command specifiers (bits 7–5 of byte 0).
constexpr std::uint8_t kCcsDownloadSegment = 0, kCcsInitiateDownload = 1, kCcsInitiateUpload = 2,
                       kCcsUploadSegment = 3, kCsAbort = 4, kCsBlockUpload = 5,
                       kCsBlockDownload = 6;
constexpr std::uint8_t kScsUploadSegment = 0, kScsDownloadSegment = 1, kScsInitiateUpload = 2,
                       kScsInitiateDownload = 3;

std::uint32_t get_u32(const std::uint8_t* p) noexcept {
  return static_cast<std::uint32_t>(p[0]) | static_cast<std::uint32_t>(p[1]) << 8 |
         static_cast<std::uint32_t>(p[2]) << 16 | static_cast<std::uint32_t>(p[3]) << 24;
}

void put_u32(std::uint8_t* p, std::uint32_t v) noexcept {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<std::uint8_t>(v >> (8 * i));
}

void put_address(std::uint8_t* d, SdoAddress a) noexcept {
  d[1] = static_cast<std::uint8_t>(a.index);
  d[2] = static_cast<std::uint8_t>(a.index >> 8);
  d[3] = a.subindex;
}

bool is_response_channel(std::uint32_t cob_id) noexcept {
  return cob_id > kSdoResponseBaseCobId && cob_id < kSdoResponseBaseCobId + 0x80;
}

}  // namespace

const char* sdo_abort_name(std::uint32_t code) noexcept {
  switch (code) {
    case SdoAbort::kToggleBit: return "toggle bit not alternated";
    case SdoAbort::kTimeout: return "SDO protocol timed out";
    case SdoAbort::kCommandSpecifier: return "client/server command specifier not valid or unknown";
    case SdoAbort::kBlockSize: return "invalid block size (block mode only)";
    case SdoAbort::kSequenceNumber: return "invalid sequence number (block mode only)";
    case SdoAbort::kCrc: return "CRC error (block mode only)";
    case SdoAbort::kOutOfMemory: return "out of memory";
    case SdoAbort::kUnsupportedAccess: return "unsupported access to an object";
    case SdoAbort::kWriteOnly: return "attempt to read a write only object";
    case SdoAbort::kReadOnly: return "attempt to write a read only object";
    case SdoAbort::kNoObject: return "object does not exist in the object dictionary";
    case SdoAbort::kNotMappable: return "object cannot be mapped to the PDO";
    case SdoAbort::kPdoLength:
      return "the number and length of the objects to be mapped would exceed the PDO length";
    case SdoAbort::kParameterIncompatible: return "general parameter incompatibility reason";
    case SdoAbort::kInternalIncompatible: return "general internal incompatibility in the device";
    case SdoAbort::kHardware: return "access failed due to a hardware error";
    case SdoAbort::kLengthMismatch:
      return "data type does not match, length of service parameter does not match";
    case SdoAbort::kLengthTooHigh: return "data type does not match, length of service parameter too high";
    case SdoAbort::kLengthTooLow: return "data type does not match, length of service parameter too low";
    case SdoAbort::kNoSubIndex: return "sub-index does not exist";
    case SdoAbort::kInvalidValue: return "invalid value for parameter (download only)";
    case SdoAbort::kValueTooHigh: return "value of parameter written too high (download only)";
    case SdoAbort::kValueTooLow: return "value of parameter written too low (download only)";
    case SdoAbort::kMaxBelowMin: return "maximum value is less than minimum value";
    case SdoAbort::kNoConnection: return "resource not available: SDO connection";
    case SdoAbort::kGeneral: return "general error";
    case SdoAbort::kCannotStore: return "data cannot be transferred or stored to the application";
    case SdoAbort::kLocalControl:
      return "data cannot be transferred or stored to the application because of local control";
    case SdoAbort::kDeviceState:
      return "data cannot be transferred or stored to the application because of the present "
             "device state";
    case SdoAbort::kNoDictionary:
      return "object dictionary dynamic generation fails or no object dictionary is present";
    case SdoAbort::kNoData: return "no data available";
    default: return "unknown abort code";
  }
}

std::string to_string(SdoAddress address) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "0x%04X:%02X", address.index, address.subindex);
  return buf;
}

const char* to_string(SdoStatus status) noexcept {
  switch (status) {
    case SdoStatus::kIdle: return "idle";
    case SdoStatus::kPending: return "pending";
    case SdoStatus::kDone: return "done";
    case SdoStatus::kAborted: return "aborted";
  }
  return "unknown";
}

SdoDecodeStatus decode_sdo(const CanFrame& frame, std::uint32_t cob_id, SdoFrame& out) noexcept {
  if (!has_standard_id(frame, cob_id)) return SdoDecodeStatus::kWrongId;
  if (!is_classic_data_frame(frame)) return SdoDecodeStatus::kNotDataFrame;
  if (frame.len != kSdoFrameLen) return SdoDecodeStatus::kWrongLength;
  const std::uint8_t* d = frame.data.data();
  const std::uint8_t cs = d[0] >> 5;
  const bool response = is_response_channel(cob_id);
  SdoFrame f;
  auto read_initiate = [&] {
    f.address = SdoAddress{static_cast<std::uint16_t>(d[1] | d[2] << 8), d[3]};
  };
  if (cs == kCsAbort) {
    f.kind = SdoFrameKind::kAbort;
    read_initiate();
    f.abort_code = get_u32(d + 4);
  } else if (cs == kCsBlockUpload || cs == kCsBlockDownload) {
    f.kind = SdoFrameKind::kBlock;
  } else if (cs == 7) {
    f.kind = SdoFrameKind::kUnknown;
  } else if ((!response && cs == kCcsInitiateDownload) || (response && cs == kScsInitiateUpload)) {
    f.kind = response ? SdoFrameKind::kInitiateUploadResponse : SdoFrameKind::kInitiateDownloadRequest;
    read_initiate();
    f.expedited = (d[0] & 0x02) != 0;
    f.size_indicated = (d[0] & 0x01) != 0;
    if (f.expedited) {
      f.data_len = static_cast<std::uint8_t>(f.size_indicated ? 4 - ((d[0] >> 2) & 0x03) : 4);
      std::copy(d + 4, d + 4 + f.data_len, f.data);
      f.size = f.data_len;
    } else if (f.size_indicated) {
      f.size = get_u32(d + 4);
    }
  } else if ((!response && cs == kCcsDownloadSegment) || (response && cs == kScsUploadSegment)) {
    f.kind = response ? SdoFrameKind::kUploadSegmentResponse : SdoFrameKind::kDownloadSegmentRequest;
    f.toggle = (d[0] & 0x10) != 0;
    f.last = (d[0] & 0x01) != 0;
    f.data_len = static_cast<std::uint8_t>(7 - ((d[0] >> 1) & 0x07));
    std::copy(d + 1, d + 1 + f.data_len, f.data);
  } else if (!response && cs == kCcsInitiateUpload) {
    f.kind = SdoFrameKind::kInitiateUploadRequest;
    read_initiate();
  } else if (!response && cs == kCcsUploadSegment) {
    f.kind = SdoFrameKind::kUploadSegmentRequest;
    f.toggle = (d[0] & 0x10) != 0;
  } else if (response && cs == kScsInitiateDownload) {
    f.kind = SdoFrameKind::kInitiateDownloadResponse;
    read_initiate();
  } else {  // response && cs == kScsDownloadSegment
    f.kind = SdoFrameKind::kDownloadSegmentResponse;
    f.toggle = (d[0] & 0x10) != 0;
  }
  out = f;
  return SdoDecodeStatus::kOk;
}

bool encode_sdo(const SdoFrame& f, std::uint32_t cob_id, std::int64_t timestamp_ns,
                CanFrame& out) noexcept {
  CanFrame c;
  c.id = cob_id;
  c.len = kSdoFrameLen;
  c.timestamp_ns = timestamp_ns;
  std::uint8_t* d = c.data.data();
  const std::uint8_t t = f.toggle ? 0x10 : 0x00;
  switch (f.kind) {
    case SdoFrameKind::kInitiateDownloadRequest:
    case SdoFrameKind::kInitiateUploadResponse: {
      const std::uint8_t cs = f.kind == SdoFrameKind::kInitiateDownloadRequest ? kCcsInitiateDownload
                                                                               : kScsInitiateUpload;
      if (f.expedited) {
        if (f.data_len < 1 || f.data_len > kSdoExpeditedMax) return false;
        d[0] = static_cast<std::uint8_t>(cs << 5 | (4 - f.data_len) << 2 | 0x02 | 0x01);
        std::copy(f.data, f.data + f.data_len, d + 4);
      } else {
        d[0] = static_cast<std::uint8_t>(cs << 5 | (f.size_indicated ? 0x01 : 0x00));
        if (f.size_indicated) put_u32(d + 4, f.size);
      }
      put_address(d, f.address);
      break;
    }
    case SdoFrameKind::kDownloadSegmentRequest:
    case SdoFrameKind::kUploadSegmentResponse: {
      if (f.data_len > kSdoSegmentMax) return false;
      const std::uint8_t cs = f.kind == SdoFrameKind::kDownloadSegmentRequest ? kCcsDownloadSegment
                                                                              : kScsUploadSegment;
      d[0] = static_cast<std::uint8_t>(cs << 5 | t | (7 - f.data_len) << 1 | (f.last ? 0x01 : 0x00));
      std::copy(f.data, f.data + f.data_len, d + 1);
      break;
    }
    case SdoFrameKind::kInitiateUploadRequest:
      d[0] = kCcsInitiateUpload << 5;
      put_address(d, f.address);
      break;
    case SdoFrameKind::kUploadSegmentRequest:
      d[0] = static_cast<std::uint8_t>(kCcsUploadSegment << 5 | t);
      break;
    case SdoFrameKind::kInitiateDownloadResponse:
      d[0] = kScsInitiateDownload << 5;
      put_address(d, f.address);
      break;
    case SdoFrameKind::kDownloadSegmentResponse:
      d[0] = static_cast<std::uint8_t>(kScsDownloadSegment << 5 | t);
      break;
    case SdoFrameKind::kAbort:
      d[0] = kCsAbort << 5;
      put_address(d, f.address);
      put_u32(d + 4, f.abort_code);
      break;
    case SdoFrameKind::kBlock:
    case SdoFrameKind::kUnknown:
      return false;
  }
  out = c;
  return true;
}

SdoClient::SdoClient(std::uint8_t server_node, std::int64_t timeout_ns) noexcept
    : node_(server_node), timeout_ns_(timeout_ns > 0 ? timeout_ns : 500'000'000) {}

void SdoClient::begin(SdoAddress address, Phase phase, std::int64_t now_ns) noexcept {
  ++counters_.transfers;
  status_ = SdoStatus::kPending;
  phase_ = phase;
  address_ = address;
  done_ = 0;
  announced_ = 0;
  toggle_ = false;
  awaiting_ = false;
  sent_ns_ = now_ns;
  abort_code_ = 0;
  aborted_by_server_ = false;
  final_after_send_ = false;
}

bool SdoClient::start_upload(SdoAddress address, std::span<std::uint8_t> buffer,
                             std::int64_t now_ns) noexcept {
  if (status_ == SdoStatus::kPending || node_ < 1 || node_ > 127) return false;
  begin(address, Phase::kInitiateUpload, now_ns);
  upload_ = buffer;
  download_ = {};
  SdoFrame f;
  f.kind = SdoFrameKind::kInitiateUploadRequest;
  f.address = address;
  queue(f);
  return true;
}

bool SdoClient::start_download(SdoAddress address, std::span<const std::uint8_t> data,
                               std::int64_t now_ns) noexcept {
  if (status_ == SdoStatus::kPending || node_ < 1 || node_ > 127 || data.empty()) return false;
  begin(address, Phase::kInitiateDownload, now_ns);
  download_ = data;
  upload_ = {};
  SdoFrame f;
  f.kind = SdoFrameKind::kInitiateDownloadRequest;
  f.address = address;
  if (data.size() <= kSdoExpeditedMax) {
    f.expedited = true;
    f.size_indicated = true;
    f.data_len = static_cast<std::uint8_t>(data.size());
    std::copy(data.begin(), data.end(), f.data);
    f.size = f.data_len;
  } else {
    f.size_indicated = true;
    f.size = static_cast<std::uint32_t>(std::min<std::size_t>(data.size(), UINT32_MAX));
  }
  queue(f);
  return true;
}

void SdoClient::queue(const SdoFrame& f) noexcept {
  request_ = f;
  have_request_ = true;
  final_after_send_ = f.kind == SdoFrameKind::kAbort;
}

void SdoClient::abort_local(std::uint32_t code, std::uint64_t& counter) noexcept {
  SdoFrame f;
  f.kind = SdoFrameKind::kAbort;
  f.address = address_;
  f.abort_code = code;
  queue(f);
  status_ = SdoStatus::kAborted;
  abort_code_ = code;
  aborted_by_server_ = false;
  awaiting_ = false;
  phase_ = Phase::kNone;
  ++counter;
}

void SdoClient::finish() noexcept {
  status_ = SdoStatus::kDone;
  phase_ = Phase::kNone;
  awaiting_ = false;
  ++counters_.completed;
}

void SdoClient::cancel(std::uint32_t code, std::int64_t) noexcept {
  if (status_ == SdoStatus::kPending) abort_local(code);
}

bool SdoClient::take_request(CanFrame& out, std::int64_t now_ns) noexcept {
  if (!have_request_) return false;
  if (!encode_sdo(request_, sdo_request_cob_id(node_), now_ns, out)) {
    have_request_ = false;  // cannot happen: the client only queues encodable frames
    return false;
  }
  have_request_ = false;
  if (!final_after_send_) {
    awaiting_ = true;
    sent_ns_ = now_ns;
  }
  final_after_send_ = false;
  return true;
}

void SdoClient::poll(std::int64_t now_ns) noexcept {
  if (status_ != SdoStatus::kPending || !awaiting_) return;
  if (now_ns - sent_ns_ > timeout_ns_) {
    abort_local(SdoAbort::kTimeout, counters_.timeouts);
  }
}

bool SdoClient::on_frame(const CanFrame& frame) noexcept {
  if (node_ < 1 || node_ > 127) return false;
  SdoFrame f;
  switch (decode_sdo(frame, sdo_response_cob_id(node_), f)) {
    case SdoDecodeStatus::kWrongId:
      return false;
    case SdoDecodeStatus::kNotDataFrame:
    case SdoDecodeStatus::kWrongLength:
      ++counters_.frames_malformed;
      return true;  // on our channel but not an SDO frame: the timeout decides
    case SdoDecodeStatus::kOk:
      break;
  }
  if (status_ != SdoStatus::kPending || !awaiting_) {
    ++counters_.frames_ignored;
    return true;
  }
  if (f.kind == SdoFrameKind::kAbort) {
    // CiA 301: an abort for another multiplexer is still the abort of this channel's transfer.
    status_ = SdoStatus::kAborted;
    abort_code_ = f.abort_code;
    aborted_by_server_ = true;
    awaiting_ = false;
    phase_ = Phase::kNone;
    ++counters_.server_aborts;
    return true;
  }
  awaiting_ = false;
  if (phase_ == Phase::kInitiateUpload || phase_ == Phase::kUploadSegment) {
    on_upload_response(f);
  } else {
    on_download_response(f);
  }
  return true;
}

void SdoClient::on_upload_response(const SdoFrame& f) noexcept {
  if (phase_ == Phase::kInitiateUpload) {
    if (f.kind != SdoFrameKind::kInitiateUploadResponse) return abort_local(SdoAbort::kCommandSpecifier);
    if (!(f.address == address_)) return abort_local(SdoAbort::kGeneral);
    if (f.expedited) {
      if (f.data_len > upload_.size()) return abort_local(SdoAbort::kOutOfMemory);
      std::copy(f.data, f.data + f.data_len, upload_.begin());
      done_ = f.data_len;
      announced_ = f.size_indicated ? f.data_len : 0;
      return finish();
    }
    if (f.size_indicated) {
      if (f.size > upload_.size()) return abort_local(SdoAbort::kOutOfMemory);
      announced_ = f.size;
    }
    phase_ = Phase::kUploadSegment;
  } else {
    if (f.kind != SdoFrameKind::kUploadSegmentResponse) return abort_local(SdoAbort::kCommandSpecifier);
    if (f.toggle != toggle_) return abort_local(SdoAbort::kToggleBit);
    if (done_ + f.data_len > upload_.size()) return abort_local(SdoAbort::kOutOfMemory);
    if (announced_ > 0 && done_ + f.data_len > announced_) return abort_local(SdoAbort::kLengthTooHigh);
    std::copy(f.data, f.data + f.data_len, upload_.begin() + static_cast<std::ptrdiff_t>(done_));
    done_ += f.data_len;
    toggle_ = !toggle_;
    if (f.last) {
      if (announced_ > 0 && done_ < announced_) return abort_local(SdoAbort::kLengthTooLow);
      return finish();
    }
  }
  SdoFrame next;
  next.kind = SdoFrameKind::kUploadSegmentRequest;
  next.toggle = toggle_;
  queue(next);
}

void SdoClient::on_download_response(const SdoFrame& f) noexcept {
  if (phase_ == Phase::kInitiateDownload) {
    if (f.kind != SdoFrameKind::kInitiateDownloadResponse) return abort_local(SdoAbort::kCommandSpecifier);
    if (!(f.address == address_)) return abort_local(SdoAbort::kGeneral);
    if (download_.size() <= kSdoExpeditedMax) {
      done_ = download_.size();
      return finish();
    }
    phase_ = Phase::kDownloadSegment;
  } else {
    if (f.kind != SdoFrameKind::kDownloadSegmentResponse) return abort_local(SdoAbort::kCommandSpecifier);
    if (f.toggle != toggle_) return abort_local(SdoAbort::kToggleBit);
    toggle_ = !toggle_;
    if (done_ >= download_.size()) return finish();  // the last segment was confirmed
  }
  queue_download_segment();
}

void SdoClient::queue_download_segment() noexcept {
  SdoFrame s;
  s.kind = SdoFrameKind::kDownloadSegmentRequest;
  s.toggle = toggle_;
  const std::size_t n = std::min(kSdoSegmentMax, download_.size() - done_);
  s.data_len = static_cast<std::uint8_t>(n);
  std::copy_n(download_.begin() + static_cast<std::ptrdiff_t>(done_), n, s.data);
  done_ += n;
  s.last = done_ >= download_.size();
  queue(s);
}

}  // namespace numen::hal
