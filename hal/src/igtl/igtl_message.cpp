/// @file igtl_message.cpp
/// OpenIGTLink header and TRANSFORM decoding through libOpenIGTLink (igtl_message.hpp).

#include "numen/hal/igtl/igtl_message.hpp"

#include <igtlMessageHeader.h>
#include <igtlTransformMessage.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>

#include "igtl_stamp.hpp"

namespace numen::hal {

namespace {

std::uint64_t igtl_read_be(const std::uint8_t* p, int bytes) noexcept {
  std::uint64_t v = 0;
  for (int i = 0; i < bytes; ++i) v = (v << 8) | p[i];
  return v;
}

// The NUL-padded text of a fixed field of `n` bytes (what the library's GetDeviceType() reads
// without a terminating NUL when the name fills the field).
std::string igtl_field_text(const std::uint8_t* p, std::size_t n) {
  std::size_t len = 0;
  while (len < n && p[len] != 0) ++len;
  return std::string(reinterpret_cast<const char*>(p), len);
}

bool igtl_printable(const std::string& s) noexcept {
  if (s.empty()) return false;
  for (char c : s)
    if (c < 0x20 || c > 0x7e) return false;
  return true;
}

}  // namespace

const char* to_string(IgtlFault fault) noexcept {
  switch (fault) {
    case IgtlFault::kNone: return "none";
    case IgtlFault::kBadHeader: return "bad header";
    case IgtlFault::kBodyTooLarge: return "body too large";
    case IgtlFault::kBodySizeMismatch: return "body size mismatch";
    case IgtlFault::kCrcMismatch: return "CRC mismatch";
    case IgtlFault::kUnknownType: return "unknown type";
    case IgtlFault::kNonFinite: return "non-finite matrix";
    case IgtlFault::kNotRigid: return "non-rigid matrix";
  }
  return "?";
}

bool igtl_known_type(const std::string& type) noexcept {
  static constexpr std::array<const char*, 19> kTypes = {
      "TRANSFORM", "POSITION", "IMAGE",   "STATUS", "CAPABILITY", "STRING", "POINT",
      "TRAJ",      "TDATA",    "QTDATA",  "SENSOR", "NDARRAY",    "POLYDATA", "IMGMETA",
      "LBMETA",    "COLORT",   "BIND",    "QTRANS", "COMMAND"};
  std::string base = type;
  for (const char* prefix : {"GET_", "STT_", "STP_", "RTS_"})
    if (base.rfind(prefix, 0) == 0) {
      base = base.substr(4);
      break;
    }
  for (const char* t : kTypes)
    if (base == t) return true;
  return false;
}

struct IgtlDecoder::Impl {
  igtl::MessageHeader::Pointer header = igtl::MessageHeader::New();
  igtl::TransformMessage::Pointer transform = igtl::TransformMessage::New();
};

IgtlDecoder::IgtlDecoder() : impl_(std::make_unique<Impl>()) {}
IgtlDecoder::~IgtlDecoder() = default;

IgtlDecodeResult IgtlDecoder::decode_header(std::span<const std::uint8_t, kIgtlHeaderBytes> bytes,
                                            std::size_t max_body_bytes, IgtlHeader& header) {
  header.version = static_cast<std::uint16_t>(igtl_read_be(bytes.data() + kIgtlVersionOffset, 2));
  if (header.version != 1 && header.version != 2)
    return {IgtlFault::kBadHeader, kIgtlVersionOffset};
  header.type = igtl_field_text(bytes.data() + kIgtlTypeOffset, 12);
  if (!igtl_printable(header.type)) return {IgtlFault::kBadHeader, kIgtlTypeOffset};
  igtl::MessageHeader& h = *impl_->header;
  h.InitPack();
  std::memcpy(h.GetPackPointer(), bytes.data(), kIgtlHeaderBytes);
  h.Unpack();  // the library's byte order and fields
  header.device_name = igtl_field_text(bytes.data() + kIgtlDeviceNameOffset, 20);
  unsigned int sec = 0, frac = 0;
  h.GetTimeStamp(&sec, &frac);
  header.timestamp_raw = (static_cast<std::uint64_t>(sec) << 32) | frac;
  header.timestamp_s = static_cast<double>(sec) + static_cast<double>(frac) * 0x1p-32;
  header.body_size = igtl_read_be(bytes.data() + kIgtlBodySizeOffset, 8);
  header.crc = igtl_read_be(bytes.data() + kIgtlCrcOffset, 8);
  if (header.body_size > max_body_bytes) return {IgtlFault::kBodyTooLarge, kIgtlBodySizeOffset};
  return {};
}

IgtlDecodeResult IgtlDecoder::decode_transform(const IgtlHeader& header,
                                               std::span<const std::uint8_t> body,
                                               IgtlTransform& out, double rigid_tolerance) {
  if (header.body_size != kIgtlTransformBodyBytes)
    return {IgtlFault::kBodySizeMismatch, kIgtlBodySizeOffset};
  if (body.size() < kIgtlTransformBodyBytes)
    return {IgtlFault::kBodySizeMismatch, kIgtlHeaderBytes + body.size()};
  igtl::TransformMessage& m = *impl_->transform;
  m.SetMessageHeader(impl_->header);  // the header of decode_header()
  m.AllocatePack();
  std::memcpy(m.GetPackBodyPointer(), body.data(), kIgtlTransformBodyBytes);
  const int r = m.Unpack(1);  // 1: check the CRC
  if ((r & igtl::MessageHeader::UNPACK_BODY) == 0) return {IgtlFault::kCrcMismatch, kIgtlCrcOffset};
  igtl::Matrix4x4 mat;
  m.GetMatrix(mat);
  // The body's floats, in the order they are sent (column by column), for the fault's offset.
  static constexpr std::array<std::array<int, 2>, 12> kOrder = {{{0, 0}, {1, 0}, {2, 0}, {0, 1},
                                                                {1, 1}, {2, 1}, {0, 2}, {1, 2},
                                                                {2, 2}, {0, 3}, {1, 3}, {2, 3}}};
  for (std::size_t i = 0; i < kOrder.size(); ++i)
    if (!std::isfinite(mat[kOrder[i][0]][kOrder[i][1]]))
      return {IgtlFault::kNonFinite, kIgtlHeaderBytes + 4 * i};
  core::Mat3 rot;
  for (int r3 = 0; r3 < 3; ++r3)
    for (int c = 0; c < 3; ++c) rot(r3, c) = static_cast<double>(mat[r3][c]);
  const double err = (rot.transpose() * rot - core::Mat3::Identity()).cwiseAbs().maxCoeff();
  if (!(err <= rigid_tolerance) || !(rot.determinant() > 0.0))
    return {IgtlFault::kNotRigid, kIgtlHeaderBytes};
  out.rotation = rot;
  out.translation = core::Vec3(mat[0][3], mat[1][3], mat[2][3]);
  return {};
}

IgtlDecodeResult decode_igtl_message(IgtlDecoder& decoder, std::span<const std::uint8_t> bytes,
                                     std::size_t max_body_bytes, IgtlHeader& header,
                                     IgtlTransform& transform) {
  if (bytes.size() < kIgtlHeaderBytes) return {IgtlFault::kBadHeader, bytes.size()};
  const IgtlDecodeResult h =
      decoder.decode_header(bytes.first<kIgtlHeaderBytes>(), max_body_bytes, header);
  if (!h.ok()) return h;
  if (!igtl_known_type(header.type)) return {IgtlFault::kUnknownType, kIgtlTypeOffset};
  if (header.type != "TRANSFORM") return {};
  return decoder.decode_transform(header, bytes.subspan(kIgtlHeaderBytes), transform);
}

std::int64_t igtl_stamp_ns(std::uint64_t raw) noexcept {
  const std::uint64_t sec = raw >> 32;
  const std::uint64_t frac = raw & 0xFFFFFFFFu;
  return static_cast<std::int64_t>(sec * 1'000'000'000u +
                                   ((frac * 1'000'000'000u + (std::uint64_t{1} << 31)) >> 32));
}

std::string pack_igtl_transform(const std::string& device_name, std::int64_t timestamp_ns,
                                const core::Mat3& rotation, const core::Vec3& translation) {
  igtl::TransformMessage::Pointer m = igtl::TransformMessage::New();
  m->SetDeviceName(device_name.c_str());
  igtl::Matrix4x4 mat;
  igtl::IdentityMatrix(mat);
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) mat[r][c] = static_cast<float>(rotation(r, c));
    mat[r][3] = static_cast<float>(translation(r));
  }
  m->SetMatrix(mat);
  igtl_set_stamp_ns(*m, timestamp_ns);
  m->Pack();
  return std::string(static_cast<const char*>(m->GetPackPointer()),
                     static_cast<std::size_t>(m->GetPackSize()));
}

}  // namespace numen::hal
