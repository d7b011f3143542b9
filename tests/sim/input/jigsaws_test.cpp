// Tests of sim/jigsaws: the shipped excerpt loads cleanly; malformed files
// give InputError with file, line and column; rotations are re-orthonormalised
// and quaternion signs continuous; row options; resampling of the real data.
#include "numen/sim/input/jigsaws.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include "jigsaws_trials.hpp"
#include "numen/sim/input/input_error.hpp"
#include "temp_dir.hpp"

namespace {

namespace fs = std::filesystem;
using numen::core::Mat3;
using numen::core::Quat;
using numen::core::Vec3;
using numen::sim::InputError;
using numen::sim::JigsawsManipulator;
using numen::sim::JigsawsOptions;
using numen::sim::load_jigsaws;

constexpr std::size_t kExcerptRows = 900;
constexpr std::size_t kExcerptFirstRow = 1056;  // row of Suturing_B002.txt

fs::path excerpt() {
  return fs::path(NUMEN_SOURCE_DIR) / "sim" / "data" / "jigsaws_suturing_b002_excerpt.txt";
}

/// A file in its own temporary directory (numen::test::TempDir), removed with the
/// directory at the end of the test.
class TempFile {
 public:
  TempFile(const std::string& name, const std::string& content)
      : path_(dir_.write(name, content)) {}
  const fs::path& path() const { return path_; }

 private:
  numen::test::TempDir dir_;
  fs::path path_;
};

using Row = std::array<double, 76>;

/// A valid row: group g has tip (g + 1, 2, 3) · 0.01 m + 1e-4 · r, rotation
/// `rot[g]`, velocities 0, gripper 0.1 · (g + 1).
Row make_row(int r, const std::array<Mat3, 4>& rot) {
  Row row{};
  for (int g = 0; g < 4; ++g) {
    double* v = row.data() + 19 * g;
    v[0] = 0.01 * (g + 1) + 1e-4 * r;
    v[1] = 0.02 - 1e-4 * r;
    v[2] = 0.03;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) v[3 + 3 * i + j] = rot[g](i, j);
    v[18] = 0.1 * (g + 1);
  }
  return row;
}

std::array<Mat3, 4> identity_rotations() {
  return {Mat3::Identity(), Mat3::Identity(), Mat3::Identity(), Mat3::Identity()};
}

/// Tokens of a row as the dataset writes them (fixed, 8 decimals).
std::vector<std::string> tokens(const Row& row) {
  std::vector<std::string> t;
  for (double v : row) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.8f", v);
    t.emplace_back(buf);
  }
  return t;
}

std::string join(const std::vector<std::string>& t) {
  std::string s;
  for (const auto& x : t) s += "    " + x;
  return s + "\n";
}

/// Character column (1-based) of token `index` in join(t).
int trial_column(const std::vector<std::string>& t, std::size_t index) {
  int c = 1;
  for (std::size_t i = 0; i < index; ++i) c += 4 + static_cast<int>(t[i].size());
  return c + 4;
}

std::string valid_lines(int n) {
  std::string s;
  for (int r = 0; r < n; ++r) s += join(tokens(make_row(r, identity_rotations())));
  return s;
}

/// Expects load_jigsaws() to throw an InputError at `line`; returns it.
InputError expect_error(const fs::path& path, int line) {
  try {
    load_jigsaws(path, JigsawsManipulator::slave_right);
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), path.string());
    EXPECT_EQ(e.line(), line);
    const std::string what = e.what();
    EXPECT_NE(what.find(path.string() + ":" + std::to_string(line)), std::string::npos) << what;
    return e;
  }
  ADD_FAILURE() << "no InputError for " << path;
  return InputError("", 0, 0, "", "");
}

TEST(Jigsaws, ExcerptLoads) {
  const auto rec = load_jigsaws(excerpt(), JigsawsManipulator::slave_right);
  EXPECT_EQ(rec.trajectory.size(), kExcerptRows);
  EXPECT_EQ(rec.file_rows, kExcerptRows);
  EXPECT_EQ(rec.first_row, 1u);
  EXPECT_DOUBLE_EQ(rec.trajectory.period(), 1.0 / 30.0);
  EXPECT_NEAR(rec.trajectory.duration(), 899.0 / 30.0, 1e-12);
  EXPECT_EQ(rec.recorded_twist.size(), kExcerptRows);
  EXPECT_EQ(numen::sim::jigsaws_excerpt_path(), excerpt());
}

TEST(Jigsaws, ExcerptRotationsAreOrthonormalAndQuaternionsContinuous) {
  for (int m = 0; m < 4; ++m) {
    const auto manipulator = static_cast<JigsawsManipulator>(m);
    const auto rec = load_jigsaws(excerpt(), manipulator);
    const auto& tr = rec.trajectory;
    ASSERT_EQ(tr.size(), kExcerptRows);
    for (std::size_t i = 0; i < tr.size(); ++i) {
      const Quat& q = tr[i].pose.orientation;
      ASSERT_NEAR(q.norm(), 1.0, 1e-12) << i;
      const Mat3 r = q.toRotationMatrix();
      ASSERT_LT((r.transpose() * r - Mat3::Identity()).cwiseAbs().maxCoeff(), 1e-12) << i;
      ASSERT_NEAR(r.determinant(), 1.0, 1e-12) << i;
      if (i > 0) {
        ASSERT_GE(q.dot(tr[i - 1].pose.orientation), 0.0) << "sign flip at " << i;
      }
    }
    // Masters are off by ~1e-3 in the file, slaves by ~4e-6.
    if (m < 2) {
      EXPECT_GT(rec.max_orthonormality_error, 5e-4) << m;
      EXPECT_LT(rec.max_orthonormality_error, 5e-3) << m;
    } else {
      EXPECT_LT(rec.max_orthonormality_error, 1e-5) << m;
    }
  }
}

TEST(Jigsaws, ExcerptValuesMatchTheFileText) {
  // Read the first and last lines independently and compare the slave right group.
  std::ifstream in(excerpt());
  std::string line, first, last;
  while (std::getline(in, line)) {
    if (first.empty()) first = line;
    last = line;
  }
  const auto rec = load_jigsaws(excerpt(), JigsawsManipulator::slave_right);
  for (const auto& [text, index] :
       {std::pair{first, std::size_t{0}}, std::pair{last, kExcerptRows - 1}}) {
    std::istringstream is(text);
    std::vector<double> v((std::istream_iterator<double>(is)), std::istream_iterator<double>());
    ASSERT_EQ(v.size(), 76u);
    const auto& s = rec.trajectory[index];
    EXPECT_EQ(s.pose.position, Vec3(v[57], v[58], v[59]));
    EXPECT_EQ(s.jaw, v[75]);
    Mat3 raw;
    raw << v[60], v[61], v[62], v[63], v[64], v[65], v[66], v[67], v[68];
    EXPECT_LT((s.pose.orientation.toRotationMatrix() - raw).cwiseAbs().maxCoeff(), 1e-5);
    EXPECT_EQ(rec.recorded_twist[index].linear, Vec3(v[69], v[70], v[71]));
    EXPECT_EQ(rec.recorded_twist[index].angular, Vec3(v[72], v[73], v[74]));
  }
}

// The full trial is outside the repository: NUMEN_JIGSAWS_DIR (jigsaws_trials.hpp).
TEST(Jigsaws, ExcerptIsTheDocumentedSliceOfTheFullTrial) {
  const auto dir = numen::test::jigsaws_trials_dir();
  if (!dir) GTEST_SKIP() << numen::test::kNoJigsawsTrials;
  const fs::path full = *dir / "Suturing_B002.txt";
  ASSERT_TRUE(fs::is_regular_file(full)) << "NUMEN_JIGSAWS_DIR: no " << full.string();
  JigsawsOptions options;
  options.first_row = kExcerptFirstRow;
  options.max_rows = kExcerptRows;
  const auto a = load_jigsaws(full, JigsawsManipulator::slave_right, options);
  const auto b = load_jigsaws(excerpt(), JigsawsManipulator::slave_right);
  ASSERT_EQ(a.trajectory.size(), b.trajectory.size());
  EXPECT_NEAR(a.start_time_in_file, (kExcerptFirstRow - 1) / 30.0, 1e-12);
  for (std::size_t i = 0; i < a.trajectory.size(); ++i) {
    ASSERT_EQ(a.trajectory[i].pose.position, b.trajectory[i].pose.position) << i;
  }
}

TEST(Jigsaws, InterpolatesTheExcerptAtA1kHzLoopsInstants) {
  const auto rec = load_jigsaws(excerpt(), JigsawsManipulator::master_left);
  for (std::size_t i = 0; i < rec.trajectory.size(); i += 3) {  // i / 30 s = k ms for i % 3 == 0
    const auto s = rec.trajectory.at(static_cast<double>(i / 3 * 100) * 1e-3);
    EXPECT_NEAR((s.pose.position - rec.trajectory[i].pose.position).norm(), 0.0, 1e-15) << i;
    EXPECT_NEAR(s.pose.orientation.angularDistance(rec.trajectory[i].pose.orientation), 0.0, 1e-14)
        << i;
  }
  numen::core::Quat previous = rec.trajectory.at(0.0).pose.orientation;
  for (int k = 1; k <= 29966; ++k) {
    const numen::core::Quat q = rec.trajectory.at(k * 1e-3).pose.orientation;
    ASSERT_GE(q.dot(previous), 0.0) << k;
    previous = q;
  }
}

TEST(Jigsaws, SelectsTheManipulatorColumns) {
  const TempFile f("groups.txt", valid_lines(3));
  for (int g = 0; g < 4; ++g) {
    const auto rec = load_jigsaws(f.path(), static_cast<JigsawsManipulator>(g));
    EXPECT_NEAR(rec.trajectory[0].pose.position.x(), 0.01 * (g + 1), 1e-15) << g;
    EXPECT_NEAR(rec.trajectory[2].pose.position.x(), 0.01 * (g + 1) + 2e-4, 1e-15) << g;
    EXPECT_NEAR(rec.trajectory[0].jaw, 0.1 * (g + 1), 1e-15) << g;
  }
}

TEST(Jigsaws, RowOptions) {
  const TempFile f("options.txt", valid_lines(100));
  JigsawsOptions o;
  o.first_row = 11;
  o.max_rows = 20;
  auto rec = load_jigsaws(f.path(), JigsawsManipulator::slave_left, o);
  EXPECT_EQ(rec.trajectory.size(), 20u);
  EXPECT_EQ(rec.first_row, 11u);
  EXPECT_EQ(rec.file_rows, 100u);
  EXPECT_NEAR(rec.trajectory[0].pose.position.x(), 0.03 + 1e-4 * 10, 1e-15);
  EXPECT_NEAR(rec.start_time_in_file, 10.0 / 30.0, 1e-15);

  o.max_rows = 1000;  // clipped at the end of the file
  EXPECT_EQ(load_jigsaws(f.path(), JigsawsManipulator::slave_left, o).trajectory.size(), 90u);

  JigsawsOptions t;
  t.start_time = 1.0;  // row 31
  t.end_time = 2.0;    // row 61, inclusive
  rec = load_jigsaws(f.path(), JigsawsManipulator::slave_left, t);
  EXPECT_EQ(rec.first_row, 31u);
  EXPECT_EQ(rec.trajectory.size(), 31u);

  JigsawsOptions both;
  both.first_row = 2;
  both.start_time = 1.0;
  EXPECT_THROW(load_jigsaws(f.path(), JigsawsManipulator::slave_left, both), InputError);
  JigsawsOptions beyond;
  beyond.first_row = 101;
  try {
    load_jigsaws(f.path(), JigsawsManipulator::slave_left, beyond);
    FAIL() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.key(), "options.first_row");
  }
  JigsawsOptions zero;
  zero.first_row = 0;
  EXPECT_THROW(load_jigsaws(f.path(), JigsawsManipulator::slave_left, zero), InputError);
  JigsawsOptions backwards;
  backwards.start_time = 2.0;
  backwards.end_time = 1.0;
  EXPECT_THROW(load_jigsaws(f.path(), JigsawsManipulator::slave_left, backwards), InputError);
}

TEST(JigsawsMalformed, SeventyFiveColumns) {
  auto t = tokens(make_row(2, identity_rotations()));
  t.pop_back();
  const TempFile f("cols75.txt", valid_lines(2) + join(t) + valid_lines(1));
  const InputError e = expect_error(f.path(), 3);
  EXPECT_NE(std::string(e.what()).find("found 75 values, expected exactly 76"), std::string::npos)
      << e.what();
}

TEST(JigsawsMalformed, SeventySevenColumns) {
  auto t = tokens(make_row(0, identity_rotations()));
  t.push_back("0.5");
  const TempFile f("cols77.txt", join(t));
  const InputError e = expect_error(f.path(), 1);
  EXPECT_EQ(e.column(), trial_column(t, 76));
}

TEST(JigsawsMalformed, WordInsteadOfANumber) {
  auto t = tokens(make_row(1, identity_rotations()));
  t[4] = "abc";  // data column 5: master left R12
  const TempFile f("word.txt", valid_lines(1) + join(t) + valid_lines(2));
  const InputError e = expect_error(f.path(), 2);
  EXPECT_EQ(e.column(), trial_column(t, 4));
  EXPECT_EQ(e.key(), "master_left.R12");
  EXPECT_NE(std::string(e.what()).find("data column 5 of 76: 'abc' is not a number"),
            std::string::npos)
      << e.what();
}

TEST(JigsawsMalformed, TrailingGarbageInANumber) {
  auto t = tokens(make_row(0, identity_rotations()));
  t[70] = "0.12x";
  const TempFile f("garbage.txt", join(t));
  const InputError e = expect_error(f.path(), 1);
  EXPECT_EQ(e.key(), "slave_right.v_y");
}

TEST(JigsawsMalformed, NanAndInf) {
  auto t = tokens(make_row(3, identity_rotations()));
  t[39] = "nan";  // data column 40: slave left tip y
  const TempFile f("nan.txt", valid_lines(3) + join(t));
  const InputError e = expect_error(f.path(), 4);
  EXPECT_EQ(e.key(), "slave_left.tip_y");
  EXPECT_NE(std::string(e.what()).find("'nan' is not a finite number"), std::string::npos)
      << e.what();

  t[39] = "-inf";
  const TempFile g("inf.txt", valid_lines(1) + join(t));
  expect_error(g.path(), 2);
  t[39] = "1e999";
  const TempFile h("overflow.txt", join(t));
  expect_error(h.path(), 1);
}

TEST(JigsawsMalformed, EmptyFile) {
  const TempFile f("empty.txt", "");
  const InputError e = expect_error(f.path(), 1);
  EXPECT_NE(std::string(e.what()).find("empty"), std::string::npos) << e.what();
  const TempFile g("blank.txt", "\n   \n");
  expect_error(g.path(), 1);
}

TEST(JigsawsMalformed, BlankLineInsideTheData) {
  const TempFile f("hole.txt", valid_lines(2) + "\n" + valid_lines(2));
  expect_error(f.path(), 3);
}

TEST(Jigsaws, AcceptsCrlfAndTrailingBlankLines) {
  std::string text = valid_lines(3);
  std::string crlf;
  for (char c : text) {
    if (c == '\n') crlf += '\r';
    crlf += c;
  }
  const TempFile f("crlf.txt", crlf + "\r\n\n");
  EXPECT_EQ(load_jigsaws(f.path(), JigsawsManipulator::master_right).trajectory.size(), 3u);
}

TEST(JigsawsMalformed, MissingFile) {
  try {
    load_jigsaws("/nonexistent/numen/file.txt", JigsawsManipulator::master_left);
    FAIL() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/numen/file.txt"), std::string::npos);
  }
}

TEST(JigsawsMalformed, MatrixFarFromARotation) {
  auto rot = identity_rotations();
  rot[3] *= 2.0;  // slave right
  const Row row = make_row(0, rot);
  const TempFile f("scaled.txt", valid_lines(4) + join(tokens(row)));
  const InputError e = expect_error(f.path(), 5);
  EXPECT_EQ(e.key(), "slave_right.rotation");
  EXPECT_EQ(e.column(), trial_column(tokens(row), 60));
  rot = identity_rotations();
  rot[3](2, 2) = -1.0;  // a reflection
  const TempFile g("reflection.txt", join(tokens(make_row(0, rot))));
  expect_error(g.path(), 1);
}

TEST(Jigsaws, ReorthonormalisesTheRotationMatrices) {
  // Perturb a rotation by ~1e-3 like the master matrices in the dataset.
  auto rot = identity_rotations();
  const Mat3 exact = Quat(Eigen::AngleAxisd(0.8, Vec3(1, 2, -1).normalized())).toRotationMatrix();
  Mat3 noise;
  noise << 1e-3, -2e-3, 0.5e-3, 1.5e-3, -1e-3, 2e-3, -0.7e-3, 0.3e-3, 1e-3;
  rot[0] = exact + noise;
  const TempFile f("noisy.txt", join(tokens(make_row(0, rot))));
  const auto rec = load_jigsaws(f.path(), JigsawsManipulator::master_left);
  const Mat3 r = rec.trajectory[0].pose.orientation.toRotationMatrix();
  EXPECT_LT((r.transpose() * r - Mat3::Identity()).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_GT(rec.max_orthonormality_error, 1e-3);
  // The nearest rotation is at least as close to the noisy matrix as the exact one.
  const Mat3 nearest = numen::sim::nearest_rotation(rot[0]);
  EXPECT_LE((nearest - rot[0]).norm(), (exact - rot[0]).norm() + 1e-12);
  EXPECT_LT((r - nearest).cwiseAbs().maxCoeff(), 1e-7);  // 8-decimal file text
  EXPECT_LT((r - exact).cwiseAbs().maxCoeff(), 5e-3);
}

TEST(Jigsaws, NearestRotationIsAProperRotation) {
  Mat3 m;
  m << 0.9, 0.1, -0.2, 0.05, 1.1, 0.3, 0.2, -0.25, 0.95;
  for (const Mat3& in : {m, Mat3(-m), Mat3(Mat3::Identity()), Mat3(-Mat3::Identity())}) {
    const Mat3 r = numen::sim::nearest_rotation(in);
    EXPECT_LT((r.transpose() * r - Mat3::Identity()).cwiseAbs().maxCoeff(), 1e-14);
    EXPECT_NEAR(r.determinant(), 1.0, 1e-14);
  }
  const Mat3 exact = Quat(Eigen::AngleAxisd(2.5, Vec3(0, 1, 1).normalized())).toRotationMatrix();
  EXPECT_LT((numen::sim::nearest_rotation(exact) - exact).cwiseAbs().maxCoeff(), 1e-14);
}

TEST(Jigsaws, QuaternionSignsAreContinuousAcrossBranchChanges) {
  // Rotation about z from 200° to 280°: Eigen's matrix → quaternion switches
  // branch at 240° (trace > 0) and flips sign there; the loader must not.
  std::string text;
  std::vector<Quat> raw;
  for (int i = 0; i <= 16; ++i) {
    auto rot = identity_rotations();
    rot[3] = Eigen::AngleAxisd((200.0 + 5.0 * i) * std::numbers::pi / 180.0, Vec3::UnitZ())
                 .toRotationMatrix();
    raw.emplace_back(rot[3]);
    text += join(tokens(make_row(i, rot)));
  }
  int raw_flips = 0;
  for (std::size_t i = 1; i < raw.size(); ++i) raw_flips += raw[i].dot(raw[i - 1]) < 0.0;
  ASSERT_GT(raw_flips, 0) << "the test data should make a naive conversion flip";
  const TempFile f("flip.txt", text);
  const auto rec = load_jigsaws(f.path(), JigsawsManipulator::slave_right);
  for (std::size_t i = 1; i < rec.trajectory.size(); ++i) {
    EXPECT_GT(rec.trajectory[i].pose.orientation.dot(rec.trajectory[i - 1].pose.orientation), 0.9)
        << i;
  }
  // The twist sees 5° per sample about z, not a 360° jump.
  const double rate = 5.0 * std::numbers::pi / 180.0 * 30.0;
  for (double t = 0.0; t < rec.trajectory.duration(); t += 0.01) {
    EXPECT_NEAR((rec.trajectory.twist_at(t).angular - Vec3(0, 0, rate)).norm(), 0.0, 1e-6) << t;
  }
}

TEST(Jigsaws, ManipulatorNames) {
  for (int m = 0; m < 4; ++m) {
    const auto manipulator = static_cast<JigsawsManipulator>(m);
    EXPECT_EQ(numen::sim::parse_jigsaws_manipulator(numen::sim::to_string(manipulator)),
              manipulator);
  }
  try {
    numen::sim::parse_jigsaws_manipulator("slave_middle", "scene.instrument.manipulator");
    FAIL() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.key(), "scene.instrument.manipulator");
    EXPECT_NE(std::string(e.what()).find("slave_right"), std::string::npos);
  }
}

}  // namespace

// ---------------------------------------------------------------- plausibility and messages (issue 17)

TEST(JigsawsMalformed, ATipFartherThan10mIsLocatedAtItsColumn) {
  for (const char* far : {"1000", "1e100", "1e308", "-1.79e308"}) {
    SCOPED_TRACE(far);
    auto t = tokens(make_row(1, identity_rotations()));
    t[58] = far;  // data column 59: slave right tip y
    const TempFile f("far.txt", valid_lines(2) + join(t) + valid_lines(1));
    const InputError e = expect_error(f.path(), 3);
    EXPECT_EQ(e.column(), trial_column(t, 58));
    EXPECT_EQ(e.key(), "slave_right.tip_y");
    const std::string what = e.what();
    EXPECT_NE(what.find("data columns 58-60 of 76: tip position"), std::string::npos) << what;
    EXPECT_NE(what.find("beyond 10 m"), std::string::npos) << what;
    EXPECT_LT(what.size(), 400u) << "no number printed in full: " << what;
  }
  // An arm that is not taken is checked too: a corrupt row is a corrupt file.
  auto t = tokens(make_row(0, identity_rotations()));
  t[0] = "-20";  // master left tip x
  const TempFile g("far_master.txt", join(t) + valid_lines(1));
  EXPECT_EQ(expect_error(g.path(), 1).key(), "master_left.tip_x");
  // 10 m exactly is still accepted (the limit is inclusive), 9.9 m anywhere too.
  t[0] = "9.9";
  const TempFile h("near.txt", join(t) + valid_lines(1));
  EXPECT_EQ(load_jigsaws(h.path(), JigsawsManipulator::master_left).trajectory.size(), 2u);
}

TEST(JigsawsMalformed, ADirectoryIsNamedAsSuchWithoutLibraryInternals) {
  const numen::test::TempDir temp;
  const fs::path& dir = temp.path();
  try {
    load_jigsaws(dir, JigsawsManipulator::slave_right);
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_EQ(e.file(), dir.string());
    EXPECT_NE(what.find("is a directory"), std::string::npos) << what;
    EXPECT_EQ(what.find("basic_filebuf"), std::string::npos) << what;
  } catch (const std::exception& e) {
    ADD_FAILURE() << "not an InputError: " << e.what();
  }
}

TEST(JigsawsMalformed, ANulByteIsShownAndDoesNotCutTheMessage) {
  auto t = tokens(make_row(0, identity_rotations()));
  t[60] = std::string("0.1\0" "2", 5);  // data column 61: slave right R11
  const TempFile f("nul.txt", join(t) + valid_lines(1));
  const InputError e = expect_error(f.path(), 1);
  const std::string what = e.what();
  // what() is a C string: everything up to the end of the message must be before its NUL.
  EXPECT_EQ(std::string(e.what(), std::strlen(e.what())), what);
  EXPECT_EQ(what.find('\0'), std::string::npos);
  EXPECT_NE(what.find("'0.1\\x002' (it holds a NUL byte) is not a number"), std::string::npos) << what;
}

TEST(Jigsaws, AUtf8ByteOrderMarkAtTheStartIsSkipped) {
  const std::string text = valid_lines(3);
  const TempFile f("bom.txt", "\xEF\xBB\xBF" + text);
  const TempFile g("plain.txt", text);
  const auto a = load_jigsaws(f.path(), JigsawsManipulator::slave_right).trajectory;
  const auto b = load_jigsaws(g.path(), JigsawsManipulator::slave_right).trajectory;
  ASSERT_EQ(a.size(), 3u);
  EXPECT_EQ(a[0].pose.position, b[0].pose.position);
  // Anywhere else it is named, not shown as an invisible character.
  const TempFile h("bom_inside.txt", text + "\xEF\xBB\xBF" + text);
  const InputError e = expect_error(h.path(), 4);
  const std::string what = e.what();
  EXPECT_EQ(e.column(), 1);
  EXPECT_NE(what.find("'\\xEF\\xBB\\xBF"), std::string::npos) << what;
  EXPECT_NE(what.find("UTF-8 byte order mark"), std::string::npos) << what;
}
