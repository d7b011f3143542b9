#pragma once
/// @file igtl_message.hpp
/// OpenIGTLink message decoding for the tracker bus (igtl_tracker_bus.hpp): the 58-byte header
/// and the bodies of the three pose messages, TRANSFORM, POSITION and QTRANS, checked, through
/// the OpenIGTLink library (libOpenIGTLink 1.11: OpenIGTLink 1 and 2, header version 1; a header
/// of version 2 — OpenIGTLink 3's, whose body opens with an extended header the library cannot
/// read — frames its body but is not read; Tokuda et al.,
/// "OpenIGTLink: an open network protocol for image-guided therapy environment", Int J Med Robot
/// 5(4), 2009; the protocol description at openigtlink.org, "Header", "TRANSFORM", "POSITION",
/// "QTRANS"): TRANSFORM through igtl::TransformMessage, POSITION through igtl::PositionMessage,
/// QTRANS through the library's C codec (igtl_qtrans.h: 1.11 has no C++ class for it).
///
/// Header, big endian (byte offsets):
///   0 version u16 | 2 type char[12] | 14 device name char[20] | 34 timestamp u64 (upper 32
///   bits seconds, lower 32 bits fraction of a second, 2⁻³² s) | 42 body size u64 | 50 CRC-64
///   (ECMA-182) of the body u64 | 58 body.
/// TRANSFORM body: 12 float32, the upper 3 × 4 of a homogeneous matrix column by column:
///   R11 R21 R31 R12 R22 R32 R13 R23 R33 TX TY TZ (48 bytes); the translation in the sender's
///   units (PLUS: millimetres).
/// POSITION body: float32 X Y Z (the sender's units), then the orientation's unit quaternion
///   OX OY OZ W (28 bytes), or only OX OY OZ (24 bytes; W = √(1 − OX² − OY² − OZ²) ≥ 0, as the
///   library computes it). The 12-byte form (a position only) has no orientation: a tool's pose
///   needs one, so it is refused as a body size mismatch.
/// QTRANS body (OpenIGTLink 3's name for the same pose): X Y Z OX OY OZ W, float32 (28 bytes).
///
/// Every fault carries the byte offset, from the start of the message, of the field that
/// failed, so that a summary can say where a message went wrong. Not real-time: the library
/// allocates its message objects (an IgtlDecoder makes them once and reuses them, so decoding
/// does not grow memory); the tracker's receiver thread decodes, never the control period.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>

#include "numen/core/types.hpp"

namespace numen::hal {

/// Size of an OpenIGTLink header, bytes.
inline constexpr std::size_t kIgtlHeaderBytes = 58;
/// Size of a TRANSFORM body, bytes (12 float32).
inline constexpr std::size_t kIgtlTransformBodyBytes = 48;
/// Size of a POSITION body with the whole quaternion, bytes (7 float32).
inline constexpr std::size_t kIgtlPositionBodyBytes = 28;
/// Size of a POSITION body with the quaternion's vector part only, bytes (6 float32).
inline constexpr std::size_t kIgtlPositionQuaternion3BodyBytes = 24;
/// Size of a QTRANS body, bytes (7 float32).
inline constexpr std::size_t kIgtlQtransBodyBytes = 28;
/// Byte offsets of the header's fields (the file comment).
inline constexpr std::size_t kIgtlVersionOffset = 0;
inline constexpr std::size_t kIgtlTypeOffset = 2;         ///< Type name, char[12].
inline constexpr std::size_t kIgtlDeviceNameOffset = 14;  ///< Device name, char[20].
inline constexpr std::size_t kIgtlTimestampOffset = 34;   ///< Timestamp, u64.
inline constexpr std::size_t kIgtlBodySizeOffset = 42;    ///< Body size, u64.
inline constexpr std::size_t kIgtlCrcOffset = 50;         ///< CRC-64 of the body, u64.
/// Default tolerance of the rigidity check: max |RᵀR − I| entry (a float32 rotation of a
/// tracker is orthonormal to ~1e-7; 1e-4 passes any honest one); for a quaternion, the bound
/// on |‖q‖² − 1|.
inline constexpr double kIgtlRigidTolerance = 1e-4;

/// What was wrong with a message (kNone: nothing).
enum class IgtlFault : std::uint8_t {
  kNone,
  kBadHeader,        ///< Version not 1 or 2, or a type name that is not printable ASCII:
                     ///< the stream's framing is lost (the connection is dropped).
  kBodyTooLarge,     ///< Body size above the receiver's limit (framing not trusted).
  kBodySizeMismatch, ///< A pose message whose body size is not its type's (TRANSFORM 48,
                     ///< POSITION 28 or 24, QTRANS 28 bytes).
  kCrcMismatch,      ///< The header's CRC-64 is not the body's.
  kUnknownType,      ///< A type name that is not an OpenIGTLink v2 message type.
  kNonFinite,        ///< A pose with a NaN or infinite entry.
  kNotRigid,         ///< A TRANSFORM whose rotation is not orthonormal with determinant +1.
  kNotUnitQuaternion,  ///< A POSITION or QTRANS whose quaternion is not of unit length
                       ///< (|‖q‖² − 1| above the tolerance; 24-byte POSITION: OX² + OY² + OZ² > 1).
  kUnsupportedVersion, ///< A pose message with header version 2 (OpenIGTLink 3's extended
                       ///< header, which libOpenIGTLink 1.11 does not read): skipped.
};
/// Number of IgtlFault values.
inline constexpr int kIgtlFaultCount = 10;

/// Short English name of an IgtlFault ("CRC mismatch", ...; static string).
const char* to_string(IgtlFault fault) noexcept;

/// A decoded header.
struct IgtlHeader {
  std::uint16_t version = 0;
  /// Type name (≤ 12 characters, NUL padding removed), e.g. "TRANSFORM".
  std::string type;
  /// Device name (≤ 20 characters), e.g. "StylusToTracker".
  std::string device_name;
  /// Timestamp, s (seconds + fraction · 2⁻³²; 0 when the sender sets none).
  double timestamp_s = 0.0;
  /// The raw 64-bit timestamp (upper 32 bits seconds, lower 32 the fraction).
  std::uint64_t timestamp_raw = 0;
  /// Body size, bytes, as the header says.
  std::uint64_t body_size = 0;
  /// CRC-64 of the body, as the header says.
  std::uint64_t crc = 0;
};

/// A decoded pose (TRANSFORM, POSITION or QTRANS): the tracked frame in the sender's reference
/// frame.
struct IgtlTransform {
  core::Mat3 rotation = core::Mat3::Identity();       ///< R (orthonormal, det +1).
  core::Vec3 translation = core::Vec3::Zero();         ///< t, in the sender's units.
};

/// Outcome of a decode: the fault (kNone: decoded) and the byte offset of the field that failed,
/// from the start of the message (the header's first byte).
struct IgtlDecodeResult {
  IgtlFault fault = IgtlFault::kNone;
  std::size_t byte_offset = 0;
  bool ok() const noexcept { return fault == IgtlFault::kNone; }
};

/// True if `type` is a message type of OpenIGTLink version 2 (TRANSFORM, POSITION, IMAGE,
/// STATUS, STRING, ..., and their GET_, STT_, STP_ and RTS_ queries).
bool igtl_known_type(const std::string& type) noexcept;

/// True if `type` is one of the pose messages the tracker reads: TRANSFORM, POSITION, QTRANS.
bool igtl_pose_type(const std::string& type) noexcept;

/// True if `body_size` is a body size of the pose message `type` (TRANSFORM 48, POSITION 28 or
/// 24, QTRANS 28 bytes); false for any other type.
bool igtl_pose_body_size_ok(const std::string& type, std::uint64_t body_size) noexcept;

/// Decodes OpenIGTLink headers and pose bodies with the library's message classes, made once
/// (construction allocates) and reused. Not thread safe: one receiver owns it.
class IgtlDecoder {
 public:
  IgtlDecoder();
  ~IgtlDecoder();
  IgtlDecoder(const IgtlDecoder&) = delete;
  IgtlDecoder& operator=(const IgtlDecoder&) = delete;

  /// Decodes the 58 header bytes into `header`. kBadHeader (offset 0 for the version, 2 for a
  /// type that is not printable ASCII or empty); kBodyTooLarge (offset 42) when the body size is
  /// above `max_body_bytes`. A known or unknown type is not a fault here (igtl_known_type()).
  IgtlDecodeResult decode_header(std::span<const std::uint8_t, kIgtlHeaderBytes> bytes,
                                 std::size_t max_body_bytes, IgtlHeader& header);

  /// Decodes the body of a TRANSFORM whose header is `header` (decode_header()'s, of the same
  /// bytes) into `out`, checking in this order: header version 1 (kUnsupportedVersion, offset
  /// 0), body size 48 (kBodySizeMismatch, offset 42; also when the library's message would not
  /// hold the header's body size),
  /// `body` holding header.body_size bytes (kBodySizeMismatch, offset 58 + body.size()), the
  /// header's CRC-64 (kCrcMismatch, offset 50), every entry finite (kNonFinite, offset of the
  /// first bad float), |RᵀR − I| ≤ `rigid_tolerance` entrywise and det R > 0 (kNotRigid,
  /// offset 58: the rotation). `out` is written only on success.
  IgtlDecodeResult decode_transform(const IgtlHeader& header, std::span<const std::uint8_t> body,
                                    IgtlTransform& out,
                                    double rigid_tolerance = kIgtlRigidTolerance);

  /// Decodes the body of a pose message of any of the three types (igtl_pose_type()) into
  /// `out`: a TRANSFORM as decode_transform(); a POSITION or QTRANS checked in this order: header
  /// version 1 (kUnsupportedVersion, offset 0), body size (igtl_pose_body_size_ok(),
  /// kBodySizeMismatch at offset 42, as when the library's message would not hold it; fewer
  /// bytes than the header
  /// says, at 58 + body.size()), the CRC-64 (kCrcMismatch, offset 50), every float finite in the
  /// order sent X Y Z OX OY OZ W (kNonFinite, offset of the first bad one), the quaternion of
  /// unit length, |‖q‖² − 1| ≤ `rigid_tolerance` (kNotUnitQuaternion, offset 70: OX). The
  /// rotation is that of the normalised quaternion. Another type: kUnknownType (offset 2).
  /// `out` is written only on success.
  IgtlDecodeResult decode_pose(const IgtlHeader& header, std::span<const std::uint8_t> body,
                               IgtlTransform& out, double rigid_tolerance = kIgtlRigidTolerance);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Decodes one whole message `bytes` (header then body) as the receiver does, for the fuzz
/// harness and tests: decode_header(), then, when the header says TRANSFORM, POSITION or QTRANS,
/// decode_pose() of the bytes after the header; kUnknownType (offset 2) for a type that neither
/// igtl_known_type() nor igtl_pose_type() knows; a message shorter than its header is kBadHeader
/// at offset bytes.size().
IgtlDecodeResult decode_igtl_message(IgtlDecoder& decoder, std::span<const std::uint8_t> bytes,
                                     std::size_t max_body_bytes, IgtlHeader& header,
                                     IgtlTransform& transform);

/// Packs a TRANSFORM message (header version 1, as PLUS and Slicer send it) with the library
/// (POSITION and QTRANS: igtl_pack.hpp):
/// device name `device_name` (≤ 20 characters), timestamp `timestamp_ns` (ns since the sender's
/// epoch, ≥ 0; its fraction rounded to the nearest 2⁻³² s, which igtl_stamp_ns() rounds back to
/// the same ns), the matrix [R t] in float32. For the replay server and tests. Allocates.
std::string pack_igtl_transform(const std::string& device_name, std::int64_t timestamp_ns,
                                const core::Mat3& rotation, const core::Vec3& translation);

/// The ns of a raw header timestamp (upper 32 bits s, lower 32 bits 2⁻³² s; the fraction
/// rounded to the nearest ns).
std::int64_t igtl_stamp_ns(std::uint64_t raw) noexcept;

}  // namespace numen::hal
