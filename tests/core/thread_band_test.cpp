/// @file thread_band_test.cpp
/// The thread's block-banded solve (core/src/thread/thread_band.cpp, linalg/thread_band.hpp):
/// its in-place block Cholesky against Eigen's dense LLᵀ on the same matrix, add_identity() as
/// add() of a multiple of the identity, the refusal of a matrix that is not positive definite,
/// and no allocation.

#include <gtest/gtest.h>

#include <random>
#include <tuple>
#include <vector>

#include <Eigen/Dense>

#include "alloc_counter.hpp"
#include "linalg/thread_band.hpp"

namespace numen {
namespace {

using core::Mat3;
using core::Vec3;

/// A symmetric positive definite matrix of `blocks` 3×3 blocks with block bandwidth 2 (as a
/// thread's: stretch couples neighbours, bending nodes two apart), added block by block to
/// `band` and written whole into `dense`, with a right-hand side in both.
void random_band(int blocks, unsigned seed, core::ThreadBand& band, Eigen::MatrixXd& dense,
                 Eigen::VectorXd& rhs) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const auto random_mat = [&] {
    Mat3 m;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) m(r, c) = u(rng);
    return m;
  };
  band.resize(blocks);
  band.clear();
  dense = Eigen::MatrixXd::Zero(3 * blocks, 3 * blocks);
  rhs.resize(3 * blocks);
  for (int i = 0; i < blocks; ++i) {
    const Mat3 g = random_mat();
    // Positive definite by blocks (Gershgorin on blocks): the off-diagonal blocks' entries are
    // at most 1 and 0.5, so their norms at most 3 and 1.5, two of each per block row, against a
    // diagonal block of eigenvalues at least 20.
    const Mat3 d = g * g.transpose() + 20.0 * Mat3::Identity();
    band.add(i, i, d);
    dense.block<3, 3>(3 * i, 3 * i) += d;
    for (int k = 1; k <= 2 && i - k >= 0; ++k) {
      const Mat3 m = random_mat() / static_cast<double>(k);
      // Both orders of add(): A(i, i − k) and A(i − k, i) = its transpose.
      if ((i + k) % 2 == 0)
        band.add(i, i - k, m);
      else
        band.add(i - k, i, m.transpose());
      dense.block<3, 3>(3 * i, 3 * (i - k)) += m;
      dense.block<3, 3>(3 * (i - k), 3 * i) += m.transpose();
    }
    const Vec3 b(u(rng), u(rng), u(rng));
    band.rhs[static_cast<std::size_t>(i)] = b;
    rhs.segment<3>(3 * i) = b;
  }
}

TEST(ThreadBand, SolvesAsADenseCholeskyDoes) {
  for (const int blocks : {1, 2, 3, 5, 201}) {
    core::ThreadBand band;
    Eigen::MatrixXd dense;
    Eigen::VectorXd rhs;
    random_band(blocks, 7u + static_cast<unsigned>(blocks), band, dense, rhs);
    const Eigen::VectorXd expected = dense.llt().solve(rhs);
    ASSERT_TRUE(band.solve()) << blocks << " blocks";
    double err = 0.0;
    for (int i = 0; i < blocks; ++i)
      err = std::max(err, (band.rhs[static_cast<std::size_t>(i)] - expected.segment<3>(3 * i)).cwiseAbs().maxCoeff());
    EXPECT_LT(err, 1e-13 * expected.cwiseAbs().maxCoeff()) << blocks << " blocks";
    // And A x = b.
    Eigen::VectorXd x(3 * blocks);
    for (int i = 0; i < blocks; ++i) x.segment<3>(3 * i) = band.rhs[static_cast<std::size_t>(i)];
    EXPECT_LT((dense * x - rhs).cwiseAbs().maxCoeff(), 1e-12) << blocks << " blocks";
  }
}

TEST(ThreadBand, AddIdentityIsAddOfAMultipleOfTheIdentity) {
  core::ThreadBand a, b;
  a.resize(5);
  b.resize(5);
  a.clear();
  b.clear();
  for (const auto& [i, j, s] : {std::tuple{2, 2, 1.5}, std::tuple{3, 2, -0.25}, std::tuple{2, 4, 3.0},
                                std::tuple{1, 0, 2.0}, std::tuple{0, 2, -1.0}}) {
    a.add_identity(i, j, s);
    b.add(i, j, s * Mat3::Identity());
  }
  for (std::size_t k = 0; k < 5; ++k) {
    EXPECT_EQ(a.diag[k], b.diag[k]) << k;
    EXPECT_EQ(a.lower1[k], b.lower1[k]) << k;
    EXPECT_EQ(a.lower2[k], b.lower2[k]) << k;
  }
}

TEST(ThreadBand, RefusesAMatrixThatIsNotPositiveDefinite) {
  core::ThreadBand band;
  Eigen::MatrixXd dense;
  Eigen::VectorXd rhs;
  random_band(6, 3u, band, dense, rhs);
  // The fourth diagonal block's eigenvalues made at most 20 + 9 − 40 < 0: its pivot (the block
  // less a positive semidefinite part) is not positive definite.
  band.add(3, 3, -40.0 * Mat3::Identity());
  EXPECT_FALSE(band.solve());
}

TEST(ThreadBand, ClearAddAndSolveAllocateNothing) {
  core::ThreadBand band;
  Eigen::MatrixXd dense;
  Eigen::VectorXd rhs;
  random_band(201, 11u, band, dense, rhs);
  const std::vector<Mat3> diag = band.diag, lower1 = band.lower1, lower2 = band.lower2;
  const std::vector<Vec3> b = band.rhs;
  bool ok = false;
  {
    test::AllocationGuard guard;
    band.clear();
    for (int i = 0; i < 201; ++i) {
      const auto k = static_cast<std::size_t>(i);
      band.add(i, i, diag[k]);
      if (i >= 1) band.add(i, i - 1, lower1[k]);
      if (i >= 2) band.add(i, i - 2, lower2[k]);
      band.rhs[k] = b[k];
    }
    ok = band.solve();
    EXPECT_EQ(guard.count(), 0);
  }
  EXPECT_TRUE(ok);
}

}  // namespace
}  // namespace numen
