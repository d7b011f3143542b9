// Tests of core/src/detail/pcg.hpp: the one preconditioned conjugate-gradient
// kernel of the implicit solves, on a small system of its own.
#include "detail/pcg.hpp"

#include <array>
#include <cmath>
#include <limits>

#include <gtest/gtest.h>

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
  s.a = -s.a;  // negative definite: pᵀAp < 0 at once
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
