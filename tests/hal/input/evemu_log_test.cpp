#include "numen/hal/input/evemu_log.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <stdexcept>
#include <string>

#include "alloc_counter.hpp"

namespace numen::hal {
namespace {

const std::string kRecording = std::string(NUMEN_TEST_DATA_DIR) + "/mouse_clutch.evemu";

// A temporary file removed at scope exit.
struct TempFile {
  std::string path;
  explicit TempFile(const std::string& text) {
    char name[] = "/tmp/numen_evemu_XXXXXX";
    const int fd = mkstemp(name);
    EXPECT_GE(fd, 0);
    close(fd);
    path = name;
    std::ofstream(path) << text;
  }
  ~TempFile() { std::remove(path.c_str()); }
};

TEST(EvemuLog, ParsesTheEventLinesEvemuRecordWrites) {
  InputEvent e;
  // evemu_write_event(): "E: %lu.%06u %04x %04x %04d\t" + a description comment.
  EvemuParseResult r =
      parse_evemu_line("E: 0.000001 0002 0000 0005\t# EV_REL / REL_X                5", e);
  ASSERT_TRUE(r.ok()) << to_string(r.error);
  EXPECT_TRUE(r.is_event);
  EXPECT_EQ(e.time_ns, 1000);
  EXPECT_EQ(e.type, EV_REL);
  EXPECT_EQ(e.code, REL_X);
  EXPECT_EQ(e.value, 5);

  r = parse_evemu_line("E: 12.345678 0002 0001 -003\t# EV_REL / REL_Y   -3\r\n", e);
  ASSERT_TRUE(r.ok()) << to_string(r.error);
  EXPECT_EQ(e.time_ns, 12'345'678'000);
  EXPECT_EQ(e.code, REL_Y);
  EXPECT_EQ(e.value, -3);

  r = parse_evemu_line("E: 1.500000 0001 0110 0001", e);  // no comment
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(e.type, EV_KEY);
  EXPECT_EQ(e.code, BTN_LEFT);
  EXPECT_EQ(e.value, 1);

  r = parse_evemu_line("E: 1.500000 4 4 90001", e);  // short hex, wide value
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(e.type, EV_MSC);
  EXPECT_EQ(e.value, 90001);

  ASSERT_TRUE(parse_evemu_line("E: 0.000001 0002 0000 -2147483648", e).ok());
  EXPECT_EQ(e.value, -2147483648);
}

TEST(EvemuLog, SkipsDescriptionLinesCommentsAndBlankLines) {
  InputEvent e{7, 1, 2, 3};
  for (const char* line :
       {"# EVEMU 1.3", "N: Logitech USB Optical Mouse", "I: 0003 046d c077 0111",
        "P: 00 00 00 00 00 00 00 00", "B: 02 43 01 00 00 00 00 00 00", "A: 00 0 1023 0 0 0",
        "L: 00 0", "S: 00 0", "", "   \t", "################################"}) {
    const EvemuParseResult r = parse_evemu_line(line, e);
    EXPECT_TRUE(r.ok()) << line << ": " << to_string(r.error);
    EXPECT_FALSE(r.is_event) << line;
  }
  EXPECT_EQ(e.time_ns, 7);  // unchanged
  EXPECT_EQ(e.value, 3);
}

TEST(EvemuLog, RejectsMalformedLinesWithTheColumn) {
  struct Case {
    const char* line;
    EvemuError error;
    std::size_t column;
  };
  const Case cases[] = {
      {"X: 1 2 3", EvemuError::kUnknownLine, 1},
      {"E 0.000001 0002 0000 0001", EvemuError::kUnknownLine, 1},
      {"  E: 0.000001 0002 0000 0001", EvemuError::kUnknownLine, 3},
      {"E:0.000001 0002 0000 0001", EvemuError::kBadTimestamp, 3},
      {"E: 0.00001 0002 0000 0001", EvemuError::kBadTimestamp, 11},    // 5 fraction digits
      {"E: 0.0000011 0002 0000 0001", EvemuError::kBadTimestamp, 12},  // 7 fraction digits
      {"E: .000001 0002 0000 0001", EvemuError::kBadTimestamp, 4},
      {"E: 0,000001 0002 0000 0001", EvemuError::kBadTimestamp, 5},
      {"E: 99999999999999999999.000001 0002 0000 0001", EvemuError::kTimestampOutOfRange, 4},
      {"E: 9999999999.000001 0002 0000 0001", EvemuError::kTimestampOutOfRange, 4},
      {"E: 0.000001 00g2 0000 0001", EvemuError::kBadType, 15},
      {"E: 0.000001 00002 0000 0001", EvemuError::kBadType, 17},  // 5 digits
      {"E: 0.000001 0020 0000 0001", EvemuError::kTypeOutOfRange, 13},
      {"E: 0.000001 0002", EvemuError::kBadCode, 17},
      {"E: 0.000001 0002 zz 0001", EvemuError::kBadCode, 18},
      {"E: 0.000001 0002 0010 0001", EvemuError::kCodeOutOfRange, 18},  // REL_MAX 0x0f
      {"E: 0.000001 0001 0300 0001", EvemuError::kCodeOutOfRange, 18},  // KEY_MAX 0x2ff
      {"E: 0.000001 0002 0000", EvemuError::kBadValue, 22},
      {"E: 0.000001 0002 0000 -", EvemuError::kBadValue, 24},
      {"E: 0.000001 0002 0000 12a", EvemuError::kBadValue, 25},
      {"E: 0.000001 0002 0000 0x10", EvemuError::kBadValue, 24},
      {"E: 0.000001 0002 0000 2147483648", EvemuError::kValueOutOfRange, 23},
      {"E: 0.000001 0002 0000 -2147483649", EvemuError::kValueOutOfRange, 23},
      {"E: 0.000001 0002 0000 99999999999999999999", EvemuError::kValueOutOfRange, 23},
      {"E: 0.000001 0002 0000 0001 extra", EvemuError::kTrailingText, 28},
  };
  for (const Case& c : cases) {
    InputEvent e{42, 9, 9, 9};
    const EvemuParseResult r = parse_evemu_line(c.line, e);
    EXPECT_EQ(r.error, c.error) << c.line << ": got " << to_string(r.error);
    EXPECT_EQ(r.column, c.column) << c.line;
    EXPECT_FALSE(r.is_event) << c.line;
    EXPECT_EQ(e.time_ns, 42) << c.line;  // unchanged on error
    EXPECT_STRNE(to_string(r.error), "unknown error");
  }
}

TEST(EvemuLog, LoadsTheShippedRecording) {
  EvemuLoadStats stats;
  const std::vector<InputEvent> ev = load_evemu_recording(kRecording, &stats);
  EXPECT_EQ(stats.lines, 86u);
  EXPECT_EQ(stats.events, 39u);
  EXPECT_EQ(stats.skipped, 47u);
  ASSERT_EQ(ev.size(), 39u);
  EXPECT_EQ(ev.front().time_ns, 1000);
  EXPECT_EQ(ev.front().type, EV_REL);
  EXPECT_EQ(ev.front().value, 5);
  EXPECT_EQ(ev[1].value, -3);
  EXPECT_EQ(ev.back().type, EV_SYN);
  EXPECT_EQ(ev.back().time_ns, 130'001'000);
}

TEST(EvemuLog, LoadReportsFileLineAndColumn) {
  TempFile f("# EVEMU 1.3\nN: mouse\nE: 0.000001 0002 0000 0001\nE: 0.000002 0002 0000 1x\n");
  try {
    load_evemu_recording(f.path);
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()), f.path + ":4:24: bad value: expected a decimal integer");
  }
  try {
    load_evemu_recording("/nonexistent/rec.evemu");
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()),
              "/nonexistent/rec.evemu: cannot open: No such file or directory");
  }
}

TEST(EvemuLog, ParseDoesNotAllocate) {
  InputEvent e;
  test::AllocationGuard guard;
  int events = 0;
  for (int i = 0; i < 1000; ++i) {
    events += parse_evemu_line("E: 3.000001 0002 0001 -012\t# EV_REL / REL_Y  -12", e).is_event;
    events += parse_evemu_line("B: 02 43 01 00 00 00 00 00 00", e).is_event;
    events += parse_evemu_line("E: 3.000001 0002 0001 zz", e).is_event;
  }
  EXPECT_EQ(guard.count(), 0);
  EXPECT_EQ(events, 1000);
}

}  // namespace
}  // namespace numen::hal
