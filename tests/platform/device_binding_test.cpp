// The binding rules shared by the control loop and the accuracy study
// (platform/src/device_binding.cpp): which body a link drives, and its target.
#include <gtest/gtest.h>

#include <stdexcept>
#include <string>
#include <vector>

#include "free_bodies.hpp"
#include "numen/core/data.hpp"
#include "numen/platform/device_binding.hpp"
#include "rotation.hpp"
#include "test_constants.hpp"

namespace numen::platform {
namespace device_binding_test {

using core::Pose;
using core::Twist;
using core::Vec3;

LinkBinding link_to(int link, int body) {
  LinkBinding b;
  b.link = link;
  b.body = body;
  return b;
}

TEST(DeviceBinding, ExplicitlyBoundBodiesMarksTheBodiesNamedByALink) {
  const DeviceBinding binding{{link_to(0, -1), link_to(1, 2)}, {}};
  EXPECT_EQ(explicitly_bound_bodies(binding, 3), (std::vector<std::uint8_t>{0, 0, 1}));
}

// The message of the std::invalid_argument `f` throws ("" if it throws none).
template <class F>
std::string refusal(F&& f) {
  try {
    f();
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

TEST(DeviceBinding, ABodyBoundTwiceOrOutOfRangeIsRefused) {
  EXPECT_EQ(refusal([] {
              explicitly_bound_bodies(DeviceBinding{{link_to(0, 1), link_to(1, 1)}, {}}, 2);
            }),
            "device binding: body 1 is bound to two links");
  EXPECT_EQ(refusal([] { explicitly_bound_bodies(DeviceBinding{{link_to(0, 2)}, {}}, 2); }),
            "device binding: body 2 out of range (2 bodies)");
}

TEST(DeviceBinding, TheHeldBindingServesOnlyAHeldBodyWithoutALinkOfItsOwn) {
  const core::Model m = test::free_bodies_model({"a", "b", "c"});
  core::Data d = core::make_data(m);
  const std::vector<std::uint8_t> own = {0, 1, 0};  // body 1 has its own link
  const LinkBinding held = link_to(0, -1);
  d.held_body = 0;
  EXPECT_EQ(bound_body(held, d, own), 0);
  d.held_body = 1;  // held body 1 follows its own link, not the held binding
  EXPECT_EQ(bound_body(held, d, own), -1);
  d.held_body = -1;
  EXPECT_EQ(bound_body(held, d, own), -1);
  EXPECT_EQ(bound_body(link_to(1, 1), d, own), 1);
}

TEST(DeviceBinding, TheBodyTargetIsTheLinkPoseTimesTheOffsetWithTheRigidTwistTransfer) {
  LinkBinding b = link_to(0, -1);
  b.body_in_link.position = Vec3(0.1, 0.0, 0.0);
  b.body_in_link.orientation = test::rot(0.3, Vec3::UnitX());
  Pose link;
  link.position = Vec3(1.0, 2.0, 3.0);
  link.orientation = test::rot(test::kPi / 2.0, Vec3::UnitZ());  // link x axis along world y
  Twist lt;
  lt.linear = Vec3(0.5, 0.0, 0.0);
  lt.angular = Vec3(0.0, 0.0, 2.0);
  Pose pose;
  Twist twist;
  body_target_of(b, link, lt, pose, twist);
  EXPECT_NEAR((pose.position - Vec3(1.0, 2.1, 3.0)).norm(), 0.0, 1e-12);
  EXPECT_NEAR(test::angle_between(pose.orientation, link.orientation * b.body_in_link.orientation),
              0.0, 1e-12);
  // v = v_link + ω × r, r = (0, 0.1, 0): ω × r = (−0.2, 0, 0).
  EXPECT_NEAR((twist.linear - Vec3(0.3, 0.0, 0.0)).norm(), 0.0, 1e-12);
  EXPECT_EQ(twist.angular, lt.angular);
}

TEST(DeviceBinding, TheHeldBodysTargetIsTheDeviceTargetAndAnotherBodysIsItsOwn) {
  const core::Model m = test::free_bodies_model({"a", "b"});
  core::Data d = core::make_data(m);
  d.held_body = 0;
  Pose pose;
  pose.position = Vec3(0.1, 0.2, 0.3);
  Twist twist;
  twist.linear = Vec3(1.0, 0.0, 0.0);
  set_body_target(d, 0, pose, twist);
  EXPECT_EQ(d.target.position, pose.position);
  EXPECT_EQ(d.target_twist.linear, twist.linear);
  set_body_target(d, 1, pose, twist);
  ASSERT_GT(d.body_targets.size(), 1u);
  EXPECT_TRUE(d.body_targets[1].enabled);
  EXPECT_EQ(d.body_targets[1].pose.position, pose.position);
  EXPECT_EQ(d.body_targets[1].twist.linear, twist.linear);
}

}  // namespace device_binding_test
}  // namespace numen::platform
