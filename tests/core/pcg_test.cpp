// Tests of core/src/linalg/pcg.hpp: the one preconditioned conjugate-gradient
// kernel of the implicit solves, on a small system of its own.
#include "linalg/pcg.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include "alloc_counter.hpp"
#include "numen/core/types.hpp"

namespace detail = numen::core::detail;
using numen::core::Vec3;

namespace {

/// A x = b with A 3×3 SPD, Jacobi preconditioner, ‖r‖ / ‖b‖, on fixed-size
/// vectors: the shape of the core's systems in miniature.
struct JacobiSystem {
  Eigen::Matrix3d a;
  Vec3 b, x, r, z, p, ap;
  double alpha = 0.0;
  int applies = 0;

  void start() {
    x.setZero();
    r = b;
    z = r.cwiseQuotient(a.diagonal());
    p = z;
  }
  double apply() noexcept {
    ++applies;
    ap.noalias() = a * p;
    return p.dot(ap);
  }
  double advance(double step) noexcept {
    x += step * p;
    r -= step * ap;
    return r.norm() / b.norm();
  }
  double precondition() noexcept {
    z = r.cwiseQuotient(a.diagonal());
    return r.dot(z);
  }
  void direction(double beta) noexcept { p = z + beta * p; }
};

JacobiSystem spd_system() {
  JacobiSystem s;
  s.a << 4.0, 1.0, 0.5, 1.0, 3.0, 0.2, 0.5, 0.2, 2.0;
  s.b << 1.0, -2.0, 0.5;
  s.start();
  return s;
}

}  // namespace

TEST(Pcg, SolvesAnSpdSystemInAtMostItsDimensionAllocationFree) {
  JacobiSystem s = spd_system();
  const detail::PcgStop stop{1e-12, 50};
  detail::PcgResult res;
  {
    numen::test::AllocationGuard guard;
    res = detail::pcg(s, 1.0, s.r.dot(s.z), stop);
    EXPECT_EQ(guard.count(), 0);
  }
  EXPECT_TRUE(res.finite);
  EXPECT_TRUE(res.converged(stop));
  EXPECT_LE(res.iterations, 3);  // exact arithmetic: n = 3 iterations at most
  EXPECT_EQ(res.iterations, s.applies);
  EXPECT_LE(res.residual, 1e-12);
  const Vec3 exact = s.a.ldlt().solve(s.b);
  EXPECT_LT((s.x - exact).norm(), 1e-10 * exact.norm());
}

TEST(Pcg, StopsOnTheIterationBudgetAndReportsTheResidualReached) {
  JacobiSystem s = spd_system();
  const detail::PcgStop stop{1e-14, 1};
  const detail::PcgResult res = detail::pcg(s, 1.0, s.r.dot(s.z), stop);
  EXPECT_EQ(res.iterations, 1);
  EXPECT_TRUE(res.finite);
  EXPECT_FALSE(res.converged(stop));
  EXPECT_NEAR(res.residual, s.r.norm() / s.b.norm(), 0.0);
  EXPECT_GT(res.residual, 1e-14);
}

TEST(Pcg, AStartThatMeetsTheRuleRunsNoIteration) {
  JacobiSystem s = spd_system();
  const detail::PcgStop stop{1e-6, 50};
  const detail::PcgResult res = detail::pcg(s, 1e-7, 1.0, stop);
  EXPECT_EQ(res.iterations, 0);
  EXPECT_EQ(s.applies, 0);
  EXPECT_TRUE(res.converged(stop));
}

TEST(Pcg, EveryNonFiniteQuantityEndsTheSolveAsNonFinite) {
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  const detail::PcgStop stop{1e-12, 50};
  {  // non-finite start
    JacobiSystem s = spd_system();
    const detail::PcgResult res = detail::pcg(s, kNaN, 1.0, stop);
    EXPECT_FALSE(res.finite);
    EXPECT_TRUE(std::isnan(res.residual));
    EXPECT_EQ(s.applies, 0);
  }
  {  // non-finite operator: pᵀAp is NaN
    JacobiSystem s = spd_system();
    s.a(1, 1) = kNaN;
    const detail::PcgResult res = detail::pcg(s, 1.0, s.r.dot(s.z), stop);
    EXPECT_FALSE(res.finite);
    EXPECT_FALSE(res.converged(stop));
    EXPECT_TRUE(std::isnan(res.residual));
  }
  {  // infinite right-hand side: the start's rᵀz
    JacobiSystem s = spd_system();
    s.b(0) = std::numeric_limits<double>::infinity();
    s.start();
    const detail::PcgResult res = detail::pcg(s, 1.0, s.r.dot(s.z), stop);
    EXPECT_FALSE(res.finite);
  }
}

TEST(Pcg, BreaksDownWithoutPositiveCurvature) {
  JacobiSystem s = spd_system();
  s.a = -s.a;                        // negative definite: pᵀAp < 0 at once
  s.a.diagonal() = -s.a.diagonal();  // keep the preconditioner positive
  s.a(0, 0) = -100.0;
  s.start();
  s.p << 1.0, 0.0, 0.0;
  const detail::PcgStop stop{1e-12, 50};
  const detail::PcgResult res = detail::pcg(s, 1.0, 1.0, stop);
  EXPECT_TRUE(res.finite);
  EXPECT_EQ(res.iterations, 1);
  EXPECT_EQ(res.residual, 1.0);  // nothing advanced
  EXPECT_TRUE(s.x.isZero(0.0));
}

namespace {

/// A x = b with A n×n SPD (a 1-D Laplacian with a varying shift: κ of a few hundred),
/// Jacobi preconditioner, for the error rule: records every iterate so that the
/// test can measure the true energy-norm error of each. All storage sized before
/// the solve.
struct LaplacianSystem {
  static constexpr int kN = 40;
  static constexpr int kMaxIterates = 201;  // x_0 … x_200
  Eigen::MatrixXd a;
  Eigen::VectorXd b, x, r, z, p, ap;
  Eigen::MatrixXd iterates;  // column k: x_k
  int k = 0;

  LaplacianSystem() : a(Eigen::MatrixXd::Zero(kN, kN)), iterates(kN, kMaxIterates) {
    for (int i = 0; i < kN; ++i) {
      a(i, i) = 2.0 + 0.01 * (1.0 + std::sin(0.7 * i)) + (i % 5 == 0 ? 1.0 : 0.0);
      if (i + 1 < kN) a(i, i + 1) = a(i + 1, i) = -1.0;
    }
    b.resize(kN);
    for (int i = 0; i < kN; ++i) b(i) = std::cos(0.3 * i) + 0.5;
    x = Eigen::VectorXd::Zero(kN);
    for (int i = 0; i < kN; ++i) x(i) = 0.2 * std::sin(0.11 * i);  // a warm start
    r = b - a * x;
    z = r.cwiseQuotient(a.diagonal());
    p = z;
    ap = Eigen::VectorXd::Zero(kN);
    iterates.col(0) = x;
  }
  double rz0() const { return r.dot(z); }
  double apply() noexcept {
    ap.noalias() = a * p;
    return p.dot(ap);
  }
  double advance(double step) noexcept {
    x += step * p;
    r -= step * ap;
    if (k + 1 < kMaxIterates) iterates.col(++k) = x;
    return r.norm() / b.norm();
  }
  double precondition() noexcept {
    z = r.cwiseQuotient(a.diagonal());
    return r.dot(z);
  }
  void direction(double beta) noexcept { p = z + beta * p; }
  double solution_energy() const noexcept { return b.dot(x); }
};

/// ‖x* − x_k‖²_A of every iterate k of a system that ran, x* = A⁻¹ b.
std::vector<double> energy_errors(const LaplacianSystem& s) {
  const Eigen::VectorXd exact = s.a.ldlt().solve(s.b);
  std::vector<double> e;
  for (int k = 0; k <= s.k; ++k) {
    const Eigen::VectorXd d = exact - s.iterates.col(k);
    e.push_back(d.dot(s.a * d));
  }
  return e;
}

}  // namespace

TEST(PcgErrorRule, EstimateIsHestenesStiefelsAndTracksTheTrueEnergyNormErrorAfterTheDelay) {
  // η_k² bᵀx_{k+d} = Σ_{j=k}^{k+d−1} α_j ρ_j = ‖e_k‖²_A − ‖e_{k+d}‖²_A (Hestenes & Stiefel):
  // checked against the true errors for every k the solve reaches, then η_k against
  // ‖e_k‖_A / ‖x*‖_A: a lower bound, within a factor that shrinks as d grows.
  for (const int delay : {1, 2, 4}) {
    const Eigen::VectorXd exact = LaplacianSystem().a.ldlt().solve(LaplacianSystem().b);
    const double x_norm = std::sqrt(exact.dot(LaplacianSystem().a * exact));
    double worst_ratio = 1.0;
    int checked = 0;
    for (int budget = delay; budget <= 30; ++budget) {
      LaplacianSystem s;
      const detail::PcgErrorStop stop{0.0, budget, delay};  // tolerance 0: runs the budget
      const detail::PcgResult res = detail::pcg(s, s.rz0(), stop);
      ASSERT_TRUE(res.finite);
      ASSERT_EQ(res.iterations, budget);
      const std::vector<double> e = energy_errors(s);
      const int k = budget - delay;  // the iterate the estimate is of
      const double identity =
          (e[static_cast<std::size_t>(k)] - e[static_cast<std::size_t>(budget)]) / s.b.dot(s.x);
      if (e[static_cast<std::size_t>(budget)] < 1e-20 * x_norm * x_norm) break;  // at rounding
      EXPECT_NEAR(res.residual * res.residual, identity, 1e-8 * identity) << delay << " " << k;
      const double truth = std::sqrt(e[static_cast<std::size_t>(k)]) / x_norm;
      // bᵀx_{k+d} = ‖x*‖²_A − x*ᵀA e_{k+d}: the estimate's denominator is within the error.
      EXPECT_LE(res.residual, truth * (1.0 + 2.0 * truth) + 1e-14) << delay << " " << k;
      worst_ratio = std::max(worst_ratio, truth / res.residual);
      ++checked;
    }
    std::printf("[pcg error rule] delay %d: %d estimates, true error / estimate at most %.3f\n",
                delay, checked, worst_ratio);
    EXPECT_GE(checked, 10);
    EXPECT_LT(worst_ratio, delay == 1 ? 2.5 : delay == 2 ? 1.6 : 1.2) << delay;
  }
}

TEST(PcgErrorRule, StopsAtTheFirstIterationWhoseEstimateMeetsTheToleranceAllocationFree) {
  for (const double tolerance : {1e-2, 1e-4, 1e-8}) {
    for (const int delay : {1, 3}) {
      // The estimates a full run gives after each iteration (budget m: η of x_{m−d}).
      std::vector<double> eta;
      for (int budget = 1; budget <= 60; ++budget) {
        LaplacianSystem s;
        eta.push_back(detail::pcg(s, s.rz0(), detail::PcgErrorStop{0.0, budget, delay}).residual);
      }
      int expected = 0;
      while (expected < 60 && !(eta[static_cast<std::size_t>(expected)] <= tolerance)) ++expected;
      ++expected;  // iterations run
      ASSERT_LT(expected, 60) << tolerance;
      ASSERT_GT(expected, delay) << "the start is not already at the tolerance";
      LaplacianSystem s;
      const detail::PcgErrorStop stop{tolerance, 200, delay};
      detail::PcgResult res;
      {
        numen::test::AllocationGuard guard;
        res = detail::pcg(s, s.rz0(), stop);
        EXPECT_EQ(guard.count(), 0);
      }
      EXPECT_TRUE(res.converged(stop));
      EXPECT_EQ(res.iterations, expected) << tolerance << " " << delay;
      EXPECT_EQ(res.residual, eta[static_cast<std::size_t>(expected - 1)]);
      EXPECT_GT(eta[static_cast<std::size_t>(expected - 2)], tolerance);  // one earlier did not
      // The returned iterate is the last one, x_{k+d}: at least as good as x_k.
      const std::vector<double> e = energy_errors(s);
      EXPECT_EQ(s.k, expected);
      EXPECT_LE(e.back(), e[static_cast<std::size_t>(expected - delay)]);
    }
  }
}

TEST(PcgErrorRule, RunsTheDelaysIterationsAndReportsNoEstimateBefore) {
  {  // a loose tolerance still needs d iterations to know the estimate
    LaplacianSystem s;
    const detail::PcgErrorStop stop{10.0, 50, 3};
    const detail::PcgResult res = detail::pcg(s, s.rz0(), stop);
    EXPECT_EQ(res.iterations, 3);
    EXPECT_TRUE(res.converged(stop));
  }
  {  // a budget below the delay: no estimate, not converged
    LaplacianSystem s;
    const detail::PcgErrorStop stop{10.0, 2, 3};
    const detail::PcgResult res = detail::pcg(s, s.rz0(), stop);
    EXPECT_EQ(res.iterations, 2);
    EXPECT_TRUE(res.finite);
    EXPECT_TRUE(std::isinf(res.residual));
    EXPECT_FALSE(res.converged(stop));
  }
  {  // an exact start (r0ᵀz0 = 0): no iteration, estimate 0
    LaplacianSystem s;
    const detail::PcgErrorStop stop{1e-12, 50, 2};
    const detail::PcgResult res = detail::pcg(s, 0.0, stop);
    EXPECT_EQ(res.iterations, 0);
    EXPECT_EQ(res.residual, 0.0);
    EXPECT_TRUE(res.converged(stop));
  }
  {  // a delay above the ring's length is clamped to it
    LaplacianSystem s;
    const detail::PcgErrorStop stop{10.0, 50, 100};
    EXPECT_EQ(detail::pcg(s, s.rz0(), stop).iterations, detail::kMaxPcgErrorDelay);
  }
  {  // the non-finite path is shared with the residual rule
    LaplacianSystem s;
    s.a(3, 3) = std::numeric_limits<double>::quiet_NaN();
    const detail::PcgResult res = detail::pcg(s, s.rz0(), detail::PcgErrorStop{1e-6, 50, 2});
    EXPECT_FALSE(res.finite);
    EXPECT_TRUE(std::isnan(res.residual));
  }
}

TEST(PcgErrorRule, AFloorEndsTheSolveOfASolutionBelowItsScaleAndLeavesLargerOnesRelative) {
  // The system scaled down to a right-hand side of rounding size (b ~ 1e-17, an organ at rest):
  // the relative rule chases it over many iterations; with a floor F far above ‖x‖²_A, a start
  // within √F · tolerance runs none, and one outside it stops as soon as the error is below
  // tolerance · √F in absolute terms. A solution far above F is solved as without a floor.
  const auto scaled = [](double scale) {
    LaplacianSystem s;
    s.b *= scale;
    s.x *= scale;
    s.r = s.b - s.a * s.x;
    s.z = s.r.cwiseQuotient(s.a.diagonal());
    s.p = s.z;
    s.iterates.col(0) = s.x;
    return s;
  };
  const double tolerance = 1e-4;
  LaplacianSystem tiny = scaled(1e-17);
  const detail::PcgResult chased = detail::pcg(tiny, tiny.rz0(), detail::PcgErrorStop{tolerance, 200, 1});
  EXPECT_GE(chased.iterations, 5) << "without a floor the relative rule chases rounding";
  tiny = scaled(1e-17);
  const detail::PcgErrorStop floored{tolerance, 200, 1, 1e-20};  // √F = 1e-10 ≫ the start's error
  const detail::PcgResult none = detail::pcg(tiny, tiny.rz0(), floored);
  EXPECT_EQ(none.iterations, 0);
  EXPECT_TRUE(none.converged(floored));
  EXPECT_LE(none.residual, tolerance);
  // A start just outside the floor's tolerance: iterations until the absolute error is below it.
  LaplacianSystem small = scaled(1e-9);
  const double floor = small.rz0() / (4.0 * tolerance * tolerance);  // √(rz0 / F) = 2 tolerance
  const detail::PcgErrorStop near_floor{tolerance, 200, 1, floor};
  const detail::PcgResult some = detail::pcg(small, small.rz0(), near_floor);
  EXPECT_GE(some.iterations, 1);
  EXPECT_TRUE(some.converged(near_floor));
  const Eigen::VectorXd exact = small.a.ldlt().solve(small.b);
  const Eigen::VectorXd e = exact - small.x;
  EXPECT_LE(std::sqrt(e.dot(small.a * e)), 2.0 * tolerance * std::sqrt(floor)) << "absolute error";
  // Far above the floor: the same iterations and iterate as without it.
  LaplacianSystem a = scaled(1.0), b = scaled(1.0);
  const detail::PcgResult ra = detail::pcg(a, a.rz0(), detail::PcgErrorStop{tolerance, 200, 1});
  const detail::PcgResult rb = detail::pcg(b, b.rz0(), detail::PcgErrorStop{tolerance, 200, 1, 1e-20});
  EXPECT_EQ(ra.iterations, rb.iterations);
  EXPECT_EQ(ra.residual, rb.residual);
  EXPECT_EQ((a.x - b.x).norm(), 0.0);
}
