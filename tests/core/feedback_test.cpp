// Tests of core/feedback: the Eq. 8 virtual-coupling wrench, its gains,
// direction and saturation, and when it must be zero.
#include "numen/core/feedback.hpp"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/step.hpp"
#include "rotation.hpp"

namespace core = numen::core;
using core::Quat;
using core::Vec3;

namespace {

using numen::test::rot;

constexpr double kInfinity = std::numeric_limits<double>::infinity();

}  // namespace

TEST(Feedback, PullsTheDeviceTowardsTheGodObjectWithItsOwnGains) {
  const core::FeedbackGains g{150.0, 3.0, 2.0, 0.05, kInfinity, kInfinity};
  core::BodyState s;
  s.position = Vec3(0.0, 0.0, 0.01);  // held above the target (e.g. by a floor)
  const core::Pose target{Vec3(0.0, 0.0, -0.02), rot(0.2, Vec3::UnitZ())};
  const core::Twist tt{Vec3(0.0, 0.0, -0.1), Vec3::Zero()};
  const core::Wrench w = core::feedback_wrench(g, target, tt, s);
  // F_d = k_d (x − x_t) + γ_d (v − v_t): up, towards the god-object.
  EXPECT_NEAR(w.force.z(), 150.0 * 0.03 + 3.0 * 0.1, 1e-12);
  EXPECT_NEAR(w.force.head<2>().norm(), 0.0, 1e-15);
  // The god-object is rotated by −0.2 about z relative to the target:
  // T_d = k_rd θu' with θu' = log(q q_t⁻¹) = −0.2 z.
  EXPECT_TRUE(w.torque.isApprox(Vec3(0.0, 0.0, -2.0 * 0.2), 1e-12));
  // Angular damping: god-object spinning faster than the target.
  s.angular_velocity = Vec3(1.0, 0.0, 0.0);
  const core::Wrench w2 = core::feedback_wrench(g, target, tt, s);
  EXPECT_TRUE((w2.torque - w.torque).isApprox(Vec3(0.05, 0.0, 0.0), 1e-12));
  // Gains scale linearly; zero gains (non-haptic device) give zero.
  const core::FeedbackGains g2{300.0, 6.0, 4.0, 0.1, kInfinity, kInfinity};
  const core::Wrench w3 = core::feedback_wrench(g2, target, tt, s);
  EXPECT_TRUE(w3.force.isApprox(2.0 * w2.force, 1e-12));
  EXPECT_TRUE(w3.torque.isApprox(2.0 * w2.torque, 1e-12));
  const core::Wrench w0 = core::feedback_wrench(core::FeedbackGains{}, target, tt, s);
  EXPECT_TRUE(w0.force.isZero(0.0) && w0.torque.isZero(0.0));
}

TEST(Feedback, SaturationClampsTheNormAndKeepsTheDirection) {
  const core::Wrench w{Vec3(3.0, -4.0, 0.0), Vec3(0.0, 0.6, 0.8)};
  const core::Wrench s = core::saturate_wrench(w, 2.5, 0.5);
  EXPECT_NEAR(s.force.norm(), 2.5, 1e-14);
  EXPECT_NEAR(s.torque.norm(), 0.5, 1e-14);
  EXPECT_GT(s.force.normalized().dot(w.force.normalized()), 1.0 - 1e-15);
  EXPECT_GT(s.torque.normalized().dot(w.torque.normalized()), 1.0 - 1e-15);
  const core::Wrench u = core::saturate_wrench(w, 10.0, kInfinity);  // under the limit: unchanged
  EXPECT_EQ(u.force, w.force);
  EXPECT_EQ(u.torque, w.torque);
  const core::Wrench z = core::saturate_wrench(w, 0.0, 0.0);
  EXPECT_TRUE(z.force.isZero(0.0) && z.torque.isZero(0.0));
  // Through feedback_wrench.
  const core::FeedbackGains g{1e4, 0.0, 10.0, 0.0, 5.0, 0.1};
  core::BodyState b;
  b.position = Vec3(0.01, 0.02, -0.02);
  b.orientation = rot(1.0, Vec3(1, 1, 0));
  const core::Wrench f = core::feedback_wrench(g, core::Pose{}, core::Twist{}, b);
  EXPECT_NEAR(f.force.norm(), 5.0, 1e-12);
  EXPECT_GT(f.force.normalized().dot(b.position.normalized()), 1.0 - 1e-12);
  EXPECT_NEAR(f.torque.norm(), 0.1, 1e-12);
}

namespace {

core::Model feedback_model(core::CouplingMode mode) {
  core::Model m;
  m.gravity = Vec3::Zero();
  m.coupling_mode = mode;
  m.material_pairs = {core::MaterialPair{}};
  core::BodyModel b;
  b.coupling = {100.0, 10.0, 1.0, 0.1};
  m.bodies = {b};
  m.feedback = {100.0, 1.0, 1.0, 0.01, 20.0, 2.0};
  EXPECT_EQ(core::finalize_model(m), "");
  return m;
}

}  // namespace

TEST(Feedback, StageFollowsTheHeldBodyAfterIntegration) {
  const core::Model m = feedback_model(core::CouplingMode::kGodObject);
  core::Data d = core::make_data(m);
  d.target.position = Vec3(0.05, 0.0, 0.0);
  core::step(m, d);
  // After the step the god-object lags behind the target: the device is pulled back (−x).
  const core::Wrench expect = core::feedback_wrench(m.feedback, d.target, d.target_twist, d.bodies[0]);
  EXPECT_EQ(d.feedback_wrench.force, expect.force);
  EXPECT_LT(d.feedback_wrench.force.x(), 0.0);
  EXPECT_LE(d.feedback_wrench.force.norm(), 20.0);
  // Detached: zero.
  core::set_held_body(m, d, -1);
  core::step(m, d);
  EXPECT_TRUE(d.feedback_wrench.force.isZero(0.0) && d.feedback_wrench.torque.isZero(0.0));
}

TEST(Feedback, ZeroInDirectMode) {
  const core::Model m = feedback_model(core::CouplingMode::kDirect);
  core::Data d = core::make_data(m);
  d.target.position = Vec3(0.05, 0.0, 0.0);
  d.target_twist.linear = Vec3(1.0, 0.0, 0.0);
  core::step(m, d);
  EXPECT_TRUE(d.feedback_wrench.force.isZero(0.0) && d.feedback_wrench.torque.isZero(0.0));
}

TEST(Feedback, EachFeedbackGroupIsSaturatedOnItsOwn) {
  // Two bodies, each pulled by its device: body 0 (held) 0.15 m from its target (15 N), body 1
  // 0.3 m (30 N), limit 20 N. One group (one tool): the composite's 45 N scales both by 20/45.
  // A group each (two devices, Data::feedback_group): body 1 saturates alone at 20 N and body
  // 0 keeps its 15 N — one device's load does not scale the other's feedback.
  core::Model m = feedback_model(core::CouplingMode::kGodObject);
  m.bodies.push_back(m.bodies[0]);
  ASSERT_EQ(core::finalize_model(m), "");
  core::Data d = core::make_data(m);
  ASSERT_EQ(d.held_body, 0);
  d.target.position = Vec3(-0.15, 0.0, 0.0);
  d.body_targets[1].pose.position = Vec3(-0.3, 0.0, 0.0);
  d.body_targets[1].enabled = true;
  core::compute_feedback(m, d);
  EXPECT_NEAR(d.body_feedback[0].force.x(), 15.0 * 20.0 / 45.0, 1e-12);
  EXPECT_NEAR(d.body_feedback[1].force.x(), 30.0 * 20.0 / 45.0, 1e-12);
  EXPECT_NEAR(d.feedback_wrench.force.norm(), 20.0, 1e-12);
  d.feedback_group[1] = 1;
  core::compute_feedback(m, d);
  EXPECT_NEAR(d.body_feedback[0].force.x(), 15.0, 1e-12);
  EXPECT_NEAR(d.body_feedback[1].force.x(), 20.0, 1e-12);
  EXPECT_NEAR(d.feedback_wrench.force.x(), 15.0, 1e-12);  // the held body's group's composite
}

TEST(Feedback, EachFeedbackGroupHasItsDevicesGains) {
  // The same two bodies, a group each: device 1's own gains (Model::extra_feedback[0]: half the
  // stiffness, a 5 N saturation) make body 1's wrench; device 0's (Model::feedback) body 0's.
  core::Model m = feedback_model(core::CouplingMode::kGodObject);
  m.bodies.push_back(m.bodies[0]);
  core::FeedbackGains other = m.feedback;
  other.k_t = 0.5 * m.feedback.k_t;
  other.max_force = 5.0;
  m.extra_feedback.push_back(other);
  ASSERT_EQ(core::finalize_model(m), "");
  EXPECT_EQ(&core::feedback_gains(m, 0), &m.feedback);
  EXPECT_EQ(&core::feedback_gains(m, 1), &m.extra_feedback[0]);
  EXPECT_EQ(&core::feedback_gains(m, 2), &m.feedback);  // no gains of its own: device 0's
  core::Data d = core::make_data(m);
  d.feedback_group[1] = 1;
  d.target.position = Vec3(-0.15, 0.0, 0.0);
  d.body_targets[1].pose.position = Vec3(-0.04, 0.0, 0.0);  // 0.04 m · 50 N/m = 2 N: unsaturated
  d.body_targets[1].enabled = true;
  core::compute_feedback(m, d);
  EXPECT_NEAR(d.body_feedback[0].force.x(), 15.0, 1e-12);
  EXPECT_NEAR(d.body_feedback[1].force.x(), 0.04 * other.k_t, 1e-12);
  d.body_targets[1].pose.position = Vec3(-0.3, 0.0, 0.0);  // 15 N asked: its own 5 N limit
  core::compute_feedback(m, d);
  EXPECT_NEAR(d.body_feedback[0].force.x(), 15.0, 1e-12);
  EXPECT_NEAR(d.body_feedback[1].force.x(), 5.0, 1e-12);
  // A group's gains are checked as device 0's are.
  m.extra_feedback[0].k_t = -1.0;
  EXPECT_EQ(core::finalize_model(m), "feedback gains must be finite and >= 0");
}

TEST(Feedback, MirroredDevicesFeelTheSameForceEachAboutItsOwnTool) {
  // Two trocar instruments on mirror-image paths (mirrored in the plane x = 0), each a sleeve
  // at its trocar (its own rotational lag) and a tube 0.12 m below it lagging its target by the
  // same 30 mm across the shaft: 9 N asked of each against an 8 N, 0.3 N·m device. Device 0
  // holds its tube (its composite about the tube's target); device 1's tube and sleeve have
  // their own targets, its composite about its controlled frame, the tube's target
  // (Data::feedback_point, as the control loop writes it). Both get 8 N; taken about device 1's
  // trocar instead, the force's 1.1 N·m moment would take the torque limit and scale its
  // whole wrench to 2.2 N.
  core::Model m = feedback_model(core::CouplingMode::kGodObject);
  m.bodies.resize(4, m.bodies[0]);  // 0 sleeve_0, 1 tube_0 (held), 2 sleeve_1, 3 tube_1
  m.initial_held_body = 1;
  m.feedback = {300.0, 1.0, 0.5, 0.005, 8.0, 0.3};
  m.extra_feedback = {m.feedback};
  ASSERT_EQ(core::finalize_model(m), "");
  core::Data d = core::make_data(m);
  ASSERT_EQ(d.held_body, 1);
  ASSERT_EQ(d.feedback_point.size(), 2u);
  d.feedback_group = {0, 0, 1, 1};
  const auto mirror = [](const Vec3& p) { return Vec3(-p.x(), p.y(), p.z()); };
  // The mirror of a rotation by a about u is a rotation by −a about the mirrored u.
  const Vec3 trocar0(-0.05, 0.01, 0.12), tool0(-0.05, 0.01, 0.0), lag0(0.03, 0.0, 0.0);
  const double sleeve_turn = 0.1;
  const Vec3 sleeve_axis = Vec3(0.3, 1.0, 0.2).normalized();
  d.bodies[0].position = trocar0;
  d.bodies[0].orientation = rot(sleeve_turn, sleeve_axis);
  d.body_targets[0] = {core::Pose{trocar0, Quat::Identity()}, core::Twist{}, true};
  d.target = core::Pose{tool0, Quat::Identity()};
  d.bodies[1].position = tool0 + lag0;
  d.bodies[2].position = mirror(trocar0);
  d.bodies[2].orientation = rot(-sleeve_turn, mirror(sleeve_axis));
  d.body_targets[2] = {core::Pose{mirror(trocar0), Quat::Identity()}, core::Twist{}, true};
  d.body_targets[3] = {core::Pose{mirror(tool0), Quat::Identity()}, core::Twist{}, true};
  d.bodies[3].position = mirror(tool0 + lag0);
  d.feedback_point[1] = mirror(tool0);  // device 1's controlled frame: its tube's target
  core::compute_feedback(m, d);
  // Each device's composite, about its own tool.
  const auto composite = [&](int first, const Vec3& about) {
    core::Wrench w;
    for (int b = first; b < first + 2; ++b) {
      const Vec3 at =
          b == 1 ? d.target.position : d.body_targets[static_cast<std::size_t>(b)].pose.position;
      const core::Wrench c =
          core::carry_wrench(d.body_feedback[static_cast<std::size_t>(b)], at, about);
      w.force += c.force;
      w.torque += c.torque;
    }
    return w;
  };
  const core::Wrench w0 = composite(0, tool0);
  const core::Wrench w1 = composite(2, mirror(tool0));
  EXPECT_NEAR(w0.force.norm(), 8.0, 1e-9);  // 9 N asked, saturated at 8 N
  EXPECT_NEAR(w1.force.norm(), w0.force.norm(), 1e-9);
  EXPECT_NEAR(w1.torque.norm(), w0.torque.norm(), 1e-9);
  EXPECT_TRUE(w1.force.isApprox(mirror(w0.force), 1e-9));
  EXPECT_NEAR(d.body_feedback[3].force.norm(), d.body_feedback[1].force.norm(), 1e-9);
  EXPECT_TRUE(d.feedback_wrench.force.isApprox(w0.force, 1e-12));
  // Swapped (device 1's tube held, device 0's on its own target): the same magnitudes.
  core::set_held_body(m, d, 3);
  d.feedback_group = {1, 1, 0, 0};
  d.body_targets[1] = {core::Pose{tool0, Quat::Identity()}, core::Twist{}, true};
  d.target = core::Pose{mirror(tool0), Quat::Identity()};
  d.bodies[1].position = tool0 + lag0;
  d.bodies[3].position = mirror(tool0 + lag0);
  d.feedback_point[1] = tool0;
  core::compute_feedback(m, d);
  EXPECT_NEAR(d.body_feedback[1].force.norm(), 8.0, 1e-9);
  EXPECT_NEAR(d.body_feedback[3].force.norm(), 8.0, 1e-9);
}
