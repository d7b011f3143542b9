#pragma once
/// @file clash_tubes.hpp
/// Two instruments' tubes for the tool–tool clash tests (tests/core/two_instruments_test.cpp,
/// tests/core/multirate_devices_test.cpp; docs/grasping.md "Hand-over", docs/multirate.md
/// "Several devices"). Header-only; needs numen::core only.

#include <algorithm>
#include <cmath>

#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "rotation.hpp"

namespace numen::test {

/// Appends two tubes to `m` (bodies `first` = m.num_bodies() and first + 1): lines of seventeen
/// 2.5 mm spheres, 80 mm long, 50 g, coupled at 1000 N/m (ζ 0.85) and 1 N·m/rad; "tube_left"
/// along x at y = −20 mm, "tube_right" upright at y = +20 mm, both centred on x = 0, z = 0.
/// Returns `first`. Not finalized.
inline int add_clash_tubes(core::Model& m) {
  const int first = m.num_bodies();
  for (int k = 0; k < 2; ++k) {
    core::BodyModel tube;
    tube.name = k == 0 ? "tube_left" : "tube_right";
    tube.mass = 0.05;
    tube.inertia_body = core::Vec3(3e-5, 3e-5, 2e-7).asDiagonal();
    tube.sphere_begin = static_cast<int>(m.body_spheres.size());
    for (int i = 0; i < 17; ++i)
      m.body_spheres.push_back(core::Sphere{core::Vec3(0, 0, -0.04 + 0.005 * i), 0.0025});
    tube.sphere_count = 17;
    tube.coupling = core::CouplingGains{1000.0, core::damping_from_ratio(0.85, 0.05, 1000.0), 1.0,
                                        core::damping_from_ratio(0.85, 3e-5, 1.0)};
    const core::Quat along = k == 0 ? rot(M_PI / 2, core::Vec3::UnitY()) : core::Quat::Identity();
    tube.initial_pose = core::Pose{core::Vec3(0, k == 0 ? -0.02 : 0.02, 0), along};
    m.bodies.push_back(tube);
  }
  return first;
}

/// The clash's hands at time t (s) for tubes at bodies 0 and 1 of `m` (add_clash_tubes() on an
/// empty model): each moves 0.5 m/s towards and past the other's line for 80 ms (40 mm), then
/// holds; tube 0 through Data::target (the held body), tube 1 through its own body target (Eq. 6).
inline void set_clash_targets(const core::Model& m, core::Data& d, double t) {
  const double travel = std::min(t, 0.08) * 0.5;
  const double v = t < 0.08 ? 0.5 : 0.0;
  d.target = core::Pose{core::Vec3(0, -0.02 + travel, 0), m.bodies[0].initial_pose.orientation};
  d.target_twist = core::Twist{core::Vec3(0, v, 0), core::Vec3::Zero()};
  core::BodyTarget& right = d.body_targets[1];
  right.pose = core::Pose{core::Vec3(0, 0.02 - travel, 0), m.bodies[1].initial_pose.orientation};
  right.twist = core::Twist{core::Vec3(0, -v, 0), core::Vec3::Zero()};
  right.enabled = true;
}

}  // namespace numen::test
