#pragma once
/// @file grasper_rig.hpp
/// A laparoscopic grasper for the grasping tests (tests/core/grasp*_test.cpp; docs/grasping.md):
/// a tube held by the device and two jaws on prescribed hinges, pointing down. Header-only;
/// needs numen::core only.

#include <cmath>

#include "numen/core/joint.hpp"
#include "numen/core/model.hpp"
#include "rotation.hpp"

namespace numen::test {

/// One degree (rad).
inline constexpr double kGraspDeg = M_PI / 180.0;

/// Appends the grasper to `m` (bodies first: call on a model whose bodies the caller numbers
/// after): the tube (60 g, no spheres), its COM at `tube_at`, its z axis down (turned π about
/// x); the device holds it (god-object coupling 1000 N/m, ζ 0.85); the jaws "jaw_1" and
/// "jaw_2" (5 g each), hinged at the tube's tip (40 mm along its z, 40 mm below its COM) about
/// its x axis by prescribed revolute joints turned ±opening/2, each a line of `jaw_spheres` (≥ 2;
/// four by default, 3 mm apart) 1.5 mm spheres 2–11 mm from the hinge; grasper "grasper" (close
/// 30°, open 40°, springs 2000 N/m, 2 N·s/m, `max_force`). Returns the tube's body index (the jaws
/// follow it). Not finalized.
inline int add_grasper(core::Model& m, const core::Vec3& tube_at, double opening, double max_force,
                       int jaw_spheres = 4) {
  const int tube_index = m.num_bodies();
  const core::Quat down = numen::test::rot(M_PI, core::Vec3::UnitX());
  core::BodyModel tube;
  tube.name = "tube";
  tube.mass = 0.06;
  tube.inertia_body = core::Vec3(2e-5, 2e-5, 1e-6).asDiagonal();
  tube.coupling = core::CouplingGains{1000.0, core::damping_from_ratio(0.85, 0.07, 1000.0), 1.0,
                                      core::damping_from_ratio(0.85, 2e-5, 1.0)};
  tube.initial_pose = core::Pose{tube_at, down};
  m.bodies.push_back(tube);
  for (int k = 0; k < 2; ++k) {
    core::BodyModel jaw;
    jaw.name = k == 0 ? "jaw_1" : "jaw_2";
    jaw.mass = 0.005;
    jaw.inertia_body = core::Vec3(6e-8, 6e-8, 6e-9).asDiagonal();
    jaw.sphere_begin = static_cast<int>(m.body_spheres.size());
    for (int i = 0; i < jaw_spheres; ++i)
      m.body_spheres.push_back(core::Sphere{core::Vec3(0, 0, -0.004 + (jaw_spheres == 4 ? 0.003 * i : 0.009 * i / (jaw_spheres - 1))), 0.0015});
    jaw.sphere_count = jaw_spheres;
    jaw.initial_pose = core::Pose{tube_at + down * core::Vec3(0, 0, 0.046), down};
    m.bodies.push_back(jaw);
    const core::Quat z_to_x = numen::test::rot(M_PI / 2, core::Vec3::UnitY());
    core::JointModel hinge;
    hinge.name = k == 0 ? "jaw_1_hinge" : "jaw_2_hinge";
    hinge.type = core::JointType::kRevolute;
    hinge.parent = tube_index;
    hinge.child = tube_index + 1 + k;
    hinge.frame_parent = core::Pose{core::Vec3(0, 0, 0.04), z_to_x};
    hinge.frame_child = core::Pose{core::Vec3(0, 0, -0.006), z_to_x};
    hinge.prescribed = true;
    // The jaw turned by ±opening/2 about the hinge (the tube's x axis, the world's): the sign
    // that gives the prescribed coordinate's.
    const double half = (k == 0 ? 0.5 : -0.5) * opening;
    const core::Vec3 pivot = tube_at + down * core::Vec3(0, 0, 0.04);
    core::BodyState tube_state{tube_at, down, core::Vec3::Zero(), core::Vec3::Zero()};
    for (double sign : {1.0, -1.0}) {
      const core::Quat turn = numen::test::rot(sign * half, core::Vec3::UnitX());
      core::BodyState jaw_state{pivot + turn * (jaw.initial_pose.position - pivot), turn * down,
                                core::Vec3::Zero(), core::Vec3::Zero()};
      if (std::abs(core::joint_coordinate(hinge, &tube_state, jaw_state) - half) < 1e-9) {
        m.bodies.back().initial_pose = core::Pose{jaw_state.position, jaw_state.orientation};
        break;
      }
    }
    m.joints.push_back(hinge);
  }
  core::GraspModel g;
  g.name = "grasper";
  g.jaws = {tube_index + 1, tube_index + 2};
  g.close_angle = 30 * kGraspDeg;
  g.open_angle = 40 * kGraspDeg;
  g.stiffness = 2000.0;
  g.damping = 2.0;
  g.max_force = max_force;
  m.grasps.push_back(g);
  m.initial_held_body = tube_index;
  return tube_index;
}

/// Sets the grasper's jaws (its first two joints after `first_joint`) to opening θ (rad) moving
/// at θ̇ (rad/s).
inline void set_grasper_opening(core::Data& d, double theta, double rate, int first_joint = 0) {
  d.joint_prescribed[static_cast<std::size_t>(first_joint)] = core::JointPrescription{0.5 * theta, 0.5 * rate};
  d.joint_prescribed[static_cast<std::size_t>(first_joint + 1)] = core::JointPrescription{-0.5 * theta, -0.5 * rate};
}

/// The tube's target at `at` moving at `v`, turned down.
inline void set_grasper_target(core::Data& d, const core::Vec3& at, const core::Vec3& v) {
  d.target = core::Pose{at, rot(M_PI, core::Vec3::UnitX())};
  d.target_twist = core::Twist{v, core::Vec3::Zero()};
}

}  // namespace numen::test
