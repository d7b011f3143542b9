#pragma once
/// @file jigsaws.hpp
/// Loader of JIGSAWS kinematics files: real da Vinci motion recorded at 30 Hz,
/// the default "tracked instrument" input of demos and studies.
///
/// Source: Gao et al., 2014, "JHU-ISI Gesture and Skill Assessment Working Set
/// (JIGSAWS): A Surgical Activity Dataset for Human Motion Modeling", MICCAI
/// M2CAI workshop; data by Johns Hopkins University and Intuitive Surgical Inc.
///
/// File format: plain text, one row per sample (30 Hz), no header, exactly 76
/// whitespace-separated finite numbers per row, SI units. Four groups of 19
/// columns (1-based): 1–19 master left (MTM), 20–38 master right, 39–57 slave
/// left (PSM), 58–76 slave right. Within a group: 1–3 tool tip position xyz
/// (m), 4–12 rotation matrix of the tip frame, row-major (R11 R12 R13 R21 …
/// R33), 13–15 linear velocity (m/s), 16–18 angular velocity (rad/s), 19
/// gripper angle (rad). Positions and rotations are in the frame of the
/// recording, which the dataset does not describe further (here called the
/// recording frame); use transformed() to place them in a scene's world.
///
/// Load time only: allocates and throws InputError.

#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "numen/core/types.hpp"
#include "numen/sim/input/trajectory.hpp"

namespace numen::sim {

/// Sampling rate of JIGSAWS kinematics (Hz).
inline constexpr double kJigsawsRateHz = 30.0;
/// Number of columns of a JIGSAWS kinematics row.
inline constexpr int kJigsawsColumns = 76;

/// Which of the four recorded arms to read.
enum class JigsawsManipulator {
  master_left,   ///< Columns 1–19: left hand controller (MTM), what a tracked device reports.
  master_right,  ///< Columns 20–38: right hand controller (MTM).
  slave_left,    ///< Columns 39–57: left patient-side instrument (PSM), pivots about a trocar.
  slave_right,   ///< Columns 58–76: right patient-side instrument (PSM).
};

/// Name of `m` as used in scene files and error keys: "master_left",
/// "master_right", "slave_left" or "slave_right".
std::string_view to_string(JigsawsManipulator m) noexcept;

/// Parses one of the names of to_string(). Throws InputError (no file or
/// line, key `key`) listing the valid names otherwise.
JigsawsManipulator parse_jigsaws_manipulator(std::string_view name,
                                             const std::string& key = "manipulator");

/// Which rows of the file to take. Rows are counted from 1 (row r is line r of
/// the file, at time (r − 1) / 30 s from the start of the recording).
struct JigsawsOptions {
  std::size_t first_row = 1;  ///< 1-based row of the first sample taken (>= 1).
  std::size_t max_rows = 0;   ///< Maximum number of rows taken; 0 = up to the end of the file.
  /// Alternative to first_row (s from the start of the recording): the first
  /// row taken is round(start_time · 30) + 1. Giving both (first_row != 1) is an error.
  std::optional<double> start_time;
  /// Alternative to max_rows (s from the start of the recording, inclusive):
  /// the last row taken is round(end_time · 30) + 1, or the last row of the
  /// file. Giving both (max_rows != 0) is an error.
  std::optional<double> end_time;
};

/// The recorded samples of one manipulator, at 30 Hz.
struct JigsawsRecording {
  std::string file;                  ///< Path of the file, as given.
  JigsawsManipulator manipulator{};  ///< Which arm.
  std::size_t first_row = 1;         ///< 1-based row of the file of sample 0.
  std::size_t file_rows = 0;         ///< Number of rows in the whole file.
  /// Time of sample 0 from the start of the recording (s): (first_row − 1) / 30.
  double start_time_in_file = 0.0;
  /// The tip frame samples at period 1/30 s, time 0 at `first_row`: positions
  /// (m) as recorded, rotations re-orthonormalised (nearest rotation) and
  /// converted to quaternions with sign continuity, gripper angle as jaw (rad).
  Trajectory trajectory;
  /// Velocity columns 13–18 of the group as recorded (m/s, rad/s), one per
  /// sample. The dataset documents no frame for them and they do not match
  /// finite differences of the poses sample by sample (they look filtered);
  /// kept for reference only. Trajectory::twist_at() is what the loop uses.
  std::vector<core::Twist> recorded_twist;
  /// Largest |RᵀR − I| entry of the rotation matrices taken, before
  /// re-orthonormalisation (unitless): ~1e-3 for the masters, ~4e-6 for the slaves.
  double max_orthonormality_error = 0.0;
};

/// Nearest rotation matrix to `m` in the Frobenius norm (polar decomposition
/// by SVD, m = U Σ Vᵀ → U diag(1, 1, det(U Vᵀ)) Vᵀ): orthonormal to rounding
/// and det = +1. Source: Higham, "Computing the polar decomposition", 1986.
core::Mat3 nearest_rotation(const core::Mat3& m) noexcept;

/// Reads the samples of `manipulator` from the JIGSAWS kinematics file `path`.
/// Every row of the file is checked (not only those taken): it must hold
/// exactly 76 finite numbers; the tip position of every arm must lie within
/// kMaxTargetDistance (10 m) of the recording frame's origin; blank lines are
/// allowed only at the end of the file; a rotation matrix must be within 0.1
/// of a rotation (singular values) with det > 0. A UTF-8 byte order mark at
/// the start of the file is skipped (columns of line 1 count after it). Each
/// rotation is replaced by nearest_rotation() and converted to a quaternion;
/// quaternion signs are made continuous. Tokens quoted in messages show every
/// byte that is not printable ASCII as \xNN and name a BOM or a NUL byte.
/// Throws InputError with the file, the 1-based line and character column, the
/// key "<manipulator>.<field>" of the bad column (e.g. "slave_right.R21") and
/// a message naming the 1-based data column and what is wrong — for a missing
/// or unreadable file, a directory, an empty file, a wrong column count, a
/// token that is not a number or not finite, a tip beyond 10 m (key
/// "<manipulator>.tip_<x|y|z>" of its largest coordinate), a matrix far from
/// a rotation, and options out of range (key "options.<field>").
JigsawsRecording load_jigsaws(const std::filesystem::path& path, JigsawsManipulator manipulator,
                              const JigsawsOptions& options = {});

/// Path of the excerpt shipped with numen (sim/data/jigsaws_suturing_b002_excerpt.txt:
/// rows 1056–1955 of Suturing_B002, 900 rows, 30 s; see sim/data/README.md),
/// so that demos run without the full dataset.
std::filesystem::path jigsaws_excerpt_path();

}  // namespace numen::sim
