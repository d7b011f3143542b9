/// @file igtl_pack.cpp
/// POLYDATA, STATUS and STRING packed and read back through libOpenIGTLink (igtl_pack.hpp).

#include "numen/hal/igtl/igtl_pack.hpp"

#include <igtlMessageHeader.h>
#include <igtlPolyDataMessage.h>
#include <igtlPositionMessage.h>
#include <igtlStatusMessage.h>
#include <igtlStringMessage.h>
#include <igtlTransformMessage.h>
#include <igtl_header.h>
#include <igtl_polydata.h>
#include <igtl_position.h>
#include <igtl_qtrans.h>
#include <igtl_util.h>

#include <cstring>
#include <stdexcept>

#include "igtl_stamp.hpp"
#include "numen/hal/igtl/igtl_message.hpp"

namespace numen::hal {

namespace {

void check_device_name(const std::string& name, const char* what) {
  if (name.empty() || name.size() > 20)
    throw std::invalid_argument(std::string(what) + ": device name '" + name +
                                "' must have 1 to 20 characters (OpenIGTLink's header)");
}

std::string packed(igtl::MessageBase& m) {
  m.Pack();
  return std::string(static_cast<const char*>(m.GetPackPointer()),
                     static_cast<std::size_t>(m.GetPackSize()));
}

}  // namespace

struct IgtlPolyDataPacker::Impl {
  igtl::PolyDataMessage::Pointer message = igtl::PolyDataMessage::New();
  igtl::PolyDataPointArray::Pointer points = igtl::PolyDataPointArray::New();
  igtl::PolyDataCellArray::Pointer polygons = igtl::PolyDataCellArray::New();
  igtl::PolyDataCellArray::Pointer lines = igtl::PolyDataCellArray::New();
};

namespace {

// Checks `lines` against `point_count` for POLYDATA `name`: each of 2 points or more, in range.
void check_lines(const std::string& name, std::size_t point_count,
                 std::span<const std::vector<std::uint32_t>> lines) {
  for (std::size_t l = 0; l < lines.size(); ++l) {
    if (lines[l].size() < 2)
      throw std::invalid_argument("POLYDATA '" + name + "': line " + std::to_string(l) + " has " +
                                  std::to_string(lines[l].size()) + " points, fewer than 2");
    for (std::uint32_t k : lines[l])
      if (k >= point_count)
        throw std::invalid_argument("POLYDATA '" + name + "': line " + std::to_string(l) +
                                    " has point " + std::to_string(k) + " of " +
                                    std::to_string(point_count));
  }
}

}  // namespace

IgtlPolyDataPacker::IgtlPolyDataPacker(const std::string& device_name, std::size_t point_count,
                                       std::span<const std::array<std::uint32_t, 3>> triangles,
                                       std::span<const std::vector<std::uint32_t>> lines)
    : impl_(std::make_unique<Impl>()), point_count_(point_count) {
  check_device_name(device_name, "POLYDATA");
  if (point_count == 0) throw std::invalid_argument("POLYDATA '" + device_name + "': no point");
  for (std::size_t t = 0; t < triangles.size(); ++t)
    for (std::uint32_t k : triangles[t])
      if (k >= point_count)
        throw std::invalid_argument("POLYDATA '" + device_name + "': triangle " +
                                    std::to_string(t) + " has point " + std::to_string(k) +
                                    " of " + std::to_string(point_count));
  impl_->points->SetNumberOfPoints(static_cast<int>(point_count));
  for (const std::array<std::uint32_t, 3>& t : triangles) {
    std::array<igtlUint32, 3> cell{t[0], t[1], t[2]};
    impl_->polygons->AddCell(3, cell.data());
  }
  impl_->message->SetDeviceName(device_name.c_str());
  impl_->message->SetPoints(impl_->points);
  impl_->message->SetPolygons(impl_->polygons);
  if (!lines.empty()) {
    set_lines(lines);
    impl_->message->SetLines(impl_->lines);
  }
}

void IgtlPolyDataPacker::set_lines(std::span<const std::vector<std::uint32_t>> lines) {
  check_lines(impl_->message->GetDeviceName(), point_count_, lines);
  impl_->lines->Clear();
  for (const std::vector<std::uint32_t>& l : lines) {
    std::vector<igtlUint32> cell(l.begin(), l.end());
    impl_->lines->AddCell(static_cast<int>(cell.size()), cell.data());
  }
  impl_->message->SetLines(impl_->lines);
}

IgtlPolyDataPacker::~IgtlPolyDataPacker() = default;

void IgtlPolyDataPacker::pack(std::int64_t timestamp_ns, std::span<const core::Vec3> points,
                              std::string& out) {
  if (points.size() != point_count_)
    throw std::invalid_argument("POLYDATA: " + std::to_string(points.size()) + " points, not " +
                                std::to_string(point_count_));
  for (std::size_t i = 0; i < points.size(); ++i)
    impl_->points->SetPoint(static_cast<unsigned int>(i), static_cast<igtlFloat32>(points[i].x()),
                            static_cast<igtlFloat32>(points[i].y()),
                            static_cast<igtlFloat32>(points[i].z()));
  igtl_set_stamp_ns(*impl_->message, timestamp_ns);
  impl_->message->Pack();
  out.append(static_cast<const char*>(impl_->message->GetPackPointer()),
             static_cast<std::size_t>(impl_->message->GetPackSize()));
}

std::string pack_igtl_status(const std::string& device_name, std::int64_t timestamp_ns,
                             IgtlStatusCode code, std::int64_t subcode,
                             const std::string& error_name, const std::string& message) {
  check_device_name(device_name, "STATUS");
  igtl::StatusMessage::Pointer m = igtl::StatusMessage::New();
  m->SetDeviceName(device_name.c_str());
  m->SetCode(static_cast<int>(code));
  m->SetSubCode(subcode);
  m->SetErrorName(error_name.substr(0, 20).c_str());
  m->SetStatusString(message.c_str());
  igtl_set_stamp_ns(*m, timestamp_ns);
  return packed(*m);
}

std::string pack_igtl_string(const std::string& device_name, std::int64_t timestamp_ns,
                             const std::string& text) {
  check_device_name(device_name, "STRING");
  igtl::StringMessage::Pointer m = igtl::StringMessage::New();
  m->SetDeviceName(device_name.c_str());
  m->SetEncoding(IGTL_STRING_MESSAGE_DEFAULT_ENCODING);
  m->SetString(text.substr(0, 65535).c_str());
  igtl_set_stamp_ns(*m, timestamp_ns);
  return packed(*m);
}

namespace {

// A message whose body `body` (n bytes, in network byte order) is packed by the caller with the
// library's C codec: the header made with it too (version 1, the CRC-64 of the body).
std::string igtl_c_message(const char* type, const std::string& device_name,
                           std::int64_t timestamp_ns, const void* body, std::size_t n) {
  igtl_header h{};
  h.version = IGTL_HEADER_VERSION;
  std::memcpy(h.name, type, std::strlen(type));                      // <= 12, NUL padded
  std::memcpy(h.device_name, device_name.data(), device_name.size());  // <= 20, NUL padded
  h.timestamp = igtl_stamp_raw(timestamp_ns);
  h.body_size = n;
  h.crc = crc64(static_cast<unsigned char*>(const_cast<void*>(body)), n, 0);
  igtl_header_convert_byte_order(&h);
  std::string out(reinterpret_cast<const char*>(&h), sizeof h);
  out.append(static_cast<const char*>(body), n);
  return out;
}

}  // namespace

std::string pack_igtl_position(const std::string& device_name, std::int64_t timestamp_ns,
                               const core::Quat& orientation, const core::Vec3& translation,
                               bool quaternion3) {
  check_device_name(device_name, "POSITION");
  if (quaternion3) {
    // The library's C codec: libOpenIGTLink 1.11's igtl::PositionMessage packs this form with
    // the 28-byte byte-order conversion, writing 4 bytes past its 24-byte body (valgrind).
    core::Quat q = orientation;
    if (q.w() < 0.0) q.coeffs() = -q.coeffs();  // the receiver makes W >= 0
    igtl_position body{};
    for (int i = 0; i < 3; ++i) body.position[i] = static_cast<igtl_float32>(translation(i));
    body.quaternion[0] = static_cast<igtl_float32>(q.x());
    body.quaternion[1] = static_cast<igtl_float32>(q.y());
    body.quaternion[2] = static_cast<igtl_float32>(q.z());
    igtl_position_convert_byte_order_quaternion3(&body);
    return igtl_c_message("POSITION", device_name, timestamp_ns, &body,
                          IGTL_POSITION_MESSAGE_WITH_QUATERNION3_SIZE);
  }
  igtl::PositionMessage::Pointer m = igtl::PositionMessage::New();
  m->SetDeviceName(device_name.c_str());
  m->SetPackType(igtl::PositionMessage::ALL);
  m->SetPosition(static_cast<float>(translation.x()), static_cast<float>(translation.y()),
                 static_cast<float>(translation.z()));
  m->SetQuaternion(static_cast<float>(orientation.x()), static_cast<float>(orientation.y()),
                   static_cast<float>(orientation.z()), static_cast<float>(orientation.w()));
  igtl_set_stamp_ns(*m, timestamp_ns);
  return packed(*m);
}

std::string pack_igtl_qtrans(const std::string& device_name, std::int64_t timestamp_ns,
                             const core::Quat& orientation, const core::Vec3& translation) {
  check_device_name(device_name, "QTRANS");
  igtl_qtrans body{};
  for (int i = 0; i < 3; ++i) body.qtrans[i] = static_cast<igtl_float32>(translation(i));
  body.quaternion[0] = static_cast<igtl_float32>(orientation.x());
  body.quaternion[1] = static_cast<igtl_float32>(orientation.y());
  body.quaternion[2] = static_cast<igtl_float32>(orientation.z());
  body.quaternion[3] = static_cast<igtl_float32>(orientation.w());
  igtl_qtrans_convert_byte_order(&body);  // to network order; the CRC is of the bytes sent
  return igtl_c_message("QTRANS", device_name, timestamp_ns, &body, sizeof body);
}

namespace {

// Unpacks `m` (whose header is `header`) from `body`, checking the body's CRC-64.
void unpack_body(igtl::MessageBase& m, const igtl::MessageHeader::Pointer& header,
                 std::span<const std::uint8_t> body, const std::string& what) {
  m.SetMessageHeader(header);
  m.AllocatePack();
  if (static_cast<std::size_t>(m.GetPackBodySize()) != body.size())
    throw std::invalid_argument(what + ": body of " + std::to_string(body.size()) +
                                " bytes, the header says " + std::to_string(m.GetPackBodySize()));
  std::memcpy(m.GetPackBodyPointer(), body.data(), body.size());
  if ((m.Unpack(1) & igtl::MessageHeader::UNPACK_BODY) == 0)
    throw std::invalid_argument(what + ": CRC mismatch or a body that does not unpack");
}

}  // namespace

IgtlUnpacked unpack_igtl(std::span<const std::uint8_t> bytes) {
  if (bytes.size() < kIgtlHeaderBytes)
    throw std::invalid_argument("OpenIGTLink message of " + std::to_string(bytes.size()) +
                                " bytes: shorter than its header");
  igtl::MessageHeader::Pointer header = igtl::MessageHeader::New();
  header->InitPack();
  std::memcpy(header->GetPackPointer(), bytes.data(), kIgtlHeaderBytes);
  header->Unpack();
  IgtlUnpacked out;
  out.type = header->GetDeviceType();
  out.device_name = header->GetDeviceName();
  unsigned int sec = 0, frac = 0;
  header->GetTimeStamp(&sec, &frac);
  out.timestamp_ns = igtl_stamp_ns((static_cast<std::uint64_t>(sec) << 32) | frac);
  const std::span<const std::uint8_t> body = bytes.subspan(kIgtlHeaderBytes);
  const std::string what = out.type + " '" + out.device_name + "'";
  if (out.type == "TRANSFORM") {
    igtl::TransformMessage::Pointer m = igtl::TransformMessage::New();
    unpack_body(*m, header, body, what);
    igtl::Matrix4x4 mat;
    m->GetMatrix(mat);
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) out.rotation(r, c) = mat[r][c];
      out.translation(r) = mat[r][3];
    }
  } else if (out.type == "POLYDATA") {
    // The library's C codec, not igtl::PolyDataMessage::Unpack(): libOpenIGTLink 1.11's
    // UnpackBody() never frees the arrays igtl_polydata_unpack() allocates (a leak per message;
    // its PackBody() frees them). The body's CRC-64 is checked first, as Unpack(1) does.
    std::uint64_t crc = 0;
    for (int i = 0; i < 8; ++i) crc = (crc << 8) | bytes[kIgtlCrcOffset + static_cast<std::size_t>(i)];
    std::vector<unsigned char> copy(body.begin(), body.end());  // unpacked in place
    if (crc64(copy.data(), copy.size(), 0) != crc)
      throw std::invalid_argument(what + ": CRC mismatch or a body that does not unpack");
    igtl_polydata_info info;
    igtl_polydata_init_info(&info);
    if (igtl_polydata_unpack(IGTL_TYPE_PREFIX_NONE, copy.data(), &info, copy.size()) == 0) {
      igtl_polydata_free_info(&info);
      throw std::invalid_argument(what + ": a body that does not unpack");
    }
    out.points.resize(info.header.npoints);
    for (std::size_t i = 0; i < out.points.size(); ++i)
      out.points[i] = core::Vec3(info.points[3 * i], info.points[3 * i + 1], info.points[3 * i + 2]);
    const igtlUint32* cell = info.polygons;
    std::string bad;
    for (igtlUint32 t = 0; t < info.header.npolygons && bad.empty(); ++t) {
      if (cell[0] != 3) {
        bad = what + ": polygon " + std::to_string(t) + " has " + std::to_string(cell[0]) +
              " points, not 3";
        break;
      }
      out.triangles.push_back({cell[1], cell[2], cell[3]});
      cell += 4;
    }
    // LINES: each cell its point count n, then n indices (size_lines bytes in all).
    const igtlUint32* line = info.lines;
    const igtlUint32* end = info.lines + info.header.size_lines / sizeof(igtlUint32);
    for (igtlUint32 l = 0; l < info.header.nlines && bad.empty() && line != nullptr; ++l) {
      if (line >= end || line + 1 + *line > end) {
        bad = what + ": line " + std::to_string(l) + " runs past the lines' data";
        break;
      }
      out.lines.emplace_back(line + 1, line + 1 + *line);
      line += 1 + *line;
    }
    igtl_polydata_free_info(&info);
    if (!bad.empty()) throw std::invalid_argument(bad);
  } else if (out.type == "STATUS") {
    igtl::StatusMessage::Pointer m = igtl::StatusMessage::New();
    unpack_body(*m, header, body, what);
    out.status_code = static_cast<std::uint16_t>(m->GetCode());
    out.status_subcode = m->GetSubCode();
    out.error_name = m->GetErrorName();
    out.text = m->GetStatusString();
  } else if (out.type == "STRING") {
    igtl::StringMessage::Pointer m = igtl::StringMessage::New();
    unpack_body(*m, header, body, what);
    out.text = m->GetString();
  } else {
    throw std::invalid_argument(what + ": not a TRANSFORM, POLYDATA, STATUS or STRING message");
  }
  return out;
}

}  // namespace numen::hal
