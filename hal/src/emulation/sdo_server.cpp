/// @file sdo_server.cpp

#include "numen/hal/emulation/sdo_server.hpp"

#include <algorithm>
#include <span>

namespace numen::hal {

SdoServer::SdoServer(std::uint8_t node_id, ObjectDictionary& dictionary)
    : node_(node_id), od_(&dictionary), staging_(std::max<std::size_t>(1, dictionary.max_length())) {}

void SdoServer::respond(const SdoFrame& f) noexcept {
  response_ = f;
  have_response_ = true;
}

void SdoServer::abort(SdoAddress address, std::uint32_t code) noexcept {
  SdoFrame f;
  f.kind = SdoFrameKind::kAbort;
  f.address = address;
  f.abort_code = code;
  respond(f);
  phase_ = Phase::kIdle;
  ++counters_.aborts_sent;
}

bool SdoServer::take_response(CanFrame& out, std::int64_t now_ns) noexcept {
  if (!have_response_) return false;
  have_response_ = false;
  return encode_sdo(response_, sdo_response_cob_id(node_), now_ns, out);
}

bool SdoServer::on_frame(const CanFrame& frame) noexcept {
  SdoFrame f;
  switch (decode_sdo(frame, sdo_request_cob_id(node_), f)) {
    case SdoDecodeStatus::kWrongId:
      return false;
    case SdoDecodeStatus::kNotDataFrame:
    case SdoDecodeStatus::kWrongLength:
      ++counters_.frames_malformed;
      return true;
    case SdoDecodeStatus::kOk:
      break;
  }
  ++counters_.requests;
  switch (f.kind) {
    case SdoFrameKind::kInitiateUploadRequest: on_initiate_upload(f); break;
    case SdoFrameKind::kUploadSegmentRequest: on_upload_segment(f); break;
    case SdoFrameKind::kInitiateDownloadRequest: on_initiate_download(f); break;
    case SdoFrameKind::kDownloadSegmentRequest: on_download_segment(f); break;
    case SdoFrameKind::kAbort:  // the client ends the transfer; no response (CiA 301)
      ++counters_.aborts_received;
      phase_ = Phase::kIdle;
      break;
    default:  // block transfers, unknown specifiers
      abort(f.address, SdoAbort::kCommandSpecifier);
      break;
  }
  return true;
}

void SdoServer::on_initiate_upload(const SdoFrame& f) noexcept {
  const OdEntry* e = od_->find(f.address);
  if (e == nullptr)
    return abort(f.address, od_->has_index(f.address.index) ? SdoAbort::kNoSubIndex : SdoAbort::kNoObject);
  if (e->access == OdAccess::kWriteOnly) return abort(f.address, SdoAbort::kWriteOnly);
  SdoFrame r;
  r.kind = SdoFrameKind::kInitiateUploadResponse;
  r.address = f.address;
  r.size_indicated = true;
  if (!e->value.empty() && e->value.size() <= kSdoExpeditedMax) {
    r.expedited = true;
    r.data_len = static_cast<std::uint8_t>(e->value.size());
    std::copy(e->value.begin(), e->value.end(), r.data);
    phase_ = Phase::kIdle;
    ++counters_.uploads;
  } else {
    r.size = static_cast<std::uint32_t>(e->value.size());
    phase_ = Phase::kUpload;
    address_ = f.address;
    entry_ = e;
    offset_ = 0;
    toggle_ = false;
  }
  respond(r);
}

void SdoServer::on_upload_segment(const SdoFrame& f) noexcept {
  if (phase_ != Phase::kUpload) return abort(address_, SdoAbort::kCommandSpecifier);
  if (f.toggle != toggle_) return abort(address_, SdoAbort::kToggleBit);
  SdoFrame r;
  r.kind = SdoFrameKind::kUploadSegmentResponse;
  r.toggle = toggle_;
  const std::size_t n = std::min(kSdoSegmentMax, entry_->value.size() - offset_);
  std::copy_n(entry_->value.begin() + static_cast<std::ptrdiff_t>(offset_), n, r.data);
  r.data_len = static_cast<std::uint8_t>(n);
  offset_ += n;
  r.last = offset_ >= entry_->value.size();
  toggle_ = !toggle_;
  if (r.last) {
    phase_ = Phase::kIdle;
    ++counters_.uploads;
  }
  respond(r);
}

void SdoServer::on_initiate_download(const SdoFrame& f) noexcept {
  OdEntry* e = od_->find(f.address);
  if (e == nullptr)
    return abort(f.address, od_->has_index(f.address.index) ? SdoAbort::kNoSubIndex : SdoAbort::kNoObject);
  if (e->access == OdAccess::kReadOnly) return abort(f.address, SdoAbort::kReadOnly);
  if (f.expedited) {
    const std::uint32_t code = od_->write(f.address, std::span<const std::uint8_t>(f.data, f.data_len));
    if (code != 0) return abort(f.address, code);
    ++counters_.downloads;
    phase_ = Phase::kIdle;
  } else {
    if (f.size_indicated && f.size > staging_.size()) return abort(f.address, SdoAbort::kLengthTooHigh);
    phase_ = Phase::kDownload;
    address_ = f.address;
    size_ = f.size_indicated ? f.size : 0;
    staged_ = 0;
    toggle_ = false;
  }
  SdoFrame r;
  r.kind = SdoFrameKind::kInitiateDownloadResponse;
  r.address = f.address;
  respond(r);
}

void SdoServer::on_download_segment(const SdoFrame& f) noexcept {
  if (phase_ != Phase::kDownload) return abort(address_, SdoAbort::kCommandSpecifier);
  if (f.toggle != toggle_) return abort(address_, SdoAbort::kToggleBit);
  if (staged_ + f.data_len > staging_.size()) return abort(address_, SdoAbort::kLengthTooHigh);
  std::copy_n(f.data, f.data_len, staging_.begin() + static_cast<std::ptrdiff_t>(staged_));
  staged_ += f.data_len;
  if (f.last) {
    if (size_ > 0 && staged_ != size_)
      return abort(address_, staged_ > size_ ? SdoAbort::kLengthTooHigh : SdoAbort::kLengthTooLow);
    const std::uint32_t code =
        od_->write(address_, std::span<const std::uint8_t>(staging_.data(), staged_));
    if (code != 0) return abort(address_, code);
    ++counters_.downloads;
    phase_ = Phase::kIdle;
  }
  SdoFrame r;
  r.kind = SdoFrameKind::kDownloadSegmentResponse;
  r.toggle = toggle_;
  toggle_ = !toggle_;
  respond(r);
}

}  // namespace numen::hal
