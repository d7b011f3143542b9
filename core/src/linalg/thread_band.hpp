#pragma once
/// @file thread_band.hpp
/// A symmetric positive definite block-banded system of 3×3 blocks with block bandwidth 2
/// (block i couples blocks i − 2 … i + 2): the implicit step of a thread (thread.hpp), whose
/// stretch springs couple neighbouring nodes and whose bend terms couple nodes two apart. Solved
/// by its block Cholesky factor L Lᵀ in place, O(n) (Golub & Van Loan, "Matrix Computations",
/// 4th ed., §4.3.5, band Cholesky, here by 3×3 blocks). Sized once; no allocation afterwards.

#include <algorithm>
#include <cstdlib>
#include <vector>

#include "numen/core/types.hpp"

namespace numen::core {

/// The lower half of the matrix and the right-hand side, then (solve()) the factor and solution.
struct ThreadBand {
  std::vector<Mat3> diag;   ///< A(i, i).
  std::vector<Mat3> lower1; ///< A(i, i − 1) (entry 0 unused).
  std::vector<Mat3> lower2; ///< A(i, i − 2) (entries 0, 1 unused).
  std::vector<Vec3> rhs;    ///< b, then the solution x of A x = b.

  /// Sizes it for `blocks` blocks (load time).
  void resize(int blocks);
  /// Zeroes the matrix and the right-hand side. No allocation.
  void clear() noexcept;
  /// The stored block that holds A(i, j), |i − j| ≤ 2, or its transpose: the lower half's, on
  /// row max(i, j).
  Mat3& lower_block(int i, int j) noexcept {
    const int d = std::abs(i - j);
    return (d == 0 ? diag : d == 1 ? lower1 : lower2)[static_cast<std::size_t>(std::max(i, j))];
  }
  /// Adds `m` to A(i, j) (and mᵀ to A(j, i)), |i − j| ≤ 2; i == j adds m to the diagonal.
  /// Inline: the thread's step calls it for every term of every Newton iteration.
  void add(int i, int j, const Mat3& m) noexcept {
    if (i >= j)
      lower_block(i, j) += m;
    else
      lower_block(i, j) += m.transpose();
  }
  /// Adds `s` times the identity to A(i, j) (and to A(j, i)), |i − j| ≤ 2: add(i, j, s I) on the
  /// three diagonal entries only (the others would gain a zero).
  void add_identity(int i, int j, double s) noexcept {
    Mat3& m = lower_block(i, j);
    m(0, 0) += s;
    m(1, 1) += s;
    m(2, 2) += s;
  }
  /// Factors A = L Lᵀ and overwrites rhs with A⁻¹ b. false if a pivot block is not positive
  /// definite (rhs is then unspecified). No allocation.
  bool solve() noexcept;
};

}  // namespace numen::core
