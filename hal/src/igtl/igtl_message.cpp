/// @file igtl_message.cpp
/// OpenIGTLink header and pose (TRANSFORM, POSITION, QTRANS) decoding through libOpenIGTLink
/// (igtl_message.hpp).

#include "numen/hal/igtl/igtl_message.hpp"

#include <igtlMessageHeader.h>
#include <igtlPositionMessage.h>
#include <igtlTransformMessage.h>
#include <igtl_qtrans.h>

#include <algorithm>
#include <array>
#include <bit>
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
    case IgtlFault::kNonFinite: return "non-finite value";
    case IgtlFault::kNotRigid: return "non-rigid matrix";
    case IgtlFault::kNotUnitQuaternion: return "non-unit quaternion";
    case IgtlFault::kUnsupportedVersion: return "unsupported header version";
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

bool igtl_pose_type(const std::string& type) noexcept {
  return type == "TRANSFORM" || type == "POSITION" || type == "QTRANS";
}

bool igtl_pose_body_size_ok(const std::string& type, std::uint64_t body_size) noexcept {
  if (type == "TRANSFORM") return body_size == kIgtlTransformBodyBytes;
  if (type == "POSITION")
    return body_size == kIgtlPositionBodyBytes || body_size == kIgtlPositionQuaternion3BodyBytes;
  if (type == "QTRANS") return body_size == kIgtlQtransBodyBytes;
  return false;
}

namespace {

// The checks of a position + quaternion body (POSITION, QTRANS) after the library decoded it:
// `f` = X Y Z OX OY OZ W in the order sent.
IgtlDecodeResult igtl_quaternion_pose(const std::array<float, 7>& f, double tolerance,
                                      IgtlTransform& out) {
  for (std::size_t i = 0; i < f.size(); ++i)
    if (!std::isfinite(f[i])) return {IgtlFault::kNonFinite, kIgtlHeaderBytes + 4 * i};
  const core::Quat q(f[6], f[3], f[4], f[5]);  // Eigen: w, x, y, z
  if (!(std::abs(q.squaredNorm() - 1.0) <= tolerance))
    return {IgtlFault::kNotUnitQuaternion, kIgtlHeaderBytes + 12};
  out.rotation = q.normalized().toRotationMatrix();
  out.translation = core::Vec3(f[0], f[1], f[2]);
  return {};
}

}  // namespace

struct IgtlDecoder::Impl {
  igtl::MessageHeader::Pointer header = igtl::MessageHeader::New();
  igtl::TransformMessage::Pointer transform = igtl::TransformMessage::New();
  igtl::PositionMessage::Pointer position = igtl::PositionMessage::New();
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
  if (header.version != 1) return {IgtlFault::kUnsupportedVersion, kIgtlVersionOffset};
  if (header.body_size != kIgtlTransformBodyBytes)
    return {IgtlFault::kBodySizeMismatch, kIgtlBodySizeOffset};
  if (body.size() < kIgtlTransformBodyBytes)
    return {IgtlFault::kBodySizeMismatch, kIgtlHeaderBytes + body.size()};
  igtl::TransformMessage& m = *impl_->transform;
  m.SetMessageHeader(impl_->header);  // the header of decode_header()
  m.AllocatePack();
  if (static_cast<std::size_t>(m.GetPackBodySize()) != kIgtlTransformBodyBytes)
    return {IgtlFault::kBodySizeMismatch, kIgtlBodySizeOffset};
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

IgtlDecodeResult IgtlDecoder::decode_pose(const IgtlHeader& header,
                                          std::span<const std::uint8_t> body, IgtlTransform& out,
                                          double rigid_tolerance) {
  if (header.type == "TRANSFORM") return decode_transform(header, body, out, rigid_tolerance);
  if (!igtl_pose_type(header.type)) return {IgtlFault::kUnknownType, kIgtlTypeOffset};
  if (header.version != 1) return {IgtlFault::kUnsupportedVersion, kIgtlVersionOffset};
  if (!igtl_pose_body_size_ok(header.type, header.body_size))
    return {IgtlFault::kBodySizeMismatch, kIgtlBodySizeOffset};
  const auto n = static_cast<std::size_t>(header.body_size);
  if (body.size() < n) return {IgtlFault::kBodySizeMismatch, kIgtlHeaderBytes + body.size()};
  std::array<float, 7> f{};
  if (header.type == "QTRANS") {
    // The library's C codec (1.11 has no igtl::QTransMessage): the CRC over the bytes as sent,
    // then the byte order.
    igtl_qtrans q{};
    std::memcpy(&q, body.data(), kIgtlQtransBodyBytes);
    if (igtl_qtrans_get_crc(&q) != header.crc) return {IgtlFault::kCrcMismatch, kIgtlCrcOffset};
    igtl_qtrans_convert_byte_order(&q);
    std::copy(std::begin(q.qtrans), std::end(q.qtrans), f.begin());
    std::copy(std::begin(q.quaternion), std::end(q.quaternion), f.begin() + 3);
    return igtl_quaternion_pose(f, rigid_tolerance, out);
  }
  igtl::PositionMessage& m = *impl_->position;
  m.SetMessageHeader(impl_->header);  // the header of decode_header(); the pack type by size
  m.AllocatePack();
  // The library sizes the body from its own reading of the header (a header it did not read
  // leaves the size of the previous message's form): never copy past what it allocated.
  if (static_cast<std::size_t>(m.GetPackBodySize()) != n)
    return {IgtlFault::kBodySizeMismatch, kIgtlBodySizeOffset};
  std::memcpy(m.GetPackBodyPointer(), body.data(), n);
  const int r = m.Unpack(1);  // 1: check the CRC
  if ((r & igtl::MessageHeader::UNPACK_BODY) == 0) return {IgtlFault::kCrcMismatch, kIgtlCrcOffset};
  m.GetPosition(f.data());
  m.GetQuaternion(f.data() + 3);
  if (n == kIgtlPositionQuaternion3BodyBytes) {
    // The library makes W = √(1 − |v|²), but answers the identity (0, 0, 0, 1) without a word
    // when |v|² > 1 or an element is infinite, and a float32 unit vector part (W ≈ 0) may have
    // |v|² a little above 1: the identity for a half turn. So the vector part is taken as sent
    // (three big-endian float32 at OX) and W made here, |v|² ≤ 1 + tolerance.
    for (std::size_t i = 0; i < 3; ++i)
      if (!std::isfinite(f[i])) return {IgtlFault::kNonFinite, kIgtlHeaderBytes + 4 * i};
    double v2 = 0.0;
    for (std::size_t i = 0; i < 3; ++i) {
      const std::size_t at = 12 + 4 * i;
      const auto bits = static_cast<std::uint32_t>(igtl_read_be(body.data() + at, 4));
      f[3 + i] = std::bit_cast<float>(bits);
      if (!std::isfinite(f[3 + i])) return {IgtlFault::kNonFinite, kIgtlHeaderBytes + at};
      v2 += static_cast<double>(f[3 + i]) * f[3 + i];
    }
    if (!(v2 <= 1.0 + rigid_tolerance))
      return {IgtlFault::kNotUnitQuaternion, kIgtlHeaderBytes + 12};
    f[6] = static_cast<float>(std::sqrt(std::max(0.0, 1.0 - v2)));
  }
  return igtl_quaternion_pose(f, rigid_tolerance, out);
}

IgtlDecodeResult decode_igtl_message(IgtlDecoder& decoder, std::span<const std::uint8_t> bytes,
                                     std::size_t max_body_bytes, IgtlHeader& header,
                                     IgtlTransform& transform) {
  if (bytes.size() < kIgtlHeaderBytes) return {IgtlFault::kBadHeader, bytes.size()};
  const IgtlDecodeResult h =
      decoder.decode_header(bytes.first<kIgtlHeaderBytes>(), max_body_bytes, header);
  if (!h.ok()) return h;
  if (!igtl_known_type(header.type)) return {IgtlFault::kUnknownType, kIgtlTypeOffset};
  if (!igtl_pose_type(header.type)) return {};
  return decoder.decode_pose(header, bytes.subspan(kIgtlHeaderBytes), transform);
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
