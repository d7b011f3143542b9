/// @file thread_band.cpp
/// Block band Cholesky of a thread's implicit system (detail/thread_band.hpp).

#include "detail/thread_band.hpp"

#include <Eigen/Cholesky>

namespace numen::core {

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

void ThreadBand::add(int i, int j, const Mat3& m) noexcept {
  if (i == j) {
    diag[static_cast<std::size_t>(i)] += m;
  } else if (i > j) {
    (i - j == 1 ? lower1 : lower2)[static_cast<std::size_t>(i)] += m;
  } else {
    (j - i == 1 ? lower1 : lower2)[static_cast<std::size_t>(j)] += m.transpose();
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
    const Eigen::LLT<Mat3> llt(d);
    if (llt.info() != Eigen::Success) return false;
    diag[i] = llt.matrixL().solve(Mat3::Identity());
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
