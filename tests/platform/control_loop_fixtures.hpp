#pragma once
/// @file control_loop_fixtures.hpp
/// Shared by the ControlLoop tests (control_loop_test.cpp, control_loop_links_test.cpp,
/// control_loop_managed_test.cpp): the bus timing of a period (SYNC, latency, phase), the
/// minimal-protocol trocar instrument, the bus settings, a one-body model and the axis values
/// the emulated encoders report.

#include <cstdint>
#include <numbers>
#include <string>

#include <gtest/gtest.h>

#include "numen/core/model.hpp"
#include "numen/hal/canopen/canopen.hpp"
#include "numen/hal/device/axis.hpp"
#include "numen/hal/device/device_config.hpp"
#include "numen/hal/transport/sim_bus.hpp"
#include "numen/platform/control_loop.hpp"
#include "test_constants.hpp"

namespace numen::test::control_loop_fixtures {

using numen::core::Pose;
using numen::core::Quat;
using numen::core::Vec3;
using numen::hal::AxisVector;
using numen::hal::CanFrame;
using numen::hal::IoStatus;
using numen::hal::SimBus;
using numen::platform::ControlLoop;
using numen::platform::PeriodReport;
using numen::test::kMs;
constexpr std::int64_t kLatency = 100'000;
constexpr std::int64_t kPhase = 250'000;

inline numen::hal::DeviceConfig trocar_config() {
  numen::hal::DeviceConfig c = numen::hal::make_default_trocar_config(1);
  c.canopen.managed = false;  // the minimal protocol; managed_config() for the full stack
  c.trocar.point = Vec3(0.0, 0.0, 0.2);
  c.trocar.orientation = Quat(Eigen::AngleAxisd(std::numbers::pi, Vec3::UnitX()));
  c.control_period_s = 1e-3;
  return c;
}

inline numen::hal::SimBusSettings bus_settings() {
  numen::hal::SimBusSettings s;
  s.latency_ns = kLatency;
  return s;
}

/// One body (no spheres), coupling gains, virtual-coupling feedback, no obstacles.
inline numen::core::Model small_model() {
  numen::core::Model m;
  m.dt = 1e-3;
  m.gravity = Vec3::Zero();
  m.material_names = {"default"};
  m.material_pairs = {numen::core::MaterialPair{}};
  numen::core::BodyModel b;
  b.name = "tool";
  b.mass = 0.1;
  b.inertia_body = 1e-4 * numen::core::Mat3::Identity();
  b.coupling.k_t = 100.0;
  b.coupling.gamma_t = numen::core::damping_from_ratio(0.85, b.mass, b.coupling.k_t);
  b.coupling.k_r = 0.1;
  b.coupling.gamma_r = numen::core::damping_from_ratio(0.85, 1e-4, b.coupling.k_r);
  m.bodies.push_back(b);
  m.feedback.k_t = 100.0;
  m.feedback.gamma_t = 0.1;
  m.feedback.max_force = 5.0;
  m.feedback.max_torque = 0.5;
  m.initial_held_body = 0;
  const std::string err = numen::core::finalize_model(m);
  EXPECT_TRUE(err.empty()) << err;
  return m;
}

const double kQ[5] = {0.1, -0.2, 0.1, 0.5, 0.3};

/// The admittance loops' model: one 50 g probe (a 5 mm sphere), no gravity, coupling `mode`.
inline numen::core::Model probe_model(
    numen::core::CouplingMode mode = numen::core::CouplingMode::kAdmittance) {
  numen::core::Model m;
  m.gravity = Vec3::Zero();
  m.coupling_mode = mode;
  m.material_pairs = {numen::core::MaterialPair{}};
  m.body_spheres = {numen::core::Sphere{Vec3::Zero(), 0.005}};
  numen::core::BodyModel b;
  b.name = "probe";
  b.mass = 0.05;
  b.inertia_body = numen::core::Mat3::Identity() * 1e-4;
  b.sphere_count = 1;
  m.bodies = {b};
  m.initial_held_body = 0;
  EXPECT_EQ(numen::core::finalize_model(m), "");
  return m;
}

}  // namespace numen::test::control_loop_fixtures
