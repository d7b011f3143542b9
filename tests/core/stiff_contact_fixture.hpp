#pragma once
/// @file stiff_contact_fixture.hpp
/// Shared by the stiff-contact tests of step_test.cpp and step_articulated_test.cpp (issue 17,
/// defect 2): a tissue plane with a lattice of spheres on it, and the hand that presses a tool
/// into it and circles there.

#include <algorithm>
#include <cmath>
#include <cstdint>

#include <gtest/gtest.h>

#include "alloc_counter.hpp"
#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/step.hpp"

namespace numen::test {

/// Adds the plane z = −0.22 (solid below) and, lying on it, a 9 × 9 × 2 lattice of 4.5 mm
/// spheres at 5 mm spacing (the default scene's organ in small), both of material 0.
inline void add_tissue_lattice(core::Model& m) {
  core::Obstacle plane;
  plane.name = "plane";
  plane.type = core::ShapeType::kPlane;
  plane.pose.position = core::Vec3(0, 0, -0.22);
  core::Obstacle lattice;
  lattice.name = "lattice";
  lattice.type = core::ShapeType::kSphereSet;
  lattice.sphere_begin = static_cast<int>(m.static_spheres.size());
  for (int i = -4; i <= 4; ++i)
    for (int j = -4; j <= 4; ++j)
      for (int l = 0; l < 2; ++l)
        m.static_spheres.push_back(
            core::Sphere{core::Vec3(0.005 * i, 0.005 * j, -0.2205 - 0.005 * l), 0.0045});
  lattice.sphere_count = static_cast<int>(m.static_spheres.size()) - lattice.sphere_begin;
  m.obstacles.push_back(plane);
  m.obstacles.push_back(lattice);
}

/// What a pressed run measured.
struct PressedRun {
  double deepest = 0.0;     ///< Largest Data::max_penetration (m).
  double fastest = 0.0;     ///< Largest body speed (m/s).
  int contact_steps = 0;    ///< Steps with a contact.
  std::int64_t clamped = 0; ///< Σ Data::contacts_clamped.
  std::int64_t allocations = 0;  ///< Heap allocations inside core::step (must stay 0).
};

/// Runs `steps` steps of 1 ms: the hand (the held body's target, its COM starting at
/// (0, 0, −0.05) with the body z axis pointing down) descends at 0.05 m/s to 30 mm below its
/// start, while circling with `radius` (m) at `hz` and tilting the shaft ±0.3 rad. Fails the
/// test (and stops) at the first non-finite step.
inline PressedRun press_and_circle(const core::Model& m, core::Data& d, int steps, double hz,
                                   double radius) {
  PressedRun r;
  const core::Quat down(Eigen::AngleAxisd(M_PI, core::Vec3::UnitX()));
  for (int i = 0; i < steps; ++i) {
    const double t = 1e-3 * i, w = 2 * M_PI * hz * t;
    d.target.position = core::Vec3(radius * std::sin(w), radius * (1 - std::cos(w)),
                                   -0.05 - std::min(0.05 * t, 0.03));
    d.target.orientation =
        core::Quat(Eigen::AngleAxisd(0.3 * std::sin(w), core::Vec3(1, 1, 0).normalized())) * down;
    d.target_twist = core::Twist{};
    {
      numen::test::AllocationGuard guard;  // the clamped contacts' path allocates nothing either
      core::step(m, d);
      r.allocations += guard.count();
    }
    EXPECT_EQ(d.nonfinite_steps, 0) << "step " << i;
    if (d.nonfinite_steps > 0) break;
    r.deepest = std::max(r.deepest, d.max_penetration);
    for (const core::BodyState& s : d.bodies) r.fastest = std::max(r.fastest, s.linear_velocity.norm());
    r.contact_steps += d.num_contacts > 0 ? 1 : 0;
    r.clamped += d.contacts_clamped;
  }
  EXPECT_EQ(r.allocations, 0);
  return r;
}

}  // namespace numen::test
