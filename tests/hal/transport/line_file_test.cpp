// Tests of numen/hal/transport/line_file.hpp: bytes reach the file, and failures (no directory, a full
// disk) are returned, never swallowed.
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
