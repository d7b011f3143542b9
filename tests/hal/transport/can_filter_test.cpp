#include "numen/hal/transport/can_filter.hpp"

#include <gtest/gtest.h>

#include <array>

namespace numen::hal {
namespace {

CanFrame frame_with(std::uint32_t id, std::uint8_t flags) {
  CanFrame f;
  f.id = id;
  f.flags = flags;
  return f;
}

TEST(CanFilter, ExactStandardFilterPassesOnlyThatDataFrame) {
  const CanFilter f = exact_standard_filter(0x181);
  EXPECT_TRUE(matches(f, frame_with(0x181, 0)));
  EXPECT_FALSE(matches(f, frame_with(0x182, 0)));
  EXPECT_FALSE(matches(f, frame_with(0x181, CanFlag::kRemote)));
  EXPECT_FALSE(matches(f, frame_with(0x181, CanFlag::kExtendedId)));
}

// An encoder's COB-ID passes whole: its remote request and the 29-bit frame of its number reach
// the controller, which counts them (rejected, unknown id); nothing else does.
TEST(CanFilter, StandardAndExtendedIdFiltersPassEveryKindOfThatNumber) {
  const CanFilter s = standard_id_filter(0x181);
  EXPECT_TRUE(matches(s, frame_with(0x181, 0)));
  EXPECT_TRUE(matches(s, frame_with(0x181, CanFlag::kRemote)));
  EXPECT_TRUE(matches(s, frame_with(0x181, CanFlag::kFd)));
  EXPECT_FALSE(matches(s, frame_with(0x181, CanFlag::kExtendedId)));
  EXPECT_FALSE(matches(s, frame_with(0x182, CanFlag::kRemote)));
  const CanFilter x = extended_id_filter(0x181);
  EXPECT_TRUE(matches(x, frame_with(0x181, CanFlag::kExtendedId)));
  EXPECT_TRUE(matches(x, frame_with(0x181, CanFlag::kExtendedId | CanFlag::kRemote)));
  EXPECT_FALSE(matches(x, frame_with(0x181, 0)));
  EXPECT_FALSE(matches(x, frame_with(0x12345181, CanFlag::kExtendedId)));  // not the low bits only
}

TEST(CanFilter, MaskSelectsARange) {
  // 0x180-0x1FF: all TPDO1 of every node.
  const CanFilter f{0x180, 0x780};
  EXPECT_TRUE(matches(f, frame_with(0x180, 0)));
  EXPECT_TRUE(matches(f, frame_with(0x1FF, 0)));
  EXPECT_FALSE(matches(f, frame_with(0x200, 0)));
  // The mask leaves the extended bit free: a 29-bit id with the same low bits passes.
  EXPECT_TRUE(matches(f, frame_with(0x181, CanFlag::kExtendedId)));
}

TEST(CanFilter, ListPassesOnAnyMatchEmptyListPassesAllErrorsAlwaysPass) {
  const std::array<CanFilter, 2> list{exact_standard_filter(0x181), exact_standard_filter(0x701)};
  EXPECT_TRUE(passes(list, frame_with(0x701, 0)));
  EXPECT_FALSE(passes(list, frame_with(0x080, 0)));
  EXPECT_TRUE(passes({}, frame_with(0x080, 0)));
  EXPECT_TRUE(passes(list, frame_with(0x004, CanFlag::kErrorFrame)));
}

}  // namespace
}  // namespace numen::hal
