// Tests of numen/hal/transport/can_frame.hpp: identifier and length rules of classic and FD frames.
#include "numen/hal/transport/can_frame.hpp"

#include <gtest/gtest.h>

namespace {

using numen::hal::CanFlag;
using numen::hal::CanFrame;
using numen::hal::check_frame;
using numen::hal::FrameError;

TEST(CanFrame, DefaultIsAnEmptyStandardDataFrame) {
  const CanFrame f;
  EXPECT_EQ(f.id, 0u);
  EXPECT_EQ(f.len, 0);
  EXPECT_FALSE(f.extended());
  EXPECT_FALSE(f.fd());
  EXPECT_EQ(check_frame(f), FrameError::kNone);
  EXPECT_EQ(sizeof(CanFrame), 80u);
}

// Frame acceptance (can_frame.hpp): which frames are "on" an 11-bit COB-ID, and which of
// those are classic data frames.
TEST(CanFrame, AcceptanceOnAClassicElevenBitId) {
  CanFrame f;
  f.id = 0x181;
  f.len = 4;
  EXPECT_TRUE(numen::hal::is_standard_frame(f));
  EXPECT_TRUE(numen::hal::has_standard_id(f, 0x181));
  EXPECT_FALSE(numen::hal::has_standard_id(f, 0x182));
  EXPECT_TRUE(numen::hal::is_classic_data_frame(f));
  EXPECT_TRUE(numen::hal::matches_classic_id(f, 0x181));
  EXPECT_FALSE(numen::hal::matches_classic_id(f, 0x182));
  // Remote and FD frames are on the identifier but are not classic data frames.
  for (std::uint8_t flags : {CanFlag::kRemote, CanFlag::kFd,
                             static_cast<std::uint8_t>(CanFlag::kFd | CanFlag::kBitRateSwitch)}) {
    f.flags = flags;
    EXPECT_TRUE(numen::hal::has_standard_id(f, 0x181)) << int(flags);
    EXPECT_FALSE(numen::hal::is_classic_data_frame(f)) << int(flags);
    EXPECT_FALSE(numen::hal::matches_classic_id(f, 0x181)) << int(flags);
  }
  // 29-bit frames (classic or FD) and error reports are not on it, whatever their number.
  for (std::uint8_t flags : {CanFlag::kExtendedId, CanFlag::kErrorFrame,
                             static_cast<std::uint8_t>(CanFlag::kExtendedId | CanFlag::kFd)}) {
    f.flags = flags;
    EXPECT_FALSE(numen::hal::is_standard_frame(f)) << int(flags);
    EXPECT_FALSE(numen::hal::has_standard_id(f, 0x181)) << int(flags);
    EXPECT_FALSE(numen::hal::matches_classic_id(f, 0x181)) << int(flags);
  }
  static_assert(numen::hal::matches_classic_id(CanFrame{}, 0));  // usable in constant expressions
}

TEST(CanFrame, StandardIdIs11BitsExtendedIs29) {
  CanFrame f;
  f.id = 0x7FF;
  EXPECT_EQ(check_frame(f), FrameError::kNone);
  f.id = 0x800;
  EXPECT_EQ(check_frame(f), FrameError::kIdOutOfRange);
  f.flags = CanFlag::kExtendedId;
  EXPECT_EQ(check_frame(f), FrameError::kNone);
  f.id = 0x1FFFFFFF;
  EXPECT_EQ(check_frame(f), FrameError::kNone);
  f.id = 0x20000000;
  EXPECT_EQ(check_frame(f), FrameError::kIdOutOfRange);
}

TEST(CanFrame, ClassicLengthAtMost8) {
  CanFrame f;
  f.len = 8;
  EXPECT_EQ(check_frame(f), FrameError::kNone);
  f.len = 9;
  EXPECT_EQ(check_frame(f), FrameError::kLengthTooLong);
}

TEST(CanFrame, FdLengthsAreTheDlcSteps) {
  CanFrame f;
  f.flags = CanFlag::kFd | CanFlag::kBitRateSwitch;
  for (int len = 0; len <= 64; ++len) {
    f.len = static_cast<std::uint8_t>(len);
    const bool valid = len <= 8 || len == 12 || len == 16 || len == 20 || len == 24 || len == 32 ||
                       len == 48 || len == 64;
    EXPECT_EQ(check_frame(f) == FrameError::kNone, valid) << "len " << len;
    EXPECT_EQ(numen::hal::is_valid_fd_length(f.len), valid);
  }
}

TEST(CanFrame, FlagRules) {
  CanFrame f;
  f.flags = CanFlag::kFd | CanFlag::kRemote;
  EXPECT_EQ(check_frame(f), FrameError::kRemoteFd);
  f.flags = CanFlag::kBitRateSwitch;
  EXPECT_EQ(check_frame(f), FrameError::kFdFlagWithoutFd);
  f.flags = CanFlag::kErrorStateIndicator;
  EXPECT_EQ(check_frame(f), FrameError::kFdFlagWithoutFd);
  f.flags = CanFlag::kRemote;
  f.len = 4;  // requested length
  EXPECT_EQ(check_frame(f), FrameError::kNone);
  f.flags = CanFlag::kErrorFrame;
  f.id = 0x1FFFFFFF;
  f.len = 8;
  EXPECT_EQ(check_frame(f), FrameError::kNone);
}

TEST(CanFrame, DlcCodes) {
  using numen::hal::dlc_to_len;
  using numen::hal::len_to_dlc;
  EXPECT_EQ(dlc_to_len(8, false), 8);
  EXPECT_EQ(dlc_to_len(15, false), 8);
  EXPECT_EQ(dlc_to_len(9, true), 12);
  EXPECT_EQ(dlc_to_len(15, true), 64);
  for (std::uint8_t dlc = 0; dlc < 16; ++dlc) EXPECT_EQ(len_to_dlc(dlc_to_len(dlc, true)), dlc);
  EXPECT_EQ(len_to_dlc(13), 10);  // 13 bytes need the 16-byte code
}

TEST(CanFrame, ErrorNamesAreDistinct) {
  EXPECT_STRNE(to_string(FrameError::kNone), to_string(FrameError::kIdOutOfRange));
}

}  // namespace
