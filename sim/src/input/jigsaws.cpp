/// @file jigsaws.cpp
/// JIGSAWS kinematics loader (see jigsaws.hpp): strict row parser, nearest
/// rotation, quaternions with sign continuity.

#include "numen/sim/input/jigsaws.hpp"

#include <Eigen/SVD>
#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <limits>
#include <optional>
#include <sstream>

#include "numen/hal/transport/line_reader.hpp"
#include "numen/sim/input/input_error.hpp"
#include "numen/sim/input/shipped_files.hpp"

namespace numen::sim {
namespace {

constexpr int kGroupColumns = 19;

/// Field names within a group of 19 columns, used in error keys.
constexpr std::array<std::string_view, kGroupColumns> kFieldNames = {
    "tip_x", "tip_y", "tip_z", "R11", "R12", "R13",     "R21",     "R22",     "R23",    "R31",
    "R32",   "R33",   "v_x",   "v_y", "v_z", "omega_x", "omega_y", "omega_z", "gripper"};

constexpr std::array<std::string_view, 4> kGroupNames = {"master_left", "master_right",
                                                         "slave_left", "slave_right"};

/// Longest line read, bytes: a row of 76 numbers is ~1.2 KB (the dataset's files); a longer
/// line is an error (it bounds the reader's buffer, hal::LineReader).
constexpr std::size_t kMaxLine = 65536;

/// Largest allowed distance of a singular value of a recorded rotation matrix from 1.
constexpr double kRotationTolerance = 0.1;

/// "<group>.<field>" of a 0-based data column.
std::string column_key(int column) {
  return std::string(kGroupNames[static_cast<std::size_t>(column / kGroupColumns)]) + "." +
         std::string(kFieldNames[static_cast<std::size_t>(column % kGroupColumns)]);
}

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

/// UTF-8 encoding of U+FEFF, the byte order mark some editors put at the start of a file.
constexpr std::string_view kUtf8Bom = "\xEF\xBB\xBF";

/// `token` in quotes, at most 40 bytes, with every byte that is not printable
/// ASCII written as \xNN (a number never holds one: the reader must see it),
/// and a note naming a byte order mark or a NUL byte if the token holds one.
std::string quoted(std::string_view token) {
  constexpr std::size_t kMax = 40;
  std::string s = "'" + InputError::visible(token.substr(0, kMax), true);
  if (token.size() > kMax) s += "...";
  s += "'";
  if (token.find(kUtf8Bom) != std::string_view::npos)
    s += " (it holds a UTF-8 byte order mark, U+FEFF)";
  else if (token.find('\0') != std::string_view::npos)
    s += " (it holds a NUL byte)";
  return s;
}

/// One data row, as parsed.
struct Row {
  std::array<double, kGroupColumns> group{};  ///< The 19 values of the manipulator taken.
  int line = 0;                               ///< 1-based line in the file.
  int rotation_column = 0;                    ///< 1-based character column of R11.
};

std::string format_number(double v) {
  std::ostringstream os;
  os.precision(6);
  os << v;
  return os.str();
}

/// Refuses a recorded tip position (data columns `first_column` + 0..2, 0-based) farther than
/// kMaxTargetDistance from the origin of the recording frame, located at its largest coordinate.
void check_tip(const std::string& file, int line, int first_column, const std::array<double, 3>& tip,
               const std::array<int, 3>& columns) {
  const core::Vec3 p(tip[0], tip[1], tip[2]);
  const double distance = p.stableNorm();  // no overflow for coordinates near DBL_MAX
  if (!(distance > kMaxTargetDistance)) return;
  Eigen::Index largest = 0;
  p.cwiseAbs().maxCoeff(&largest);
  const int column = first_column + static_cast<int>(largest);
  throw InputError(file, line, columns[static_cast<std::size_t>(largest)], column_key(column),
                   "data columns " + std::to_string(first_column + 1) + "-" +
                       std::to_string(first_column + 3) + " of 76: tip position (" +
                       format_number(tip[0]) + ", " + format_number(tip[1]) + ", " +
                       format_number(tip[2]) + ") m is " + format_number(distance) +
                       " m from the origin of the recording frame; beyond " +
                       format_number(kMaxTargetDistance) +
                       " m it is not instrument motion (a wrong unit or a corrupt file?)");
}

/// Checks the rotation matrix of a taken row and appends its pose, jaw and recorded twist;
/// sets `error` (and appends nothing) if the matrix is far from a rotation.
void take_row(const std::string& file, JigsawsManipulator manipulator, const Row& row,
              JigsawsRecording& rec, std::vector<core::Pose>& poses, std::vector<double>& jaw,
              std::optional<InputError>& error) {
  const int group_begin = static_cast<int>(manipulator) * kGroupColumns;
  const auto& g = row.group;
  core::Mat3 r;
  r << g[3], g[4], g[5], g[6], g[7], g[8], g[9], g[10], g[11];
  const double ortho = (r.transpose() * r - core::Mat3::Identity()).cwiseAbs().maxCoeff();
  const Eigen::JacobiSVD<core::Mat3> svd(r);
  const core::Vec3 sigma = svd.singularValues();
  const double det = r.determinant();
  if ((sigma.array() - 1.0).abs().maxCoeff() > kRotationTolerance || !(det > 0.0)) {
    error = InputError(file, row.line, row.rotation_column,
                       std::string(kGroupNames[static_cast<std::size_t>(manipulator)]) + ".rotation",
                       "data columns " + std::to_string(group_begin + 4) + "-" +
                           std::to_string(group_begin + 12) +
                           ": rotation matrix is not close to a rotation (singular values " +
                           format_number(sigma[0]) + " " + format_number(sigma[1]) + " " +
                           format_number(sigma[2]) + ", det " + format_number(det) + ")");
    return;
  }
  rec.max_orthonormality_error = std::max(rec.max_orthonormality_error, ortho);
  poses.push_back(core::Pose{core::Vec3(g[0], g[1], g[2]), core::Quat(nearest_rotation(r))});
  jaw.push_back(g[18]);
  core::Twist twist;
  twist.linear = core::Vec3(g[12], g[13], g[14]);
  twist.angular = core::Vec3(g[15], g[16], g[17]);
  rec.recorded_twist.push_back(twist);
}

}  // namespace

std::string_view to_string(JigsawsManipulator m) noexcept {
  return kGroupNames[static_cast<std::size_t>(m)];
}

JigsawsManipulator parse_jigsaws_manipulator(std::string_view name, const std::string& key) {
  for (std::size_t i = 0; i < kGroupNames.size(); ++i) {
    if (name == kGroupNames[i]) return static_cast<JigsawsManipulator>(i);
  }
  throw InputError("", 0, 0, key,
                   "unknown manipulator '" + std::string(name) +
                       "'; expected master_left, master_right, slave_left or slave_right");
}

core::Mat3 nearest_rotation(const core::Mat3& m) noexcept {
  const Eigen::JacobiSVD<core::Mat3> svd(m, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const core::Mat3& u = svd.matrixU();
  const core::Mat3& v = svd.matrixV();
  core::Vec3 d(1.0, 1.0, (u * v.transpose()).determinant() < 0.0 ? -1.0 : 1.0);
  return u * d.asDiagonal() * v.transpose();
}

std::filesystem::path jigsaws_excerpt_path() {
  return shipped_data_dir() / "data" / "jigsaws_suturing_b002_excerpt.txt";
}

JigsawsRecording load_jigsaws(const std::filesystem::path& path, JigsawsManipulator manipulator,
                              const JigsawsOptions& options) {
  const std::string file = path.string();
  auto option_error = [&](const std::string& field, const std::string& message) {
    return InputError(file, 0, 0, "options." + field, message);
  };

  // Rows to take, 1-based, inclusive; `last_row` may exceed the file.
  std::size_t first_row = options.first_row;
  std::size_t last_row = std::numeric_limits<std::size_t>::max();
  if (options.start_time) {
    if (options.first_row != 1)
      throw option_error("start_time", "give first_row or start_time, not both");
    const double t = *options.start_time;
    if (!std::isfinite(t) || t < 0.0 || t > 1e8) {
      throw option_error("start_time", "must be finite and >= 0 s, got " + format_number(t));
    }
    first_row = static_cast<std::size_t>(std::llround(t * kJigsawsRateHz)) + 1;
  }
  if (first_row < 1) throw option_error("first_row", "rows are counted from 1, got 0");
  if (options.end_time) {
    if (options.max_rows != 0)
      throw option_error("end_time", "give max_rows or end_time, not both");
    const double t = *options.end_time;
    if (!std::isfinite(t) || t < 0.0 || t > 1e8) {
      throw option_error("end_time", "must be finite and >= 0 s, got " + format_number(t));
    }
    last_row = static_cast<std::size_t>(std::llround(t * kJigsawsRateHz)) + 1;
    if (last_row < first_row) {
      throw option_error("end_time", "is before the start (" + format_number(t) + " s)");
    }
  } else if (options.max_rows != 0) {
    last_row = first_row + options.max_rows - 1;
  }

  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw InputError(file, 0, 0, "", "is a directory, not a JIGSAWS kinematics file");
  // Read one line at a time in a fixed buffer: memory holds the rows taken, never the file.
  std::optional<hal::LineReader> reader;
  try {
    reader.emplace(file, kMaxLine);
  } catch (const std::runtime_error&) {
    throw InputError(file, 0, 0, "", "cannot open the file");
  }

  const int group_begin = static_cast<int>(manipulator) * kGroupColumns;
  JigsawsRecording rec;
  std::vector<core::Pose> poses;
  std::vector<double> jaw;
  // The first rotation matrix far from a rotation: thrown after the whole file is read (the
  // column checks of every row come first, as does a start beyond the end of the file).
  std::optional<InputError> rotation_error;
  std::size_t file_rows = 0;
  int line_number = 0;
  int first_blank_line = 0;  // first blank line seen after the last data row
  // The tip position (columns 1-3 of each group) of the row being read, and their columns.
  std::array<double, 3> tip{};
  std::array<int, 3> tip_columns{};
  std::string_view line;
  bool cut = false;
  for (;;) {
    try {
      if (!reader->next(line, cut)) break;
    } catch (const std::runtime_error&) {  // a read error (EIO, ...)
      throw InputError(file, 0, 0, "", "cannot read the file");
    }
    ++line_number;
    // A UTF-8 byte order mark at the start of the file is an encoding marker, not data: skipped
    // (columns of line 1 are counted after it, as an editor shows them).
    if (line_number == 1 && line.substr(0, kUtf8Bom.size()) == kUtf8Bom) line.remove_prefix(kUtf8Bom.size());
    if (cut) {
      throw InputError(file, line_number, static_cast<int>(kMaxLine) + 1, "",
                       "line longer than " + std::to_string(kMaxLine) +
                           " characters; expected 76 numbers per line");
    }

    std::size_t c = 0;
    while (c < line.size() && is_space(line[c])) ++c;
    if (c == line.size()) {
      if (first_blank_line == 0) first_blank_line = line_number;
      continue;
    }
    if (first_blank_line != 0) {
      throw InputError(file, first_blank_line, 0, "",
                       "blank line inside the data; expected 76 numbers per line");
    }
    ++file_rows;
    const bool taken = file_rows >= first_row && file_rows <= last_row;
    Row row;
    row.line = line_number;
    int count = 0;
    while (c < line.size()) {
      const std::size_t start = c;
      while (c < line.size() && !is_space(line[c])) ++c;
      const std::string_view token = line.substr(start, c - start);
      const int column = static_cast<int>(start) + 1;
      if (count >= kJigsawsColumns) {
        throw InputError(
            file, line_number, column, "",
            "too many columns: found a 77th value " + quoted(token) + ", expected exactly 76");
      }
      double value = 0.0;
      const char* first = token.data();
      const char* last = token.data() + token.size();
      bool sign_ok = true;
      if (*first == '+') {  // from_chars rejects a leading '+'; allow one
        ++first;
        sign_ok = first != last && *first != '-' && *first != '+';
      }
      const auto [ptr, ec] = std::from_chars(first, last, value);
      const std::string where = "data column " + std::to_string(count + 1) + " of 76: ";
      if (!sign_ok || ptr != last || (ec != std::errc() && ec != std::errc::result_out_of_range)) {
        throw InputError(file, line_number, column, column_key(count),
                         where + quoted(token) + " is not a number");
      }
      if (ec == std::errc::result_out_of_range || !std::isfinite(value)) {
        throw InputError(file, line_number, column, column_key(count),
                         where + quoted(token) + " is not a finite number");
      }
      if (const int field = count % kGroupColumns; field < 3) {
        tip[static_cast<std::size_t>(field)] = value;
        tip_columns[static_cast<std::size_t>(field)] = column;
        if (field == 2) check_tip(file, line_number, count - 2, tip, tip_columns);
      }
      if (taken && count >= group_begin && count < group_begin + kGroupColumns) {
        row.group[static_cast<std::size_t>(count - group_begin)] = value;
        if (count == group_begin + 3) row.rotation_column = column;
      }
      ++count;
      while (c < line.size() && is_space(line[c])) ++c;
    }
    if (count != kJigsawsColumns) {
      throw InputError(
          file, line_number, static_cast<int>(line.size()) + 1, "",
          "too few columns: found " + std::to_string(count) + " values, expected exactly 76");
    }
    if (taken && !rotation_error) take_row(file, manipulator, row, rec, poses, jaw, rotation_error);
  }
  if (file_rows == 0) {
    throw InputError(file, 1, 0, "", "the file is empty; expected lines of 76 numbers");
  }
  if (first_row > file_rows) {
    throw option_error(options.start_time ? "start_time" : "first_row",
                       "starts at row " + std::to_string(first_row) + " but the file has " +
                           std::to_string(file_rows) + " rows");
  }
  if (rotation_error) throw *rotation_error;

  rec.file = file;
  rec.manipulator = manipulator;
  rec.first_row = first_row;
  rec.file_rows = file_rows;
  rec.start_time_in_file = static_cast<double>(first_row - 1) / kJigsawsRateHz;
  // The Trajectory constructor normalises and makes the quaternion signs continuous.
  rec.trajectory = Trajectory(1.0 / kJigsawsRateHz, std::move(poses), std::move(jaw));
  return rec;
}

}  // namespace numen::sim
