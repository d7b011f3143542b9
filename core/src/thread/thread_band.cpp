/// @file thread_band.cpp
/// Block band Cholesky of a thread's implicit system (linalg/thread_band.hpp).

#include "linalg/thread_band.hpp"

#include <cmath>

namespace numen::core {
namespace {

/// L⁻¹ of the Cholesky factor L Lᵀ = d of a symmetric 3×3 block (its lower half read), written
/// out: Eigen's general triangular solve took a fifth of a 200-segment step. false if d is not
/// positive definite.
bool lower_cholesky_inverse(const Mat3& d, Mat3& inverse) noexcept {
  const double a = d(0, 0);
  if (!(a > 0.0)) return false;
  const double l00 = std::sqrt(a);
  const double l10 = d(1, 0) / l00, l20 = d(2, 0) / l00;
  const double b = d(1, 1) - l10 * l10;
  if (!(b > 0.0)) return false;
  const double l11 = std::sqrt(b);
  const double l21 = (d(2, 1) - l20 * l10) / l11;
  const double c = d(2, 2) - l20 * l20 - l21 * l21;
  if (!(c > 0.0)) return false;
  const double l22 = std::sqrt(c);
  const double i00 = 1.0 / l00, i11 = 1.0 / l11, i22 = 1.0 / l22;
  const double i10 = -l10 * i00 * i11;
  inverse << i00, 0.0, 0.0,  //
      i10, i11, 0.0,         //
      -(l20 * i00 + l21 * i10) * i22, -l21 * i11 * i22, i22;
  return true;
}

}  // namespace

void ThreadBand::resize(int blocks) {
  const auto n = static_cast<std::size_t>(blocks);
  diag.assign(n, Mat3::Zero());
  lower1.assign(n, Mat3::Zero());
  lower2.assign(n, Mat3::Zero());
  rhs.assign(n, Vec3::Zero());
}

void ThreadBand::clear() noexcept {
  for (std::size_t i = 0; i < diag.size(); ++i) {
    diag[i].setZero();
    lower1[i].setZero();
    lower2[i].setZero();
    rhs[i].setZero();
  }
}

bool ThreadBand::solve() noexcept {
  // In place: diag[i] becomes L(i,i)⁻¹ (lower triangular), lower1/lower2 the factor's blocks.
  const std::size_t n = diag.size();
  for (std::size_t i = 0; i < n; ++i) {
    if (i >= 2) lower2[i] = lower2[i] * diag[i - 2].transpose();
    if (i >= 1) {
      Mat3 a = lower1[i];
      if (i >= 2) a.noalias() -= lower2[i] * lower1[i - 1].transpose();
      lower1[i] = a * diag[i - 1].transpose();
    }
    Mat3 d = diag[i];
    if (i >= 1) d.noalias() -= lower1[i] * lower1[i].transpose();
    if (i >= 2) d.noalias() -= lower2[i] * lower2[i].transpose();
    if (!lower_cholesky_inverse(d, diag[i])) return false;
  }
  for (std::size_t i = 0; i < n; ++i) {  // L y = b
    Vec3 b = rhs[i];
    if (i >= 1) b.noalias() -= lower1[i] * rhs[i - 1];
    if (i >= 2) b.noalias() -= lower2[i] * rhs[i - 2];
    rhs[i] = diag[i] * b;
  }
  for (std::size_t k = n; k-- > 0;) {  // Lᵀ x = y
    Vec3 y = rhs[k];
    if (k + 1 < n) y.noalias() -= lower1[k + 1].transpose() * rhs[k + 1];
    if (k + 2 < n) y.noalias() -= lower2[k + 2].transpose() * rhs[k + 2];
    rhs[k] = diag[k].transpose() * y;
  }
  return true;
}

}  // namespace numen::core
