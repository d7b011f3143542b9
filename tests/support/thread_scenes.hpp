#pragma once
/// @file thread_scenes.hpp
/// Models with one suture thread (core/include/numen/core/thread.hpp) for the thread's tests and
/// figures: the default 3-0 silk thread, no gravity unless asked, dt 1 ms, one material, no
/// bodies unless added. Header-only; needs numen::core and GoogleTest.

#include <gtest/gtest.h>

#include <functional>
#include <string>

#include "numen/core/model.hpp"

namespace numen::test {

/// A model with `thread` (its start tied to the world point `thread.start` unless `edit` says
/// otherwise); `edit` may add bodies and change anything before core::finalize_model(), whose
/// refusal fails the calling test.
inline core::Model thread_model(core::ThreadModel thread,
                                const std::function<void(core::Model&)>& edit = {}) {
  core::Model m;
  m.dt = 1e-3;
  m.gravity = core::Vec3::Zero();
  m.material_names = {"default"};
  m.material_pairs = {core::MaterialPair{}};
  m.initial_held_body = -1;
  thread.tie_start.body = -1;
  thread.tie_start.point = thread.start;
  m.threads.push_back(thread);
  if (edit) edit(m);
  const std::string err = core::finalize_model(m);
  EXPECT_TRUE(err.empty()) << err;
  return m;
}

/// A body of mass `mass` (kg), inertia `inertia` · I (kg·m²) at `position`, one sphere of
/// `radius` (0: none) at its centre of mass.
inline int add_thread_test_body(core::Model& m, double mass, double inertia,
                                const core::Vec3& position, double radius) {
  core::BodyModel b;
  b.name = "body" + std::to_string(m.bodies.size());
  b.mass = mass;
  b.inertia_body = inertia * core::Mat3::Identity();
  b.initial_pose.position = position;
  if (radius > 0.0) {
    b.sphere_begin = static_cast<int>(m.body_spheres.size());
    b.sphere_count = 1;
    m.body_spheres.push_back({core::Vec3::Zero(), radius});
  }
  m.bodies.push_back(b);
  return static_cast<int>(m.bodies.size()) - 1;
}

}  // namespace numen::test
