// Tests of sim/scene: the shipped scenes load with what their files describe, and what a
// scene file selects (integrator, coupling, events, device settings) is what the scene holds.
// Scene-file errors: scene_errors_test.cpp; the default scene's geometry:
// scene_geometry_test.cpp; [device.canopen]: scene_device_test.cpp.
#include "numen/sim/scene/scene.hpp"

#include <gtest/gtest.h>

#include "sanitizer.hpp"
#include "scene_text.hpp"
#include "temp_dir.hpp"

#include "numen/core/data.hpp"
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <numbers>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "numen/hal/device/device_config.hpp"
#include "numen/sim/device/simulated_instrument.hpp"
#include "numen/sim/input/input_error.hpp"

#include "articulation/joint_system.hpp"
#include "build_features.hpp"
#include "lattice_scene.hpp"
#include "rotation.hpp"

namespace {

using numen::test::replace;

using numen::core::CouplingMode;
using numen::core::Quat;
using numen::core::ShapeType;
using numen::core::Vec3;
using numen::sim::InputError;
using numen::sim::load_scene;
using numen::sim::Scene;
using numen::sim::SceneOverrides;

std::string shipped_construction_path() { return std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/construction.toml"; }

/// Angle (rad) between two rotations, q and -q being the same.
using numen::test::angle_between;
using numen::test::TempDir;

// A small valid scene (pose tracker, scripted path; tests/support/scene_text.hpp). Every error
// test below changes one thing in it, so that the error can only come from that change.
using numen::test::kMiniScene;

}  // namespace

// ---------------------------------------------------------------- shipped scenes

TEST(Scene, LatticeSceneLoadsWhatItsFileDescribes) {
  NUMEN_REQUIRE_ARTICULATION();
  const Scene s = load_scene(numen::test::lattice_scene_path());
  EXPECT_EQ(s.name, "lattice");
  EXPECT_EQ(s.model.dt, 0.001);
  EXPECT_EQ(s.model.coupling_mode, CouplingMode::kGodObject);
  EXPECT_EQ(s.model.gravity, Vec3::Zero());

  // The articulated instrument of the paper's Fig. 3: sleeve, tube, two jaws.
  ASSERT_EQ(s.model.num_bodies(), 4);
  EXPECT_EQ(s.model.bodies[0].name, "sleeve");
  EXPECT_EQ(s.model.bodies[0].sphere_count, 0);
  EXPECT_EQ(s.model.bodies[1].name, "tube");
  EXPECT_EQ(s.model.bodies[1].sphere_count, 30);  // [[body.sphere_line]] count = 30
  EXPECT_DOUBLE_EQ(s.model.bodies[1].mass, 0.05);
  EXPECT_EQ(s.model.initial_held_body, 1);
  ASSERT_EQ(s.model.num_joints(), 4);
  EXPECT_EQ(s.model.joints[0].type, numen::core::JointType::kSpherical);
  EXPECT_EQ(s.model.joints[0].parent, -1);
  EXPECT_EQ(s.model.joints[0].frame_parent.position, s.device.trocar.point);
  EXPECT_EQ(s.model.joints[1].type, numen::core::JointType::kCylindrical);
  EXPECT_EQ(s.model.joints[2].type, numen::core::JointType::kRevolute);
  EXPECT_TRUE(s.model.joints[2].prescribed);
  EXPECT_TRUE(s.model.joints[3].prescribed);
  // Every body chases its own link (Eq. 6); both jaws follow the jaw axis.
  ASSERT_EQ(s.binding.links.size(), 5u);  // + the fallback link 0 → held body
  for (std::size_t b = 0; b < 4; ++b) EXPECT_EQ(s.binding.links[b].body, static_cast<int>(b));
  EXPECT_EQ(s.binding.links[4].body, -1);
  ASSERT_EQ(s.binding.prescriptions.size(), 2u);
  EXPECT_EQ(s.binding.prescriptions[0].axis, 4);
  EXPECT_DOUBLE_EQ(s.binding.prescriptions[0].scale, 0.5);
  EXPECT_DOUBLE_EQ(s.binding.prescriptions[1].scale, -0.5);
  // Every body starts where its link puts it: the joints hold at t = 0.
  numen::core::Data d = numen::core::make_data(s.model);
  if constexpr (numen::core::kWithArticulation)  // not linked without it (test skipped)
    numen::core::measure_joint_drift(s.model, d);
  EXPECT_LT(d.max_joint_drift, 1e-9);
  ASSERT_EQ(s.model.num_materials(), 2);
  EXPECT_EQ(s.model.material_names[0], "steel");
  EXPECT_EQ(s.model.material_names[1], "tissue");

  ASSERT_EQ(s.model.obstacles.size(), 2u);
  EXPECT_EQ(s.model.obstacles[0].name, "tissue");
  EXPECT_EQ(s.model.obstacles[0].type, ShapeType::kPlane);
  EXPECT_EQ(s.model.obstacles[1].name, "organ");
  EXPECT_EQ(s.model.obstacles[1].type, ShapeType::kSphereSet);

  // The organ: an ellipsoid 35 × 25 × 20 mm filled with 4.5 mm spheres on a
  // 5 mm lattice whose centres lie inside the ellipsoid shrunk by 4.5 mm. Count
  // the lattice points here independently of the loader.
  const Vec3 inner(0.0305, 0.0205, 0.0155);
  int expected = 0;
  for (int i = -10; i <= 10; ++i)
    for (int j = -10; j <= 10; ++j)
      for (int k = -10; k <= 10; ++k)
        if (Vec3(i * 0.005, j * 0.005, k * 0.005).cwiseQuotient(inner).squaredNorm() <= 1.0) ++expected;
  EXPECT_GE(expected, 200);
  const auto& organ = s.model.obstacles[1];
  EXPECT_EQ(organ.sphere_count, expected);
  EXPECT_GE(organ.sphere_count, 200) << "the organ has several hundred spheres";
  EXPECT_EQ(s.model.static_spheres.size(), static_cast<std::size_t>(organ.sphere_count));
  for (int i = 0; i < organ.sphere_count; ++i)
    EXPECT_DOUBLE_EQ(s.model.static_spheres[static_cast<std::size_t>(organ.sphere_begin + i)].radius, 0.0045);

  EXPECT_EQ(s.device.kind, numen::hal::DeviceKind::kTrocarInstrument);
  EXPECT_EQ(s.device.axes.size(), 5u);
  EXPECT_EQ(s.device.name, "laparoscopic_trainer");
  EXPECT_EQ(s.device.control_period_s, s.model.dt);
  EXPECT_EQ(s.device.axes[0].encoder_cob_id, 0x181u);
  EXPECT_DOUBLE_EQ(s.device.axes[4].min, -std::numbers::pi);  // the jaw: one encoder turn
  EXPECT_DOUBLE_EQ(s.device.axes[4].max, std::numbers::pi);
  EXPECT_FALSE(s.trocar_note.empty());
  EXPECT_DOUBLE_EQ(s.model.feedback.max_force, 8.0);

  // 900 rows at 30 Hz → 899/30 s, kept as recorded (interpolated at each period's time).
  EXPECT_EQ(s.trajectory.size(), 900u);
  EXPECT_NEAR(s.trajectory.period(), 1.0 / 30.0, 1e-15);
  EXPECT_NEAR(s.trajectory.duration(), 899.0 / 30.0, 1e-12);
  EXPECT_NEAR(s.duration_s, 30.0, 0.1);
  EXPECT_EQ(s.duration_s, s.trajectory.duration());
  EXPECT_TRUE(s.events.empty());
  EXPECT_TRUE(s.warnings.empty()) << s.warnings.front();
  EXPECT_EQ(s.bus.latency_ns, 100'000);
  EXPECT_GE(s.compute_phase_s, 2.0 * 100e-6);
  EXPECT_LT(s.compute_phase_s, s.model.dt);
}

TEST(Scene, ConstructionSceneLoadsWhatItsFileDescribes) {
  const Scene s = load_scene(shipped_construction_path());
  EXPECT_EQ(s.name, "construction");
  ASSERT_EQ(s.model.num_bodies(), 12);
  for (const auto& b : s.model.bodies) {
    EXPECT_EQ(b.sphere_count, 8) << b.name;  // 2 × 2 × 2 sphere grid
    EXPECT_DOUBLE_EQ(b.mass, 0.05) << b.name;
  }
  EXPECT_EQ(s.model.body_spheres.size(), 96u);
  ASSERT_EQ(s.model.obstacles.size(), 1u);
  EXPECT_EQ(s.model.obstacles[0].type, ShapeType::kBox);
  EXPECT_EQ(s.model.gravity, Vec3(0.0, 0.0, -9.81));
  EXPECT_EQ(s.device.kind, numen::hal::DeviceKind::kPoseTracker);
  EXPECT_EQ(s.device.axes.size(), 6u);
  ASSERT_GE(s.model.initial_held_body, 0);
  EXPECT_EQ(s.model.bodies[static_cast<std::size_t>(s.model.initial_held_body)].name, "held");
  EXPECT_DOUBLE_EQ(s.duration_s, 9.0);
  // Segments: 0.5 + 1 + 0.4 + 1 + 1.5 + 1 + 0.3 + 1.5 + 1 + 0.8 = 9 s.
  EXPECT_NEAR(s.trajectory.duration(), 9.0, 1e-9);
  ASSERT_EQ(s.events.size(), 2u);
  EXPECT_DOUBLE_EQ(s.events[0].time_s, 5.7);
  EXPECT_EQ(s.events[0].body, -1);
  EXPECT_DOUBLE_EQ(s.events[1].time_s, 7.2);
  ASSERT_GE(s.events[1].body, 0);
  EXPECT_EQ(s.model.bodies[static_cast<std::size_t>(s.events[1].body)].name, "loose_1");
  EXPECT_TRUE(s.trocar_note.empty());
  // The held block starts where the hand starts.
  const Vec3 p0 = s.model.bodies[static_cast<std::size_t>(s.model.initial_held_body)].initial_pose.position;
  EXPECT_LT((p0 - s.trajectory[0].pose.position).norm(), 1e-12);
}

TEST(Scene, HeldBodyStartsAtTheDevicesFirstTarget) {
  NUMEN_REQUIRE_ARTICULATION();
  // Lattice scene (the default scene's instrument): the instrument's position is omitted, so it
  // starts at the device's first controlled pose (no jump at start).
  const Scene s = load_scene(numen::test::lattice_scene_path());
  const numen::core::Pose initial =
      s.model.bodies[static_cast<std::size_t>(s.model.initial_held_body)].initial_pose;
  const numen::sim::SimulatedInstrument inst(s.device, s.trajectory);
  const numen::core::Pose first = inst.controlled_pose_at(0);
  EXPECT_LT((initial.position - first.position).norm(), 1e-12);
  EXPECT_LT(angle_between(initial.orientation, first.orientation), 1e-9);
  // The controlled frame is 40 mm behind the recorded tip along the shaft: the
  // tool tip (COM + R·(0, 0, 0.04)) is the trajectory's first tip position.
  const Vec3 tip = initial.position + initial.orientation * Vec3(0.0, 0.0, 0.04);
  EXPECT_LT((tip - s.trajectory[0].pose.position).norm(), 1e-9);
  // The shaft points from the trocar to the tip.
  const Vec3 shaft = (s.trajectory[0].pose.position - s.device.trocar.point).normalized();
  EXPECT_LT((initial.orientation * Vec3::UnitZ() - shaft).norm(), 1e-9);

  // Construction scene: the pose tracker reports the hand pose itself.
  const Scene c = load_scene(shipped_construction_path());
  const numen::sim::SimulatedInstrument hand(c.device, c.trajectory);
  const auto& held = c.model.bodies[static_cast<std::size_t>(c.model.initial_held_body)];
  EXPECT_LT((held.initial_pose.position - hand.controlled_pose_at(0).position).norm(), 1e-9);
  EXPECT_LT(angle_between(held.initial_pose.orientation, hand.controlled_pose_at(0).orientation), 1e-9);
}

TEST(Scene, CouplingOverrideChangesTheMode) {
  NUMEN_REQUIRE_ARTICULATION();
  const Scene god = load_scene(shipped_construction_path());
  EXPECT_EQ(god.model.coupling_mode, CouplingMode::kGodObject);
  const Scene direct = load_scene(shipped_construction_path(), SceneOverrides{CouplingMode::kDirect});
  EXPECT_EQ(direct.model.coupling_mode, CouplingMode::kDirect);
  const Scene first = load_scene(numen::test::lattice_scene_path(), SceneOverrides{CouplingMode::kFirstOrder});
  EXPECT_EQ(first.model.coupling_mode, CouplingMode::kFirstOrder);
  // Nothing else changes.
  EXPECT_EQ(direct.model.num_bodies(), god.model.num_bodies());
  EXPECT_EQ(direct.trajectory.size(), god.trajectory.size());
}

TEST(Scene, CouplingModeNames) {
  using numen::sim::parse_coupling_mode;
  EXPECT_EQ(parse_coupling_mode("god-object"), CouplingMode::kGodObject);
  EXPECT_EQ(parse_coupling_mode("first-order"), CouplingMode::kFirstOrder);
  EXPECT_EQ(parse_coupling_mode("direct"), CouplingMode::kDirect);
  for (CouplingMode m : {CouplingMode::kGodObject, CouplingMode::kFirstOrder, CouplingMode::kDirect})
    EXPECT_EQ(parse_coupling_mode(numen::sim::to_string(m)), m);
  try {
    (void)parse_coupling_mode("godobject");
    ADD_FAILURE() << "no error for an unknown coupling mode";
  } catch (const InputError& e) {
    EXPECT_EQ(e.key(), "coupling");
    EXPECT_NE(std::string(e.what()).find("godobject"), std::string::npos);
  }
}

TEST(Scene, EventsAreSortedByTime) {
  TempDir dir;
  std::string text = replace(kMiniScene, "[device]", R"([[body]]
name = "other"
mass = 0.1
position = [0.0, 0.2, 0.0]
spheres = [[0.0, 0.0, 0.0, 0.01]]

[device])");
  text += R"(
[[event]]
time = 0.6
attach = "tool"

[[event]]
time = 0.2
attach = "other"

[[event]]
time = 0.4
attach = "none"
)";
  const Scene s = load_scene(dir.write("events.toml", text));
  ASSERT_EQ(s.events.size(), 3u);
  EXPECT_DOUBLE_EQ(s.events[0].time_s, 0.2);
  EXPECT_EQ(s.events[0].body, 1);
  EXPECT_DOUBLE_EQ(s.events[1].time_s, 0.4);
  EXPECT_EQ(s.events[1].body, -1);
  EXPECT_DOUBLE_EQ(s.events[2].time_s, 0.6);
  EXPECT_EQ(s.events[2].body, 0);
}

TEST(Scene, TrapezoidalIntegratorIsSelectedByName) {
  TempDir dir;
  const std::string text = replace(kMiniScene, "dt = 0.001", "dt = 0.001\nintegrator = \"trapezoidal\"");
  const Scene s = load_scene(dir.write("trap.toml", text));
  EXPECT_EQ(s.model.integrator, numen::core::Integrator::kTrapezoidal);
  EXPECT_STREQ(numen::sim::to_string(s.model.integrator), "trapezoidal");
}

namespace {

/// The shipped deformable scene with `integrator`, its data and DCF paths made absolute so that
/// it loads from a temporary directory.
std::string deformable_scene_with(const std::string& integrator) {
  std::ifstream in(std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/deformable.toml");
  std::stringstream text;
  text << in.rdbuf();
  std::string toml =
      replace(text.str(), "integrator = \"implicit-euler\"", "integrator = \"" + integrator + "\"");
  // (built as one std::string, not "\"" + std::string(...): g++ 12's -Wrestrict false positive,
  // GCC bug 105329)
  const std::string data_dir = std::string("\"") + NUMEN_SOURCE_DIR + "/sim/data/";
  toml = replace(toml, "\"../data/", data_dir);
  return numen::test::with_absolute_dcf_paths(toml, std::string(NUMEN_SOURCE_DIR) + "/sim/scenes");
}

}  // namespace

TEST(Scene, TrapezoidalWithADeformableNetIsWarnedAbout) {
  NUMEN_REQUIRE_DEFORMABLE();
  const Scene plain = load_scene(std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/deformable.toml");
  for (const std::string& w : plain.warnings) EXPECT_EQ(w.find("L-stable"), std::string::npos) << w;
  TempDir dir;
  const Scene s = load_scene(dir.write("trap_deformable.toml", deformable_scene_with("trapezoidal")));
  EXPECT_EQ(s.model.integrator, numen::core::Integrator::kTrapezoidal);
  bool warned = false;
  for (const std::string& w : s.warnings)
    warned = warned || w.find("L-stable") != std::string::npos;
  EXPECT_TRUE(warned);
}

TEST(Scene, TrBdf2IntegratorIsSelectedByNameAndRunsFirstOrderCoupling) {
  TempDir dir;
  const std::string text = replace(
      kMiniScene, "dt = 0.001", "dt = 0.001\nintegrator = \"tr-bdf2\"\ncoupling = \"first-order\"");
  const Scene s = load_scene(dir.write("trbdf2.toml", text));
  EXPECT_EQ(s.model.integrator, numen::core::Integrator::kTrBdf2);
  EXPECT_EQ(s.model.coupling_mode, numen::core::CouplingMode::kFirstOrder);
  EXPECT_STREQ(numen::sim::to_string(s.model.integrator), "tr-bdf2");
}

TEST(Scene, TrBdf2WithADeformableNetIsNotWarnedAbout) {
  NUMEN_REQUIRE_DEFORMABLE();
  TempDir dir;
  const Scene s = load_scene(dir.write("trbdf2_deformable.toml", deformable_scene_with("tr-bdf2")));
  EXPECT_EQ(s.model.integrator, numen::core::Integrator::kTrBdf2);
  for (const std::string& w : s.warnings) EXPECT_EQ(w.find("L-stable"), std::string::npos) << w;
}

TEST(Scene, ContactOnsetDepthIsReadPerPairWithTheDefaultsFallback) {
  TempDir dir;
  const Scene plain = load_scene(dir.write("plain.toml", kMiniScene));
  for (const auto& p : plain.model.material_pairs) EXPECT_EQ(p.onset_depth, 0.0);
  const Scene s = load_scene(
      dir.write("onset.toml", kMiniScene + "\n[contact_default]\nstiffness = 2e4\nonset_depth = 2e-4\n"));
  for (const auto& p : s.model.material_pairs) EXPECT_EQ(p.onset_depth, 2e-4);
}

TEST(Scene, DeviceVelocityCutoffIsReadInHertz) {
  TempDir dir;
  EXPECT_EQ(load_scene(dir.write("mini.toml", kMiniScene)).device.velocity_cutoff_hz,
            numen::hal::kDefaultVelocityCutoffHz);
  const std::string text = replace(kMiniScene, "attach = \"tool\"", "attach = \"tool\"\nvelocity_cutoff = 20.5");
  EXPECT_EQ(load_scene(dir.write("cutoff.toml", text)).device.velocity_cutoff_hz, 20.5);
}

TEST(Scene, DeviceVelocityEstimatorAndFoawSettingsAreRead) {
  TempDir dir;
  const numen::hal::DeviceConfig plain = load_scene(dir.write("mini.toml", kMiniScene)).device;
  EXPECT_EQ(plain.velocity_estimator, numen::hal::VelocityEstimator::kFoaw);
  EXPECT_EQ(plain.foaw_max_window, numen::hal::kFoawMaxWindow);
  EXPECT_EQ(plain.foaw_noise_counts, numen::hal::kDefaultFoawNoiseCounts);
  for (const auto& [name, kind] :
       {std::pair<std::string, numen::hal::VelocityEstimator>{"difference", numen::hal::VelocityEstimator::kDifference},
        {"filter", numen::hal::VelocityEstimator::kFilter}, {"foaw", numen::hal::VelocityEstimator::kFoaw}}) {
    const std::string text = replace(kMiniScene, "attach = \"tool\"",
                                     "attach = \"tool\"\nvelocity_estimator = \"" + name +
                                         "\"\nfoaw_max_window = 12\nfoaw_noise_counts = 1.5");
    const numen::hal::DeviceConfig c = load_scene(dir.write(name + ".toml", text)).device;
    EXPECT_EQ(c.velocity_estimator, kind) << name;
    EXPECT_EQ(c.foaw_max_window, 12) << name;
    EXPECT_EQ(c.foaw_noise_counts, 1.5) << name;
  }
}

TEST(Scene, DeviceSoftStartIsReadInSecondsAndDefaultsToATenthOfASecond) {
  TempDir dir;
  EXPECT_EQ(load_scene(dir.write("mini.toml", kMiniScene)).device.soft_start_s,
            numen::hal::kDefaultSceneSoftStartS);
  EXPECT_EQ(numen::hal::kDefaultSceneSoftStartS, 0.1);
  for (const auto& [value, seconds] : {std::pair<std::string, double>{"0.25", 0.25}, {"0", 0.0}, {"10", 10.0}}) {
    const std::string text =
        replace(kMiniScene, "attach = \"tool\"", "attach = \"tool\"\nsoft_start = " + value);
    EXPECT_EQ(load_scene(dir.write("soft.toml", text)).device.soft_start_s, seconds) << value;
  }
}

TEST(Scene, APartThisBuildLeftOutIsRefusedByName) {
  // lattice.toml has [[joint]] tables, deformable.toml [[deformable]] ones.
  const std::string dir = std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/";
  const auto error_of = [](const std::string& path) -> std::string {
    try {
      numen::sim::load_scene(path);
    } catch (const numen::sim::InputError& e) {
      return e.what();
    }
    return {};
  };
  const std::string joints = error_of(dir + "lattice.toml");
  if (numen::core::kWithArticulation) {
    EXPECT_EQ(joints, "");
  } else {
    EXPECT_NE(joints.find("lattice.toml:"), std::string::npos) << joints;  // file:line
    EXPECT_NE(joints.find("needs joints: this build has NUMEN_WITH_ARTICULATION=OFF"),
              std::string::npos)
        << joints;
  }
  const std::string nets = error_of(dir + "deformable.toml");
  if (numen::core::kWithDeformable) {
    EXPECT_EQ(nets, "");
  } else {
    EXPECT_NE(nets.find("deformable.toml:"), std::string::npos) << nets;
    EXPECT_NE(nets.find("needs deformable nets: this build has NUMEN_WITH_DEFORMABLE=OFF"),
              std::string::npos)
        << nets;
  }
}
