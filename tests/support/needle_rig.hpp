#pragma once
/// @file needle_rig.hpp
/// The needle-through-tissue rig of the puncture tests (tests/core/needle_puncture_test.cpp,
/// thread_tissue_test.cpp): a flat patch of tissue, a 26 mm half-circle needle held by the device
/// as the god-object, and the device's target turning it about its own circle's axis (so that it
/// travels along its arc). Header-only; needs numen::core and the test support.

#include <algorithm>
#include <cmath>

#include <gtest/gtest.h>

#include "numen/core/model.hpp"
#include "numen/core/needle.hpp"
#include "numen/core/data.hpp"
#include "organ_indentation.hpp"
#include "rotation.hpp"

namespace numen::test {

inline constexpr double kPunctureDeg = M_PI / 180.0;
/// The puncture threshold of these tests (N): not a published value (docs/suturing.md).
inline constexpr double kPunctureThreshold = 1.0;

/// The needle's arc in the world's x–z plane about C, its tip at world angle β (rad, from +x
/// towards +z about C), going round towards decreasing β as it advances (a turn about +y): the
/// rotation of its body frame and the position of its centre of mass.
inline core::Pose puncture_needle_pose(const core::NeedleModel& n, const core::Vec3& c, double beta_tip) {
  const double g = beta_tip + M_PI / 2;
  core::Mat3 r;
  r.col(0) = core::Vec3(std::cos(g), 0, std::sin(g));
  r.col(1) = core::Vec3(std::sin(g), 0, -std::cos(g));
  r.col(2) = core::Vec3(0, 1, 0);
  const core::Quat q(r);
  return core::Pose{c - q * n.centre, q};
}

/// Body 0 the patch's anchored core; the patch (14 × 14 cells of 2 mm in z = 0, normals +z, the
/// shipped organ's constants); body 1 the needle (26 mm half circle, 0.35 mm wire, 78 mg), its
/// circle's centre C = (0, 0, R/2) (so that its arc meets the patch 60° either side of straight
/// down, x = ±7.2 mm), its tip at β = −10° (2.7 mm above the patch), held by the device (the
/// god-object: coupling 500 N/m and 0.05 N·m/rad, ζ 0.85). No gravity; implicit Euler at 1 ms.
/// `below`: the pass mirrored under the patch, C = (0, 0, −R/2), the tip at β = 190° (5.6 mm
/// below), going up into the patch's underside near β = 150°. `finalize` false: the model before
/// core::finalize_model(), for a caller that adds to it (a thread at the needle's tail).
inline core::Model puncture_rig(double threshold = kPunctureThreshold, double max_angle = 60 * kPunctureDeg, bool below = false,
                                bool finalize = true) {
  core::Model m = organ::patch_rig_start();
  const core::TriangleMesh patch = organ::flat_patch(14, 0.002);
  EXPECT_EQ(core::add_net(m, patch, organ::organ_net_settings(patch, {})), "");
  core::NeedleSpec spec;
  spec.name = "needle";
  spec.puncture_force = threshold;
  spec.puncture_max_angle = max_angle;
  core::add_needle(m, spec);
  core::NeedleModel& n = m.needles[0];
  m.bodies[1].initial_pose = below ? puncture_needle_pose(n, core::Vec3(0, 0, -n.radius / 2), 190 * kPunctureDeg)
                                  : puncture_needle_pose(n, core::Vec3(0, 0, n.radius / 2), -10 * kPunctureDeg);
  const double mass = m.bodies[1].mass, inertia = m.bodies[1].inertia_body(2, 2);
  m.bodies[1].coupling = core::CouplingGains{500.0, core::damping_from_ratio(0.85, mass, 500.0), 0.05,
                                             core::damping_from_ratio(0.85, inertia, 0.05)};
  m.feedback = core::FeedbackGains{500.0, m.bodies[1].coupling.gamma_t, 0.05, m.bodies[1].coupling.gamma_r};
  m.initial_held_body = 1;
  if (finalize) {
    EXPECT_EQ(core::finalize_model(m), "");
  }
  return m;
}

/// The device's target: the needle turned about its circle's axis (world y through C) by ψ = ω t
/// (its tip going round towards −z), ψ capped at `turn`.
inline void puncture_drive(const core::Model& m, core::Data& d, double t, double omega, double turn) {
  const core::NeedleModel& n = m.needles[0];
  const core::Pose& p0 = m.bodies[1].initial_pose;
  const core::Vec3 c = p0.position + p0.orientation * n.centre;  // the circle's centre
  const double psi = std::min(turn, omega * t);
  const double rate = omega * t < turn ? omega : 0.0;
  const core::Quat turn_q = rot(psi, core::Vec3::UnitY());
  d.target = core::Pose{c + turn_q * (p0.position - c), turn_q * p0.orientation};
  const core::Vec3 w(0, rate, 0);
  d.target_twist = core::Twist{w.cross(d.target.position - c), w};
}

}  // namespace numen::test
