#pragma once
/// @file block_cholesky.hpp
/// Cholesky factorisation and solve of 6×6 symmetric positive definite blocks
/// (Golub & Van Loan, Matrix Computations, Alg. 4.2.1), with compile-time
/// loop bounds so that the compiler unrolls them: the implicit integrator's
/// block-Jacobi preconditioner and the articulation tree solve run these on
/// every body and joint node of every step. Header-only (inlined), noexcept,
/// no allocation.

#include <cmath>
#include <limits>

#include "numen/core/types.hpp"

namespace numen::core {

/// Cholesky factor A = L Lᵀ of a 6×6 symmetric positive definite block: the
/// lower triangle of `lower` holds L (the strict upper triangle is not used),
/// `inv_diag` holds 1 / L_kk. Applied by forward and back substitution.
struct BlockCholesky {
  Mat6 lower = Mat6::Identity();
  Vec6 inv_diag = Vec6::Ones();
};

/// A pivot below this fraction of its diagonal entry counts as not positive
/// (so that exactly dependent rows are caught despite round-off).
inline constexpr double kBlockPivotTolerance = 1e-12;

/// Factors in place the block whose lower triangle is in f.lower. Returns
/// false when a pivot is not positive (≤ kBlockPivotTolerance × its diagonal
/// entry, or the entry is not finite); the factor is then all NaN, so that
/// every solve with it is non-finite and the step's checks reject it.
inline bool factor_block_in_place(BlockCholesky& f) noexcept {
  Mat6& l = f.lower;
#pragma GCC unroll 6
  for (int j = 0; j < 6; ++j) {
    const double diag = l(j, j);
    double d = diag;
#pragma GCC unroll 6
    for (int k = 0; k < j; ++k) d -= l(j, k) * l(j, k);
    if (!(d > kBlockPivotTolerance * diag) || !(diag < std::numeric_limits<double>::infinity())) {
      l.setConstant(std::numeric_limits<double>::quiet_NaN());
      f.inv_diag.setConstant(std::numeric_limits<double>::quiet_NaN());
      return false;
    }
    const double ljj = std::sqrt(d);
    const double inv = 1.0 / ljj;
    l(j, j) = ljj;
    f.inv_diag(j) = inv;
#pragma GCC unroll 6
    for (int i = j + 1; i < 6; ++i) {
      double v = l(i, j);
#pragma GCC unroll 6
      for (int k = 0; k < j; ++k) v -= l(i, k) * l(j, k);
      l(i, j) = v * inv;
    }
  }
  return true;
}

/// Factors `a` (its lower triangle is read) into `f`. Same result as
/// factor_block_in_place().
inline bool factor_block(const Mat6& a, BlockCholesky& f) noexcept {
  f.lower = a;
  return factor_block_in_place(f);
}

/// z = A⁻¹ r = L⁻ᵀ L⁻¹ r by forward and back substitution; z may be r.
inline void solve_block(const BlockCholesky& f, const Vec6& r, Vec6& z) noexcept {
  const Mat6& l = f.lower;
  Vec6 y;
#pragma GCC unroll 6
  for (int i = 0; i < 6; ++i) {
    double v = r(i);
#pragma GCC unroll 6
    for (int k = 0; k < i; ++k) v -= l(i, k) * y(k);
    y(i) = v * f.inv_diag(i);
  }
#pragma GCC unroll 6
  for (int i = 5; i >= 0; --i) {
    double v = y(i);
#pragma GCC unroll 6
    for (int k = i + 1; k < 6; ++k) v -= l(k, i) * z(k);
    z(i) = v * f.inv_diag(i);
  }
}

}  // namespace numen::core
