// Tests of the two-scale contact law of a sphere on an organ given by its material
// (core/net_tissue_contact.hpp; docs/tissue.md, "The contact").
#include <gtest/gtest.h>

#include <cmath>

#include "net/neo_hookean_sphere.hpp"
#include "alloc_counter.hpp"
#include "numen/core/net_tissue_contact.hpp"

namespace {

using numen::core::make_tissue_contact_law;
using numen::core::tissue_contact_depth;
using numen::core::tissue_contact_force;
using numen::core::tissue_half_space;
using numen::core::TissueContactLaw;
namespace table = numen::core::detail;

constexpr double kModulus = 125e3;  // E* (Pa): E = 100 kPa, ν = 0.45
constexpr double kNu = 0.45;
constexpr double kRadius = 0.0025;  // R (m)
constexpr double kPenalty = 2e4;    // k (N/m)

/// Hertz's force (N) of a sphere of radius R pressed δ into a half-space of modulus E*.
double hertz(double depth) { return 4.0 / 3.0 * kModulus * std::sqrt(kRadius) * std::pow(depth, 1.5); }

}  // namespace

// Without a patch to share the approach with (ρ → ∞: c_ρ → 0), the law is the neo-Hookean
// half-space's: Hertz's within 2 % for δ ≤ 0.1 R, the table's below it deeper (14 % at δ = R).
TEST(TissueContactLaw, WithAnUnboundedPatchItIsTheHalfSpacesNearHertzWhenShallow) {
  const TissueContactLaw law = make_tissue_contact_law(kModulus, kNu, 0.0, kRadius, 1e9, kPenalty);
  for (const double d : {1e-6, 1e-5, 5e-5, 1e-4, 2.5e-4})
    EXPECT_NEAR(tissue_contact_force(law, d).force, hertz(d), 0.02 * hertz(d)) << d;
  const double at_r = tissue_contact_force(law, kRadius).force;
  EXPECT_LT(at_r, 0.9 * hertz(kRadius));
  EXPECT_GT(at_r, 0.8 * hertz(kRadius));
}

// At a block's b and a row's ν the law's g is the table's at every knot; between rows and
// blocks it is linear in each.
TEST(TissueContactLaw, TheHalfSpaceIsTheTablesAtItsKnotsRowsAndBlocks) {
  for (int k = 0; k < table::kNeoHookeanSphereStiffenings; ++k)
    for (int j = 0; j < table::kNeoHookeanSphereNus; ++j) {
      const TissueContactLaw law = make_tissue_contact_law(
          kModulus, table::kNeoHookeanSphereNu[j], table::kNeoHookeanSphereB[k], kRadius, 0.009, kPenalty);
      for (int i = 0; i < table::kNeoHookeanSpherePoints; ++i)
        EXPECT_NEAR(tissue_half_space(law, table::kNeoHookeanSphereX[i]).g, table::kNeoHookeanSphereG[k][j][i],
                    1e-12 * table::kNeoHookeanSphereG[k][j][i])
            << k << " " << j << " " << i;
    }
  const double lo = table::kNeoHookeanSphereNu[3], hi = table::kNeoHookeanSphereNu[4];
  const double b0 = table::kNeoHookeanSphereB[2], b1 = table::kNeoHookeanSphereB[3];
  const TissueContactLaw mid =
      make_tissue_contact_law(kModulus, 0.5 * (lo + hi), 0.25 * b0 + 0.75 * b1, kRadius, 0.009, kPenalty);
  for (int i = 0; i < table::kNeoHookeanSpherePoints; ++i) {
    const double g = tissue_half_space(mid, table::kNeoHookeanSphereX[i]).g;
    const auto& t = table::kNeoHookeanSphereG;
    EXPECT_NEAR(g, 0.125 * (t[2][3][i] + t[2][4][i]) + 0.375 * (t[3][3][i] + t[3][4][i]), 1e-12 * g);
  }
  // The rows' span, and a ν outside it takes the nearest row; a b past the last block takes it.
  EXPECT_EQ(numen::core::tissue_law_poisson_range().min, table::kNeoHookeanSphereNu[0]);
  EXPECT_EQ(numen::core::tissue_law_poisson_range().max,
            table::kNeoHookeanSphereNu[table::kNeoHookeanSphereNus - 1]);
  const TissueContactLaw below = make_tissue_contact_law(kModulus, -0.5, 0.0, kRadius, 0.009, kPenalty);
  const double first = table::kNeoHookeanSphereNu[0];
  EXPECT_DOUBLE_EQ(tissue_half_space(below, 1.0).g,
                   tissue_half_space(make_tissue_contact_law(kModulus, first, 0.0, kRadius, 0.009, kPenalty), 1.0).g);
  EXPECT_DOUBLE_EQ(
      tissue_half_space(make_tissue_contact_law(kModulus, kNu, 9.0, kRadius, 0.009, kPenalty), 1.0).g,
      tissue_half_space(make_tissue_contact_law(kModulus, kNu, numen::core::kMaxStrainStiffening, kRadius,
                                                0.009, kPenalty), 1.0).g);
}

// Strain stiffening leaves the small-indentation response (Hertz's) and stiffens the deep one
// monotonically: at δ = 2 R the neo-Hookean half-space (b = 0) is 31 % below Hertz, b = 1 about
// Hertz's, b = 4 38 % above (ν = 0.45, the GetFEM solves of docs/indentation-reference.md).
TEST(TissueContactLaw, StrainStiffeningStiffensTheDeepResponseAndLeavesTheShallowOne) {
  double last_deep = 0.0;
  for (const double b : {0.0, 0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 4.0}) {
    const TissueContactLaw law = make_tissue_contact_law(kModulus, kNu, b, kRadius, 1e9, kPenalty);
    const double shallow = tissue_contact_force(law, 0.02 * kRadius).force;
    EXPECT_NEAR(shallow, hertz(0.02 * kRadius), 0.01 * hertz(0.02 * kRadius)) << b;
    const double deep = tissue_contact_force(law, 2.0 * kRadius).force;
    EXPECT_GT(deep, last_deep) << b;
    last_deep = deep;
    if (b == 0.0) {
      EXPECT_NEAR(deep / hertz(2.0 * kRadius), 0.69, 0.02);
    } else if (b == 1.0) {
      EXPECT_NEAR(deep / hertz(2.0 * kRadius), 0.99, 0.02);
    } else if (b == 4.0) {
      EXPECT_NEAR(deep / hertz(2.0 * kRadius), 1.38, 0.02);
    }
  }
}

// g is C¹ and increasing over the table and past it (the linear continuation), its slope dg/dx.
TEST(TissueContactLaw, TheHalfSpaceIsC1AndIncreasing) {
  const TissueContactLaw law = make_tissue_contact_law(kModulus, kNu, 0.0, kRadius, 0.009, kPenalty);
  double last = 0.0;
  for (double x = 0.001; x < 4.0; x *= 1.07) {
    const auto h = tissue_half_space(law, x);
    EXPECT_GT(h.g, last) << x;
    last = h.g;
    const double e = 1e-7 * x;
    const double fd = (tissue_half_space(law, x + e).g - tissue_half_space(law, x - e).g) / (2 * e);
    EXPECT_NEAR(h.slope, fd, 1e-5 * fd) << x;
  }
  // Across each knot the slope is continuous.
  for (int i = 0; i < table::kNeoHookeanSpherePoints; ++i) {
    const double x = table::kNeoHookeanSphereX[i];
    const double a = tissue_half_space(law, x * (1 - 1e-12)).slope, b = tissue_half_space(law, x * (1 + 1e-12)).slope;
    EXPECT_NEAR(a, b, 1e-6 * b) << x;
  }
}

// F(d) inverts d(F), rises with d, and its stiffness is dF/dd.
TEST(TissueContactLaw, TheForceInvertsTheDepthAndIsC1) {
  const TissueContactLaw law = make_tissue_contact_law(kModulus, kNu, 0.0, kRadius, 0.009, kPenalty);
  EXPECT_GT(law.patch, 0.0);
  double last = 0.0;
  for (double f = 0.01; f < 8.0; f *= 1.3) {
    const double d = tissue_contact_depth(law, f);
    const auto r = tissue_contact_force(law, d);
    EXPECT_NEAR(r.force, f, 1e-9 * f) << f;
    EXPECT_GT(r.force, last);
    last = r.force;
    const double h = 1e-9;
    const double slope = (tissue_contact_force(law, d + h).force - tissue_contact_force(law, d - h).force) / (2 * h);
    EXPECT_NEAR(r.stiffness, slope, 1e-4 * slope) << f;
  }
  EXPECT_EQ(tissue_contact_force(law, 0.0).force, 0.0);
  EXPECT_EQ(tissue_contact_force(law, -1e-3).stiffness, 0.0);
}

// A patch too small for the sphere: the law turns linear with the pair's penalty stiffness where
// its own slope reaches it (C¹).
TEST(TissueContactLaw, APatchTooSmallForTheSphereTurnsToThePenalty) {
  const TissueContactLaw law = make_tissue_contact_law(kModulus, kNu, 0.0, kRadius, 0.002, kPenalty);
  ASSERT_TRUE(std::isfinite(law.switch_depth));
  const auto at = tissue_contact_force(law, law.switch_depth - 1e-12);
  EXPECT_NEAR(at.stiffness, kPenalty, 1e-3 * kPenalty);
  const auto past = tissue_contact_force(law, law.switch_depth + 1e-4);
  EXPECT_NEAR(past.force, law.switch_force + kPenalty * 1e-4, 1e-9);
  EXPECT_EQ(past.stiffness, kPenalty);
  // A patch large for the sphere never switches.
  EXPECT_FALSE(std::isfinite(make_tissue_contact_law(kModulus, kNu, 0.0, kRadius, 0.009, kPenalty).switch_depth));
}

// The touched point's blend (kTissueTouchDepthScale): a face contact's K(τ) is 0 where its point
// is on an edge of its triangle (where a face contact appears or vanishes), 1 at its centroid,
// increasing in between and flat at both ends; the depth factor is 1 at the deepest and e⁻¹ a
// tenth of the radius less deep.
TEST(TissueContactLaw, TheTouchedPointsBlendFadesAtATrianglesEdgesAndWithDepth) {
  using numen::core::tissue_touch_depth_factor;
  using numen::core::tissue_touch_fade;
  using numen::core::Vec3;
  EXPECT_EQ(tissue_touch_fade(Vec3(0.0, 0.5, 0.5)), 0.0);
  EXPECT_EQ(tissue_touch_fade(Vec3(1.0, 0.0, 0.0)), 0.0);
  EXPECT_DOUBLE_EQ(tissue_touch_fade(Vec3(1.0, 1.0, 1.0) / 3.0), 1.0);
  double last = 0.0;
  for (int i = 1; i <= 100; ++i) {  // from an edge's midpoint to the centroid
    const double t = i / 100.0;
    const Vec3 b = (1.0 - t) * Vec3(0.0, 0.5, 0.5) + t * Vec3(1.0, 1.0, 1.0) / 3.0;
    const double k = tissue_touch_fade(b);
    EXPECT_GT(k, last) << t;
    last = k;
  }
  EXPECT_LT(tissue_touch_fade(Vec3(0.001, 0.4995, 0.4995)), 1e-4);  // C¹: flat at the edge
  EXPECT_EQ(tissue_touch_depth_factor(0.0, kRadius), 1.0);
  EXPECT_EQ(tissue_touch_depth_factor(-1e-6, kRadius), 1.0);
  EXPECT_NEAR(tissue_touch_depth_factor(0.1 * kRadius, kRadius), std::exp(-1.0), 1e-12);
  EXPECT_LT(tissue_touch_depth_factor(0.2 * kRadius, kRadius), tissue_touch_depth_factor(0.1 * kRadius, kRadius));
}

// The law is evaluated in the period: no allocation.
TEST(TissueContactLaw, AllocatesNothing) {
  numen::test::AllocationGuard guard;
  double sum = 0.0;
  for (int i = 1; i <= 1000; ++i) {
    const TissueContactLaw law = make_tissue_contact_law(kModulus, kNu, 0.0, kRadius, 0.009, kPenalty);
    sum += tissue_contact_force(law, 1e-5 * i).force;
  }
  EXPECT_EQ(guard.count(), 0);
  EXPECT_GT(sum, 0.0);
}
