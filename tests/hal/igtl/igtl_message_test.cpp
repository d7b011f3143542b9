/// @file igtl_message_test.cpp
/// OpenIGTLink header and pose decoding (hal/igtl/igtl_message.hpp): a packed TRANSFORM,
/// POSITION or QTRANS reads back (packed by the library: igtl_pack.hpp for the last two), and
/// each malformed one is refused with its fault and the byte offset of its field.

#include "numen/hal/igtl/igtl_message.hpp"

#include <gtest/gtest.h>

#include "numen/hal/igtl/igtl_pack.hpp"

#include <cmath>
#include <cstring>
#include <limits>
#include <string>

namespace {

numen::core::Mat3 igtl_message_test_rotation() {
  return (numen::core::Quat(Eigen::AngleAxisd(0.7, numen::core::Vec3(1.0, 2.0, 3.0).normalized())))
      .toRotationMatrix();
}

numen::hal::IgtlDecodeResult igtl_message_test_decode(const std::string& bytes,
                                                      numen::hal::IgtlHeader& h,
                                                      numen::hal::IgtlTransform& tf) {
  numen::hal::IgtlDecoder decoder;
  return numen::hal::decode_igtl_message(
      decoder,
      std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size()),
      1 << 20, h, tf);
}

// Decodes `bytes` and expects `fault` located at `offset`.
void igtl_message_test_expect(const std::string& bytes, numen::hal::IgtlFault fault,
                              std::size_t offset) {
  numen::hal::IgtlHeader h;
  numen::hal::IgtlTransform tf;
  const numen::hal::IgtlDecodeResult res = igtl_message_test_decode(bytes, h, tf);
  EXPECT_EQ(res.fault, fault) << numen::hal::to_string(res.fault);
  EXPECT_EQ(res.byte_offset, offset);
}

// A good TRANSFORM of "Stylus" (each test breaks one thing of it).
std::string igtl_message_test_good() {
  return numen::hal::pack_igtl_transform("Stylus", 0, igtl_message_test_rotation(),
                                         numen::core::Vec3(1, 2, 3));
}

// Writes `v` big endian into the 8 bytes at `at`.
void igtl_message_test_put_u64(std::string& bytes, std::size_t at, std::uint64_t v) {
  for (int i = 7; i >= 0; --i, v >>= 8) bytes[at + static_cast<std::size_t>(i)] = static_cast<char>(v & 0xFF);
}

}  // namespace

TEST(IgtlMessage, APackedTransformReadsBack) {
  namespace hal = numen::hal;
  const numen::core::Mat3 r = igtl_message_test_rotation();
  const numen::core::Vec3 t(12.5, -300.25, 1500.0);  // mm
  const std::int64_t stamp = 1'764'000'000'123'456'789;
  const std::string m = hal::pack_igtl_transform("StylusToTracker", stamp, r, t);
  ASSERT_EQ(m.size(), hal::kIgtlHeaderBytes + hal::kIgtlTransformBodyBytes);
  hal::IgtlHeader h;
  hal::IgtlTransform tf;
  const hal::IgtlDecodeResult res = igtl_message_test_decode(m, h, tf);
  ASSERT_TRUE(res.ok()) << hal::to_string(res.fault) << " at " << res.byte_offset;
  EXPECT_EQ(h.type, "TRANSFORM");
  EXPECT_EQ(h.device_name, "StylusToTracker");
  EXPECT_EQ(h.body_size, hal::kIgtlTransformBodyBytes);
  EXPECT_EQ(hal::igtl_stamp_ns(h.timestamp_raw), stamp);  // the ns round trip is exact
  EXPECT_LT((tf.rotation - r).cwiseAbs().maxCoeff(), 1e-7);  // float32
  EXPECT_LT((tf.translation - t).cwiseAbs().maxCoeff(), 1e-4);
}

TEST(IgtlMessage, ACrcMismatchIsLocatedAtTheCrcField) {
  namespace hal = numen::hal;
  std::string m = igtl_message_test_good();
  m[hal::kIgtlHeaderBytes + 45] ^= 0x01;  // a bit of TZ
  igtl_message_test_expect(m, hal::IgtlFault::kCrcMismatch, hal::kIgtlCrcOffset);
}

TEST(IgtlMessage, ABodySizeThatLiesIsLocated) {
  namespace hal = numen::hal;
  const std::string good = igtl_message_test_good();
  std::string m = good;
  igtl_message_test_put_u64(m, hal::kIgtlBodySizeOffset, 40);  // a TRANSFORM is 48 bytes
  igtl_message_test_expect(m, hal::IgtlFault::kBodySizeMismatch, hal::kIgtlBodySizeOffset);
  // The header says 48 bytes, 20 follow: located where the body ends.
  igtl_message_test_expect(good.substr(0, hal::kIgtlHeaderBytes + 20),
                           hal::IgtlFault::kBodySizeMismatch, hal::kIgtlHeaderBytes + 20);
  // Above the receiver's limit.
  m = good;
  igtl_message_test_put_u64(m, hal::kIgtlBodySizeOffset, std::uint64_t{1} << 40);
  igtl_message_test_expect(m, hal::IgtlFault::kBodyTooLarge, hal::kIgtlBodySizeOffset);
}

TEST(IgtlMessage, AnUnknownTypeAndABadHeaderAreLocated) {
  namespace hal = numen::hal;
  const std::string good = igtl_message_test_good();
  std::string m = good;
  std::memcpy(m.data() + hal::kIgtlTypeOffset, "BOGUS\0\0\0\0\0\0\0", 12);
  igtl_message_test_expect(m, hal::IgtlFault::kUnknownType, hal::kIgtlTypeOffset);
  hal::IgtlHeader h;
  hal::IgtlTransform tf;
  igtl_message_test_decode(m, h, tf);
  EXPECT_EQ(h.type, "BOGUS");
  m = good;
  m[0] = 0x07;  // version 0x0701
  igtl_message_test_expect(m, hal::IgtlFault::kBadHeader, hal::kIgtlVersionOffset);
  m = good;
  m[hal::kIgtlTypeOffset] = '\x01';
  igtl_message_test_expect(m, hal::IgtlFault::kBadHeader, hal::kIgtlTypeOffset);
  igtl_message_test_expect(good.substr(0, 30), hal::IgtlFault::kBadHeader, 30);
  // A known type that is not a TRANSFORM decodes (the receiver skips it).
  EXPECT_TRUE(hal::igtl_known_type("STATUS"));
  EXPECT_TRUE(hal::igtl_known_type("GET_TRANSFORM"));
  EXPECT_FALSE(hal::igtl_known_type("BOGUS"));
}

TEST(IgtlMessage, ANanOrANonOrthonormalMatrixIsRefused) {
  namespace hal = numen::hal;
  const numen::core::Vec3 t(1, 2, 3);
  numen::core::Mat3 r = igtl_message_test_rotation();
  r(2, 1) = std::numeric_limits<double>::quiet_NaN();  // R32: the 6th float of the body
  igtl_message_test_expect(hal::pack_igtl_transform("Stylus", 0, r, t), hal::IgtlFault::kNonFinite,
                           hal::kIgtlHeaderBytes + 4 * 5);
  igtl_message_test_expect(
      hal::pack_igtl_transform("Stylus", 0, igtl_message_test_rotation(),
                               numen::core::Vec3(1, std::numeric_limits<double>::infinity(), 3)),
      hal::IgtlFault::kNonFinite, hal::kIgtlHeaderBytes + 4 * 10);  // TY
  igtl_message_test_expect(  // a scale
      hal::pack_igtl_transform("Stylus", 0, 1.01 * igtl_message_test_rotation(), t),
      hal::IgtlFault::kNotRigid, hal::kIgtlHeaderBytes);
  igtl_message_test_expect(  // a reflection
      hal::pack_igtl_transform("Stylus", 0, -igtl_message_test_rotation(), t),
      hal::IgtlFault::kNotRigid, hal::kIgtlHeaderBytes);
}

TEST(IgtlMessage, APositionAndAQtransReadBackAsTheTransformsPose) {
  namespace hal = numen::hal;
  const numen::core::Mat3 r = igtl_message_test_rotation();
  const numen::core::Quat q(r);
  const numen::core::Vec3 t(12.5, -300.25, 1500.0);  // mm
  const std::int64_t stamp = 1'764'000'000'123'456'789;
  struct Sent {
    std::string bytes;
    const char* type;
    std::size_t body;
  };
  const Sent sent[] = {
      {hal::pack_igtl_position("StylusToTracker", stamp, q, t), "POSITION",
       hal::kIgtlPositionBodyBytes},
      {hal::pack_igtl_position("StylusToTracker", stamp, numen::core::Quat(-q.coeffs()), t, true),
       "POSITION", hal::kIgtlPositionQuaternion3BodyBytes},  // W < 0 sent as its W >= 0 twin
      {hal::pack_igtl_qtrans("StylusToTracker", stamp, q, t), "QTRANS", hal::kIgtlQtransBodyBytes},
  };
  for (const Sent& m : sent) {
    ASSERT_EQ(m.bytes.size(), hal::kIgtlHeaderBytes + m.body) << m.type;
    hal::IgtlHeader h;
    hal::IgtlTransform tf;
    const hal::IgtlDecodeResult res = igtl_message_test_decode(m.bytes, h, tf);
    ASSERT_TRUE(res.ok()) << m.type << ": " << hal::to_string(res.fault) << " at "
                          << res.byte_offset;
    EXPECT_EQ(h.type, m.type);
    EXPECT_EQ(h.device_name, "StylusToTracker");
    EXPECT_EQ(hal::igtl_stamp_ns(h.timestamp_raw), stamp) << m.type;
    EXPECT_LT((tf.rotation - r).cwiseAbs().maxCoeff(), 1e-6) << m.type;  // float32 quaternion
    EXPECT_LT((tf.translation - t).cwiseAbs().maxCoeff(), 1e-4) << m.type;
    EXPECT_TRUE(hal::igtl_pose_type(h.type));
  }
  EXPECT_FALSE(hal::igtl_pose_type("STATUS"));
  EXPECT_FALSE(hal::igtl_pose_body_size_ok("POSITION", 12));  // a position only: no orientation
  EXPECT_FALSE(hal::igtl_pose_body_size_ok("QTRANS", 24));
}

TEST(IgtlMessage, ABadPositionOrQtransIsLocated) {
  namespace hal = numen::hal;
  const numen::core::Quat q(igtl_message_test_rotation());
  const numen::core::Vec3 t(1, 2, 3);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  constexpr std::size_t body = hal::kIgtlHeaderBytes;
  const numen::core::Quat scaled(1.01 * q.w(), 1.01 * q.x(), 1.01 * q.y(), 1.01 * q.z());
  // A quaternion of length 1.01: located at OX.
  igtl_message_test_expect(hal::pack_igtl_position("Stylus", 0, scaled, t),
                           hal::IgtlFault::kNotUnitQuaternion, body + 12);
  igtl_message_test_expect(hal::pack_igtl_qtrans("Stylus", 0, scaled, t),
                           hal::IgtlFault::kNotUnitQuaternion, body + 12);
  // 24 bytes whose vector part is longer than 1: no W makes it a unit quaternion (the library
  // answers the identity for it; the decoder does not take that).
  igtl_message_test_expect(
      hal::pack_igtl_position("Stylus", 0, numen::core::Quat(0.1, 0.8, 0.8, 0.0), t, true),
      hal::IgtlFault::kNotUnitQuaternion, body + 12);
  // NaN and infinity, each at its float: Y is the 2nd, W the 7th, OY the 5th.
  igtl_message_test_expect(hal::pack_igtl_position("Stylus", 0, q, numen::core::Vec3(1, nan, 3)),
                           hal::IgtlFault::kNonFinite, body + 4);
  igtl_message_test_expect(
      hal::pack_igtl_qtrans("Stylus", 0, numen::core::Quat(nan, q.x(), q.y(), q.z()), t),
      hal::IgtlFault::kNonFinite, body + 24);
  igtl_message_test_expect(
      hal::pack_igtl_position(
          "Stylus", 0,
          numen::core::Quat(q.w(), q.x(), std::numeric_limits<double>::infinity(), q.z()), t, true),
      hal::IgtlFault::kNonFinite, body + 16);
  // A CRC that is not the body's; a body size that is not the type's.
  std::string m = hal::pack_igtl_qtrans("Stylus", 0, q, t);
  m[body + 27] ^= 0x01;  // a bit of W
  igtl_message_test_expect(m, hal::IgtlFault::kCrcMismatch, hal::kIgtlCrcOffset);
  m = hal::pack_igtl_position("Stylus", 0, q, t);
  m[body + 3] ^= 0x01;  // a bit of X
  igtl_message_test_expect(m, hal::IgtlFault::kCrcMismatch, hal::kIgtlCrcOffset);
  m = hal::pack_igtl_qtrans("Stylus", 0, q, t);
  igtl_message_test_put_u64(m, hal::kIgtlBodySizeOffset, 24);
  igtl_message_test_expect(m.substr(0, body + 24), hal::IgtlFault::kBodySizeMismatch,
                           hal::kIgtlBodySizeOffset);
  m = hal::pack_igtl_position("Stylus", 0, q, t);
  igtl_message_test_put_u64(m, hal::kIgtlBodySizeOffset, 12);  // a position only
  igtl_message_test_expect(m.substr(0, body + 12), hal::IgtlFault::kBodySizeMismatch,
                           hal::kIgtlBodySizeOffset);
  // The header says 28 bytes, 20 follow: located where the body ends.
  igtl_message_test_expect(hal::pack_igtl_position("Stylus", 0, q, t).substr(0, body + 20),
                           hal::IgtlFault::kBodySizeMismatch, body + 20);
}

TEST(IgtlMessage, AHeaderOfVersion2IsNotReadAndSaysSo) {
  namespace hal = numen::hal;
  // OpenIGTLink 3's header version 2 opens the body with an extended header that
  // libOpenIGTLink 1.11 cannot read. The decoder is reused as the receiver's is: a 24-byte
  // POSITION first (the library keeps that form), then 28-byte bodies under a version-2 header
  // (the fuzz finding: the library sized the body from the previous form, 24 bytes, and the
  // copy of 28 ran past it).
  const numen::core::Quat q(igtl_message_test_rotation());
  const numen::core::Vec3 t(1, 2, 3);
  hal::IgtlDecoder decoder;
  hal::IgtlHeader h;
  hal::IgtlTransform tf;
  const auto decode = [&](const std::string& m) {
    return hal::decode_igtl_message(
        decoder,
        std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(m.data()), m.size()),
        1 << 20, h, tf);
  };
  ASSERT_TRUE(decode(hal::pack_igtl_position("Stylus", 0, q, t, true)).ok());
  for (std::string m : {hal::pack_igtl_position("Stylus", 0, q, t),
                        hal::pack_igtl_qtrans("Stylus", 0, q, t), igtl_message_test_good()}) {
    m[1] = 2;  // version 2
    const hal::IgtlDecodeResult r = decode(m);
    EXPECT_EQ(r.fault, hal::IgtlFault::kUnsupportedVersion)
        << h.type << ": " << hal::to_string(r.fault);
    EXPECT_EQ(r.byte_offset, hal::kIgtlVersionOffset) << h.type;
  }
  EXPECT_STREQ(hal::to_string(hal::IgtlFault::kUnsupportedVersion), "unsupported header version");
  // The same messages with header version 1 still read.
  EXPECT_TRUE(decode(hal::pack_igtl_position("Stylus", 0, q, t)).ok());
  EXPECT_TRUE(decode(hal::pack_igtl_position("Stylus", 0, q, t, true)).ok());
  EXPECT_TRUE(decode(igtl_message_test_good()).ok());
}
