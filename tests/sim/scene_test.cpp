// Tests of sim/scene: the shipped scenes load with what their files describe;
// scene-file errors name the file, line, column and dotted key with a message
// a user can act on; the default scene's geometry keeps its promise (the
// recorded tool tip goes at least 10 mm into the tissue and into the organ).
#include "numen/sim/scene.hpp"

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
#include "numen/sim/input_error.hpp"
#include "numen/sim/simulated_instrument.hpp"

#include "detail/joint_system.hpp"
#include "build_features.hpp"

namespace {

using numen::test::column_of;
using numen::test::line_of;
using numen::test::load_error;
using numen::test::replace;

namespace fs = std::filesystem;
using numen::core::CouplingMode;
using numen::core::Quat;
using numen::core::ShapeType;
using numen::core::Sphere;
using numen::core::Vec3;
using numen::sim::InputError;
using numen::sim::load_scene;
using numen::sim::Scene;
using numen::sim::SceneOverrides;

std::string construction_path() { return std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/construction.toml"; }
std::string excerpt_path() {
  return std::string(NUMEN_SOURCE_DIR) + "/sim/data/jigsaws_suturing_b002_excerpt.txt";
}

/// Angle (rad) between two rotations, q and -q being the same.
double angle_between(const Quat& a, const Quat& b) {
  const double d = std::min(1.0, std::abs(a.normalized().dot(b.normalized())));
  return 2.0 * std::acos(d);
}

using numen::test::TempDir;

// A small valid scene (pose tracker, scripted path; tests/support/scene_text.hpp). Every error
// test below changes one thing in it, so that the error can only come from that change.
const std::string& kMini = numen::test::kMiniScene;

/// what() must contain the scene file's name, the line (and column), the key and `message`.
void expect_located(const InputError& e, const std::string& file, int line, int column,
                    const std::string& key, const std::string& message) {
  const std::string what = e.what();
  SCOPED_TRACE(what);
  EXPECT_EQ(e.file(), file);
  EXPECT_NE(what.find(fs::path(file).filename().string()), std::string::npos) << "file name";
  EXPECT_GT(line, 0) << "test bug: the line was not found in the template";
  EXPECT_EQ(e.line(), line);
  std::ostringstream place;
  place << ':' << line << ':';
  if (column > 0) {
    EXPECT_EQ(e.column(), column);
    place << column << ':';
  }
  EXPECT_NE(what.find(place.str()), std::string::npos) << place.str();
  if (!key.empty()) {
    EXPECT_EQ(e.key(), key);
    EXPECT_NE(what.find(key), std::string::npos) << "dotted key";
  }
  EXPECT_NE(e.message().find(message), std::string::npos) << "message: " << e.message();
}

// ---------------------------------------------------------------- shipped scenes

TEST(Scene, DefaultSceneLoadsWhatItsFileDescribes) {
  NUMEN_REQUIRE_ARTICULATION();
  const Scene s = load_scene(numen::sim::default_scene_path());
  EXPECT_EQ(s.name, "default");
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
  EXPECT_EQ(s.model.initial_attached_body, 1);
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
  const Scene s = load_scene(construction_path());
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
  ASSERT_GE(s.model.initial_attached_body, 0);
  EXPECT_EQ(s.model.bodies[static_cast<std::size_t>(s.model.initial_attached_body)].name, "held");
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
  const Vec3 p0 = s.model.bodies[static_cast<std::size_t>(s.model.initial_attached_body)].initial_pose.position;
  EXPECT_LT((p0 - s.trajectory[0].pose.position).norm(), 1e-12);
}

TEST(Scene, AttachedBodyStartsAtTheDevicesFirstTarget) {
  NUMEN_REQUIRE_ARTICULATION();
  // Default scene: the instrument's position is omitted, so it starts at the
  // device's first controlled pose (no jump at start).
  const Scene s = load_scene(numen::sim::default_scene_path());
  const numen::core::Pose initial =
      s.model.bodies[static_cast<std::size_t>(s.model.initial_attached_body)].initial_pose;
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
  const Scene c = load_scene(construction_path());
  const numen::sim::SimulatedInstrument hand(c.device, c.trajectory);
  const auto& held = c.model.bodies[static_cast<std::size_t>(c.model.initial_attached_body)];
  EXPECT_LT((held.initial_pose.position - hand.controlled_pose_at(0).position).norm(), 1e-9);
  EXPECT_LT(angle_between(held.initial_pose.orientation, hand.controlled_pose_at(0).orientation), 1e-9);
}

TEST(Scene, CouplingOverrideChangesTheMode) {
  NUMEN_REQUIRE_ARTICULATION();
  const Scene god = load_scene(construction_path());
  EXPECT_EQ(god.model.coupling_mode, CouplingMode::kGodObject);
  const Scene direct = load_scene(construction_path(), SceneOverrides{CouplingMode::kDirect});
  EXPECT_EQ(direct.model.coupling_mode, CouplingMode::kDirect);
  const Scene first = load_scene(numen::sim::default_scene_path(), SceneOverrides{CouplingMode::kFirstOrder});
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
  std::string text = replace(kMini, "[device]", R"([[body]]
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

// ---------------------------------------------------------------- scene-file errors

TEST(SceneErrors, TheTemplateIsValid) {
  TempDir dir;
  const Scene s = load_scene(dir.write("mini.toml", kMini));
  EXPECT_EQ(s.name, "mini");
  EXPECT_EQ(s.model.num_bodies(), 1);
  EXPECT_NEAR(s.trajectory.duration(), 0.75, 1e-9);
  EXPECT_TRUE(s.warnings.empty());
}

TEST(Scene, TrapezoidalIntegratorIsSelectedByName) {
  TempDir dir;
  const std::string text = replace(kMini, "dt = 0.001", "dt = 0.001\nintegrator = \"trapezoidal\"");
  const Scene s = load_scene(dir.write("trap.toml", text));
  EXPECT_EQ(s.model.integrator, numen::core::Integrator::kTrapezoidal);
  EXPECT_STREQ(numen::sim::to_string(s.model.integrator), "trapezoidal");
}

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
      kMini, "dt = 0.001", "dt = 0.001\nintegrator = \"tr-bdf2\"\ncoupling = \"first-order\"");
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
  const Scene plain = load_scene(dir.write("plain.toml", kMini));
  for (const auto& p : plain.model.material_pairs) EXPECT_EQ(p.onset_depth, 0.0);
  const Scene s = load_scene(
      dir.write("onset.toml", kMini + "\n[contact_default]\nstiffness = 2e4\nonset_depth = 2e-4\n"));
  for (const auto& p : s.model.material_pairs) EXPECT_EQ(p.onset_depth, 2e-4);
}

TEST(SceneErrors, NegativeContactOnsetDepthNamesTheKey) {
  TempDir dir;
  const std::string text = kMini + "\n[contact_default]\nonset_depth = -1e-4\n";
  const InputError e = load_error(dir, text);
  expect_located(e, (dir.path() / "bad.toml").string(), line_of(text, "onset_depth = "),
                 column_of(text, "onset_depth = ", "-1e-4"), "contact_default.onset_depth", "");
}

TEST(SceneErrors, TrapezoidalWithFirstOrderCouplingNamesTheIntegratorKey) {
  TempDir dir;
  const std::string text = replace(
      kMini, "dt = 0.001", "dt = 0.001\nintegrator = \"trapezoidal\"\ncoupling = \"first-order\"");
  const InputError e = load_error(dir, text);
  expect_located(e, (dir.path() / "bad.toml").string(), line_of(text, "integrator = "),
                 column_of(text, "integrator = ", "\"trapezoidal\""), "integrator", "first-order");
  EXPECT_NE(e.message().find("L-stable"), std::string::npos) << e.what();
}

TEST(SceneErrors, MissingSceneFile) {
  const std::string path = (fs::temp_directory_path() / "numen_no_such_scene_file.toml").string();
  try {
    (void)load_scene(path);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), path);
    EXPECT_NE(std::string(e.what()).find("numen_no_such_scene_file.toml"), std::string::npos);
    EXPECT_NE(e.message().find("cannot open"), std::string::npos) << e.what();
  }
}

TEST(SceneErrors, TomlSyntaxError) {
  TempDir dir;
  const std::string text = replace(kMini, "mass = 0.1", "mass = = 0.1");
  const InputError e = load_error(dir, text, "syntax.toml");
  const std::string what = e.what();
  EXPECT_EQ(e.file(), (dir.path() / "syntax.toml").string());
  EXPECT_NE(what.find("syntax.toml"), std::string::npos) << what;
  EXPECT_EQ(e.line(), line_of(text, "mass = = 0.1")) << what;
  EXPECT_GT(e.column(), 0) << what;
  EXPECT_NE(e.message().find("TOML syntax"), std::string::npos) << what;
}

// toml++ 3.3.0 (upstream marzer/tomlplusplus#295, fixed by PR #305) reaches TOML_UNREACHABLE,
// undefined behaviour, on a non-ASCII character in U+00A1..U+0499 where the parser skips
// whitespace; sim/CMakeLists.txt compiles the parser with that fix. The 2-byte file is the
// fuzz corpus's regression input (tests/fuzz/corpus/scene); under UBSan the unfixed parser aborts.
TEST(SceneErrors, NonAsciiCharacterInABarePositionIsALocatedSyntaxError) {
  const std::string path =
      std::string(NUMEN_SOURCE_DIR) + "/tests/fuzz/corpus/scene/toml-issue-295-middle-dot";
  try {
    (void)load_scene(path);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), path);
    EXPECT_EQ(e.line(), 1) << e.what();
    EXPECT_EQ(e.column(), 1) << e.what();
    EXPECT_NE(e.message().find("TOML syntax"), std::string::npos) << e.what();
  }
  // The same character class after a value and as a key on a later line (U+00E9, U+0416).
  TempDir dir;
  for (const std::string bad : {"\xC3\xA9", "\xD0\x96"}) {
    const std::string text = replace(kMini, "mass = 0.1", "mass = 0.1 " + bad + "\n" + bad + " = 1");
    const InputError e = load_error(dir, text, "non_ascii.toml");
    EXPECT_EQ(e.line(), line_of(text, "mass = 0.1")) << e.what();
    EXPECT_GT(e.column(), 0) << e.what();
    EXPECT_NE(e.message().find("TOML syntax"), std::string::npos) << e.what();
  }
}

TEST(SceneErrors, UnknownTopLevelKeyIsATypo) {
  TempDir dir;
  const std::string text = replace(kMini, "gravity = [", "gravitty = [");
  const InputError e = load_error(dir, text);
  expect_located(e, (dir.path() / "bad.toml").string(), line_of(text, "gravitty"),
                 column_of(text, "gravitty", "["), "gravitty", "unknown key");
  EXPECT_NE(e.message().find("gravity"), std::string::npos) << "lists the allowed keys: " << e.what();
}

TEST(SceneErrors, UnknownKeyInsideSecondBody) {
  TempDir dir;
  const std::string text = replace(kMini, "[[obstacle]]", R"([[body]]
name = "second"
mass = 0.2
radiuss = 0.01
position = [0.0, 0.3, 0.0]

[[obstacle]])");
  const InputError e = load_error(dir, text);
  expect_located(e, (dir.path() / "bad.toml").string(), line_of(text, "radiuss"),
                 column_of(text, "radiuss", "0.01"), "body[1].radiuss", "unknown key");
}

TEST(SceneErrors, NumberWhereAStringIsExpected) {
  TempDir dir;
  const std::string text = replace(kMini, "name = \"tool\"", "name = 42");
  const InputError e = load_error(dir, text);
  expect_located(e, (dir.path() / "bad.toml").string(), line_of(text, "name = 42"),
                 column_of(text, "name = 42", "42"), "body[0].name", "expected a string");
  EXPECT_NE(e.message().find("integer"), std::string::npos) << e.what();
}

TEST(SceneErrors, NegativeMass) {
  TempDir dir;
  const std::string text = replace(kMini, "mass = 0.1", "mass = -0.1");
  const InputError e = load_error(dir, text);
  expect_located(e, (dir.path() / "bad.toml").string(), line_of(text, "mass = -0.1"),
                 column_of(text, "mass = -0.1", "-0.1"), "body[0].mass", "must be in");
  EXPECT_NE(e.message().find("-0.1"), std::string::npos) << "quotes the value: " << e.what();
}

TEST(SceneErrors, UnknownMaterial) {
  TempDir dir;
  const std::string text = replace(kMini, "material = \"steel\"", "material = \"wood\"");
  const InputError e = load_error(dir, text);
  expect_located(e, (dir.path() / "bad.toml").string(), line_of(text, "material = \"wood\""),
                 column_of(text, "material = \"wood\"", "\"wood\""), "body[0].material",
                 "unknown material \"wood\"");
  EXPECT_NE(e.message().find("steel"), std::string::npos) << "lists the declared ones: " << e.what();
}

TEST(SceneErrors, UnknownBodyInDeviceAttach) {
  TempDir dir;
  const std::string text = replace(kMini, "attach = \"tool\"", "attach = \"tol\"");
  const InputError e = load_error(dir, text);
  expect_located(e, (dir.path() / "bad.toml").string(), line_of(text, "attach = \"tol\""),
                 column_of(text, "attach = \"tol\"", "\"tol\""), "device.attach", "no body named \"tol\"");
}

TEST(Scene, DeviceVelocityCutoffIsReadInHertz) {
  TempDir dir;
  EXPECT_EQ(load_scene(dir.write("mini.toml", kMini)).device.velocity_cutoff_hz,
            numen::hal::kDefaultVelocityCutoffHz);
  const std::string text = replace(kMini, "attach = \"tool\"", "attach = \"tool\"\nvelocity_cutoff = 20.5");
  EXPECT_EQ(load_scene(dir.write("cutoff.toml", text)).device.velocity_cutoff_hz, 20.5);
}

TEST(SceneErrors, ANonPositiveVelocityCutoffIsLocated) {
  TempDir dir;
  for (const std::string bad : {"0.0", "-50.0", "nan", "inf"}) {
    const std::string line = "velocity_cutoff = " + bad;
    const std::string text = replace(kMini, "attach = \"tool\"", "attach = \"tool\"\n" + line);
    const InputError e = load_error(dir, text);
    expect_located(e, (dir.path() / "bad.toml").string(), line_of(text, line),
                   column_of(text, line, bad), "device.velocity_cutoff",
                   bad == "nan" || bad == "inf" ? "must be finite" : "must be in");
  }
}

TEST(Scene, DeviceSoftStartIsReadInSecondsAndDefaultsToATenthOfASecond) {
  TempDir dir;
  EXPECT_EQ(load_scene(dir.write("mini.toml", kMini)).device.soft_start_s,
            numen::hal::kDefaultSceneSoftStartS);
  EXPECT_EQ(numen::hal::kDefaultSceneSoftStartS, 0.1);
  for (const auto& [value, seconds] : {std::pair<std::string, double>{"0.25", 0.25}, {"0", 0.0}, {"10", 10.0}}) {
    const std::string text =
        replace(kMini, "attach = \"tool\"", "attach = \"tool\"\nsoft_start = " + value);
    EXPECT_EQ(load_scene(dir.write("soft.toml", text)).device.soft_start_s, seconds) << value;
  }
}

TEST(SceneErrors, ASoftStartOutsideZeroToTenSecondsIsLocated) {
  TempDir dir;
  for (const std::string bad : {"-0.1", "10.5", "nan", "inf", "\"fast\""}) {
    const std::string line = "soft_start = " + bad;
    const std::string text = replace(kMini, "attach = \"tool\"", "attach = \"tool\"\n" + line);
    const InputError e = load_error(dir, text);
    expect_located(e, (dir.path() / "bad.toml").string(), line_of(text, line),
                   column_of(text, line, bad), "device.soft_start",
                   bad == "nan" || bad == "inf" ? "must be finite"
                   : bad[0] == '"'              ? "expected a number"
                                                : "must be in [0, 10]");
  }
}

TEST(SceneErrors, MissingTrajectoryFile) {
  TempDir dir;
  const std::string text = replace(kMini, R"(source = "scripted"
start = { position = [0.0, 0.0, 0.0] })",
                                   R"(source = "jigsaws"
file = "no_such_recording.txt")");
  // Drop the segments that a jigsaws trajectory does not take.
  const std::string trimmed = text.substr(0, text.find("[[trajectory.segment]]"));
  const InputError e = load_error(dir, trimmed);
  expect_located(e, (dir.path() / "bad.toml").string(), line_of(trimmed, "no_such_recording"),
                 column_of(trimmed, "file = ", "\""), "trajectory.file", "not found");
  EXPECT_NE(e.message().find("no_such_recording.txt"), std::string::npos) << e.what();
}

namespace {

/// A trocar-instrument scene reading the JIGSAWS file `data` (absolute path), with `extra`
/// lines in its [trajectory].
std::string jigsaws_scene(const std::string& data, const std::string& extra = "") {
  std::string text = R"(name = "jig"
[[body]]
name = "tool"
mass = 0.05
spheres = [[0.0, 0.0, 0.0, 0.0025]]
[device]
kind = "trocar-instrument"
attach = "tool"
[device.trocar]
placement = "approach"
[trajectory]
source = "jigsaws"
file = ")";
  text += data;
  text += "\"\nmanipulator = \"slave_right\"\n";
  text += extra;
  return text;
}

}  // namespace

TEST(SceneErrors, JigsawsTrajectoryWithAMalformedLineNamesTheDataFile) {
  TempDir dir;
  // A copy of the shipped excerpt with one token of line 7 replaced.
  std::ifstream in(excerpt_path());
  ASSERT_TRUE(in) << excerpt_path();
  std::ostringstream data;
  std::string line;
  int bad_column = 0;
  for (int n = 1; std::getline(in, line); ++n) {
    if (n == 7) {
      // Replace the 5th token.
      std::size_t c = 0;
      for (int tok = 0; tok < 5; ++tok) {
        c = line.find_first_not_of(" \t", c);
        if (tok < 4) c = line.find_first_of(" \t", c);
      }
      const std::size_t end = line.find_first_of(" \t", c);
      line.replace(c, end - c, "1.2.3");
      bad_column = static_cast<int>(c) + 1;
    }
    data << line << '\n';
  }
  const std::string data_path = dir.write("recording.txt", data.str());
  const std::string text = jigsaws_scene(data_path);
  const std::string scene_path = dir.write("jig.toml", text);
  try {
    (void)load_scene(scene_path);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    const std::string what = e.what();
    std::printf("[   info   ] %s\n", what.c_str());
    SCOPED_TRACE(what);
    EXPECT_EQ(e.file(), data_path);
    EXPECT_NE(what.find("recording.txt"), std::string::npos);
    EXPECT_EQ(e.line(), 7);
    EXPECT_EQ(e.column(), bad_column);
    std::ostringstream place;
    place << ":7:" << bad_column << ':';
    EXPECT_NE(what.find(place.str()), std::string::npos);
    EXPECT_EQ(e.key(), "master_left.R12");  // 5th column: tip_x tip_y tip_z R11 R12
    EXPECT_NE(e.message().find("'1.2.3'"), std::string::npos);
    EXPECT_NE(e.message().find("not a number"), std::string::npos);
  }
  // The same scene with the shipped excerpt loads.
  const std::string good = replace(text, data_path, excerpt_path());
  const Scene s = load_scene(dir.write("jig_ok.toml", good));
  EXPECT_NEAR(s.trajectory.duration(), 899.0 / 30.0, 1.5e-3);
}

TEST(SceneErrors, ScriptedSegmentWithNegativeDurationIsLocatedAtThatSegment) {
  TempDir dir;
  const std::string text = replace(kMini, "duration = 0.25", "duration = -0.25");
  const InputError e = load_error(dir, text);
  expect_located(e, (dir.path() / "bad.toml").string(), line_of(text, "duration = -0.25"),
                 column_of(text, "duration = -0.25", "-0.25"), "trajectory.segment[1].duration", "> 0");
}

TEST(SceneErrors, WrongNumberOfDeviceAxes) {
  TempDir dir;
  const std::string text = kMini + R"(
[[device.axis]]
name = "x"

[[device.axis]]
name = "y"
)";
  const InputError e = load_error(dir, text);
  const std::string what = e.what();
  SCOPED_TRACE(what);
  EXPECT_EQ(e.file(), (dir.path() / "bad.toml").string());
  EXPECT_NE(what.find("bad.toml"), std::string::npos);
  EXPECT_EQ(e.key(), "device.axis");
  EXPECT_NE(e.message().find("6 axes, 2 given"), std::string::npos);
  // Located at the axis list: its first [[device.axis]] header.
  EXPECT_EQ(e.line(), line_of(text, "[[device.axis]]"));
}

TEST(SceneErrors, AContactStiffnessTheStepCannotResolveIsAWarningNamingTheBody) {
  // The mini scene's tool: 0.1 kg, its sphere at the COM (effective mass 0.1 kg); at dt = 1 ms the
  // time-constant floor ω h ≤ 5 lets a contact act with at most 0.1 · (5 / 1 ms)² = 2.5e6 N/m.
  TempDir dir;
  const std::string stiff = kMini + "\n[contact_default]\nstiffness = 1e9\n";
  const Scene s = load_scene(dir.write("stiff.toml", stiff));
  ASSERT_EQ(s.warnings.size(), 1u);
  const std::string& w = s.warnings[0];
  EXPECT_NE(w.find("body \"tool\""), std::string::npos) << w;
  EXPECT_NE(w.find("1e+09 N/m"), std::string::npos) << w;
  EXPECT_NE(w.find("2.5e+06 N/m"), std::string::npos) << w;
  EXPECT_NE(w.find("contact_max_omega_dt"), std::string::npos) << w;
  // Below the floor, or with the floor raised in [solver]: no warning.
  const Scene soft = load_scene(dir.write("soft.toml", kMini + "\n[contact_default]\nstiffness = 2e6\n"));
  EXPECT_TRUE(soft.warnings.empty());
  const Scene raised = load_scene(
      dir.write("raised.toml", kMini + "\n[contact_default]\nstiffness = 1e9\n[solver]\ncontact_max_omega_dt = 100.0\n"));
  EXPECT_TRUE(raised.warnings.empty()) << raised.warnings.front();
  EXPECT_DOUBLE_EQ(raised.model.solver.contact_max_omega_dt, 100.0);
  // Out of range: an error naming the key.
  const InputError e = load_error(dir, kMini + "\n[solver]\ncontact_max_omega_dt = 0.0\n");
  EXPECT_EQ(e.key(), "solver.contact_max_omega_dt");
}

TEST(SceneErrors, DampingOutsideThePapersRuleIsAWarningNotAnError) {
  TempDir dir;
  // ζ = 0.5 → γ/√(mk) = 1.0 < 1.4.
  const std::string low = replace(kMini, "damping_ratio = 0.85", "damping_ratio = 0.5");
  const Scene s = load_scene(dir.write("low.toml", low));
  ASSERT_EQ(s.warnings.size(), 1u);
  const std::string& w = s.warnings[0];
  EXPECT_NE(w.find("low.toml"), std::string::npos) << w;
  EXPECT_NE(w.find("body[0].coupling"), std::string::npos) << w;
  EXPECT_NE(w.find("1.4"), std::string::npos) << w;
  // Explicit damping: γ = 2.5 √(m k) → above 2.
  const double gamma = 2.5 * std::sqrt(0.1 * 100.0);
  const std::string high = replace(kMini, "damping_ratio = 0.85", "damping = " + std::to_string(gamma));
  const Scene h = load_scene(dir.write("high.toml", high));
  ASSERT_EQ(h.warnings.size(), 1u);
  EXPECT_NE(h.warnings[0].find("body[0].coupling.damping"), std::string::npos) << h.warnings[0];
  EXPECT_NEAR(h.model.bodies[0].coupling.gamma_t, gamma, 1e-6);
  // Inside the rule (γ/√(mk) = 1.6): no warning.
  const std::string ok = replace(kMini, "damping_ratio = 0.85", "damping_ratio = 0.8");
  EXPECT_TRUE(load_scene(dir.write("ok.toml", ok)).warnings.empty());
}

TEST(SceneErrors, MissingDevice) {
  TempDir dir;
  const std::string text = replace(kMini, "[device]\nkind = \"pose-tracker\"\nattach = \"tool\"\n", "");
  const InputError e = load_error(dir, text);
  const std::string what = e.what();
  SCOPED_TRACE(what);
  EXPECT_EQ(e.file(), (dir.path() / "bad.toml").string());
  EXPECT_NE(what.find("bad.toml"), std::string::npos);
  EXPECT_EQ(e.key(), "device");
  EXPECT_NE(what.find("device: missing"), std::string::npos);
  EXPECT_NE(e.message().find("[device]"), std::string::npos);
}

TEST(SceneErrors, MissingTrajectory) {
  TempDir dir;
  const std::string text = kMini.substr(0, kMini.find("[trajectory]"));
  const InputError e = load_error(dir, text);
  const std::string what = e.what();
  SCOPED_TRACE(what);
  EXPECT_EQ(e.file(), (dir.path() / "bad.toml").string());
  EXPECT_NE(what.find("bad.toml"), std::string::npos);
  EXPECT_EQ(e.key(), "trajectory");
  EXPECT_NE(what.find("trajectory: missing"), std::string::npos);
  EXPECT_NE(e.message().find("[trajectory]"), std::string::npos);
}

// ---------------------------------------------------------------- default scene geometry

/// The spheres of a sphere set bucketed in a uniform grid, for fast "is this
/// point covered by the union?" queries (brute force over the 27 cells around).
class SphereUnion {
 public:
  explicit SphereUnion(std::vector<Sphere> spheres) : spheres_(std::move(spheres)) {
    double r_max = 0.0;
    lo_ = Vec3::Constant(1e300);
    Vec3 hi = Vec3::Constant(-1e300);
    for (const Sphere& sp : spheres_) {
      r_max = std::max(r_max, sp.radius);
      lo_ = lo_.cwiseMin(sp.center - Vec3::Constant(sp.radius));
      hi = hi.cwiseMax(sp.center + Vec3::Constant(sp.radius));
    }
    cell_ = 2.0 * r_max;
    for (int k = 0; k < 3; ++k) n_[k] = static_cast<int>(std::ceil((hi[k] - lo_[k]) / cell_)) + 1;
    cells_.resize(static_cast<std::size_t>(n_[0] * n_[1] * n_[2]));
    for (std::size_t i = 0; i < spheres_.size(); ++i) cells_[index(cell_of(spheres_[i].center))].push_back(i);
    centre_ = 0.5 * (lo_ + hi);
    bound_ = 0.5 * (hi - lo_).norm();
  }
  /// True if `p` lies strictly inside one of the spheres.
  bool covered(const Vec3& p) const {
    const Eigen::Vector3i c = cell_of(p);
    for (int i = c.x() - 1; i <= c.x() + 1; ++i)
      for (int j = c.y() - 1; j <= c.y() + 1; ++j)
        for (int k = c.z() - 1; k <= c.z() + 1; ++k) {
          if (i < 0 || j < 0 || k < 0 || i >= n_[0] || j >= n_[1] || k >= n_[2]) continue;
          for (std::size_t s : cells_[index(Eigen::Vector3i(i, j, k))]) {
            const Sphere& sp = spheres_[s];
            if ((p - sp.center).squaredNorm() < sp.radius * sp.radius) return true;
          }
        }
    return false;
  }
  /// Distance from `p` beyond which no sphere lies.
  double reach(const Vec3& p) const { return (p - centre_).norm() + bound_; }
  const std::vector<Sphere>& spheres() const { return spheres_; }

 private:
  Eigen::Vector3i cell_of(const Vec3& p) const {
    return ((p - lo_) / cell_).array().floor().cast<int>().matrix();
  }
  std::size_t index(const Eigen::Vector3i& c) const {
    return static_cast<std::size_t>((c.x() * n_[1] + c.y()) * n_[2] + c.z());
  }
  std::vector<Sphere> spheres_;
  std::vector<std::vector<std::size_t>> cells_;
  Vec3 lo_, centre_;
  double cell_ = 1.0, bound_ = 0.0;
  int n_[3] = {0, 0, 0};
};

constexpr double kMarchStep = 0.00025;  // 0.25 mm

/// Depth of `p` below the union: distance to the nearest point not covered by
/// any sphere, estimated as the smallest distance, over `dirs`, at which a
/// march in 0.25 mm steps first finds an uncovered point. Enclosed voids count.
double depth_below_union(const SphereUnion& u, const Vec3& p, const std::vector<Vec3>& dirs) {
  if (!u.covered(p)) return 0.0;
  double best = u.reach(p);
  for (const Vec3& d : dirs)
    for (double s = kMarchStep; s < best; s += kMarchStep)
      if (!u.covered(p + s * d)) {
        best = s;
        break;
      }
  return best;
}

/// Depth of `p` inside the solid bounded by the union's outer surface:
/// smallest distance, over `dirs`, at which a ray leaves the union for the
/// last time (enclosed voids do not count as outside).
double depth_to_exterior(const SphereUnion& u, const Vec3& p, const std::vector<Vec3>& dirs) {
  if (!u.covered(p)) return 0.0;
  const double reach = u.reach(p);
  double best = reach;
  for (const Vec3& d : dirs) {
    double last_covered = 0.0;
    for (double s = kMarchStep; s < reach; s += kMarchStep)
      if (u.covered(p + s * d)) last_covered = s;
    best = std::min(best, last_covered + kMarchStep);
  }
  return best;
}

std::vector<Vec3> cube_directions() {  // the 26 neighbours of a cube cell
  std::vector<Vec3> d;
  for (int i = -1; i <= 1; ++i)
    for (int j = -1; j <= 1; ++j)
      for (int k = -1; k <= 1; ++k)
        if (i || j || k) d.push_back(Vec3(i, j, k).normalized());
  return d;
}

std::vector<Vec3> dense_directions(int n) {  // the 26 plus n near-uniform (Fibonacci) ones
  std::vector<Vec3> d = cube_directions();
  const double golden = std::numbers::pi * (3.0 - std::sqrt(5.0));
  for (int i = 0; i < n; ++i) {
    const double z = 1.0 - 2.0 * (i + 0.5) / n;
    const double r = std::sqrt(1.0 - z * z);
    d.push_back(Vec3(r * std::cos(golden * i), r * std::sin(golden * i), z));
  }
  return d;
}

const Scene& default_scene() {
  static const Scene s = load_scene(numen::sim::default_scene_path());
  return s;
}

const numen::core::Obstacle* obstacle(const Scene& s, const std::string& name) {
  for (const auto& o : s.model.obstacles)
    if (o.name == name) return &o;
  return nullptr;
}

SphereUnion organ_union(const Scene& s) {
  const numen::core::Obstacle* organ = obstacle(s, "organ");
  EXPECT_NE(organ, nullptr);
  if (!organ) return SphereUnion({Sphere{}});
  EXPECT_EQ(organ->type, ShapeType::kSphereSet);
  return SphereUnion(std::vector<Sphere>(s.model.static_spheres.begin() + organ->sphere_begin,
                                         s.model.static_spheres.begin() + organ->sphere_begin + organ->sphere_count));
}

/// Recorded tip positions of the default scene every 10 ms that lie inside the
/// organ's union, deepest first by depth_to_exterior() over the 26 directions.
const std::vector<std::pair<double, Vec3>>& organ_tips() {
  static const std::vector<std::pair<double, Vec3>> inside = [] {
    const Scene& s = default_scene();
    const SphereUnion u = organ_union(s);
    const std::vector<Vec3> coarse = cube_directions();
    std::vector<std::pair<double, Vec3>> out;
    for (int k = 0; k * 0.01 <= s.trajectory.duration(); ++k) {
      const Vec3 p = s.trajectory.at(k * 0.01).pose.position;
      const double d = depth_to_exterior(u, p, coarse);
      if (d > 0.0) out.emplace_back(d, p);
    }
    std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
    return out;
  }();
  return inside;
}

TEST(DefaultSceneGeometry, RecordedTipGoesAtLeast10mmIntoTheTissue) {
  NUMEN_REQUIRE_ARTICULATION();
  const Scene& s = default_scene();
  const numen::core::Obstacle* tissue = obstacle(s, "tissue");
  ASSERT_NE(tissue, nullptr);
  ASSERT_EQ(tissue->type, ShapeType::kPlane);
  // The solid is below the plane (against the normal).
  const Vec3 n = tissue->pose.orientation * Vec3::UnitZ();
  double depth = 0.0;
  for (std::size_t idx = 0; idx < s.trajectory.size(); ++idx) {
    const auto sample = s.trajectory[idx];
    depth = std::max(depth, -(sample.pose.position - tissue->pose.position).dot(n));
  }
  std::printf("[   info   ] recorded tip depth below the tissue plane: max %.2f mm\n", depth * 1e3);
  EXPECT_GE(depth, 0.010);
}

TEST(DefaultSceneGeometry, RecordedTipGoesAtLeast10mmIntoTheOrgan) {
  NUMEN_SKIP_UNDER_SANITIZER(
      "checks the shipped recording against the shipped organ (data, not code): 40 s under "
      "ASan+UBSan with coverage");
  NUMEN_REQUIRE_ARTICULATION();
  // Depth inside the solid the organ's spheres bound: distance to the nearest
  // point outside the union's outer surface.
  const Scene& s = default_scene();
  const SphereUnion u = organ_union(s);
  const auto& inside = organ_tips();
  ASSERT_FALSE(inside.empty()) << "the recorded tip never enters the organ";
  const std::vector<Vec3> fine = dense_directions(400);
  double depth = 0.0;
  for (std::size_t i = 0; i < std::min<std::size_t>(inside.size(), 12); ++i)
    depth = std::max(depth, depth_to_exterior(u, inside[i].second, fine));
  std::printf("[   info   ] recorded tip depth inside the organ's outer surface (%zu spheres): max %.2f mm "
              "(26 directions: %.2f mm; %zu of %zu sampled positions inside)\n",
              u.spheres().size(), depth * 1e3, inside.front().first * 1e3, inside.size(),
              static_cast<std::size_t>(s.trajectory.duration() / 0.01) + 1);
  EXPECT_GE(depth, 0.010);
}

TEST(DefaultSceneGeometry, RecordedTipGoesAtLeast10mmBelowTheUnionOfTheOrgansSpheres) {
  NUMEN_SKIP_UNDER_SANITIZER(
      "checks the shipped recording against the shipped organ (data, not code): 60 s under "
      "ASan+UBSan with coverage");
  NUMEN_REQUIRE_ARTICULATION();
  // Depth below the union itself: distance to the nearest point that no
  // sphere covers (enclosed voids count), marched along 26 + 400 directions.
  const Scene& s = default_scene();
  const SphereUnion u = organ_union(s);
  const auto& inside = organ_tips();
  ASSERT_FALSE(inside.empty());
  const std::vector<Vec3> fine = dense_directions(400);
  double depth26 = 0.0, depth = 0.0;
  for (const auto& c : inside) depth26 = std::max(depth26, depth_below_union(u, c.second, cube_directions()));
  for (std::size_t i = 0; i < std::min<std::size_t>(inside.size(), 40); ++i)
    depth = std::max(depth, depth_below_union(u, inside[i].second, fine));

  // Diagnosis: lattice cells of the fill whose 8 corners are all organ spheres
  // but whose centre no sphere covers are voids inside the organ.
  int interior_cells = 0, void_cells = 0;
  const auto& sp = u.spheres();
  for (std::size_t a = 0; a < sp.size(); ++a) {
    // Cells are spanned by a sphere and its 3 lattice neighbours at the pitch.
    std::vector<Vec3> nb;
    double pitch = 1e300;
    for (std::size_t b = 0; b < sp.size(); ++b)
      if (b != a) pitch = std::min(pitch, (sp[b].center - sp[a].center).norm());
    for (std::size_t b = 0; b < sp.size(); ++b)
      if (std::abs((sp[b].center - sp[a].center).norm() - pitch) < 1e-9) nb.push_back(sp[b].center - sp[a].center);
    // Take the cell in the +e1 +e2 +e3 octant of a local lattice frame.
    if (nb.size() < 6) continue;
    const Vec3 e1 = nb[0];
    Vec3 e2 = Vec3::Zero(), e3 = Vec3::Zero();
    for (const Vec3& v : nb)
      if (std::abs(v.dot(e1)) < 1e-12) {
        if (e2.isZero()) e2 = v;
        else if (std::abs(v.dot(e2)) < 1e-12) e3 = v;
      }
    if (e2.isZero() || e3.isZero()) continue;
    bool all_corners = true;
    for (int c = 1; c < 8; ++c) {
      const Vec3 corner = sp[a].center + ((c & 1) ? e1 : Vec3::Zero()) + ((c & 2) ? e2 : Vec3::Zero()) +
                          ((c & 4) ? e3 : Vec3::Zero());
      bool found = false;
      for (const Sphere& q : sp) found = found || (q.center - corner).norm() < 1e-9;
      all_corners = all_corners && found;
    }
    if (!all_corners) continue;
    ++interior_cells;
    if (!u.covered(sp[a].center + 0.5 * (e1 + e2 + e3))) ++void_cells;
  }
  std::printf("[   info   ] recorded tip depth below the union of the organ's spheres: max %.2f mm over 26+400 "
              "directions (%.2f mm over the 26 alone); %d of %d interior lattice cells have an uncovered centre\n",
              depth * 1e3, depth26 * 1e3, void_cells, interior_cells);
  EXPECT_GE(depth, 0.010) << "the union of the organ's spheres has enclosed voids: " << void_cells << " of "
                          << interior_cells
                          << " interior lattice cells have their centre uncovered (sphere_radius < spacing·√3/2)";
}

}  // namespace

// ---------------------------------------------------------------- [device.canopen]

TEST(SceneCanopen, DefaultsAreTheManagedStackAndKeysAreRead) {
  TempDir dir;
  const Scene d = load_scene(dir.write("mini.toml", kMini));
  EXPECT_TRUE(d.device.canopen.managed);
  ASSERT_EQ(d.device.canopen.axes.size(), 6u);
  EXPECT_EQ(d.device.canopen.axes[0].node_id, 1);
  EXPECT_EQ(d.device.canopen.axes[5].node_id, 6);
  EXPECT_EQ(d.device.canopen.axes[0].effective_heartbeat_timeout_ms(), 30u);
  EXPECT_EQ(d.device.canopen.axes[0].drive_tpdo_cob_id, 0u);  // a pose tracker has no drives

  const std::string text = replace(kMini, "attach = \"tool\"\n", R"(attach = "tool"

[device.canopen]
controller_node_id = 100
node_heartbeat_period = 20
heartbeat_timeout = 50
startup_timeout = 500
)");
  const Scene s = load_scene(dir.write("canopen.toml", text));
  EXPECT_EQ(s.device.canopen.controller_node_id, 100);
  EXPECT_EQ(s.device.canopen.startup_timeout_ms, 500u);
  EXPECT_EQ(s.device.canopen.axes[3].heartbeat_period_ms, 20);
  EXPECT_EQ(s.device.canopen.axes[3].effective_heartbeat_timeout_ms(), 50u);

  const Scene m = load_scene(dir.write(
      "minimal.toml", replace(kMini, "attach = \"tool\"\n", "attach = \"tool\"\ncanopen = { managed = false }\n")));
  EXPECT_FALSE(m.device.canopen.managed);
}

TEST(SceneCanopen, MappingsAreListedAndErrorsAreLocated) {
  TempDir dir;
  const std::string axis = R"(
[[device.canopen.axis]]
encoder_tpdo = [0x60040020, 0x60410010]
[[device.canopen.axis]]
[[device.canopen.axis]]
[[device.canopen.axis]]
[[device.canopen.axis]]
[[device.canopen.axis]]
node_id = 9
)";
  const std::string text = replace(kMini, "attach = \"tool\"\n", "attach = \"tool\"\n" + axis);
  const Scene s = load_scene(dir.write("map.toml", text));
  ASSERT_EQ(s.device.canopen.axes[0].encoder_tpdo.size(), 2u);
  EXPECT_EQ(s.device.canopen.axes[0].encoder_tpdo[1].index, 0x6041);
  EXPECT_EQ(s.device.canopen.axes[5].node_id, 9);

  // An object numen does not map: located at the list element.
  const std::string bad = replace(text, "[0x60040020, 0x60410010]", "[0x60040020, 0x60720010]");
  const InputError e = load_error(dir, bad, "badmap.toml");
  expect_located(e, (dir.path() / "badmap.toml").string(), line_of(bad, "0x60720010"),
                 column_of(bad, "encoder_tpdo", "0x60720010"),
                 "device.canopen.axis[0].encoder_tpdo[1]", "is not an object numen maps");
  // No position object: the whole mapping is refused, at its key.
  const std::string nopos = replace(text, "[0x60040020, 0x60410010]", "[0x60410010]");
  const InputError e2 = load_error(dir, nopos, "nopos.toml");
  EXPECT_EQ(e2.line(), line_of(nopos, "[0x60410010]"));
  EXPECT_NE(std::string(e2.what()).find("must map the position value 0x6004:00"), std::string::npos);
  // A node id used by the controller.
  const std::string clash = replace(text, "node_id = 9", "node_id = 127");
  const InputError e3 = load_error(dir, clash, "clash.toml");
  EXPECT_EQ(e3.line(), line_of(clash, "node_id = 127"));
  EXPECT_NE(std::string(e3.what()).find("controller's node id"), std::string::npos);
  // An unknown key.
  const InputError e4 = load_error(dir, replace(kMini, "attach = \"tool\"\n", "attach = \"tool\"\ncanopen = { manged = true }\n"), "typo.toml");
  EXPECT_NE(std::string(e4.what()).find("manged"), std::string::npos);
}

std::string shipped_dcf_text(const char* name) {
  std::ifstream in(std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/devices/" + name);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

TEST(SceneCanopen, DcfsAreReadPerNodeRelativeToTheScene) {
  TempDir dir;
  const std::string dcf = shipped_dcf_text("encoder.dcf");
  dir.write("enc.dcf", dcf);
  const std::string text = replace(kMini, "attach = \"tool\"\n", R"(attach = "tool"

[device.canopen]
dcf = "enc.dcf"
sdo_timeout = 50
sdo_poll_period = 100
)");
  const Scene s = load_scene(dir.write("dcf.toml", text));
  EXPECT_EQ(s.device.canopen.sdo_timeout_ms, 50u);
  EXPECT_EQ(s.device.canopen.sdo_poll_period_ms, 100u);
  for (std::size_t i = 0; i < 6; ++i) {
    const numen::hal::CanopenAxisConfig& x = s.device.canopen.axes[i];
    ASSERT_NE(x.dcf, nullptr);
    EXPECT_EQ(x.dcf->resolved_node_id, x.node_id);
    EXPECT_EQ(x.dcf->find({0x1800, 1})->value, 0x180u + x.node_id);  // $NODEID resolved per node
    EXPECT_EQ(x.dcf->path, (dir.path() / "enc.dcf").string());
  }
  // One axis's own DCF wins over the device's.
  dir.write("own.dcf", dcf);
  const std::string own = replace(text, "sdo_poll_period = 100\n", "sdo_poll_period = 100\n" R"(
[[device.canopen.axis]]
[[device.canopen.axis]]
[[device.canopen.axis]]
[[device.canopen.axis]]
[[device.canopen.axis]]
[[device.canopen.axis]]
dcf = "own.dcf"
)");
  const Scene o = load_scene(dir.write("own.toml", own));
  EXPECT_EQ(o.device.canopen.axes[5].dcf->path, (dir.path() / "own.dcf").string());
  EXPECT_EQ(o.device.canopen.axes[4].dcf->path, (dir.path() / "enc.dcf").string());
}

TEST(SceneCanopen, DcfErrorsAreLocatedInTheSceneOrInTheDcf) {
  TempDir dir;
  const std::string dcf = shipped_dcf_text("encoder.dcf");
  const std::string scene = replace(kMini, "attach = \"tool\"\n", "attach = \"tool\"\n\n[device.canopen]\ndcf = \"enc.dcf\"\n");
  // No such file: at the scene's key.
  const InputError missing = load_error(dir, scene, "missing.toml");
  expect_located(missing, (dir.path() / "missing.toml").string(), line_of(scene, "dcf = "),
                 column_of(scene, "dcf = ", "\"enc.dcf\""), "device.canopen.dcf", "DCF file not found");
  // A malformed DCF: at its line, section and key, naming the scene key.
  const std::string bad = replace(dcf, "AccessType=rw\nDefaultValue=10", "AccessType=rx\nDefaultValue=10");
  dir.write("enc.dcf", bad);
  const InputError e = load_error(dir, scene, "bad.toml");
  EXPECT_EQ(e.file(), (dir.path() / "enc.dcf").string());
  EXPECT_EQ(e.line(), line_of(bad, "AccessType=rx"));
  EXPECT_EQ(e.key(), "[1017] AccessType");
  EXPECT_NE(std::string(e.what()).find("is not ro, wo, rw, rwr, rww or const (the DCF of device.canopen.dcf)"),
            std::string::npos);
  // A DCF that disagrees with the scene: the heartbeat, at the DCF's value.
  dir.write("enc.dcf", dcf);
  const std::string hb = replace(scene, "dcf = \"enc.dcf\"\n", "dcf = \"enc.dcf\"\nnode_heartbeat_period = 20\n");
  const InputError e2 = load_error(dir, hb, "hb.toml");
  EXPECT_EQ(e2.line(), line_of(dcf, "ParameterValue=10"));
  EXPECT_EQ(e2.key(), "[1017] ParameterValue");
  EXPECT_NE(std::string(e2.what()).find("producer heartbeat time 10 ms, the axis 'x' node's heartbeat_period is 20 ms"),
            std::string::npos) << e2.what();
  // A COB-ID the DCF does not configure: at the file.
  const std::string cob = replace(dcf, "ParameterValue=$NODEID+0x180", "ParameterValue=$NODEID+0x190");
  dir.write("enc.dcf", cob);
  const InputError e3 = load_error(dir, scene, "cob.toml");
  EXPECT_EQ(e3.line(), 0);
  EXPECT_NE(std::string(e3.what()).find("no enabled TPDO with COB-ID 0x181 (the encoder TPDO of axis 'x')"),
            std::string::npos) << e3.what();
  // Only the managed stack is configured.
  dir.write("enc.dcf", dcf);
  const InputError e4 = load_error(dir, replace(scene, "[device.canopen]\n", "[device.canopen]\nmanaged = false\n"), "minimal.toml");
  EXPECT_NE(std::string(e4.what()).find("set managed = true"), std::string::npos);
}

TEST(SceneCanopen, ShippedScenesConfigureEveryNodeFromItsDcf) {
  const std::string dir = std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/";
  for (const char* name : {"construction.toml"}) {  // mouse.toml: needs libevdev for its codes
    SCOPED_TRACE(name);
    const Scene s = load_scene(dir + name);
    for (const numen::hal::CanopenAxisConfig& x : s.device.canopen.axes) {
      ASSERT_NE(x.dcf, nullptr);
      EXPECT_NE(x.dcf->path.find("devices/encoder.dcf"), std::string::npos);
    }
  }
  if (!numen::core::kWithArticulation) GTEST_SKIP() << "the trocar and arm scenes have joints: NUMEN_WITH_ARTICULATION=OFF";
  for (const char* name : {"default.toml", "phantom.toml"}) {
    SCOPED_TRACE(name);
    const Scene s = load_scene(dir + name);
    for (std::size_t i = 0; i < s.device.axes.size(); ++i) {
      const numen::hal::CanopenAxisConfig& x = s.device.canopen.axes[i];
      ASSERT_NE(x.dcf, nullptr);
      EXPECT_EQ(x.dcf->find({0x1400, 1}) != nullptr, s.device.axes[i].has_drive());
    }
  }
}

TEST(Scene, APartThisBuildLeftOutIsRefusedByName) {
  // default.toml has [[joint]] tables, deformable.toml [[deformable]] ones.
  const std::string dir = std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/";
  const auto error_of = [](const std::string& path) -> std::string {
    try {
      numen::sim::load_scene(path);
    } catch (const numen::sim::InputError& e) {
      return e.what();
    }
    return {};
  };
  const std::string joints = error_of(dir + "default.toml");
  if (numen::core::kWithArticulation) {
    EXPECT_EQ(joints, "");
  } else {
    EXPECT_NE(joints.find("default.toml:"), std::string::npos) << joints;  // file:line
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

// ---------------------------------------------------------------- input plausibility (issue 17)

namespace {

/// The first `rows` lines of the shipped excerpt, with `edit` applied to line `line` (1-based).
std::string excerpt_lines(int rows, int line = 0,
                          const std::function<void(std::string&)>& edit = nullptr) {
  std::ifstream in(excerpt_path());
  std::string out, l;
  for (int n = 1; n <= rows && std::getline(in, l); ++n) {
    if (n == line && edit) edit(l);
    out += l + "\n";
  }
  return out;
}

}  // namespace

TEST(SceneErrors, ObstacleNameDeclaredTwice) {
  TempDir dir;
  const std::string text = replace(kMini, "[device]", R"([[obstacle]]
name = "floor"
type = "sphere"
radius = 0.01
position = [0.0, 0.5, 0.0]

[device])");
  const InputError e = load_error(dir, text);
  expect_located(e, (dir.path() / "bad.toml").string(), line_of(text, "name = \"floor\"", 2),
                 8 /* the value of name = "floor" */, "obstacle[1].name",
                 "obstacle \"floor\" declared twice");
}

TEST(SceneErrors, ScriptedTargetsFartherThan10mAreLocated) {
  TempDir dir;
  {  // The start of the path.
    const std::string text = replace(kMini, "start = { position = [0.0, 0.0, 0.0] }",
                                     "start = { position = [1000.0, 0.0, 0.0] }");
    const InputError e = load_error(dir, text);
    expect_located(e, (dir.path() / "bad.toml").string(), line_of(text, "start = {"),
                   column_of(text, "start = {", "[1000"), "trajectory.start.position", "1000 m");
    EXPECT_NE(e.message().find("beyond 10 m"), std::string::npos) << e.what();
  }
  {  // A segment's end point.
    const std::string text = replace(kMini, "to = [0.01, 0.0, 0.0]", "to = [0.01, 1e100, 0.0]");
    const InputError e = load_error(dir, text);
    expect_located(e, (dir.path() / "bad.toml").string(), line_of(text, "to = [0.01, 1e100"),
                   column_of(text, "to = [0.01, 1e100", "["), "trajectory.segment[0].to", "1e+100 m");
  }
  {  // A placement that scales the path out of the room.
    const std::string text = replace(kMini, "start = { position = [0.0, 0.0, 0.0] }",
                                     "start = { position = [0.5, 0.0, 0.0] }\nplacement = { scale = 100.0 }");
    const InputError e = load_error(dir, text);
    EXPECT_EQ(e.key(), "trajectory.placement") << e.what();
    EXPECT_EQ(e.line(), line_of(text, "placement = {")) << e.what();
    EXPECT_NE(e.message().find("50 m from the origin"), std::string::npos) << e.what();
  }
}

TEST(SceneErrors, AJigsawsTipAt1e308IsBlamedOnTheDataFileNotOnTheDevice) {
  TempDir dir;
  int column = 0;
  const std::string data = dir.write("tip.txt", excerpt_lines(40, 12, [&](std::string& l) {
    // Data column 58 (slave right tip x) is the 58th token.
    std::size_t c = 0;
    for (int tok = 0; tok < 58; ++tok) {
      c = l.find_first_not_of(" \t", c);
      if (tok < 57) c = l.find_first_of(" \t", c);
    }
    l.replace(c, l.find_first_of(" \t", c) - c, "1e308");
    column = static_cast<int>(c) + 1;
  }));
  const InputError e = load_error(dir, jigsaws_scene(data));
  EXPECT_EQ(e.file(), data);
  EXPECT_EQ(e.line(), 12);
  EXPECT_EQ(e.column(), column);
  EXPECT_EQ(e.key(), "slave_right.tip_x");
  EXPECT_NE(e.message().find("beyond 10 m"), std::string::npos) << e.what();
}

TEST(SceneErrors, AJigsawsTrajectoryOfOneRowIsRefused) {
  TempDir dir;
  {  // start_time == end_time: one row.
    const std::string text =
        jigsaws_scene(excerpt_path(), "start_time = 2.0\nend_time = 2.0\n");
    const InputError e = load_error(dir, text);
    expect_located(e, (dir.path() / "bad.toml").string(), line_of(text, "end_time"),
                   column_of(text, "end_time", "2.0"), "trajectory.end_time", "holds one row");
    EXPECT_NE(e.message().find("at least two"), std::string::npos) << e.what();
  }
  {  // A file of one row.
    const std::string data = dir.write("one.txt", excerpt_lines(1));
    const std::string text = jigsaws_scene(data);
    const InputError e = load_error(dir, text);
    expect_located(e, (dir.path() / "bad.toml").string(), line_of(text, "file = "),
                   column_of(text, "file = ", "\""), "trajectory.file", "holds one row of one.txt");
  }
  {  // Two rows (1/30 s) are enough.
    const std::string data = dir.write("two.txt", excerpt_lines(2));
    const Scene s = load_scene(dir.write("two.toml", jigsaws_scene(data)));
    EXPECT_NEAR(s.duration_s, 1.0 / 30.0, 1e-3);
  }
}

TEST(SceneErrors, ATrajectoryFileThatIsADirectoryIsLocated) {
  TempDir dir;
  fs::create_directories(dir.path() / "recording");
  const std::string text = jigsaws_scene((dir.path() / "recording").string());
  const InputError e = load_error(dir, text);
  expect_located(e, (dir.path() / "bad.toml").string(), line_of(text, "file = "),
                 column_of(text, "file = ", "\""), "trajectory.file", "is a directory");
  EXPECT_EQ(std::string(e.what()).find("basic_filebuf"), std::string::npos) << e.what();
}

// dt = 1e-7 with a [bus] table that sets no compute_phase was blamed on bus.compute_phase at
// the [bus] header, quoting nothing: dt is blamed at its value, with the values that clash.
TEST(SceneErrors, APeriodShorterThanTheBusRoundTripBlamesDtWithTheValues) {
  TempDir dir;
  const std::string text =
      replace(kMini, "dt = 0.001", "dt = 1e-7") + "\n[bus]\nlatency = 0.0001\n";
  const InputError e = load_error(dir, text);
  expect_located(e, (dir.path() / "bad.toml").string(), line_of(text, "dt = 1e-7"),
                 column_of(text, "dt = 1e-7", "1e-7"), "dt",
                 "the period 1e-07 s is not longer than the compute phase 0.00025 s (one SYNC "
                 "round trip, 2·[bus] latency = 0.0002 s, plus 50 µs unless [bus] compute_phase "
                 "is set)");
  // A compute_phase the file sets is blamed at its own value, with the interval it misses.
  const std::string set = replace(kMini, "dt = 0.001", "dt = 0.0005") +
                          "\n[bus]\nlatency = 0.0001\ncompute_phase = 0.0006\n";
  const InputError p = load_error(dir, set);
  expect_located(p, (dir.path() / "bad.toml").string(), line_of(set, "compute_phase = 0.0006"),
                 column_of(set, "compute_phase = 0.0006", "0.0006"), "bus.compute_phase",
                 "must be in [2·latency, dt) = [0.0002, 0.0005) s: one SYNC round trip must fit "
                 "in the period (got 0.0006 s)");
}

TEST(SceneErrors, ADurationShorterThanOnePeriodIsRefused) {
  TempDir dir;
  const std::string text = replace(kMini, "dt = 0.001", "dt = 0.001\nduration = 0.0001");
  const InputError e = load_error(dir, text);
  expect_located(e, (dir.path() / "bad.toml").string(), line_of(text, "duration = 0.0001"),
                 column_of(text, "duration = 0.0001", "0.0001"), "duration", "no step");
  const std::string huge = replace(kMini, "dt = 0.001", "dt = 0.001\nduration = 1e300");
  const InputError h = load_error(dir, huge);
  EXPECT_EQ(h.key(), "duration");
  EXPECT_LT(std::string(h.what()).size(), 300u) << h.what();
}

TEST(SceneErrors, ANulByteInAMessageDoesNotCutIt) {
  const InputError e("scene.toml", 3, 7, "body[0].name", std::string("bad \0byte here", 14));
  const std::string what(e.what());  // up to the first NUL, as a terminal prints it
  EXPECT_EQ(what, "scene.toml:3:7: body[0].name: bad \\x00byte here");
}

TEST(SceneErrors, ASceneFileThatIsADirectoryIsNamedAsSuch) {
  TempDir dir;
  try {
    (void)load_scene(dir.path().string());
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), dir.path().string());
    EXPECT_NE(e.message().find("is a directory"), std::string::npos) << e.what();
  }
}

TEST(SceneErrors, AByteOrderMarkStartsASceneButIsNamedElsewhere) {
  TempDir dir;
  EXPECT_EQ(load_scene(dir.write("bom.toml", "\xEF\xBB\xBF" + kMini)).name, "mini");
  const std::string text = replace(kMini, "dt = 0.001", "\xEF\xBB\xBF" "dt = 0.001");
  const InputError e = load_error(dir, text);
  EXPECT_EQ(e.line(), line_of(text, "dt = 0.001")) << e.what();
  EXPECT_NE(e.message().find("byte order mark"), std::string::npos) << e.what();
}
