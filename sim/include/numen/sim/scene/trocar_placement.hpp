#pragma once
/// @file trocar_placement.hpp
/// Where to put the trocar (remote centre of motion, RCM) of a scene so that a
/// recorded instrument motion can pass through it. Two estimators:
///
/// - least_squares_axis_intersection(): the point closest, in the least-squares
///   sense, to all recorded tool axes. Exact when every recorded axis goes
///   through one point (recovered to 1e-9 m on synthetic data). On JIGSAWS
///   slave (PSM) data it is poor: the recorded rotation is that of the tip
///   frame, after the wrist, so none of its axes is the shaft. On the shipped
///   excerpt (Suturing_B002 rows 1056–1955, slave right) the rms distance from
///   the fitted point to the axes is 12.8 mm for the tip x axis (the point
///   lands inside the workspace, 12 mm from the tip centroid), 31.4 mm for y
///   and 26.4 mm for z (see sim/data/README.md).
/// - trocar_from_approach(): centroid of the tip positions moved back by a
///   standoff along the mean approach direction (mean tip z axis). It does not
///   need the axes to meet, always puts the trocar outside the workspace on
///   the side the instrument comes from, at an insertion depth the scene
///   chooses, and is stable on short excerpts. On the excerpt its rms distance
///   to the z axes is 26.6 mm at a 5 cm standoff, as good as the least-squares
///   z fit (26.4 mm), which lies 4.4 cm behind the centroid along the same
///   direction. **Scenes use trocar_from_approach()**; the least-squares
///   intersection is kept as a diagnostic and for synthetic data.
///
/// Frames: the trajectory's (recording) frame; move the result with apply()
/// from trajectory.hpp together with the trajectory. Units m. Load time only
/// (may throw InputError, with file and line 0).

#include <cstddef>

#include "numen/core/types.hpp"
#include "numen/sim/input/trajectory.hpp"

namespace numen::sim {

/// Result of least_squares_axis_intersection().
struct AxisIntersection {
  core::Vec3 point = core::Vec3::Zero();  ///< Point nearest to all tool axes (m, trajectory frame).
  double rms_residual = 0.0;  ///< Root mean square distance from `point` to the axes (m).
  double max_residual = 0.0;  ///< Largest distance from `point` to an axis (m).
  /// Smallest eigenvalue of (1/n) Σ (I − d dᵀ) (unitless, in [0, 1]): how well
  /// the axis directions d constrain the point; near 0 = nearly parallel axes.
  double conditioning = 0.0;
  std::size_t samples = 0;  ///< Number of axes used (one per sample).
};

/// Least-squares intersection of the tool axes of `trajectory`: the lines
/// through each sample's tip position p_i along the column `axis_column`
/// (0 = x, 1 = y, 2 = z) of its rotation matrix, d_i. Minimises
/// Σ |(I − d_i d_iᵀ)(x − p_i)|², i.e. solves Σ (I − d_i d_iᵀ) x = Σ (I − d_i d_iᵀ) p_i.
/// Throws InputError (key "trocar.axis_column") if axis_column is not 0, 1 or
/// 2, ("trocar.trajectory") if the trajectory is empty or its axes are all
/// (nearly) parallel (conditioning < 1e-10), so that the point is undefined.
AxisIntersection least_squares_axis_intersection(const Trajectory& trajectory, int axis_column);

/// Result of trocar_from_approach().
struct ApproachTrocar {
  core::Vec3 point = core::Vec3::Zero();     ///< Trocar / RCM (m, trajectory frame).
  core::Vec3 centroid = core::Vec3::Zero();  ///< Mean tip position (m).
  /// Unit mean of the tip frame's z axis over the samples: the approach
  /// direction, from the trocar toward the workspace (unitless).
  core::Vec3 approach = core::Vec3::UnitZ();
  /// Length of the (unnormalised) mean z axis, in [0, 1]: 1 = the tip z axis
  /// never changes direction, small = it wanders (unitless).
  double approach_consistency = 0.0;
  /// Root mean square distance from `point` to the recorded tool z axes (m):
  /// the same measure as AxisIntersection::rms_residual, for comparison.
  double rms_axis_distance = 0.0;
  double min_depth = 0.0;  ///< Smallest distance from `point` to a tip position (m).
  double max_depth = 0.0;  ///< Largest distance from `point` to a tip position (m).
};

/// Trocar placed behind the recorded workspace: centroid of the tip positions
/// − standoff_m · (normalised mean of the tip frame's z axis). The standoff is
/// the insertion depth of the centroid (m; JIGSAWS suturing motion spans
/// ~8 cm, so 0.10–0.15 m is a laparoscopic-looking choice). This is the
/// estimator the scenes use (see the file comment for why).
/// Throws InputError (key "trocar.standoff") if standoff_m is not finite and
/// >= 0, ("trocar.trajectory") if the trajectory is empty or its z axes
/// average to (nearly) zero (|mean| < 1e-6).
ApproachTrocar trocar_from_approach(const Trajectory& trajectory, double standoff_m);

}  // namespace numen::sim
