// Tests of sim/run: runs of the shipped scenes are bit-for-bit deterministic (two runners,
// every trace field compared bit for bit).
#include "numen/sim/run/run.hpp"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <atomic>

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <numbers>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "alloc_counter.hpp"
#include "child_process.hpp"
#include "run_scenes.hpp"
#include "scene_text.hpp"
#include "temp_dir.hpp"
#include "numen/core/data.hpp"
#include "numen/core/features.hpp"
#include "numen/hal/device/kinematics_factory.hpp"
#include "numen/sim/input/jigsaws.hpp"
#include "numen/sim/run/run_verdict.hpp"
#include "numen/sim/scene/scene.hpp"
#include "numen/sim/device/simulated_instrument.hpp"
#include "build_features.hpp"
#include "numen/hal/canopen/emcy.hpp"
#include "sanitizer.hpp"

namespace {

using namespace numen::test::run_scenes;

// ---------------------------------------------------------------- determinism

void expect_deterministic(const Scene& scene, std::int64_t n, const char* name) {
  SceneRunner a(scene, static_cast<std::size_t>(n));
  SceneRunner b(scene, static_cast<std::size_t>(n));
  for (std::int64_t k = 0; k < n; ++k) {
    a.period();
    b.period();
  }
  const auto& ra = a.trace().records();
  const auto& rb = b.trace().records();
  ASSERT_EQ(ra.size(), static_cast<std::size_t>(n));
  ASSERT_EQ(rb.size(), ra.size());
  for (std::size_t i = 0; i < ra.size(); ++i) ASSERT_TRUE(same_record(ra[i], rb[i])) << name << ": record " << i;
  const numen::core::Data& da = a.data();
  const numen::core::Data& db = b.data();
  EXPECT_TRUE(same_bits(da.time, db.time));
  EXPECT_EQ(da.step_count, db.step_count);
  ASSERT_EQ(da.bodies.size(), db.bodies.size());
  for (std::size_t i = 0; i < da.bodies.size(); ++i) {
    EXPECT_TRUE(same_bits(da.bodies[i].position, db.bodies[i].position)) << name << ": body " << i;
    EXPECT_TRUE(same_bits(da.bodies[i].orientation, db.bodies[i].orientation)) << name << ": body " << i;
    EXPECT_TRUE(same_bits(da.bodies[i].linear_velocity, db.bodies[i].linear_velocity)) << name << ": body " << i;
    EXPECT_TRUE(same_bits(da.bodies[i].angular_velocity, db.bodies[i].angular_velocity)) << name << ": body " << i;
  }
  ASSERT_EQ(da.nodes.size(), db.nodes.size());
  for (std::size_t i = 0; i < da.nodes.size(); ++i) {
    EXPECT_TRUE(same_bits(da.nodes[i].position, db.nodes[i].position)) << name << ": node " << i;
    EXPECT_TRUE(same_bits(da.nodes[i].velocity, db.nodes[i].velocity)) << name << ": node " << i;
  }
  EXPECT_TRUE(same_bits(da.feedback_wrench.force, db.feedback_wrench.force));
  EXPECT_TRUE(same_bits(da.target.position, db.target.position));
  // Something happened: the bodies moved and there were contacts.
  EXPECT_GT(a.summary().contacts_max + a.summary().node_contacts_max, 0) << name;
  bool moved = false;
  for (std::size_t i = 0; i < da.bodies.size(); ++i)
    moved = moved || (da.bodies[i].position - scene.model.bodies[i].initial_pose.position).norm() > 1e-3;
  EXPECT_TRUE(moved) << name;
}

TEST(RunDeterminism, LatticeSceneTwoRunnersAreBitIdentical) {
  NUMEN_SKIP_UNDER_SANITIZER(
      "bit-identity is not what a sanitizer checks; 12 s of the scene twice take 31 s under"
      " ASan+UBSan with coverage (RunLatticeScene.* runs it there)");
  NUMEN_REQUIRE_ARTICULATION();
  expect_deterministic(lattice_scene(), periods_for(lattice_scene(), 12.0), "lattice");
}

TEST(RunDeterminism, ConstructionSceneTwoRunnersAreBitIdentical) {
  NUMEN_SKIP_UNDER_SANITIZER(
      "bit-identity is not what a sanitizer checks; 9 s of the scene twice take 37 s under "
      "ASan+UBSan with coverage (RunConstructionScene.* runs it there)");
  expect_deterministic(construction_scene(), periods_for(construction_scene(), 9.0), "construction");
}

TEST(RunDeterminism, DeformableSceneTwoRunnersAreBitIdentical) {
  NUMEN_SKIP_UNDER_SANITIZER(kDeformableRunTooSlow);
  NUMEN_REQUIRE_DEFORMABLE();
  expect_deterministic(deformable_scene(), periods_for(deformable_scene(), 10.0), "deformable");
}

TEST(RunDeterminism, EndobagSceneTwoRunnersAreBitIdentical) {
  NUMEN_SKIP_UNDER_SANITIZER(kDeformableRunTooSlow);
  NUMEN_REQUIRE_DEFORMABLE();
  NUMEN_REQUIRE_ARTICULATION();
  expect_deterministic(endobag_scene(), periods_for(endobag_scene(), 10.0), "endobag");
}

}  // namespace
