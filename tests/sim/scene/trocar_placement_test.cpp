// Tests of sim/trocar_placement: the least-squares axis intersection recovers a
// known trocar from synthetic motion through it; the approach-based placement
// follows its formula; figures on the real excerpt are printed and bounded.
#include "numen/sim/scene/trocar_placement.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <numbers>
#include <random>
#include <vector>

#include "numen/sim/input/input_error.hpp"
#include "numen/sim/input/jigsaws.hpp"

namespace {

using numen::core::Mat3;
using numen::core::Pose;
using numen::core::Quat;
using numen::core::Vec3;
using numen::sim::InputError;
using numen::sim::Trajectory;

/// Motion of an instrument pivoting about `trocar`: tool axis (column
/// `axis_column` of the tip rotation) through the trocar, random directions in
/// a 35° cone about `mean_dir`, random insertion depth and roll about the axis.
Trajectory pivoting(const Vec3& trocar, const Vec3& mean_dir, int axis_column, std::size_t n,
                    unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  std::vector<Pose> poses(n);
  const Vec3 m = mean_dir.normalized();
  for (std::size_t i = 0; i < n; ++i) {
    Vec3 tilt(uni(rng), uni(rng), uni(rng));
    tilt -= tilt.dot(m) * m;
    const Vec3 d = (Quat(Eigen::AngleAxisd(0.6 * uni(rng), tilt.normalized())) * m).normalized();
    const double depth = 0.12 + 0.04 * uni(rng);
    // Frame with column `axis_column` = d, rolled by a random angle about d.
    Mat3 r = numen::core::rotation_between(Vec3::Unit(axis_column), d).toRotationMatrix();
    r = Eigen::AngleAxisd(3.0 * uni(rng), d).toRotationMatrix() * r;
    poses[i].position = trocar + depth * d;
    poses[i].orientation = Quat(r);
  }
  return Trajectory(1.0 / 30, std::move(poses));
}

TEST(TrocarPlacement, LeastSquaresRecoversAKnownTrocar) {
  const Vec3 trocar(0.1, -0.05, 0.2);
  for (int axis = 0; axis < 3; ++axis) {
    const Trajectory tr = pivoting(trocar, Vec3(0.3, -0.5, -0.8), axis, 300, 7u + axis);
    ASSERT_NEAR(tr[5]
                    .pose.orientation.toRotationMatrix()
                    .col(axis)
                    .cross(tr[5].pose.position - trocar)
                    .norm(),
                0.0, 1e-12);
    const auto fit = numen::sim::least_squares_axis_intersection(tr, axis);
    EXPECT_NEAR((fit.point - trocar).norm(), 0.0, 1e-9) << axis;
    EXPECT_LT(fit.rms_residual, 1e-9) << axis;
    EXPECT_LT(fit.max_residual, 1e-9) << axis;
    EXPECT_EQ(fit.samples, 300u);
    EXPECT_GT(fit.conditioning, 0.01);
    // With the wrong column the axes do not meet: a large residual.
    const auto wrong = numen::sim::least_squares_axis_intersection(tr, (axis + 1) % 3);
    EXPECT_GT(wrong.rms_residual, 1e-3) << axis;
  }
}

TEST(TrocarPlacement, LeastSquaresToleratesNoise) {
  const Vec3 trocar(-0.02, 0.03, 0.0);
  std::vector<Pose> poses;
  const Trajectory clean = pivoting(trocar, Vec3(0, 0, -1), 2, 500, 3u);
  std::mt19937 rng(11);
  std::normal_distribution<double> noise(0.0, 1e-3);  // 1 mm on the tip
  for (std::size_t idx = 0; idx < clean.size(); ++idx) {
    const auto s = clean[idx];
    Pose p = s.pose;
    p.position += Vec3(noise(rng), noise(rng), noise(rng));
    poses.push_back(p);
  }
  const auto fit = numen::sim::least_squares_axis_intersection(Trajectory(1.0 / 30, poses), 2);
  EXPECT_LT((fit.point - trocar).norm(), 2e-3);
  EXPECT_GT(fit.rms_residual, 0.5e-3);
  EXPECT_LT(fit.rms_residual, 2e-3);
}

TEST(TrocarPlacement, FromApproachFollowsItsFormula) {
  const Vec3 trocar(0.1, -0.05, 0.2);
  const Trajectory tr = pivoting(trocar, Vec3(0.3, -0.5, -0.8), 2, 300, 5u);
  Vec3 centroid = Vec3::Zero(), mean_z = Vec3::Zero();
  for (std::size_t idx = 0; idx < tr.size(); ++idx) {
    const auto s = tr[idx];
    centroid += s.pose.position / 300.0;
    mean_z += s.pose.orientation.toRotationMatrix().col(2) / 300.0;
  }
  const double standoff = 0.12;
  const auto placed = numen::sim::trocar_from_approach(tr, standoff);
  EXPECT_NEAR((placed.centroid - centroid).norm(), 0.0, 1e-14);
  EXPECT_NEAR((placed.approach - mean_z.normalized()).norm(), 0.0, 1e-14);
  EXPECT_NEAR((placed.point - (centroid - standoff * mean_z.normalized())).norm(), 0.0, 1e-14);
  EXPECT_NEAR(placed.approach_consistency, mean_z.norm(), 1e-14);
  // With axes through a trocar and the mean depth as standoff, it lands near it.
  const double mean_depth = (centroid - trocar).dot(mean_z.normalized());
  const auto near = numen::sim::trocar_from_approach(tr, mean_depth);
  EXPECT_LT((near.point - trocar).norm(), 0.02);
  EXPECT_LE(near.min_depth, near.max_depth);
  EXPECT_EQ(numen::sim::trocar_from_approach(tr, 0.0).point, placed.centroid);
}

TEST(TrocarPlacement, BadInput) {
  std::vector<Pose> parallel(10);
  for (int i = 0; i < 10; ++i) parallel[i].position = Vec3(0.01 * i, 0.0, 0.0);
  const Trajectory tr(0.1, parallel);  // all z axes parallel
  EXPECT_THROW(numen::sim::least_squares_axis_intersection(tr, 2), InputError);
  EXPECT_THROW(numen::sim::least_squares_axis_intersection(tr, 3), InputError);
  EXPECT_THROW(numen::sim::least_squares_axis_intersection(Trajectory{}, 2), InputError);
  EXPECT_THROW(numen::sim::trocar_from_approach(tr, -0.1), InputError);
  EXPECT_THROW(numen::sim::trocar_from_approach(Trajectory{}, 0.1), InputError);
  std::vector<Pose> opposite(2);
  opposite[1].orientation = Quat(Eigen::AngleAxisd(std::numbers::pi, Vec3::UnitX()));
  EXPECT_THROW(numen::sim::trocar_from_approach(Trajectory(0.1, opposite), 0.1), InputError);
}

TEST(TrocarPlacement, RealExcerptFigures) {
  // Not a pass/fail of the method: records what the two estimators give on the
  // shipped excerpt, and bounds them so a regression in loading shows up.
  const auto rec = numen::sim::load_jigsaws(numen::sim::jigsaws_excerpt_path(),
                                            numen::sim::JigsawsManipulator::slave_right);
  const auto& tr = rec.trajectory;
  for (int axis = 0; axis < 3; ++axis) {
    const auto fit = numen::sim::least_squares_axis_intersection(tr, axis);
    std::printf(
        "[ figures  ] slave_right LS intersection, tip axis %c: point (%.4f, %.4f, %.4f) m, "
        "rms %.1f mm, max %.1f mm, conditioning %.3f\n",
        "xyz"[axis], fit.point.x(), fit.point.y(), fit.point.z(), 1e3 * fit.rms_residual,
        1e3 * fit.max_residual, fit.conditioning);
    // Poor, as expected: the recorded rotation includes the wrist.
    EXPECT_GT(fit.rms_residual, 5e-3);
    EXPECT_LT(fit.rms_residual, 50e-3);
  }
  const auto z_fit = numen::sim::least_squares_axis_intersection(tr, 2);
  for (double standoff : {0.05, 0.10, 0.15}) {
    const auto placed = numen::sim::trocar_from_approach(tr, standoff);
    std::printf(
        "[ figures  ] slave_right trocar_from_approach(%.2f m): point (%.4f, %.4f, %.4f) m, "
        "approach (%.3f, %.3f, %.3f), consistency %.3f, rms axis distance %.1f mm, "
        "depth %.1f..%.1f mm\n",
        standoff, placed.point.x(), placed.point.y(), placed.point.z(), placed.approach.x(),
        placed.approach.y(), placed.approach.z(), placed.approach_consistency,
        1e3 * placed.rms_axis_distance, 1e3 * placed.min_depth, 1e3 * placed.max_depth);
    EXPECT_GT(placed.approach_consistency, 0.8);  // the tip z axis keeps a clear mean direction
    // No point is closer to all z axes than the least-squares one.
    EXPECT_GE(placed.rms_axis_distance, z_fit.rms_residual - 1e-12);
  }
  // The least-squares z intersection lies behind the workspace along the
  // approach direction: the sign convention of trocar_from_approach is right.
  const auto placed = numen::sim::trocar_from_approach(tr, 0.0);
  EXPECT_LT((z_fit.point - placed.centroid).dot(placed.approach), 0.0);
}

}  // namespace
