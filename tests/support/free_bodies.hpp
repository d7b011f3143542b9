#pragma once
/// @file free_bodies.hpp
/// A model of free rigid bodies for the tests of what reads a core::Data without stepping it
/// much (the state frame and the state stream, tests/platform/state_frame_test.cpp and
/// state_stream_test.cpp): each body 0.1 kg with inertia 1e-4 kg·m² · I about its centre of
/// mass, coupling k_t = 100 N/m; no gravity; dt = 1 ms; one material; the first body held by
/// the device. Header-only; needs only numen::core and GoogleTest.

#include <gtest/gtest.h>

#include <functional>
#include <initializer_list>
#include <string>

#include "numen/core/model.hpp"

namespace numen::test {

/// The bodies named `names`, in that order, at the world origin; `edit` may change the model
/// (poses, masses, ...) before core::finalize_model(), whose refusal fails the calling test.
inline core::Model free_bodies_model(std::initializer_list<const char*> names,
                                     const std::function<void(core::Model&)>& edit = {}) {
  core::Model m;
  m.dt = 1e-3;
  m.gravity = core::Vec3::Zero();
  m.material_names = {"default"};
  m.material_pairs = {core::MaterialPair{}};
  for (const char* name : names) {
    core::BodyModel b;
    b.name = name;
    b.mass = 0.1;
    b.inertia_body = 1e-4 * core::Mat3::Identity();
    b.coupling.k_t = 100.0;
    m.bodies.push_back(b);
  }
  m.initial_held_body = 0;
  if (edit) edit(m);
  const std::string err = core::finalize_model(m);
  EXPECT_TRUE(err.empty()) << err;
  return m;
}

}  // namespace numen::test
