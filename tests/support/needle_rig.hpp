#pragma once
/// @file needle_rig.hpp
/// The needle-through-tissue rig of the puncture tests (tests/core/needle_puncture_test.cpp,
/// thread_tissue_test.cpp): a flat patch of tissue, a 26 mm half-circle needle held by the device
/// as the god-object, and the device's target turning it about its own circle's axis (so that it
/// travels along its arc). Header-only; needs numen::core and the test support.

#include <algorithm>
#include <array>
#include <cmath>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "numen/core/model.hpp"
#include "numen/core/needle.hpp"
#include "numen/core/net_material.hpp"
#include "numen/core/data.hpp"
#include "numen/core/thread.hpp"
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

/// Adds the rigs' needle to `m` (body 1 after the tissue's core): the 26 mm half circle of
/// `threshold` and `max_angle`, its circle's centre C = (0, 0, ±R/2) and its tip at β (rad),
/// held by the device as the god-object (coupling 500 N/m and 0.05 N·m/rad, ζ 0.85).
inline void hold_rig_needle(core::Model& m, double threshold, double max_angle, double centre_z_sign, double beta_tip) {
  core::NeedleSpec spec;
  spec.name = "needle";
  spec.puncture_force = threshold;
  spec.puncture_max_angle = max_angle;
  core::add_needle(m, spec);
  const core::NeedleModel& n = m.needles[0];
  m.bodies[1].initial_pose = puncture_needle_pose(n, core::Vec3(0, 0, centre_z_sign * n.radius / 2), beta_tip);
  const double mass = m.bodies[1].mass, inertia = m.bodies[1].inertia_body(2, 2);
  m.bodies[1].coupling = core::CouplingGains{500.0, core::damping_from_ratio(0.85, mass, 500.0), 0.05,
                                             core::damping_from_ratio(0.85, inertia, 0.05)};
  m.feedback = core::FeedbackGains{500.0, m.bodies[1].coupling.gamma_t, 0.05, m.bodies[1].coupling.gamma_r};
  m.initial_held_body = 1;
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
  hold_rig_needle(m, threshold, max_angle, below ? -1.0 : 1.0, (below ? 190 : -10) * kPunctureDeg);
  if (finalize) {
    EXPECT_EQ(core::finalize_model(m), "");
  }
  return m;
}

/// Adds to the puncture rig `m` (before core::finalize_model()) a thread of `length` (m) and
/// `segments` tied at its needle's tail (body 1), starting straight up: along the tail's tangent
/// it would start through the patch.
inline void add_tail_thread(core::Model& m, double length, int segments) {
  const core::NeedleModel& n = m.needles[0];
  const core::Pose& pose = m.bodies[1].initial_pose;
  core::ThreadModel t;
  t.name = "suture";
  t.length = length;
  t.segments = segments;
  t.start = pose.position + pose.orientation * core::needle_tail(n);
  t.direction = core::Vec3::UnitZ();
  t.tie_start.body = 1;
  t.tie_start.point = core::needle_tail(n);
  m.threads.push_back(t);
}

/// puncture_rig() at step `dt` (s) with its needle weighted to `mass` (kg; inertia scaled alike,
/// the coupling's and the feedback's damping ratio 0.85 kept): the mass a needle has in a
/// grasper's jaws, where the jaws and the instrument move with it. The multirate needle tests
/// and benchmark take 20 g at 0.1 ms: the 78 mg needle alone on the hand's coupling is not what
/// the device loop can hold on the organ's planes (docs/multirate-suturing.md, "The needle's mass").
/// `thread_length` > 0: with add_tail_thread() of that length (m) and one segment a millimetre.
inline core::Model weighted_puncture_rig(double mass, double dt, double thread_length = 0.0) {
  core::Model m = puncture_rig(kPunctureThreshold, 60 * kPunctureDeg, false, false);
  if (thread_length > 0.0) add_tail_thread(m, thread_length, static_cast<int>(std::lround(thread_length * 1e3)));
  m.dt = dt;
  const double q = mass / m.bodies[1].mass;
  m.bodies[1].mass *= q;
  m.bodies[1].inertia_body *= q;
  const double inertia = m.bodies[1].inertia_body(2, 2);
  m.bodies[1].coupling = core::CouplingGains{500.0, core::damping_from_ratio(0.85, mass, 500.0), 0.05,
                                             core::damping_from_ratio(0.85, inertia, 0.05)};
  m.feedback = core::FeedbackGains{500.0, m.bodies[1].coupling.gamma_t, 0.05, m.bodies[1].coupling.gamma_r};
  EXPECT_EQ(core::finalize_model(m), "");
  return m;
}

/// puncture_rig() with a box of tissue in place of the patch: 28 × 20 × 8 mm in cells of 2 mm
/// (2.67 mm on its sides, as the suturing pad's), per spring with the patch's constants, its
/// top at z = 0 and its +y side `edge` (m) from the needle's plane y = 0.
inline core::Model puncture_rig_box(double edge) {
  core::Model m = organ::patch_rig_start();
  core::TriangleMesh box = core::make_box(core::Vec3(0.014, 0.010, 0.004), {14, 10, 3});
  for (core::Vec3& v : box.vertices) v += core::Vec3(0.0, edge - 0.010, -0.004);
  EXPECT_EQ(core::add_net(m, box, organ::organ_net_settings(box, {})), "");
  hold_rig_needle(m, kPunctureThreshold, 60 * kPunctureDeg, 1.0, -10 * kPunctureDeg);
  EXPECT_EQ(core::finalize_model(m), "");
  return m;
}

/// A 2n h × 2n h × d h slab of tissue (m; its top face at z = 0, centred on the z axis) as a
/// tetrahedral mesh: a grid of cubes of edge h, each split into six tetrahedra about its
/// diagonal (Kuhn), its boundary's squares split into two triangles along the same diagonals
/// (from a square's lowest corner to its highest), wound outward; boundary nodes first.
inline core::TetrahedralMesh material_slab(int n, int d, double h) {
  const int nx = 2 * n + 1, nz = d + 1;
  const auto id = [&](int i, int j, int k) { return (k * nx + j) * nx + i; };
  const auto at = [&](int i, int j, int k) { return core::Vec3((i - n) * h, (j - n) * h, (k - d) * h); };
  const auto boundary = [&](int i, int j, int k) {
    return i == 0 || j == 0 || k == 0 || i == nx - 1 || j == nx - 1 || k == nz - 1;
  };
  core::TetrahedralMesh m;
  std::vector<int> index(static_cast<std::size_t>(nx * nx * nz), -1);
  for (int pass = 0; pass < 2; ++pass)
    for (int k = 0; k < nz; ++k)
      for (int j = 0; j < nx; ++j)
        for (int i = 0; i < nx; ++i) {
          if (boundary(i, j, k) != (pass == 0)) continue;
          if (pass == 0) {
            index[static_cast<std::size_t>(id(i, j, k))] = m.surface.num_vertices();
            m.surface.vertices.push_back(at(i, j, k));
          } else {
            index[static_cast<std::size_t>(id(i, j, k))] =
                static_cast<int>(m.surface.vertices.size() + m.interior.size());
            m.interior.push_back(at(i, j, k));
          }
        }
  const auto node = [&](int i, int j, int k) { return index[static_cast<std::size_t>(id(i, j, k))]; };
  // Kuhn: the path 000 → e_a → e_a + e_b → 111 for each order (a, b, c) of the axes.
  const int orders[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (int k = 0; k + 1 < nz; ++k)
    for (int j = 0; j + 1 < nx; ++j)
      for (int i = 0; i + 1 < nx; ++i)
        for (const auto& o : orders) {
          int c[3] = {i, j, k};
          std::array<int, 4> t{};
          t[0] = node(c[0], c[1], c[2]);
          for (int s = 0; s < 3; ++s) {
            ++c[o[s]];
            t[static_cast<std::size_t>(s + 1)] = node(c[0], c[1], c[2]);
          }
          m.tetrahedra.push_back(t);
        }
  // The boundary's squares: axis `a` normal, at the grid's side `side`.
  const int size[3] = {nx, nx, nz};
  for (int a = 0; a < 3; ++a)
    for (int side = 0; side < 2; ++side) {
      const int u = (a + 1) % 3, v = (a + 2) % 3;
      for (int p = 0; p + 1 < size[u]; ++p)
        for (int q = 0; q + 1 < size[v]; ++q) {
          const auto corner = [&](int du, int dv) {
            int c[3];
            c[a] = side == 0 ? 0 : size[a] - 1;
            c[u] = p + du;
            c[v] = q + dv;
            return node(c[0], c[1], c[2]);
          };
          const int lo = corner(0, 0), b = corner(1, 0), hi = corner(1, 1), e = corner(0, 1);
          core::Vec3 out = core::Vec3::Zero();
          out[a] = side == 0 ? -1.0 : 1.0;
          for (const std::array<int, 3>& t0 : {std::array<int, 3>{lo, b, hi}, std::array<int, 3>{lo, hi, e}}) {
            std::array<int, 3> t = t0;
            const core::Vec3& x0 = m.surface.vertices[static_cast<std::size_t>(t[0])];
            const core::Vec3 nrm = (m.surface.vertices[static_cast<std::size_t>(t[1])] - x0)
                                       .cross(m.surface.vertices[static_cast<std::size_t>(t[2])] - x0);
            if (nrm.dot(out) < 0.0) std::swap(t[1], t[2]);
            m.surface.triangles.push_back(t);
          }
        }
    }
  return m;
}

/// puncture_rig() with the patch given by its material instead (core::add_material_net()): a
/// material_slab(7, 4, 2 mm) — 28 × 28 mm, 8 mm deep, its top at z = 0 where the patch is —
/// of E = 120 kPa, ν = 0.45, ρ = 1000 kg/m³, β = 1 ms, ℓ = 8 mm (docs/tissue.md).
inline core::Model puncture_rig_material(double threshold = kPunctureThreshold) {
  core::Model m = organ::patch_rig_start();
  core::MaterialNetSettings s;
  s.name = "organ";
  s.body = 0;
  s.material = 1;
  s.tissue.youngs_modulus = 120e3;
  s.tissue.poisson_ratio = 0.45;
  s.tissue.density = 1000.0;
  s.tissue.rayleigh_stiffness = 1e-3;
  s.tissue.support_length = 0.008;
  EXPECT_EQ(core::add_material_net(m, material_slab(7, 4, 0.002), s), "");
  hold_rig_needle(m, threshold, core::NeedleSpec{}.puncture_max_angle, 1.0, -10 * kPunctureDeg);
  EXPECT_EQ(core::finalize_model(m), "");
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
