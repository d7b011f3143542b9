// Tests of sim/scene_articulation (through load_scene): [[joint]] tables,
// [baumgarte], the bodies' `link` / `link_offset` keys and the joints'
// `prescribed` axes compile into Model::joints and the DeviceBinding; errors
// name the file, line and dotted key.
#include <gtest/gtest.h>

#include "scene_text.hpp"
#include "temp_dir.hpp"
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "numen/core/joint.hpp"
#include "numen/hal/device/kinematics_factory.hpp"
#include "numen/hal/device/trocar_kinematics.hpp"
#include "numen/sim/device/simulated_instrument.hpp"
#include "numen/sim/input/input_error.hpp"
#include "numen/sim/scene/scene.hpp"
#include "rotation.hpp"

namespace {

using numen::test::column_of;
using numen::test::line_of;
using numen::test::load_error;
using numen::test::replace;

namespace fs = std::filesystem;
using numen::core::JointType;
using numen::core::Pose;
using numen::core::Quat;
using numen::core::Vec3;
using numen::hal::TrocarKinematics;
using numen::sim::InputError;
using numen::sim::load_scene;
using numen::sim::Scene;


using numen::test::angle_between;
using numen::test::TempDir;

// The articulated trocar instrument of lattice.toml, on one second of the
// shipped excerpt, plus a body bound to link "tool" with a given position.
std::string art_scene() {
  return R"(name = "art"
dt = 0.001
gravity = [0.0, 0.0, 0.0]

[[material]]
name = "steel"

[[body]]
name = "sleeve"
mass = 0.02
inertia = [2.0e-5, 2.0e-5, 1.0e-6]
material = "steel"
link = "trocar"

[[body]]
name = "tube"
mass = 0.05
inertia = [2.0e-5, 2.0e-5, 1.0e-6]
material = "steel"
link = "tube"
link_offset = { position = [0.0, 0.0, -0.04] }
[body.coupling]
stiffness = 1000.0
damping_ratio = 0.85

[[body]]
name = "jaw_1"
mass = 0.005
inertia = [1.0e-7, 1.0e-7, 1.0e-8]
material = "steel"
link = "jaw_1"
link_offset = { position = [0.0, 0.001, 0.006], orientation = [0.9238795325112867, 0.3826834323650898, 0.0, 0.0] }

[[body]]
name = "jaw_2"
mass = 0.005
inertia = [1.0e-7, 1.0e-7, 1.0e-8]
material = "steel"
link = "jaw_2"
link_offset = { position = [0.0, 0.0, 0.006] }

[[body]]
name = "marker"
mass = 0.01
inertia = [1.0e-6, 1.0e-6, 1.0e-6]
material = "steel"
link = "tool"
position = [0.3, 0.2, 0.1]

[[joint]]
name = "pivot"
type = "spherical"
parent = "world"
parent_frame = "trocar"
child = "sleeve"

[[joint]]
name = "insertion"
type = "cylindrical"
parent = "sleeve"
child = "tube"

[[joint]]
name = "jaw_1_hinge"
type = "revolute"
parent = "tube"
parent_frame = { position = [0.0, 0.0, 0.04], axis = [1.0, 0.0, 0.0] }
child = "jaw_1"
child_frame = { position = [0.0, 0.0, -0.006], axis = [0.0, 3.0, 4.0] }
prescribed = { axis = "jaw", scale = 0.5, offset = 0.1 }

[[joint]]
name = "jaw_2_hinge"
type = "prismatic"
parent = "tube"
parent_frame = { position = [0.0, 0.0, 0.04], orientation = [0.0, 1.0, 0.0, 0.0] }
child = "jaw_2"
prescribed = { axis = "roll", scale = -0.25 }

[[joint]]
name = "marker_weld"
type = "fixed"
parent = "world"
child = "marker"

[device]
kind = "trocar-instrument"
attach = "tube"
tool_offset = { position = [0.0, 0.0, -0.04] }

[device.trocar]
placement = "approach"
standoff = 0.12

[trajectory]
source = "jigsaws"
file = ")" + numen::test::jigsaws_excerpt_path() + R"("
manipulator = "slave_right"
end_time = 1.0
)";
}

Scene load_text(const TempDir& dir, const std::string& text) { return load_scene(dir.write("art.toml", text)); }

/// what() names the file, the line, the key (if given) and contains `message`.
void expect_joint_error_located(const InputError& e, int line, const std::string& key,
                                const std::string& message) {
  const std::string what = e.what();
  SCOPED_TRACE(what);
  EXPECT_NE(what.find("bad.toml"), std::string::npos) << "file name";
  EXPECT_GT(line, 0) << "test bug: line not found";
  EXPECT_EQ(e.line(), line);
  EXPECT_NE(what.find("bad.toml:" + std::to_string(line) + ":"), std::string::npos) << "file:line";
  if (!key.empty()) {
    EXPECT_EQ(e.key(), key);
    EXPECT_NE(what.find(key + ": "), std::string::npos) << "dotted key";
  }
  EXPECT_NE(e.message().find(message), std::string::npos) << "message: " << e.message();
}

// ------------------------------------------------------------------ valid scene

TEST(SceneArticulation, JointsCompileIntoTheModel) {
  TempDir dir;
  const Scene s = load_text(dir, art_scene());
  ASSERT_EQ(s.model.num_bodies(), 5);
  ASSERT_EQ(s.model.num_joints(), 5);
  const auto& j = s.model.joints;

  EXPECT_EQ(j[0].name, "pivot");
  EXPECT_EQ(j[0].type, JointType::kSpherical);
  EXPECT_EQ(j[0].parent, -1);
  EXPECT_EQ(j[0].child, 0);
  EXPECT_FALSE(j[0].prescribed);
  // parent_frame = "trocar": the device's trocar point and frame.
  EXPECT_LT((j[0].frame_parent.position - s.device.trocar.point).norm(), 1e-15);
  EXPECT_LT(angle_between(j[0].frame_parent.orientation, s.device.trocar.orientation), 1e-12);
  EXPECT_GT((s.device.trocar.orientation * Vec3::UnitZ() - Vec3::UnitZ()).norm(), 1e-3)
      << "test is weak: the trocar frame is the identity";
  EXPECT_EQ(j[0].frame_child.position, Vec3::Zero());

  EXPECT_EQ(j[1].type, JointType::kCylindrical);
  EXPECT_EQ(j[1].parent, 0);
  EXPECT_EQ(j[1].child, 1);
  EXPECT_EQ(j[1].frame_parent.position, Vec3::Zero());
  EXPECT_LT(angle_between(j[1].frame_parent.orientation, Quat::Identity()), 1e-15);

  // Frames from `axis`: the frame's z axis is the (normalised) axis.
  EXPECT_EQ(j[2].type, JointType::kRevolute);
  EXPECT_EQ(j[2].parent, 1);
  EXPECT_EQ(j[2].child, 2);
  EXPECT_TRUE(j[2].prescribed);
  EXPECT_LT((j[2].frame_parent.position - Vec3(0.0, 0.0, 0.04)).norm(), 1e-15);
  EXPECT_LT((j[2].frame_parent.orientation * Vec3::UnitZ() - Vec3::UnitX()).norm(), 1e-12);
  EXPECT_LT((j[2].frame_child.position - Vec3(0.0, 0.0, -0.006)).norm(), 1e-15);
  EXPECT_LT((j[2].frame_child.orientation * Vec3::UnitZ() - Vec3(0.0, 0.6, 0.8)).norm(), 1e-12);
  EXPECT_NEAR(j[2].frame_child.orientation.norm(), 1.0, 1e-12);

  // Frame from `orientation` [w, x, y, z]: 180° about x.
  EXPECT_EQ(j[3].type, JointType::kPrismatic);
  EXPECT_EQ(j[3].child, 3);
  EXPECT_TRUE(j[3].prescribed);
  EXPECT_LT(angle_between(j[3].frame_parent.orientation, Quat(0.0, 1.0, 0.0, 0.0)), 1e-12);

  EXPECT_EQ(j[4].type, JointType::kFixed);
  EXPECT_EQ(j[4].parent, -1);
  EXPECT_EQ(j[4].child, 4);
  EXPECT_FALSE(j[4].prescribed);

  // Default Baumgarte settings (paper: 2/Δt, 1/Δt²).
  EXPECT_DOUBLE_EQ(s.model.baumgarte.alpha_dt, 2.0);
  EXPECT_DOUBLE_EQ(s.model.baumgarte.beta_dt2, 1.0);
}

TEST(SceneArticulation, PrescribedJointsBecomeAxisPrescriptions) {
  TempDir dir;
  const Scene s = load_text(dir, art_scene());
  ASSERT_EQ(s.binding.prescriptions.size(), 2u);
  const auto& p0 = s.binding.prescriptions[0];
  EXPECT_EQ(p0.joint, 2);
  EXPECT_EQ(p0.axis, TrocarKinematics::kJaw);
  EXPECT_EQ(s.device.axes[static_cast<std::size_t>(p0.axis)].name, "jaw");
  EXPECT_DOUBLE_EQ(p0.scale, 0.5);
  EXPECT_DOUBLE_EQ(p0.offset, 0.1);
  const auto& p1 = s.binding.prescriptions[1];
  EXPECT_EQ(p1.joint, 3);
  EXPECT_EQ(p1.axis, TrocarKinematics::kRoll);
  EXPECT_EQ(s.device.axes[static_cast<std::size_t>(p1.axis)].name, "roll");
  EXPECT_DOUBLE_EQ(p1.scale, -0.25);
  EXPECT_DOUBLE_EQ(p1.offset, 0.0);
}

TEST(SceneArticulation, BodiesBindToLinksByName) {
  TempDir dir;
  const Scene s = load_text(dir, art_scene());
  const auto kin = numen::hal::make_kinematics(s.device);
  // Every body has a link, plus the fallback link 0 → the held body (used only
  // while the held body has no link of its own, e.g. after a tool switch).
  ASSERT_EQ(s.binding.links.size(), 6u);
  EXPECT_EQ(s.binding.links.back().link, 0);
  EXPECT_EQ(s.binding.links.back().body, -1);
  const char* names[5] = {"trocar", "tube", "jaw_1", "jaw_2", "tool"};
  const int expected_links[5] = {TrocarKinematics::kLinkTrocar, TrocarKinematics::kLinkTube,
                                 TrocarKinematics::kLinkJaw1, TrocarKinematics::kLinkJaw2,
                                 TrocarKinematics::kLinkTool};
  for (int b = 0; b < 5; ++b) {
    const auto& lb = s.binding.links[static_cast<std::size_t>(b)];
    EXPECT_EQ(lb.body, b);
    EXPECT_EQ(lb.link, kin->find_link(names[b])) << names[b];
    EXPECT_EQ(lb.link, expected_links[b]) << names[b];
  }
  // body_in_link from link_offset (identity without one).
  EXPECT_EQ(s.binding.links[0].body_in_link.position, Vec3::Zero());
  EXPECT_LT(angle_between(s.binding.links[0].body_in_link.orientation, Quat::Identity()), 1e-15);
  EXPECT_LT((s.binding.links[1].body_in_link.position - Vec3(0.0, 0.0, -0.04)).norm(), 1e-15);
  EXPECT_LT((s.binding.links[2].body_in_link.position - Vec3(0.0, 0.001, 0.006)).norm(), 1e-15);
  const Quat q45(0.9238795325112867, 0.3826834323650898, 0.0, 0.0);
  EXPECT_LT(angle_between(s.binding.links[2].body_in_link.orientation, q45), 1e-9);
  EXPECT_LT((s.binding.links[3].body_in_link.position - Vec3(0.0, 0.0, 0.006)).norm(), 1e-15);
}

TEST(SceneArticulation, LinkedBodiesWithoutPositionStartAtTheirLinkPose) {
  TempDir dir;
  const Scene s = load_text(dir, art_scene());
  const auto kin = numen::hal::make_kinematics(s.device);
  const numen::hal::AxisVector q0 = numen::sim::instrument_axes(s.device, *kin, s.trajectory.at(0.0));
  for (int b = 0; b < 4; ++b) {
    const auto& lb = s.binding.links[static_cast<std::size_t>(b)];
    const Pose link = kin->link_pose(lb.link, q0);
    const Vec3 p = link.position + link.orientation * lb.body_in_link.position;
    const Quat r = link.orientation * lb.body_in_link.orientation;
    const Pose& got = s.model.bodies[static_cast<std::size_t>(b)].initial_pose;
    EXPECT_LT((got.position - p).norm(), 1e-12) << s.model.bodies[static_cast<std::size_t>(b)].name;
    EXPECT_LT(angle_between(got.orientation, r), 1e-9) << s.model.bodies[static_cast<std::size_t>(b)].name;
  }
  // The tube (held, link "tube", offset −40 mm): the tip is 40 mm ahead.
  const Pose& tube = s.model.bodies[1].initial_pose;
  EXPECT_LT((tube.position + tube.orientation * Vec3(0.0, 0.0, 0.04) - s.trajectory[0].pose.position).norm(), 1e-9);
  // The sleeve starts at the trocar point.
  EXPECT_LT((s.model.bodies[0].initial_pose.position - s.device.trocar.point).norm(), 1e-12);
  // A body with a link and a position keeps its position.
  EXPECT_EQ(s.model.bodies[4].initial_pose.position, Vec3(0.3, 0.2, 0.1));
}

TEST(SceneArticulation, AnUnboundHeldBodyKeepsTheRigidLinkZeroBinding) {
  TempDir dir;
  // The tube has no link: the others are bound, and link 0 drives the held body.
  std::string text = replace(art_scene(), "link = \"tube\"\nlink_offset = { position = [0.0, 0.0, -0.04] }\n", "");
  const Scene s = load_text(dir, text);
  ASSERT_EQ(s.binding.links.size(), 5u);
  const auto& last = s.binding.links.back();
  EXPECT_EQ(last.link, 0);
  EXPECT_EQ(last.body, -1);
  for (std::size_t i = 0; i + 1 < s.binding.links.size(); ++i) EXPECT_NE(s.binding.links[i].body, 1);

  // No link anywhere: the rigid binding.
  std::string none = art_scene();
  for (const char* l : {"link = \"trocar\"\n", "link = \"jaw_1\"\n", "link = \"jaw_2\"\n", "link = \"tool\"\n"})
    none = replace(none, l, "");
  none = replace(none, "link_offset = { position = [0.0, 0.001, 0.006], orientation = [0.9238795325112867, 0.3826834323650898, 0.0, 0.0] }\n", "");
  none = replace(none, "link_offset = { position = [0.0, 0.0, 0.006] }\n", "");
  none = replace(none, "link = \"tube\"\nlink_offset = { position = [0.0, 0.0, -0.04] }\n", "");
  const Scene r = load_text(dir, none);
  ASSERT_EQ(r.binding.links.size(), 1u);
  EXPECT_EQ(r.binding.links[0].link, 0);
  EXPECT_EQ(r.binding.links[0].body, -1);
  EXPECT_EQ(r.binding.prescriptions.size(), 2u);
}

TEST(SceneArticulation, BaumgarteSettingsAreRead) {
  TempDir dir;
  const Scene s = load_text(dir, art_scene() + "\n[baumgarte]\nalpha_dt = 0.5\nbeta_dt2 = 0.0\n");
  EXPECT_DOUBLE_EQ(s.model.baumgarte.alpha_dt, 0.5);
  EXPECT_DOUBLE_EQ(s.model.baumgarte.beta_dt2, 0.0);
}

// ------------------------------------------------------------------ errors

TEST(SceneArticulationErrors, UnknownJointType) {
  TempDir dir;
  const std::string t = replace(art_scene(), "type = \"cylindrical\"", "type = \"hinge\"");
  expect_joint_error_located(load_error(dir, t), line_of(t, "type = \"hinge\""), "joint[1].type",
                             "\"hinge\"");
}

TEST(SceneArticulationErrors, UnknownParentBody) {
  TempDir dir;
  const std::string t = replace(art_scene(), "parent = \"sleeve\"", "parent = \"shaft\"");
  expect_joint_error_located(load_error(dir, t), line_of(t, "parent = \"shaft\""),
                             "joint[1].parent", "no body named \"shaft\"");
}

TEST(SceneArticulationErrors, UnknownChildBody) {
  TempDir dir;
  const std::string t = replace(art_scene(), "child = \"tube\"", "child = \"tubes\"");
  expect_joint_error_located(load_error(dir, t), line_of(t, "child = \"tubes\""), "joint[1].child",
                             "no body named \"tubes\"");
}

TEST(SceneArticulationErrors, WorldIsNotAChild) {
  TempDir dir;
  const std::string t = replace(art_scene(), "child = \"tube\"", "child = \"world\"");
  expect_joint_error_located(load_error(dir, t), line_of(t, "child = \"world\""), "joint[1].child",
                             "no body named \"world\"");
}

TEST(SceneArticulationErrors, ChildEqualsParent) {
  TempDir dir;
  const std::string t = replace(art_scene(), "child = \"tube\"", "child = \"sleeve\"");
  expect_joint_error_located(load_error(dir, t), line_of(t, "child = \"sleeve\"", 2),
                             "joint[1].child", "two different bodies");
}

TEST(SceneArticulationErrors, TrocarParentFrameNeedsTheWorldAsParent) {
  TempDir dir;
  const std::string t =
      replace(art_scene(), "parent = \"sleeve\"\n", "parent = \"sleeve\"\nparent_frame = \"trocar\"\n");
  expect_joint_error_located(load_error(dir, t), line_of(t, "parent_frame = \"trocar\"", 2),
                             "joint[1].parent_frame", "trocar");
}

TEST(SceneArticulationErrors, ParentFrameStringOtherThanTrocar) {
  TempDir dir;
  const std::string t = replace(art_scene(), "parent_frame = \"trocar\"", "parent_frame = \"sleeve\"");
  expect_joint_error_located(load_error(dir, t), line_of(t, "parent_frame = \"sleeve\""),
                             "joint[0].parent_frame", "\"trocar\"");
}

TEST(SceneArticulationErrors, PrescribedSphericalJoint) {
  TempDir dir;
  const std::string t =
      replace(art_scene(), "child = \"sleeve\"\n", "child = \"sleeve\"\nprescribed = { axis = \"jaw\" }\n");
  expect_joint_error_located(load_error(dir, t), line_of(t, "prescribed = { axis = \"jaw\" }"),
                             "joint[0].prescribed", "only revolute and prismatic");
}

TEST(SceneArticulationErrors, PrescribedAxisThatDoesNotExist) {
  TempDir dir;
  const std::string t = replace(art_scene(), "axis = \"jaw\", scale = 0.5", "axis = \"grip\", scale = 0.5");
  const InputError e = load_error(dir, t);
  expect_joint_error_located(e, line_of(t, "axis = \"grip\""), "joint[2].prescribed.axis",
                             "no axis \"grip\"");
  EXPECT_NE(e.message().find("pivot_x, pivot_y, depth, roll, jaw"), std::string::npos) << e.message();
}

TEST(SceneArticulationErrors, UnknownKeyInPrescribed) {
  TempDir dir;
  const std::string t = replace(art_scene(), "axis = \"jaw\", scale = 0.5", "axis = \"jaw\", gain = 0.5");
  expect_joint_error_located(load_error(dir, t), line_of(t, "gain = 0.5"),
                             "joint[2].prescribed.gain", "unknown key");
}

TEST(SceneArticulationErrors, UnknownLinkListsTheDevicesLinks) {
  TempDir dir;
  const std::string t = replace(art_scene(), "link = \"jaw_1\"", "link = \"jaw_3\"");
  const InputError e = load_error(dir, t);
  expect_joint_error_located(e, line_of(t, "link = \"jaw_3\""), "body[2].link",
                             "no link \"jaw_3\"");
  EXPECT_NE(e.message().find("tool, trocar, tube, jaw_1, jaw_2"), std::string::npos) << e.message();
}

TEST(SceneArticulationErrors, LinkOffsetWithoutLink) {
  TempDir dir;
  const std::string t = replace(art_scene(), "link = \"jaw_2\"\n", "");
  expect_joint_error_located(load_error(dir, t),
                             line_of(t, "link_offset = { position = [0.0, 0.0, 0.006] }"),
                             "body[3].link_offset", "link");
}

TEST(SceneArticulationErrors, FrameWithBothAxisAndOrientation) {
  TempDir dir;
  const std::string t = replace(art_scene(), "axis = [1.0, 0.0, 0.0] }",
                                "axis = [1.0, 0.0, 0.0], orientation = [1.0, 0.0, 0.0, 0.0] }");
  expect_joint_error_located(load_error(dir, t), line_of(t, "orientation = [1.0, 0.0, 0.0, 0.0] }"),
                             "joint[2].parent_frame.axis", "either orientation or axis");
}

TEST(SceneArticulationErrors, LinkOffsetWithBothAxisAndOrientation) {
  TempDir dir;
  const std::string t = replace(art_scene(), "link_offset = { position = [0.0, 0.0, 0.006] }",
                                "link_offset = { axis = [1.0, 0.0, 0.0], orientation = [1.0, 0.0, 0.0, 0.0] }");
  expect_joint_error_located(load_error(dir, t), line_of(t, "link_offset = { axis"),
                             "body[3].link_offset.axis", "either orientation or axis");
}

TEST(SceneArticulationErrors, ZeroAxis) {
  TempDir dir;
  const std::string t = replace(art_scene(), "axis = [0.0, 3.0, 4.0]", "axis = [0.0, 0.0, 0.0]");
  expect_joint_error_located(load_error(dir, t), line_of(t, "axis = [0.0, 0.0, 0.0]"),
                             "joint[2].child_frame.axis", "non-zero");
}

TEST(SceneArticulationErrors, DuplicateJointName) {
  TempDir dir;
  const std::string t = replace(art_scene(), "name = \"jaw_2_hinge\"", "name = \"jaw_1_hinge\"");
  expect_joint_error_located(load_error(dir, t), line_of(t, "name = \"jaw_1_hinge\"", 2),
                             "joint[3].name", "declared twice");
}

TEST(SceneArticulationErrors, BodyThatIsTheChildOfTwoJoints) {
  TempDir dir;
  const std::string t = replace(art_scene(), "child = \"jaw_2\"", "child = \"jaw_1\"");
  const InputError e = load_error(dir, t);
  const std::string what = e.what();
  EXPECT_NE(what.find("bad.toml"), std::string::npos) << what;
  EXPECT_GT(e.line(), 0) << what;
  EXPECT_NE(what.find("bad.toml:" + std::to_string(e.line()) + ":"), std::string::npos) << what;
  EXPECT_NE(e.message().find("joint 'jaw_2_hinge'"), std::string::npos) << e.message();
  EXPECT_NE(e.message().find("jaw_1"), std::string::npos) << e.message();
  // Located at the offending joint's child key (the second `child = "jaw_1"`).
  const std::size_t first = t.find("child = \"jaw_1\"");
  const std::size_t second = t.find("child = \"jaw_1\"", first + 1);
  ASSERT_NE(second, std::string::npos);
  EXPECT_EQ(e.line(), static_cast<int>(std::count(t.begin(), t.begin() + static_cast<long>(second), '\n')) + 1)
      << what;
  EXPECT_NE(e.key().find("child"), std::string::npos) << e.key();
}

TEST(SceneArticulationErrors, BaumgarteBothZeroIsRejected) {
  TempDir dir;
  const std::string t = art_scene() + "\n[baumgarte]\nalpha_dt = 0.0\nbeta_dt2 = 0.0\n";
  expect_joint_error_located(load_error(dir, t), line_of(t, "beta_dt2 = 0.0"), "baumgarte.beta_dt2",
                             "cannot both be 0");
}

TEST(SceneArticulationErrors, BaumgarteNegativeAndUnknownKey) {
  TempDir dir;
  std::string t = art_scene() + "\n[baumgarte]\nalpha_dt = -1.0\n";
  expect_joint_error_located(load_error(dir, t), line_of(t, "alpha_dt = -1.0"),
                             "baumgarte.alpha_dt", "");
  t = art_scene() + "\n[baumgarte]\nalpha = 1.0\n";
  expect_joint_error_located(load_error(dir, t), line_of(t, "alpha = 1.0"), "baumgarte.alpha",
                             "unknown key");
}

TEST(SceneArticulationErrors, UnknownKeyInJoint) {
  TempDir dir;
  const std::string t = replace(art_scene(), "parent = \"sleeve\"\n", "parent = \"sleeve\"\nstiffness = 1.0\n");
  expect_joint_error_located(load_error(dir, t), line_of(t, "stiffness = 1.0"),
                             "joint[1].stiffness", "unknown key");
}

TEST(SceneArticulationErrors, JointWithoutChild) {
  TempDir dir;
  const std::string t = replace(art_scene(), "child = \"tube\"\n", "");
  const InputError e = load_error(dir, t);
  EXPECT_EQ(e.key(), "joint[1].child") << e.what();
  EXPECT_GT(e.line(), 0) << e.what();
}

}  // namespace

namespace {

TEST(SceneArticulationErrors, LinkedBodyWithOrientationButNoPosition) {
  // The link gives the starting pose: an orientation alone would be dropped.
  TempDir dir;
  const std::string t =
      replace(art_scene(), "link = \"jaw_1\"", "link = \"jaw_1\"\norientation = [1.0, 0.0, 0.0, 0.0]");
  expect_joint_error_located(load_error(dir, t), line_of(t, "orientation = [1.0, 0.0, 0.0, 0.0]"),
                             "body[2].orientation", "give both position and orientation");
}

}  // namespace

// ---------------------------------------------------------------- several devices ([[device]])

TEST(SceneArticulationDevices, EachBodyIsBoundToTheDeviceItsKeyNames) {
  numen::test::TempDir dir;
  const std::string& two = numen::test::kTwoDeviceScene;
  const numen::sim::Scene s = numen::sim::load_scene(dir.write("two.toml", two));
  ASSERT_EQ(s.extra_devices.size(), 1u);
  // Device 0: the rigid binding (link 0 → the held body "left_tool"); device 1: its link → body 1.
  ASSERT_EQ(s.binding.links.size(), 1u);
  EXPECT_EQ(s.binding.links[0].body, -1);
  const numen::platform::DeviceBinding& right = s.extra_devices[0].binding;
  ASSERT_EQ(right.links.size(), 1u);
  EXPECT_EQ(right.links[0].body, 1);
  EXPECT_EQ(right.links[0].link, 0);
  // The right tool starts where its device's path starts (5 cm along y), not the left one's.
  EXPECT_NEAR(s.model.bodies[1].initial_pose.position.y(), 0.05, 1e-9);
}

TEST(SceneArticulationDevices, ABindingWithoutItsDeviceOrToAnotherDevicesHeldBodyIsLocated) {
  numen::test::TempDir dir;
  const std::string& two = numen::test::kTwoDeviceScene;
  // No device key with two devices: at the link.
  const std::string nodev = replace(two, "device = \"right\"\n", "");
  const numen::sim::InputError e1 = load_error(dir, nodev, "nodev.toml");
  numen::test::expect_located(e1, (dir.path() / "nodev.toml").string(), line_of(nodev, "link = \"tool\""),
                              column_of(nodev, "link = ", "\"tool\""), "body[1].link",
                              "the scene has several devices (\"left\", \"right\")");
  // A device that does not exist: at the key.
  const std::string unknown = replace(two, "device = \"right\"", "device = \"middle\"");
  const numen::sim::InputError e2 = load_error(dir, unknown, "unknown.toml");
  numen::test::expect_located(e2, (dir.path() / "unknown.toml").string(),
                              line_of(unknown, "device = \"middle\""),
                              column_of(unknown, "device = ", "\"middle\""), "body[1].device",
                              "no device named \"middle\"");
  // Two bindings to one body: the left device holds the body the right one's link drives.
  const std::string twice = replace(two, "attach = \"left_tool\"", "attach = \"right_tool\"");
  const numen::sim::InputError e3 = load_error(dir, twice, "twice.toml");
  numen::test::expect_located(e3, (dir.path() / "twice.toml").string(),
                              line_of(twice, "attach = \"right_tool\""),
                              column_of(twice, "attach = ", "\"right_tool\""), "device[0].attach",
                              "body \"right_tool\" is bound twice");
  // A tool switch to the right device's body: at the event's attach.
  const std::string event = two + "\n[[event]]\ntime = 0.1\nattach = \"right_tool\"\n";
  const numen::sim::InputError e4 = load_error(dir, event, "event.toml");
  numen::test::expect_located(e4, (dir.path() / "event.toml").string(),
                              line_of(event, "attach = \"right_tool\""),
                              column_of(event, "attach = ", "\"right_tool\""), "event[0].attach",
                              "is driven by device \"right\"");
  // A device key on a body without a link.
  const std::string nolink = replace(two, "link = \"tool\"\n", "");
  const numen::sim::InputError e5 = load_error(dir, nolink, "nolink.toml");
  EXPECT_EQ(e5.key(), "body[1].device") << e5.what();
}
