/// @file igtl_pack_test.cpp
/// POLYDATA, STATUS and STRING packed by numen (hal/igtl/igtl_pack.hpp) read back through the
/// library's classes with the CRC checked: what was packed comes back (points as float32, the
/// timestamp to the ns); a corrupted body, a bad triangle or a wrong point count is refused.

#include "numen/hal/igtl/igtl_pack.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

std::span<const std::uint8_t> igtl_pack_test_bytes(const std::string& m) {
  return {reinterpret_cast<const std::uint8_t*>(m.data()), m.size()};
}

}  // namespace

TEST(IgtlPack, APolyDataReadsBackWithItsPointsTrianglesAndTime) {
  const std::vector<std::array<std::uint32_t, 3>> triangles{{0, 1, 2}, {0, 2, 3}, {0, 3, 1}, {1, 3, 2}};
  numen::hal::IgtlPolyDataPacker packer("organ", 4, triangles);
  std::string out = "prefix";
  const std::vector<numen::core::Vec3> first{{0, 0, 0}, {10, 0, 0}, {0, 10, 0}, {0, 0, 10}};
  const std::vector<numen::core::Vec3> second{{1, 2, 3}, {11.5, 0, 0}, {0, 10.25, 0}, {0, 0, -7}};
  packer.pack(1'234'567'891, first, out);
  const std::size_t one = out.size() - 6;
  packer.pack(2'000'000'001, second, out);  // the same packer: only the points and time change
  ASSERT_EQ(out.substr(0, 6), "prefix");
  ASSERT_EQ(out.size(), 6 + 2 * one);
  for (int k = 0; k < 2; ++k) {
    const numen::hal::IgtlUnpacked u =
        numen::hal::unpack_igtl(igtl_pack_test_bytes(out.substr(6 + k * one, one)));
    EXPECT_EQ(u.type, "POLYDATA");
    EXPECT_EQ(u.device_name, "organ");
    EXPECT_EQ(u.timestamp_ns, k == 0 ? 1'234'567'891 : 2'000'000'001);
    const auto& want = k == 0 ? first : second;
    ASSERT_EQ(u.points.size(), 4u);
    for (std::size_t i = 0; i < 4; ++i) EXPECT_EQ(u.points[i], want[i]) << i;  // exact in float32
    EXPECT_EQ(u.triangles, triangles);
  }
}

TEST(IgtlPack, AStatusAndAStringReadBack) {
  const numen::hal::IgtlUnpacked s = numen::hal::unpack_igtl(igtl_pack_test_bytes(
      numen::hal::pack_igtl_status("numen", 5'000'000'000, numen::hal::IgtlStatusCode::kPanicMode,
                                   12, "encoder timeout", "the device latched its safe state")));
  EXPECT_EQ(s.type, "STATUS");
  EXPECT_EQ(s.device_name, "numen");
  EXPECT_EQ(s.timestamp_ns, 5'000'000'000);
  EXPECT_EQ(s.status_code, 3);
  EXPECT_EQ(s.status_subcode, 12);
  EXPECT_EQ(s.error_name, "encoder timeout");
  EXPECT_EQ(s.text, "the device latched its safe state");
  const numen::hal::IgtlUnpacked t = numen::hal::unpack_igtl(
      igtl_pack_test_bytes(numen::hal::pack_igtl_string("numen_events", 7, "the device holds 'stylus'")));
  EXPECT_EQ(t.type, "STRING");
  EXPECT_EQ(t.timestamp_ns, 7);
  EXPECT_EQ(t.text, "the device holds 'stylus'");
}

TEST(IgtlPack, BadInputIsRefusedNamingIt) {
  const std::vector<std::array<std::uint32_t, 3>> bad{{0, 1, 3}};
  EXPECT_THROW(numen::hal::IgtlPolyDataPacker("organ", 3, bad), std::invalid_argument);
  EXPECT_THROW(numen::hal::IgtlPolyDataPacker("a_name_of_21_letters_", 3, {}), std::invalid_argument);
  numen::hal::IgtlPolyDataPacker packer("organ", 3, {});
  std::string out;
  const std::vector<numen::core::Vec3> two{{0, 0, 0}, {1, 0, 0}};
  EXPECT_THROW(packer.pack(0, two, out), std::invalid_argument);
  std::string status = numen::hal::pack_igtl_status("numen", 0, numen::hal::IgtlStatusCode::kOk, 0,
                                                    "ok", "all is well");
  status[status.size() - 3] ^= 0x20;  // the body no longer has the header's CRC-64
  try {
    (void)numen::hal::unpack_igtl(igtl_pack_test_bytes(status));
    ADD_FAILURE() << "a corrupted STATUS was read";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("STATUS 'numen': CRC mismatch"), std::string::npos) << e.what();
  }
  EXPECT_THROW((void)numen::hal::unpack_igtl(igtl_pack_test_bytes("short")), std::invalid_argument);
}
