// Tests of numen/hal/transport/line_file.hpp: bytes reach the file, and failures (no directory, a full
// disk) are returned, never swallowed; CountedLineFile counts the lines the kernel accepted; a
// refused run leaves the path as it was.
#include "numen/hal/transport/line_file.hpp"

#include <gtest/gtest.h>

#include <filesystem>
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

namespace {

std::string slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

void put(const std::string& path, const std::string& text) { std::ofstream(path) << text; }

/// Files in `dir` (names), to check that no temporary file is left behind.
std::size_t entries(const numen::test::TempDir& dir) {
  std::size_t n = 0;
  for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(dir.path())) ++n;
  return n;
}

/// A record sink's shape: closes its file in its destructor (as CandumpWriter, TraceWriter).
struct ClosingOwner {
  explicit ClosingOwner(const std::string& path) : file(path) {}
  ~ClosingOwner() { file.close(); }
  numen::hal::LineFile file;
};

}  // namespace

TEST(LineFile, ThePreviousFileStaysUntilClose) {
  numen::test::TempDir dir;
  const std::string path = (dir / "keep.csv").string();
  put(path, "previous\n");
  numen::hal::LineFile f(path);
  EXPECT_NE(f.writing_path(), path);  // a temporary file beside it
  EXPECT_TRUE(f.write("new\n", 4));
  EXPECT_TRUE(f.flush());
  EXPECT_EQ(slurp(path), "previous\n");
  EXPECT_TRUE(f.close());
  EXPECT_EQ(slurp(path), "new\n");
  EXPECT_EQ(entries(dir), 1u);
}

TEST(LineFile, DestroyedWithoutCloseLeavesThePathAsItWas) {
  numen::test::TempDir dir;
  const std::string path = (dir / "keep.log").string();
  put(path, "previous\n");
  {
    numen::hal::LineFile f(path);
    EXPECT_TRUE(f.write("new\n", 4));
  }
  EXPECT_EQ(slurp(path), "previous\n");
  EXPECT_EQ(entries(dir), 1u);
  {
    numen::hal::CountedLineFile f(path, 16);
    EXPECT_TRUE(f.append("new\n", 4));
    EXPECT_TRUE(f.flush());
  }
  EXPECT_EQ(slurp(path), "previous\n");
  const std::string fresh = (dir / "fresh.log").string();
  { numen::hal::LineFile f(fresh); }
  EXPECT_FALSE(std::filesystem::exists(fresh));  // a new path is not created either
  EXPECT_EQ(entries(dir), 1u);
}

TEST(LineFile, ClosedDuringUnwindingLeavesThePathAsItWas) {
  numen::test::TempDir dir;
  const std::string path = (dir / "keep.nmv").string();
  put(path, "previous\n");
  try {
    ClosingOwner owner(path);
    EXPECT_TRUE(owner.file.write("new\n", 4));
    throw std::invalid_argument("refused after the outputs were opened");
  } catch (const std::invalid_argument&) {
  }
  EXPECT_EQ(slurp(path), "previous\n");
  EXPECT_EQ(entries(dir), 1u);
  // A LineFile opened while an exception is already in flight (a handler's own output) and
  // closed there is kept.
  try {
    throw std::invalid_argument("x");
  } catch (const std::invalid_argument&) {
    ClosingOwner inner(path);
    EXPECT_TRUE(inner.file.write("handler\n", 8));
  }
  EXPECT_EQ(slurp(path), "handler\n");
}

TEST(LineFile, ModeAndLinksOfAnExistingFileAreKept) {
  numen::test::TempDir dir;
  const std::string target = (dir / "target.csv").string();
  const std::string link = (dir / "link.csv").string();
  put(target, "previous\n");
  std::filesystem::permissions(target, std::filesystem::perms(0640));
  std::filesystem::create_symlink(target, link);
  numen::hal::LineFile f(link);
  EXPECT_TRUE(f.write("new\n", 4));
  EXPECT_TRUE(f.close());
  EXPECT_TRUE(std::filesystem::is_symlink(link));
  EXPECT_EQ(slurp(target), "new\n");
  EXPECT_EQ(std::filesystem::status(target).permissions() & std::filesystem::perms::all,
            std::filesystem::perms(0640));
  EXPECT_EQ(entries(dir), 2u);
}

TEST(LineFile, DevicesAreWrittenInPlaceAndDirectoriesRefused) {
  numen::hal::LineFile null("/dev/null");
  EXPECT_EQ(null.writing_path(), "/dev/null");
  EXPECT_TRUE(null.write("x\n", 2));
  EXPECT_TRUE(null.close());
  EXPECT_TRUE(std::filesystem::is_character_file("/dev/null"));
  numen::test::TempDir dir;
  try {
    numen::hal::LineFile d(dir.path().string());
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()), dir.path().string() + ": cannot open for writing: Is a directory");
  }
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
