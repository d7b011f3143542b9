#pragma once
/// @file igtl_pack.hpp
/// The OpenIGTLink messages numen sends besides TRANSFORM (igtl_message.hpp's
/// pack_igtl_transform()): POLYDATA (a triangle surface: the organ), STATUS (a fault or an
/// event, with the protocol's status code) and STRING (a line of text), and the tracker's other
/// pose messages POSITION and QTRANS (for the replay and tests), packed by the library
/// (libOpenIGTLink 1.11: igtl::PolyDataMessage, igtl::StatusMessage, igtl::StringMessage;
/// openigtlink.org, "POLYDATA", "STATUS", "STRING"), and read back through the same classes,
/// with the body's CRC-64 checked, for the tests and any reader of numen's world
/// (`numen run --igtl`, docs/openigtlink.md). Not real-time: the library allocates.

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "numen/core/types.hpp"

namespace numen::hal {

/// OpenIGTLink STATUS codes (the protocol's "STATUS" message; igtl::StatusMessage's enum).
enum class IgtlStatusCode : std::uint16_t {
  kInvalid = 0,
  kOk = 1,
  kUnknownError = 2,
  kPanicMode = 3,        ///< Emergency.
  kNotFound = 4,
  kAccessDenied = 5,
  kBusy = 6,
  kTimeOut = 7,          ///< Time out / connection lost.
  kOverflow = 8,
  kChecksumError = 9,
  kConfigError = 10,
  kResourceError = 11,
  kUnknownInstruction = 12,
  kNotReady = 13,        ///< Device not ready (starting up).
  kManualMode = 14,
  kDisabled = 15,        ///< Device disabled.
  kNotPresent = 16,      ///< Device not present.
  kUnknownVersion = 17,
  kHardwareFailure = 18,
  kShutDown = 19,        ///< Exiting / shut down in progress.
};

/// Packs POLYDATA messages of one triangle surface (or polylines: a suture thread) whose cells
/// rarely change and whose points move: the library's message is made once with the triangles
/// as its POLYGONS and the polylines as its LINES, and each pack() sets the points and the
/// timestamp (header version 1, as Slicer reads it). Points, triangles and lines only: no
/// vertices, strips or attributes.
class IgtlPolyDataPacker {
 public:
  /// `device_name` ≤ 20 characters; `triangles` index the surface's `point_count` points, as
  /// do `lines` (each a polyline of at least 2 points, a LINES cell).
  /// Throws std::invalid_argument: a name too long or empty, no point, an index out of range, a
  /// polyline of fewer than 2 points.
  IgtlPolyDataPacker(const std::string& device_name, std::size_t point_count,
                     std::span<const std::array<std::uint32_t, 3>> triangles,
                     std::span<const std::vector<std::uint32_t>> lines = {});
  /// Replaces the LINES cells by `lines` (a thread that broke: two polylines), checked as the
  /// constructor checks them (std::invalid_argument; the old lines are kept then). Allocates.
  void set_lines(std::span<const std::vector<std::uint32_t>> lines);
  ~IgtlPolyDataPacker();
  IgtlPolyDataPacker(const IgtlPolyDataPacker&) = delete;
  IgtlPolyDataPacker& operator=(const IgtlPolyDataPacker&) = delete;

  /// Points of the surface.
  std::size_t point_count() const noexcept { return point_count_; }
  /// Appends to `out` the message with `points` (point_count() of them, in the sender's units,
  /// stored as float32) stamped `timestamp_ns` (ns since the sender's epoch, ≥ 0). Throws
  /// std::invalid_argument when points.size() != point_count().
  void pack(std::int64_t timestamp_ns, std::span<const core::Vec3> points, std::string& out);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::size_t point_count_ = 0;
};

/// Packs a STATUS message: `code`, `subcode` (the sender's own detail code), `error_name` (≤ 20
/// characters, cut), `message` (any length), stamped `timestamp_ns`.
std::string pack_igtl_status(const std::string& device_name, std::int64_t timestamp_ns,
                             IgtlStatusCode code, std::int64_t subcode,
                             const std::string& error_name, const std::string& message);

/// Packs a STRING message (encoding 3, US-ASCII; ≤ 65535 bytes, cut), stamped `timestamp_ns`.
std::string pack_igtl_string(const std::string& device_name, std::int64_t timestamp_ns,
                             const std::string& text);

/// Packs a POSITION message with the library (igtl::PositionMessage, header version 1): the
/// position `translation` (the sender's units) and the orientation `orientation` (OX OY OZ W)
/// as given, not normalised, so that a test can send a faulty one; `quaternion3`: the 24-byte
/// form that leaves W out (the receiver makes W = √(1 − |v|²) ≥ 0, so the vector part sent is
/// that of the representative with W ≥ 0; packed with the library's C codec, igtl_position.h:
/// 1.11's class writes 4 bytes past the body of this form), else the whole quaternion (28
/// bytes). Stamped `timestamp_ns` (as pack_igtl_transform()). For the replay server and tests.
/// Allocates.
std::string pack_igtl_position(const std::string& device_name, std::int64_t timestamp_ns,
                               const core::Quat& orientation, const core::Vec3& translation,
                               bool quaternion3 = false);

/// Packs a QTRANS message (28 bytes: X Y Z OX OY OZ W, the quaternion as given) with the
/// library's C codec (igtl_header.h, igtl_qtrans.h: libOpenIGTLink 1.11 has no C++ class for
/// QTRANS), header version 1, stamped `timestamp_ns`. For the replay server and tests.
/// Allocates.
std::string pack_igtl_qtrans(const std::string& device_name, std::int64_t timestamp_ns,
                             const core::Quat& orientation, const core::Vec3& translation);

/// A message read back (unpack_igtl()): the header's type, device name and timestamp, and the
/// body's content by type (TRANSFORM: rotation and translation; POLYDATA: points,
/// triangles (polygons of three points only) and lines (polylines, point indices); STATUS: code,
/// subcode, error name, message; STRING: text in `text`).
struct IgtlUnpacked {
  std::string type;
  std::string device_name;
  std::int64_t timestamp_ns = 0;
  core::Mat3 rotation = core::Mat3::Identity();
  core::Vec3 translation = core::Vec3::Zero();
  std::vector<core::Vec3> points;
  std::vector<std::array<std::uint32_t, 3>> triangles;
  std::vector<std::vector<std::uint32_t>> lines;  ///< POLYDATA's LINES cells, each a polyline.
  std::uint16_t status_code = 0;
  std::int64_t status_subcode = 0;
  std::string error_name;
  std::string text;  ///< STATUS: its message; STRING: its string.
};

/// Reads one whole message `bytes` (header and body) of type TRANSFORM, POLYDATA, STATUS or
/// STRING with the library, the body's CRC-64 checked. Throws std::invalid_argument naming what
/// is wrong: short, another type, a CRC mismatch, a polygon that is not a triangle.
IgtlUnpacked unpack_igtl(std::span<const std::uint8_t> bytes);

}  // namespace numen::hal
