// Tests of numen/hal/transport/line_file.hpp: bytes reach the file, and failures (no directory, a full
// disk) are returned, never swallowed; CountedLineFile counts the lines the kernel accepted.
#include "numen/hal/transport/line_file.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>

#include "temp_dir.hpp"

TEST(LineFile, WritesFlushesAndCloses) {
  numen::test::TempDir dir;
  const std::string path = (dir / "a.txt").string();
  numen::hal::LineFile f(path);
  EXPECT_TRUE(f.is_open());
  EXPECT_EQ(f.path(), path);
  EXPECT_TRUE(f.write("one\n", 4));
  EXPECT_TRUE(f.flush());
  EXPECT_TRUE(f.write("two\n", 4));
  EXPECT_TRUE(f.close());
  EXPECT_TRUE(f.close());  // idempotent
  EXPECT_FALSE(f.is_open());
  EXPECT_FALSE(f.write("x", 1));
  EXPECT_FALSE(f.flush());
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  EXPECT_EQ(ss.str(), "one\ntwo\n");
}

TEST(LineFile, FailuresAreReturned) {
  numen::test::TempDir dir;
  const std::string missing = (dir / "no/such/dir/a.txt").string();
  try {
    numen::hal::LineFile f(missing);
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()), missing + ": cannot open for writing: No such file or directory");
  }
  numen::hal::LineFile full("/dev/full");
  const std::string block(1 << 16, 'x');  // more than stdio's buffer: fwrite reaches the device
  EXPECT_FALSE(full.write(block.data(), block.size()));
  numen::hal::LineFile tail("/dev/full");
  EXPECT_TRUE(tail.write("x\n", 2));  // buffered
  EXPECT_FALSE(tail.flush());
  numen::hal::LineFile closing("/dev/full");
  EXPECT_TRUE(closing.write("x\n", 2));
  EXPECT_FALSE(closing.close());  // the buffered tail cannot be written
}

// CountedLineFile counts a line as written only once write(2) accepted all of its bytes: on a
// full device none is, however many fit into the buffer first (stdio's fwrite succeeded for
// them, and the summary said "24 924 of 25 159 frames written" when none was).
TEST(CountedLineFile, CountsOnlyTheLinesTheKernelAccepted) {
  numen::test::TempDir dir;
  const std::string path = (dir / "a.log").string();
  {
    numen::hal::CountedLineFile f(path, 16);  // a small buffer: appends write it out
    EXPECT_TRUE(f.is_open());
    EXPECT_EQ(f.path(), path);
    for (int i = 0; i < 10; ++i) EXPECT_TRUE(f.append("line\n", 5));
    EXPECT_FALSE(f.append("no newline", 10));
    EXPECT_FALSE(f.append("", 0));
    EXPECT_FALSE(f.append(std::string(17, '\n').c_str(), 17));  // longer than the buffer
    const numen::hal::LineCounts before = f.take_counts();
    EXPECT_EQ(before.written, 9u) << "3 lines per 16-byte buffer: 3 write-outs so far";
    EXPECT_TRUE(f.flush());
    const numen::hal::LineCounts c = f.take_counts();
    EXPECT_EQ(c.written, 1u);
    EXPECT_EQ(c.lost, 0u);
    EXPECT_EQ(c.failed_writes, 0u);
    EXPECT_TRUE(f.close());
    EXPECT_TRUE(f.close());  // idempotent
    EXPECT_FALSE(f.append("x\n", 2));
  }
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  std::string want;
  for (int i = 0; i < 10; ++i) want += "line\n";
  EXPECT_EQ(ss.str(), want);

  numen::hal::CountedLineFile full("/dev/full", 16);
  for (int i = 0; i < 10; ++i) EXPECT_TRUE(full.append("line\n", 5));  // buffered, or kept
  EXPECT_FALSE(full.flush());
  const numen::hal::LineCounts c = full.take_counts();
  EXPECT_EQ(c.written, 0u);
  EXPECT_EQ(c.lost, 10u);
  EXPECT_EQ(c.failed_writes, 3u) << "the write-outs appends made, each refused";
  EXPECT_TRUE(full.append("line\n", 5));
  EXPECT_FALSE(full.close());  // the tail cannot be written
  EXPECT_EQ(full.take_counts().lost, 1u);
  try {
    numen::hal::CountedLineFile f((dir / "no/such/dir/a.txt").string());
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()),
              (dir / "no/such/dir/a.txt").string() + ": cannot open for writing: No such file or directory");
  }
}
