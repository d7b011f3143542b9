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

/// The triangular products below add their products in the order Eigen's fixed-size 3×3
/// products do under SSE2 (rows 0 and 1 of a matrix product as one packet, the products in
/// order; row 2 by its scalar reduction, a0 + (a1 + a2)) and leave out those with a structural
/// zero of the triangular block (adding an exact zero changes no sum): the step is the same to
/// the bit as with Eigen's general products, the solve of a 200-segment thread about 20 % faster
/// (99 multiplications a block in the factor instead of 135).
inline double sum_packet(double a0, double a1, double a2) noexcept { return (a0 + a1) + a2; }
inline double sum_scalar(double a0, double a1, double a2) noexcept { return a0 + (a1 + a2); }

/// A Lᵀ for a lower triangular L: column c sums k ≤ c.
inline Mat3 times_lower_transpose(const Mat3& a, const Mat3& l) noexcept {
  Mat3 m;
  for (int r = 0; r < 3; ++r) {
    m(r, 0) = a(r, 0) * l(0, 0);
    m(r, 1) = a(r, 0) * l(1, 0) + a(r, 1) * l(1, 1);
  }
  for (int r = 0; r < 2; ++r)
    m(r, 2) = sum_packet(a(r, 0) * l(2, 0), a(r, 1) * l(2, 1), a(r, 2) * l(2, 2));
  m(2, 2) = sum_scalar(a(2, 0) * l(2, 0), a(2, 1) * l(2, 1), a(2, 2) * l(2, 2));
  return m;
}

/// d −= A Aᵀ on d's lower half only (the half lower_cholesky_inverse() reads).
inline void subtract_gram_lower(Mat3& d, const Mat3& a) noexcept {
  for (int c = 0; c < 3; ++c) {
    for (int r = c; r < 2; ++r)
      d(r, c) -= sum_packet(a(r, 0) * a(c, 0), a(r, 1) * a(c, 1), a(r, 2) * a(c, 2));
    d(2, c) -= sum_scalar(a(2, 0) * a(c, 0), a(2, 1) * a(c, 1), a(2, 2) * a(c, 2));
  }
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
    if (i >= 2) lower2[i] = times_lower_transpose(lower2[i], diag[i - 2]);
    if (i >= 1) {
      Mat3 a = lower1[i];
      if (i >= 2) a.noalias() -= lower2[i] * lower1[i - 1].transpose();
      lower1[i] = times_lower_transpose(a, diag[i - 1]);
    }
    Mat3 d = diag[i];
    if (i >= 1) subtract_gram_lower(d, lower1[i]);
    if (i >= 2) subtract_gram_lower(d, lower2[i]);
    if (!lower_cholesky_inverse(d, diag[i])) return false;
  }
  for (std::size_t i = 0; i < n; ++i) {  // L y = b
    Vec3 b = rhs[i];
    if (i >= 1) b.noalias() -= lower1[i] * rhs[i - 1];
    if (i >= 2) b.noalias() -= lower2[i] * rhs[i - 2];
    const Mat3& l = diag[i];  // L(i,i)⁻¹, lower triangular
    rhs[i] = Vec3(l(0, 0) * b(0), l(1, 0) * b(0) + l(1, 1) * b(1),
                  sum_scalar(l(2, 0) * b(0), l(2, 1) * b(1), l(2, 2) * b(2)));
  }
  for (std::size_t k = n; k-- > 0;) {  // Lᵀ x = y
    Vec3 y = rhs[k];
    if (k + 1 < n) y.noalias() -= lower1[k + 1].transpose() * rhs[k + 1];
    if (k + 2 < n) y.noalias() -= lower2[k + 2].transpose() * rhs[k + 2];
    const Mat3& l = diag[k];
    rhs[k] = Vec3(sum_packet(l(0, 0) * y(0), l(1, 0) * y(1), l(2, 0) * y(2)),
                  l(1, 1) * y(1) + l(2, 1) * y(2), l(2, 2) * y(2));
  }
  return true;
}

}  // namespace numen::core
