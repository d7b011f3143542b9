// Tests of numen/hal/device/kinematics.hpp: the default link API of a single-frame Kinematics,
// find_link, and the shared mappings twist = J q̇, τ = Jᵀ w.
#include "numen/hal/device/kinematics.hpp"

#include <gtest/gtest.h>

#include "alloc_counter.hpp"

namespace {

using namespace numen::hal;
using numen::core::Pose;
using numen::core::Vec3;

// One prismatic axis along x: the smallest Kinematics, using every link default.
class Slider final : public Kinematics {
 public:
  int num_axes() const noexcept override { return 1; }
  Pose forward(const AxisVector& q) const noexcept override {
    Pose p;
    p.position = Vec3(q[0], 0, 0);
    return p;
  }
  Jacobian jacobian(const AxisVector&) const noexcept override {
    Jacobian j(6, 1);
    j.setZero();
    j(0, 0) = 1.0;
    return j;
  }
  AxisVector inverse(const Pose& pose, const AxisVector&) const noexcept override {
    AxisVector q(1);
    q[0] = pose.position.x();
    return q;
  }
};

// Three named links, to check the search goes past link 0.
class ThreeLinks final : public Kinematics {
 public:
  int num_axes() const noexcept override { return 1; }
  Pose forward(const AxisVector&) const noexcept override { return Pose{}; }
  Jacobian jacobian(const AxisVector&) const noexcept override { return Jacobian::Zero(6, 1); }
  AxisVector inverse(const Pose&, const AxisVector&) const noexcept override {
    return AxisVector::Zero(1);
  }
  int num_links() const noexcept override { return 3; }
  const char* link_name(int link) const noexcept override {
    static const char* const names[] = {"tool", "left", "right"};
    return link >= 0 && link < 3 ? names[link] : "";
  }
};

TEST(Kinematics, DefaultLinkApiIsTheControlledFrame) {
  const Slider k;
  EXPECT_EQ(k.num_links(), 1);
  EXPECT_STREQ(k.link_name(0), "tool");
  EXPECT_STREQ(k.link_name(1), "");
  AxisVector q(1);
  q << 0.25;
  EXPECT_EQ(k.link_pose(0, q).position, Vec3(0.25, 0, 0));
  EXPECT_EQ(k.link_jacobian(0, q), k.jacobian(q));
}

TEST(Kinematics, FindLinkComparesNamesExactly) {
  const Slider one;
  EXPECT_EQ(one.find_link("tool"), 0);
  EXPECT_EQ(one.find_link("Tool"), -1);
  EXPECT_EQ(one.find_link("too"), -1);
  EXPECT_EQ(one.find_link(""), -1);
  EXPECT_EQ(one.find_link(nullptr), -1);
  const ThreeLinks three;
  EXPECT_EQ(three.find_link("tool"), 0);
  EXPECT_EQ(three.find_link("left"), 1);
  EXPECT_EQ(three.find_link("right"), 2);
  EXPECT_EQ(three.find_link("righ"), -1);
  numen::test::AllocationGuard guard;
  int sum = 0;
  for (int i = 0; i < 100; ++i) sum += three.find_link("right");
  EXPECT_EQ(guard.count(), 0);
  EXPECT_EQ(sum, 200);
}

TEST(Kinematics, TwistAndTorqueAreJAndJTranspose) {
  Jacobian j(6, 2);
  j << 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12;
  AxisVector qdot(2);
  qdot << 0.5, -1.0;
  const numen::core::Twist t = twist_from_rates(j, qdot);
  const numen::core::Vec6 v = j * qdot;
  EXPECT_EQ(t.linear, v.head<3>());
  EXPECT_EQ(t.angular, v.tail<3>());
  numen::core::Wrench w;
  w.force = Vec3(1, -2, 3);
  w.torque = Vec3(0.5, 0, -1);
  numen::core::Vec6 wv;
  wv << w.force, w.torque;
  const AxisVector tau = torques_from_wrench(j, w);
  ASSERT_EQ(tau.size(), 2);
  EXPECT_DOUBLE_EQ(tau[0], j.col(0).dot(wv));
  EXPECT_DOUBLE_EQ(tau[1], j.col(1).dot(wv));
  EXPECT_DOUBLE_EQ(tau[0], 1 * 1 + 3 * -2 + 5 * 3 + 7 * 0.5 + 9 * 0 + 11 * -1);
}

}  // namespace
