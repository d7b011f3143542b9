// Tests of the two-scale contact law of a sphere on an organ given by its material
// (core/net_tissue_contact.hpp; docs/tissue.md, "The contact").
#include <gtest/gtest.h>

#include <cmath>

#include "alloc_counter.hpp"
#include "numen/core/net_tissue_contact.hpp"

namespace {

using numen::core::make_tissue_contact_law;
using numen::core::tissue_contact_depth;
using numen::core::tissue_contact_force;
using numen::core::TissueContactLaw;

constexpr double kModulus = 125e3;  // E* (Pa): E = 100 kPa, ν = 0.45
constexpr double kRadius = 0.0025;  // R (m)
constexpr double kPenalty = 2e4;    // k (N/m)

/// Hertz's force (N) of a sphere of radius R pressed δ into a half-space of modulus E*.
double hertz(double depth) { return 4.0 / 3.0 * kModulus * std::sqrt(kRadius) * std::pow(depth, 1.5); }

}  // namespace

// Without a patch to share the approach with (ρ → ∞: c_ρ → 0), the law is Hertz's up to the
// submerging depth R, where its contact radius √(R δ) reaches R.
TEST(TissueContactLaw, WithAnUnboundedPatchItIsHertz) {
  const TissueContactLaw law = make_tissue_contact_law(kModulus, kRadius, 1e9, kPenalty);
  for (const double d : {1e-6, 1e-4, 5e-4, 1e-3, 2e-3, 0.99 * kRadius})
    EXPECT_NEAR(tissue_contact_force(law, d).force, hertz(d), 1e-9 * hertz(d)) << d;
  EXPECT_NEAR(law.submerge_force, hertz(kRadius), 1e-12);
}

// F(d) inverts d(F) on both branches, rises with d, and its stiffness is dF/dd: continuous at the
// submerging force F_R, where Hertz's 2 E* a equals the punch's 2 E* R (C¹).
TEST(TissueContactLaw, TheForceInvertsTheDepthAndIsC1) {
  const TissueContactLaw law = make_tissue_contact_law(kModulus, kRadius, 0.009, kPenalty);
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
  const double dr = tissue_contact_depth(law, law.submerge_force);
  const double below = tissue_contact_force(law, dr - 1e-12).stiffness;
  const double above = tissue_contact_force(law, dr + 1e-12).stiffness;
  EXPECT_NEAR(below, above, 1e-4 * above);
  EXPECT_EQ(tissue_contact_force(law, 0.0).force, 0.0);
  EXPECT_EQ(tissue_contact_force(law, -1e-3).stiffness, 0.0);
}

// A patch too small for the sphere (c_ρ above the submerged sphere's compliance): the law turns
// linear with the pair's penalty stiffness where its own slope reaches it (C¹).
TEST(TissueContactLaw, APatchTooSmallForTheSphereTurnsToThePenalty) {
  const TissueContactLaw law = make_tissue_contact_law(kModulus, kRadius, 0.002, kPenalty);
  ASSERT_TRUE(std::isfinite(law.switch_depth));
  const auto at = tissue_contact_force(law, law.switch_depth - 1e-12);
  EXPECT_NEAR(at.stiffness, kPenalty, 1e-3 * kPenalty);
  const auto past = tissue_contact_force(law, law.switch_depth + 1e-4);
  EXPECT_NEAR(past.force, law.switch_force + kPenalty * 1e-4, 1e-9);
  EXPECT_EQ(past.stiffness, kPenalty);
  // A patch large for the sphere never switches.
  EXPECT_FALSE(std::isfinite(make_tissue_contact_law(kModulus, kRadius, 0.009, kPenalty).switch_depth));
}

// The law is evaluated in the period: no allocation.
TEST(TissueContactLaw, AllocatesNothing) {
  numen::test::AllocationGuard guard;
  double sum = 0.0;
  for (int i = 1; i <= 1000; ++i) {
    const TissueContactLaw law = make_tissue_contact_law(kModulus, kRadius, 0.009, kPenalty);
    sum += tissue_contact_force(law, 1e-5 * i).force;
  }
  EXPECT_EQ(guard.count(), 0);
  EXPECT_GT(sum, 0.0);
}
