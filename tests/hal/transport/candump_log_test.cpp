// Tests of numen/hal/transport/candump_log.hpp: exact candump lines, format/parse round trips, every
// parse error with its column, the file loader's skipping rules and error locations.
#include "numen/hal/transport/candump_log.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <vector>

#include "alloc_counter.hpp"
#include "numen/hal/transport/splitmix64.hpp"
#include "temp_dir.hpp"

namespace {

using numen::hal::CandumpDirection;
using numen::hal::CandumpError;
using numen::hal::CandumpFormatError;
using numen::hal::CandumpIface;
using numen::hal::CandumpParseResult;
using numen::hal::CandumpRecord;
using numen::hal::CanFlag;
using numen::hal::CanFrame;
using numen::hal::format_candump_line;
using numen::hal::kCandumpLineBufferSize;
using numen::hal::kCandumpMaxLineLength;
using numen::hal::make_candump_iface;
using numen::hal::parse_candump_line;

CanFrame make_frame(std::uint32_t id, std::uint8_t flags, std::vector<std::uint8_t> bytes) {
  CanFrame f;
  f.id = id;
  f.flags = flags;
  f.len = static_cast<std::uint8_t>(bytes.size());
  for (std::size_t i = 0; i < bytes.size(); ++i) f.data[i] = bytes[i];
  return f;
}

std::string format(std::int64_t t_ns, const char* iface, const CanFrame& frame,
                   CandumpDirection dir = CandumpDirection::kUnmarked) {
  std::array<char, kCandumpLineBufferSize> buf{};
  const auto r = format_candump_line(t_ns, make_candump_iface(iface), frame, dir, buf);
  EXPECT_TRUE(r.ok()) << to_string(r.error);
  if (!r.ok()) return {};
  EXPECT_EQ(buf[r.length], '\0');
  return std::string(buf.data(), r.length);
}

CandumpRecord parse_ok(const std::string& line) {
  CandumpRecord rec;
  const CandumpParseResult r = parse_candump_line(line, rec);
  EXPECT_TRUE(r.ok()) << line << ": column " << r.column << ": " << to_string(r.error);
  return rec;
}

void expect_same_frame(const CanFrame& a, const CanFrame& b) {
  EXPECT_EQ(a.id, b.id);
  EXPECT_EQ(a.flags, b.flags);
  ASSERT_EQ(a.len, b.len);
  for (std::size_t i = 0; i < a.len; ++i) EXPECT_EQ(a.data[i], b.data[i]) << "byte " << i;
}

// --- exact strings against candump output ------------------------------------------------

TEST(CandumpLog, ClassicFrameMatchesCandumpLine) {
  const std::string line = "(1436509052.249713) vcan0 123#DEADBEEF";
  const CanFrame f = make_frame(0x123, 0, {0xDE, 0xAD, 0xBE, 0xEF});
  EXPECT_EQ(format(1436509052249713000, "vcan0", f), line);
  const CandumpRecord rec = parse_ok(line);
  EXPECT_EQ(rec.timestamp_ns, 1436509052249713000);
  EXPECT_EQ(rec.frame.timestamp_ns, 1436509052249713000);
  EXPECT_EQ(rec.iface.view(), "vcan0");
  EXPECT_EQ(rec.direction, CandumpDirection::kUnmarked);
  expect_same_frame(rec.frame, f);
}

TEST(CandumpLog, ExtendedEmptyFrameAndUnpaddedSeconds) {
  // candump pads seconds to 10 digits; shorter input (other tools, hand-written) is read.
  const CandumpRecord rec = parse_ok("(0.000000) can0 12345678#");
  EXPECT_EQ(rec.timestamp_ns, 0);
  expect_same_frame(rec.frame, make_frame(0x12345678, CanFlag::kExtendedId, {}));
  EXPECT_EQ(format(0, "can0", rec.frame), "(0000000000.000000) can0 12345678#");
  // An extended id below 0x800 keeps its 8 digits (the IDE bit is in the digit count).
  EXPECT_EQ(format(0, "can0", make_frame(0x80, CanFlag::kExtendedId, {1})),
            "(0000000000.000000) can0 00000080#01");
}

TEST(CandumpLog, FdFramesWithFlagsNibble) {
  const CandumpRecord brs = parse_ok("(1.000001) can1 123##1AABB");
  EXPECT_EQ(brs.timestamp_ns, 1'000'001'000);
  expect_same_frame(brs.frame,
                    make_frame(0x123, CanFlag::kFd | CanFlag::kBitRateSwitch, {0xAA, 0xBB}));
  EXPECT_EQ(format(1'000'001'000, "can1", brs.frame), "(0000000001.000001) can1 123##1AABB");

  const CanFrame esi = make_frame(0x123, CanFlag::kFd | CanFlag::kErrorStateIndicator, {0x11});
  EXPECT_EQ(format(0, "can1", esi), "(0000000000.000000) can1 123##211");
  const CanFrame both = make_frame(
      0x1FFFFFFF,
      CanFlag::kExtendedId | CanFlag::kFd | CanFlag::kBitRateSwitch | CanFlag::kErrorStateIndicator,
      {});
  EXPECT_EQ(format(0, "can1", both), "(0000000000.000000) can1 1FFFFFFF##3");
  EXPECT_EQ(format(0, "can1", make_frame(0x7FF, CanFlag::kFd, {})),
            "(0000000000.000000) can1 7FF##0");
  // FDF (0x4, set by newer kernels and printed by newer candump) is implied by '##'.
  expect_same_frame(parse_ok("(1.000000) can1 123##5AABB").frame, brs.frame);
}

TEST(CandumpLog, RemoteRequestsWithAndWithoutLength) {
  const CandumpRecord r0 = parse_ok("(1.000000) can0 123#R");
  expect_same_frame(r0.frame, make_frame(0x123, CanFlag::kRemote, {}));
  const CandumpRecord r7 = parse_ok("(1.000000) can0 123#R7");
  EXPECT_EQ(r7.frame.len, 7);
  EXPECT_EQ(r7.frame.flags, CanFlag::kRemote);
  EXPECT_EQ(parse_ok("(1.000000) can0 123#r0").frame.len, 0);  // lower case, explicit 0

  CanFrame ext_rtr;
  ext_rtr.id = 0x1ABCDEF0;
  ext_rtr.flags = CanFlag::kExtendedId | CanFlag::kRemote;
  ext_rtr.len = 8;
  EXPECT_EQ(format(0, "can0", ext_rtr), "(0000000000.000000) can0 1ABCDEF0#R8");
  ext_rtr.len = 0;
  EXPECT_EQ(format(0, "can0", ext_rtr), "(0000000000.000000) can0 1ABCDEF0#R");
}

TEST(CandumpLog, ErrorFramesCarryTheErrorFlagInTheId) {
  // CAN_ERR_CRTL (0x004) with CAN_ERR_CRTL_RX_WARNING (0x04) in data[1] (linux/can/error.h).
  const std::string line = "(1436509052.000000) can0 20000004#0004000000000000";
  const CandumpRecord rec = parse_ok(line);
  EXPECT_EQ(rec.frame.id, 0x004u);
  EXPECT_EQ(rec.frame.flags, CanFlag::kErrorFrame);
  EXPECT_EQ(rec.frame.len, 8);
  EXPECT_EQ(rec.frame.data[1], 0x04);
  EXPECT_EQ(format(rec.timestamp_ns, "can0", rec.frame), line);
}

TEST(CandumpLog, LowerCaseDotsAndPaddingAreRead) {
  // lib.c accepts lower case and '.' before each byte; candump right-aligns interface names.
  const CandumpRecord rec = parse_ok("(1436509052.249713)  can0 123#de.ad.BE.ef.\n");
  EXPECT_EQ(rec.iface.view(), "can0");
  expect_same_frame(rec.frame, make_frame(0x123, 0, {0xDE, 0xAD, 0xBE, 0xEF}));
  expect_same_frame(parse_ok("(1.000000)\tcan0\t123#.0102\r\n").frame,
                    make_frame(0x123, 0, {1, 2}));
  expect_same_frame(parse_ok("(1.000000) can0 123##1.AA.BB").frame,
                    make_frame(0x123, CanFlag::kFd | CanFlag::kBitRateSwitch, {0xAA, 0xBB}));
}

TEST(CandumpLog, DirectionMarkers) {
  const CanFrame sync = make_frame(0x080, 0, {});
  EXPECT_EQ(format(1'000'000, "can0", sync, CandumpDirection::kTransmitted),
            "(0000000000.001000) can0 080# T");
  EXPECT_EQ(format(1'000'000, "can0", sync, CandumpDirection::kReceived),
            "(0000000000.001000) can0 080# R");
  EXPECT_EQ(parse_ok("(0.001000) can0 080# T").direction, CandumpDirection::kTransmitted);
  EXPECT_EQ(parse_ok("(0.001000) can0 080#  R  ").direction, CandumpDirection::kReceived);
}

TEST(CandumpLog, TimestampIsTruncatedToMicroseconds) {
  const CanFrame f = make_frame(0x181, 0, {1});
  EXPECT_EQ(format(1'500'999, "can0", f), "(0000000000.001500) can0 181#01");
  EXPECT_EQ(format(9'223'372'036'854'775'807, "can0", f), "(9223372036.854775) can0 181#01");
  EXPECT_EQ(parse_ok("(9223372036.854775) can0 181#01").timestamp_ns, 9'223'372'036'854'775'000);
}

// --- round trips ---------------------------------------------------------------------------

TEST(CandumpLog, RandomFramesOfEveryKindRoundTrip) {
  constexpr std::uint8_t kFdLens[] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64};
  numen::hal::SplitMix64 rng(42);
  const char* ifaces[] = {"can0", "vcan12", "x", "abcdefghijklmno"};
  for (int n = 0; n < 2000; ++n) {
    CanFrame f;
    const std::uint32_t kind = rng.below(5);  // std, ext, remote, fd, error
    const bool ext = rng.below(2) == 1;
    f.id = static_cast<std::uint32_t>(rng.next()) & (ext ? 0x1FFFFFFFu : 0x7FFu);
    if (ext) f.flags |= CanFlag::kExtendedId;
    if (kind == 0 || kind == 1) {
      f.len = static_cast<std::uint8_t>(rng.below(9));
    } else if (kind == 2) {
      f.flags |= CanFlag::kRemote;
      f.len = static_cast<std::uint8_t>(rng.below(9));
    } else if (kind == 3) {
      f.flags |= CanFlag::kFd;
      if (rng.below(2) == 1) f.flags |= CanFlag::kBitRateSwitch;
      if (rng.below(2) == 1) f.flags |= CanFlag::kErrorStateIndicator;
      f.len = kFdLens[rng.below(16)];
    } else {
      f.flags = CanFlag::kErrorFrame;
      f.len = 8;
    }
    if (!f.remote()) {
      for (std::size_t i = 0; i < f.len; ++i) f.data[i] = static_cast<std::uint8_t>(rng.next());
    }
    const auto t_ns = static_cast<std::int64_t>(rng.next() >> 2) / 1000 * 1000;  // whole µs
    const auto dir = static_cast<CandumpDirection>(rng.below(3));
    const char* iface = ifaces[rng.below(4)];
    const std::string line = format(t_ns, iface, f, dir);
    ASSERT_LE(line.size(), kCandumpMaxLineLength);
    CandumpRecord rec;
    const CandumpParseResult r = parse_candump_line(line, rec);
    ASSERT_TRUE(r.ok()) << line << ": column " << r.column << ": " << to_string(r.error);
    EXPECT_EQ(rec.timestamp_ns, t_ns) << line;
    EXPECT_EQ(rec.iface.view(), iface);
    EXPECT_EQ(rec.direction, dir);
    expect_same_frame(rec.frame, f);
  }
}

TEST(CandumpLog, LongestLineFitsTheBufferExactly) {
  CanFrame f;
  f.id = 0x1FFFFFFF;
  f.flags = CanFlag::kExtendedId | CanFlag::kFd | CanFlag::kBitRateSwitch;
  f.len = 64;
  const CandumpIface iface = make_candump_iface("abcdefghijklmno");
  std::array<char, kCandumpLineBufferSize> buf{};
  const auto r =
      format_candump_line(9'000'000'000'000'000'000, iface, f, CandumpDirection::kTransmitted, buf);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r.length, kCandumpMaxLineLength);
  // One byte short of line + NUL is refused, and nothing past the buffer is touched.
  std::array<char, kCandumpLineBufferSize + 1> guard{};
  guard.back() = 'G';
  const auto small =
      format_candump_line(9'000'000'000'000'000'000, iface, f, CandumpDirection::kTransmitted,
                          std::span<char>(guard.data(), kCandumpMaxLineLength));
  EXPECT_EQ(small.error, CandumpFormatError::kBufferTooSmall);
  EXPECT_EQ(small.length, 0u);
  EXPECT_EQ(guard[kCandumpMaxLineLength], '\0');
  EXPECT_EQ(guard.back(), 'G');
}

TEST(CandumpLog, FormatRefusesWhatTheFormatCannotHold) {
  std::array<char, kCandumpLineBufferSize> buf{};
  const CandumpIface can0 = make_candump_iface("can0");
  const auto dir = CandumpDirection::kUnmarked;
  EXPECT_EQ(format_candump_line(-1, can0, make_frame(0x80, 0, {}), dir, buf).error,
            CandumpFormatError::kNegativeTimestamp);
  EXPECT_EQ(format_candump_line(0, CandumpIface{}, make_frame(0x80, 0, {}), dir, buf).error,
            CandumpFormatError::kBadIface);
  EXPECT_EQ(format_candump_line(0, can0, make_frame(0x800, 0, {}), dir, buf).error,
            CandumpFormatError::kMalformedFrame);
  CanFrame long_classic = make_frame(0x80, 0, {});
  long_classic.len = 9;
  EXPECT_EQ(format_candump_line(0, can0, long_classic, dir, buf).error,
            CandumpFormatError::kMalformedFrame);
  EXPECT_EQ(
      format_candump_line(0, can0, make_frame(4, CanFlag::kErrorFrame | CanFlag::kFd, {}), dir, buf)
          .error,
      CandumpFormatError::kErrorFrameFlags);
  EXPECT_EQ(format_candump_line(0, can0, make_frame(4, CanFlag::kErrorFrame | CanFlag::kRemote, {}),
                                dir, buf)
                .error,
            CandumpFormatError::kErrorFrameFlags);
}

TEST(CandumpLog, InterfaceNames) {
  CandumpIface iface;
  EXPECT_TRUE(numen::hal::to_candump_iface("vcan0", iface));
  EXPECT_EQ(iface.view(), "vcan0");
  EXPECT_FALSE(numen::hal::to_candump_iface("", iface));
  EXPECT_FALSE(numen::hal::to_candump_iface("abcdefghijklmnop", iface));  // 16 characters
  EXPECT_FALSE(numen::hal::to_candump_iface("can 0", iface));
  EXPECT_FALSE(numen::hal::to_candump_iface("can#0", iface));
  EXPECT_FALSE(numen::hal::to_candump_iface("a/b", iface));
  EXPECT_EQ(iface.view(), "vcan0");  // unchanged by the refusals
  EXPECT_THROW(make_candump_iface("can:0", "RecordingBus iface"), std::invalid_argument);
}

TEST(CandumpLog, FormatAndParseDoNotAllocate) {
  const CanFrame f = make_frame(0x123, CanFlag::kFd | CanFlag::kBitRateSwitch,
                                std::vector<std::uint8_t>(64, 0x5A));
  const CandumpIface iface = make_candump_iface("can0");
  std::array<char, kCandumpLineBufferSize> buf{};
  CandumpRecord rec;
  numen::test::AllocationGuard guard;
  const auto w = format_candump_line(123'456'789, iface, f, CandumpDirection::kReceived, buf);
  const auto r = parse_candump_line(std::string_view(buf.data(), w.length), rec);
  const auto bad = parse_candump_line("(1.000000) can0 123#ABC", rec);
  EXPECT_EQ(guard.count(), 0);
  EXPECT_TRUE(w.ok());
  EXPECT_TRUE(r.ok());
  EXPECT_FALSE(bad.ok());
}

// --- parse errors and their columns --------------------------------------------------------

struct BadLine {
  std::string line;
  CandumpError error;
  std::size_t column;
};

// "(1.000000) can0 " is 16 characters: the frame field starts at column 17.
const std::string P = "(1.000000) can0 ";

TEST(CandumpLog, EveryParseErrorNamesItsColumn) {
  const std::vector<BadLine> cases = {
      {"", CandumpError::kMissingOpenParen, 1},
      {"1.000000) can0 123#00", CandumpError::kMissingOpenParen, 1},
      {" (1.000000) can0 123#00", CandumpError::kMissingOpenParen, 1},
      {"(.000000) can0 123#00", CandumpError::kBadTimestamp, 2},
      {"(1,000000) can0 123#00", CandumpError::kBadTimestamp, 3},
      {"(1x.000000) can0 123#00", CandumpError::kBadTimestamp, 3},
      {"(1.00000) can0 123#00", CandumpError::kBadTimestamp, 9},
      {"(1.0000000) can0 123#00", CandumpError::kBadTimestamp, 10},
      {"(1.000000 can0 123#00", CandumpError::kMissingCloseParen, 10},
      {"(1.000000", CandumpError::kMissingCloseParen, 10},
      {"(99999999999.000000) can0 123#00", CandumpError::kTimestampOutOfRange, 2},
      {"(9223372036.854776) can0 123#00", CandumpError::kTimestampOutOfRange, 2},
      {"(1.000000)", CandumpError::kMissingIface, 11},
      {"(1.000000) 123#00", CandumpError::kMissingIface, 12},
      {"(1.000000) abcdefghijklmnop 123#00", CandumpError::kIfaceTooLong, 27},
      {"(1.000000) can:0 123#00", CandumpError::kBadIface, 15},
      {"(1.000000) can0", CandumpError::kMissingFrame, 16},
      {P + "12#00", CandumpError::kBadId, 17},
      {P + "1234#00", CandumpError::kBadId, 17},
      {P + "1234567#00", CandumpError::kBadId, 17},
      {P + "12G#00", CandumpError::kBadId, 19},
      {P + "#00", CandumpError::kBadId, 17},
      {P + "123456789#00", CandumpError::kIdTooLong, 25},
      {P + "800#00", CandumpError::kIdOutOfRange, 17},
      {P + "40000123#00", CandumpError::kIdOutOfRange, 17},
      {P + "A0000004#00", CandumpError::kIdOutOfRange, 17},
      {P + "123", CandumpError::kMissingIdDelimiter, 20},
      {P + "123#ABC", CandumpError::kOddHexDigits, 23},
      {P + "123#AB.C", CandumpError::kOddHexDigits, 24},
      {P + "123#A.BC", CandumpError::kOddHexDigits, 21},
      {P + "123#ABXY", CandumpError::kBadHexDigit, 23},
      {P + "123#AX", CandumpError::kBadHexDigit, 22},
      {P + "123#AB..CD", CandumpError::kBadHexDigit, 24},
      {P + "123#0102030405060708AA", CandumpError::kDataTooLong, 37},
      {P + "123#01.02.03.04.05.06.07.08.09", CandumpError::kDataTooLong, 45},
      {P + "123#0102030405060708_9", CandumpError::kLen8DlcUnsupported, 37},
      {P + "123##", CandumpError::kBadFdFlags, 22},
      {P + "123##G00", CandumpError::kBadFdFlags, 22},
      {P + "123##800", CandumpError::kBadFdFlags, 22},
      {P + "123##1" + std::string(18, 'A'), CandumpError::kInvalidFdLength, 23},
      {P + "123##1" + std::string(130, 'A'), CandumpError::kDataTooLong, 151},
      {P + "123#R9", CandumpError::kBadRemoteLength, 22},
      {P + "123#RX", CandumpError::kBadRemoteLength, 22},
      {P + "123#R12", CandumpError::kBadRemoteLength, 23},
      {P + "123#R8_9", CandumpError::kLen8DlcUnsupported, 23},
      {P + "123###00", CandumpError::kCanXlUnsupported, 20},
      {P + "12345#80:00:11223344#00", CandumpError::kCanXlUnsupported, 17},
      {P + "20000004#R", CandumpError::kErrorFrameNotClassic, 26},
      {P + "20000004##000", CandumpError::kErrorFrameNotClassic, 26},
      {P + "123#00 X", CandumpError::kTrailingText, 24},
      {P + "123#00 RT", CandumpError::kTrailingText, 24},
      {P + "123#00 R R", CandumpError::kTrailingText, 26},
  };
  for (const BadLine& c : cases) {
    CandumpRecord rec;
    rec.timestamp_ns = 77;
    const CandumpParseResult r = parse_candump_line(c.line, rec);
    EXPECT_EQ(r.error, c.error) << "'" << c.line << "' gave: " << to_string(r.error);
    EXPECT_EQ(r.column, c.column) << "'" << c.line << "'";
    EXPECT_EQ(rec.timestamp_ns, 77) << "record changed by a failed parse: '" << c.line << "'";
  }
}

TEST(CandumpLog, EveryErrorHasADescription) {
  for (int e = 0; e <= static_cast<int>(CandumpError::kTrailingText); ++e) {
    EXPECT_STRNE(to_string(static_cast<CandumpError>(e)), "unknown candump log error") << e;
  }
  for (int e = 0; e <= static_cast<int>(CandumpFormatError::kErrorFrameFlags); ++e) {
    EXPECT_STRNE(to_string(static_cast<CandumpFormatError>(e)), "unknown candump format error");
  }
}

// --- file loading --------------------------------------------------------------------------

TEST(CandumpLog, LoadSkipsCommentsBlankLinesAndCountsDropNotes) {
  numen::test::TempDir dir;
  const std::string path = dir.write("run.log",
                                     "# numen bus recording\n"
                                     "\n"
                                     "(1436509052.249713) vcan0 123#DEADBEEF\n"
                                     "DROPCOUNT: dropped 2 CAN frames on 'vcan0' socket (total "
                                     "drops 2)\n"
                                     "( 1436509052.249800) x\n"  // starts with '(': must parse
                                     "(1436509052.250000)  can0 12345678#R R\n");
  EXPECT_THROW(numen::hal::load_candump_log(path), std::runtime_error);
  const std::string good = dir.write("good.log",
                                     "# numen bus recording\n"
                                     "\n"
                                     "(1436509052.249713) vcan0 123#DEADBEEF\n"
                                     "DROPCOUNT: dropped 2 CAN frames on 'vcan0' socket (total "
                                     "drops 2)\n"
                                     "(1436509052.250000)  can0 12345678#R T\n"
                                     "(1436509052.250001) can0 181##1AABB");  // no final '\n'
  numen::hal::CandumpLoadStats stats;
  const std::vector<CandumpRecord> log = numen::hal::load_candump_log(good, &stats);
  EXPECT_EQ(stats.lines, 6u);
  EXPECT_EQ(stats.records, 3u);
  EXPECT_EQ(stats.skipped, 3u);
  EXPECT_EQ(stats.drop_notes, 1u);
  EXPECT_EQ(stats.dropped_frames, 2u);  // the recording lost frames: said, not hidden
  EXPECT_EQ(stats.out_of_order, 0u);
  ASSERT_EQ(log.size(), 3u);
  EXPECT_EQ(log[0].timestamp_ns, 1436509052249713000);
  EXPECT_EQ(log[0].iface.view(), "vcan0");
  EXPECT_EQ(log[1].iface.view(), "can0");
  EXPECT_EQ(log[1].direction, CandumpDirection::kTransmitted);
  EXPECT_TRUE(log[1].frame.remote());
  EXPECT_TRUE(log[2].frame.fd());
  EXPECT_EQ(log[2].frame.len, 2);
}

// The message of the exception load_candump_log(path, nullptr, limits) throws ("" if none).
std::string load_error(const std::string& path, const numen::hal::CandumpLoadLimits& limits = {}) {
  try {
    numen::hal::load_candump_log(path, nullptr, limits);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

// Issue 17 #5: a step back in time within one interface and direction is a located error.
TEST(CandumpLog, TimestampGoingBackOnOneInterfaceIsALocatedError) {
  numen::test::TempDir dir;
  const std::string path = dir.write("back.log",
                                     "(1.000000) can0 181#01020304\n"
                                     "(1.001000) can0 181#01020304\n"
                                     "# a comment\n"
                                     "(1.000500) can0 181#01020304\n");
  EXPECT_EQ(load_error(path), path +
                                  ":4:2: timestamp 1.000500 s goes back 0.000500 s against line "
                                  "2 (1.001000 s) of the same interface 'can0' and direction "
                                  "(unmarked): a recording's times never decrease there");
  // A tolerance for such steps (a wall-clock step during a candump recording) loads it and
  // counts the record.
  numen::hal::CandumpLoadLimits tolerant;
  tolerant.max_backward_ns = 1'000'000;
  numen::hal::CandumpLoadStats stats;
  EXPECT_EQ(numen::hal::load_candump_log(path, &stats, tolerant).size(), 3u);
  EXPECT_EQ(stats.out_of_order, 1u);
  tolerant.max_backward_ns = 499'000;
  EXPECT_NE(load_error(path, tolerant), "");
}

// Streams of their own (another interface, the other direction) may interleave slightly out of
// order: loaded, and counted.
TEST(CandumpLog, OtherInterfacesAndDirectionsMayInterleaveOutOfOrder) {
  numen::test::TempDir dir;
  const std::string path = dir.write("mixed.log",
                                     "(2.000000) can0 080# T\n"
                                     "(1.999900) can0 181#01020304 R\n"  // received before
                                     "(1.999950) can1 185#01020304\n"
                                     "(2.000200) can0 201#6400 T\n");
  numen::hal::CandumpLoadStats stats;
  EXPECT_EQ(numen::hal::load_candump_log(path, &stats).size(), 4u);
  EXPECT_EQ(stats.out_of_order, 2u);
}

// Issue 17 #5: a jump of 9e9 s (or any step of more than 1 h, forward or back) between records.
TEST(CandumpLog, TimestampJumpBeyondTheLimitIsALocatedError) {
  numen::test::TempDir dir;
  const std::string ahead = dir.write("ahead.log",
                                      "(1.000000) can0 181#01020304\n"
                                      "(1.001000) can0 181#01020304\n"
                                      "(9000000001.002000) can0 181#01020304\n");
  EXPECT_EQ(load_error(ahead), ahead +
                                   ":3:2: timestamp 9000000001.002000 s is 9000000000.001000 s "
                                   "after the latest record (line 2, 1.001000 s): more than the "
                                   "3600.000000 s allowed between records");
  // Back by more than the limit on another interface (a splice of two recordings).
  const std::string back = dir.write("back.log",
                                     "(7200.000000) can0 181#01020304\n"
                                     "(1.000000) can1 181#01020304\n");
  EXPECT_NE(load_error(back).find(back + ":2:2: timestamp 1.000000 s is 7199.000000 s before "
                                         "the latest record (line 1, 7200.000000 s)"),
            std::string::npos)
      << load_error(back);
  // Exactly the limit is allowed; the limit is configurable.
  const std::string hour = dir.write("hour.log",
                                     "(1.000000) can0 181#01020304\n"
                                     "(3601.000000) can0 181#01020304\n");
  EXPECT_EQ(load_error(hour), "");
  numen::hal::CandumpLoadLimits strict;
  strict.max_gap_ns = 1'000'000'000;
  EXPECT_NE(load_error(hour, strict).find(hour + ":2:2: "), std::string::npos);
  strict.max_gap_ns = 0;
  EXPECT_THROW(numen::hal::load_candump_log(hour, nullptr, strict), std::invalid_argument);
}

// Issue 17 #5: an empty log, or one of comments only, replays nothing: an error.
TEST(CandumpLog, EmptyLogIsAnError) {
  numen::test::TempDir dir;
  const std::string empty = dir.write("empty.log", "");
  EXPECT_EQ(load_error(empty), empty +
                                   ": no frame records (0 lines: blank, '#' comments or "
                                   "DROPCOUNT notes): nothing to replay");
  const std::string comments = dir.write("comments.log", "# nothing\n\n   \n");
  EXPECT_EQ(load_error(comments), comments +
                                      ": no frame records (3 lines: blank, '#' comments or "
                                      "DROPCOUNT notes): nothing to replay");
}

// Issue 17 #5: garbage is not skipped as canplayer would (it would replay 0 frames): the first
// line that is neither a record, blank, a '#' comment nor a DROPCOUNT note is an error.
TEST(CandumpLog, GarbageIsALocatedError) {
  numen::test::TempDir dir;
  const std::string text = dir.write("text.log",
                                     "# candump without -l prints another format:\n"
                                     "  can0  181   [4]  01 02 03 04\n");
  const std::string what =
      ":1: not a candump log line: a record starts with '(' (besides records, only blank "
      "lines, '#' comments and DROPCOUNT notes)";
  EXPECT_EQ(load_error(text), text + ":2" + what);
  const std::string binary = dir.write("binary.log", std::string("\x7f" "ELF\x02\x01\x00\x00", 8));
  EXPECT_EQ(load_error(binary), binary + ":1" + what);
  // Garbage after good records is refused too, not dropped.
  const std::string tail = dir.write("tail.log",
                                     "(1.000000) can0 181#01020304\n"
                                     "garbage\n");
  EXPECT_EQ(load_error(tail), tail + ":2" + what);
}

// A DROPCOUNT count is candump's unsigned 32-bit counter: one that does not fit wrapped to a
// negative "lost by the recording" figure with exit 0; it is now a located error (column of N).
TEST(CandumpLog, DropCountThatDoesNotFitIsALocatedError) {
  numen::test::TempDir dir;
  const std::string record = "(1436509052.249713) vcan0 123#DEADBEEF\n";
  const auto note = [](const std::string& n) {
    return "DROPCOUNT: dropped " + n + " CAN frames on 'vcan0' socket (total drops 2)\n";
  };
  const std::string largest = dir.write("largest.log", record + note("4294967295") + note("7"));
  numen::hal::CandumpLoadStats stats;
  numen::hal::load_candump_log(largest, &stats);
  EXPECT_EQ(stats.dropped_frames, 4294967302u);
  EXPECT_EQ(stats.drop_notes, 2u);
  const std::string what =
      ": DROPCOUNT note: the dropped-frame count does not fit in 32 bits (candump writes an "
      "unsigned 32-bit count): not a candump note";
  const std::string over = dir.write("over.log", record + note("4294967296"));
  EXPECT_EQ(load_error(over), over + ":2:20" + what);
  const std::string huge = dir.write("huge.log", record + note("99999999999999999999999999"));
  EXPECT_EQ(load_error(huge), huge + ":2:20" + what);
  const std::string tab = dir.write("tab.log", record + "DROPCOUNT:\tdropped 18446744073709551616\n");
  EXPECT_EQ(load_error(tab), tab + ":2:20" + what);
}

// CandumpLogReader reads the log in a fixed buffer: a record line longer than
// kCandumpMaxReadLine is an error at the column after the limit, a '#' comment of any length
// is skipped, and lines across buffer refills come out whole.
TEST(CandumpLog, ReaderBoundsTheLineLengthAndSkipsLongComments) {
  numen::test::TempDir dir;
  const std::size_t limit = numen::hal::kCandumpMaxReadLine;
  const std::string comment = "#" + std::string(3 * limit, 'x') + "\n";
  std::string many;
  for (int i = 0; i < 20000; ++i) {  // ~600 KB: several buffer refills
    char line[64];
    std::snprintf(line, sizeof line, "(1.%06d) can0 181#%08X R\n", i % 1000000, i);
    many += line;
  }
  const std::string good = dir.write("good.log", comment + many + comment);
  numen::hal::CandumpLoadStats stats;
  const std::vector<CandumpRecord> log = numen::hal::load_candump_log(good, &stats);
  ASSERT_EQ(log.size(), 20000u);
  EXPECT_EQ(stats.lines, 20002u);
  EXPECT_EQ(stats.skipped, 2u);
  EXPECT_EQ(log[19999].frame.data[3], 0x1F);  // 0x4E1F
  EXPECT_EQ(log[19999].timestamp_ns, 1'019'999'000);
  const std::string long_record =
      dir.write("long.log", many.substr(0, 31) + "(1.000000) can0 181#01" +
                                std::string(limit, ' ') + "R\n");
  EXPECT_EQ(load_error(long_record), long_record + ":2:" + std::to_string(limit + 1) +
                                         ": line longer than " + std::to_string(limit) +
                                         " characters: not a candump record");
  // The reader one record at a time gives what the loader gives, with the same counts.
  numen::hal::CandumpLogReader reader(good);
  CandumpRecord r;
  std::size_t n = 0;
  while (reader.next(r)) {
    ASSERT_EQ(r.timestamp_ns, log[n].timestamp_ns) << n;
    ++n;
  }
  EXPECT_EQ(n, log.size());
  EXPECT_EQ(reader.stats().lines, stats.lines);
  EXPECT_EQ(reader.stats().records, stats.records);
  EXPECT_THROW(numen::hal::CandumpLogReader(dir.path().string() + "/missing.log"),
               std::runtime_error);
}

TEST(CandumpLog, LoadErrorNamesFileLineAndColumn) {
  numen::test::TempDir dir;
  const std::string path = dir.write("bad.log",
                                     "(1.000000) can0 080#\n"
                                     "# comment\n"
                                     "(1.001000) can0 181#01020304\n"
                                     "(1.002000) can0 181#0102030\n"
                                     "(1.003000) can0 181#zz\n");
  try {
    numen::hal::load_candump_log(path);
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()),
              path + ":4:27: odd number of hex digits: data byte with one digit");
  }
  EXPECT_THROW(
      {
        try {
          numen::hal::load_candump_log(dir.path().string() + "/missing.log");
        } catch (const std::runtime_error& e) {
          EXPECT_NE(std::string(e.what()).find("missing.log: cannot open: "), std::string::npos)
              << e.what();
          throw;
        }
      },
      std::runtime_error);
}

}  // namespace
