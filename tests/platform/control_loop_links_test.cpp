// Tests of platform/control_loop with link bindings: an articulated instrument drives bodies
// through its links and imposes its axes on prescribed joints (paper Eq. 6, Eq. 9).
#include "numen/platform/control_loop.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <numbers>
#include <string>
#include <vector>

#include "alloc_counter.hpp"
#include "build_features.hpp"
#include "control_loop_fixtures.hpp"
#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/step.hpp"
#include "numen/hal/device/axis.hpp"
#include "numen/hal/canopen/canopen.hpp"
#include "numen/hal/device/device_config.hpp"
#include "numen/hal/emulation/device_emulator.hpp"
#include "numen/hal/canopen/emcy.hpp"
#include "numen/hal/canopen/nmt.hpp"
#include "numen/hal/device/instrument_device.hpp"
#include "numen/hal/device/trocar_kinematics.hpp"
#include "numen/hal/device/rate_estimator.hpp"
#include "numen/hal/transport/sim_bus.hpp"

using namespace numen::test::control_loop_fixtures;

// ------------------------------------------------------------- link bindings
// An articulated binding (paper Eq. 6, Eq. 9): link "tube" drives the held
// body through an offset, link "jaw_1" another body through another offset,
// and the jaw axis imposes a prescribed revolute joint between them.

namespace {

using numen::core::Twist;
using numen::core::Wrench;
using numen::hal::TrocarKinematics;
using numen::platform::AxisPrescription;
using numen::platform::DeviceBinding;
using numen::platform::LinkBinding;

const double kQa[5] = {0.1, -0.2, 0.1, 0.5, 0.3};
const double kQb[5] = {0.103, -0.198, 0.1006, 0.506, 0.312};  // within every axis's max_speed · dt

/// Axis values as the device decodes them (quantised by the encoders).
AxisVector quantised(const numen::hal::DeviceConfig& c, const double* q) {
  AxisVector out(5);
  for (int i = 0; i < 5; ++i) {
    const auto& a = c.axes[static_cast<std::size_t>(i)];
    out[i] = numen::hal::counts_to_value(a, numen::hal::value_to_counts(a, q[i]));
  }
  return out;
}

Pose compose(const Pose& a, const Pose& b) {
  Pose p;
  p.position = a.position + a.orientation * b.position;
  p.orientation = a.orientation * b.orientation;
  return p;
}

Pose tube_offset() {
  Pose p;
  p.position = Vec3(0.001, -0.002, -0.04);
  p.orientation = Quat(Eigen::AngleAxisd(0.2, Vec3(1.0, 1.0, 0.0).normalized()));
  return p;
}
Pose jaw_offset() {
  Pose p;
  p.position = Vec3(0.0, 0.002, 0.006);
  p.orientation = Quat(Eigen::AngleAxisd(-0.3, Vec3::UnitY()));
  return p;
}

/// Two bodies ("tube" held, "jaw") a little off their link targets, a
/// revolute tube–jaw joint (prescribed or not), small feedback gains.
numen::core::Model linked_model(bool prescribed) {
  const numen::hal::DeviceConfig c = trocar_config();
  const TrocarKinematics kin(c.trocar, c.tool_offset);
  const AxisVector q = quantised(c, kQa);
  numen::core::Model m;
  m.dt = 1e-3;
  m.gravity = Vec3::Zero();
  m.material_names = {"default"};
  m.material_pairs = {numen::core::MaterialPair{}};
  for (int b = 0; b < 2; ++b) {
    numen::core::BodyModel body;
    body.name = b == 0 ? "tube" : "jaw";
    body.mass = b == 0 ? 0.05 : 0.005;
    body.inertia_body = (b == 0 ? 1e-5 : 1e-7) * numen::core::Mat3::Identity();
    body.coupling.k_t = b == 0 ? 100.0 : 10.0;
    body.coupling.gamma_t = numen::core::damping_from_ratio(0.85, body.mass, body.coupling.k_t);
    body.coupling.k_r = 0.01;
    body.coupling.gamma_r = 1e-5;
    const Pose target = b == 0 ? compose(kin.link_pose(TrocarKinematics::kLinkTube, q), tube_offset())
                               : compose(kin.link_pose(TrocarKinematics::kLinkJaw1, q), jaw_offset());
    body.initial_pose.position = target.position + (b == 0 ? Vec3(0.01, -0.005, 0.003) : Vec3(-0.004, 0.006, 0.002));
    body.initial_pose.orientation = target.orientation * Quat(Eigen::AngleAxisd(0.1, Vec3::UnitX()));
    m.bodies.push_back(body);
  }
  numen::core::JointModel j;
  j.name = "hinge";
  j.type = numen::core::JointType::kRevolute;
  j.parent = 0;
  j.child = 1;
  j.frame_parent.position = Vec3(0.0, 0.0, 0.04);
  j.frame_parent.orientation = numen::core::rotation_between(Vec3::UnitZ(), Vec3::UnitX());
  j.frame_child.position = Vec3(0.0, 0.0, -0.006);
  j.frame_child.orientation = j.frame_parent.orientation;
  j.prescribed = prescribed;
  m.joints.push_back(j);
  m.feedback.k_t = 20.0;
  m.feedback.gamma_t = 0.05;
  m.feedback.k_r = 0.05;
  m.feedback.gamma_r = 1e-4;
  m.feedback.max_force = 1e9;
  m.feedback.max_torque = 1e9;
  m.initial_held_body = 0;
  const std::string err = numen::core::finalize_model(m);
  EXPECT_TRUE(err.empty()) << err;
  return m;
}

DeviceBinding linked_binding() {
  DeviceBinding b;
  b.links.push_back(LinkBinding{TrocarKinematics::kLinkTube, 0, tube_offset()});
  b.links.push_back(LinkBinding{TrocarKinematics::kLinkJaw1, 1, jaw_offset()});
  b.prescriptions.push_back(AxisPrescription{0, TrocarKinematics::kJaw, 0.5, 0.1});
  return b;
}

struct LinkedRig {
  numen::hal::DeviceConfig config = trocar_config();
  SimBus bus{bus_settings()};
  numen::hal::DeviceEmulator emulator{config};
  numen::hal::InstrumentDevice device{config};
  numen::core::Model model = linked_model(true);
  numen::core::Data data = numen::core::make_data(model);
  ControlLoop loop;

  explicit LinkedRig(DeviceBinding binding = linked_binding())
      : loop{model, data, bus.controller(), device, std::move(binding)} {
    emulator.set_axis_values(kQa);
  }

  const PeriodReport& period(std::int64_t k) {
    const std::int64_t t = k * kMs;
    bus.set_time_ns(t);
    loop.begin_period(t);
    bus.set_time_ns(t + kLatency);
    emulator.poll(bus.device());
    bus.set_time_ns(t + kPhase);
    const PeriodReport& r = loop.end_period(t + kPhase);
    bus.set_time_ns(t + kPhase + kLatency);
    emulator.poll(bus.device());
    return r;
  }
};

/// Twist of a frame whose origin is `link.position` with twist `lt`, carried to `point`.
Twist carried(const Twist& lt, const Vec3& link_origin, const Vec3& point) {
  Twist t;
  t.angular = lt.angular;
  t.linear = lt.linear + lt.angular.cross(point - link_origin);
  return t;
}

Twist link_twist(const numen::hal::Kinematics& kin, int link, const AxisVector& q, const AxisVector& qdot) {
  const numen::hal::Jacobian j = kin.link_jacobian(link, q);
  const Eigen::Matrix<double, 6, 1> v = j * qdot;
  Twist t;
  t.linear = v.head<3>();
  t.angular = v.tail<3>();
  return t;
}

TEST(ControlLoopLinks, BoundBodiesGetTheirLinkTargetsAndPrescribedJointsTheirAxis) {
  NUMEN_REQUIRE_ARTICULATION();  // the trocar instrument's jointed model
  LinkedRig rig;
  const auto& kin = rig.device.kinematics();
  ASSERT_EQ(kin.num_links(), TrocarKinematics::kNumLinks);
  ASSERT_STREQ(kin.link_name(TrocarKinematics::kLinkTube), "tube");
  ASSERT_STREQ(kin.link_name(TrocarKinematics::kLinkJaw1), "jaw_1");

  // Period 0: targets from the first sample (no rate yet).
  const PeriodReport& r0 = rig.period(0);
  ASSERT_TRUE(r0.sample_valid);
  ASSERT_TRUE(r0.target_ready);
  AxisVector q = quantised(rig.config, kQa);
  ASSERT_LT((rig.device.last_sample().q - q).norm(), 1e-12);
  {
    const Pose tube = compose(kin.link_pose(TrocarKinematics::kLinkTube, q), tube_offset());
    const Pose jaw = compose(kin.link_pose(TrocarKinematics::kLinkJaw1, q), jaw_offset());
    EXPECT_LT((rig.data.target.position - tube.position).norm(), 1e-12);
    EXPECT_LT(rig.data.target.orientation.angularDistance(tube.orientation), 1e-9);
    EXPECT_GT((tube.position - kin.forward(q).position).norm(), 1e-3)
        << "test is weak: the tube target coincides with the controlled frame";
    const numen::core::BodyTarget& bt = rig.data.body_targets[1];
    EXPECT_TRUE(bt.enabled);
    EXPECT_LT((bt.pose.position - jaw.position).norm(), 1e-12);
    EXPECT_LT(bt.pose.orientation.angularDistance(jaw.orientation), 1e-9);
    EXPECT_FALSE(rig.data.body_targets[0].enabled) << "the held body's target goes to data.target";
    EXPECT_NEAR(rig.data.joint_prescribed[0].value, 0.5 * q[TrocarKinematics::kJaw] + 0.1, 1e-12);
    EXPECT_EQ(rig.data.joint_prescribed[0].rate, 0.0);
  }

  // Period 1: the axes moved: twists and the prescribed rate follow q̇.
  rig.emulator.set_axis_values(kQb);
  const PeriodReport& r1 = rig.period(1);
  ASSERT_TRUE(r1.sample_valid);
  const AxisVector q0 = q;
  q = quantised(rig.config, kQb);
  // q̇: each axis's default estimator (FOAW) over its only interval: the bounded difference.
  ASSERT_EQ(rig.config.velocity_estimator, numen::hal::VelocityEstimator::kFoaw);
  AxisVector qdot(q.size());
  for (int i = 0; i < q.size(); ++i) {
    const double vmax = rig.config.axes[static_cast<std::size_t>(i)].max_speed;
    qdot[i] = std::clamp((q[i] - q0[i]) / 1e-3, -vmax, vmax);
  }
  ASSERT_LT((rig.device.last_sample().q - q).norm(), 1e-12);
  ASSERT_LT((rig.device.last_sample().qdot - qdot).norm(), 1e-6 * qdot.norm());
  ASSERT_GT(std::abs(qdot[TrocarKinematics::kJaw]), 0.2);

  const Pose tube_link = kin.link_pose(TrocarKinematics::kLinkTube, q);
  const Pose jaw_link = kin.link_pose(TrocarKinematics::kLinkJaw1, q);
  const Pose tube = compose(tube_link, tube_offset());
  const Pose jaw = compose(jaw_link, jaw_offset());
  EXPECT_LT((rig.data.target.position - tube.position).norm(), 1e-12);
  EXPECT_LT(rig.data.target.orientation.angularDistance(tube.orientation), 1e-9);
  const numen::core::BodyTarget& bt = rig.data.body_targets[1];
  EXPECT_TRUE(bt.enabled);
  EXPECT_LT((bt.pose.position - jaw.position).norm(), 1e-12);
  EXPECT_LT(bt.pose.orientation.angularDistance(jaw.orientation), 1e-9);

  const Twist tube_tw = carried(link_twist(kin, TrocarKinematics::kLinkTube, q, qdot), tube_link.position, tube.position);
  const Twist jaw_tw = carried(link_twist(kin, TrocarKinematics::kLinkJaw1, q, qdot), jaw_link.position, jaw.position);
  const double tol = 1e-6 * (1.0 + qdot.norm());
  EXPECT_LT((rig.data.target_twist.linear - tube_tw.linear).norm(), tol);
  EXPECT_LT((rig.data.target_twist.angular - tube_tw.angular).norm(), tol);
  EXPECT_LT((bt.twist.linear - jaw_tw.linear).norm(), tol);
  EXPECT_LT((bt.twist.angular - jaw_tw.angular).norm(), tol);
  // The offset matters: the carried linear velocity differs from the link's own.
  EXPECT_GT((tube_tw.linear - link_twist(kin, TrocarKinematics::kLinkTube, q, qdot).linear).norm(), 1e-4);
  EXPECT_GT((jaw_tw.angular - tube_tw.angular).norm(), 1.0) << "jaw_1 turns at q̇_jaw/2 about x";

  EXPECT_NEAR(rig.data.joint_prescribed[0].value, 0.5 * q[TrocarKinematics::kJaw] + 0.1, 1e-12);
  EXPECT_NEAR(rig.data.joint_prescribed[0].rate, 0.5 * qdot[TrocarKinematics::kJaw], 1e-6);
}

TEST(ControlLoopLinks, TorquesAreTheSumOfTheLinkJacobiansTransposedTimesTheBodyWrenches) {
  NUMEN_REQUIRE_ARTICULATION();  // the trocar instrument's jointed model
  LinkedRig rig;
  const auto& kin = rig.device.kinematics();
  for (int k = 0; k < 3; ++k) {
    rig.emulator.set_axis_values(k % 2 == 0 ? kQa : kQb);
    const PeriodReport& r = rig.period(k);
    ASSERT_TRUE(r.sample_valid) << k;
    ASSERT_EQ(r.command_status, IoStatus::kOk) << k;
    const AxisVector& q = rig.device.last_sample().q;
    const int links[2] = {TrocarKinematics::kLinkTube, TrocarKinematics::kLinkJaw1};
    const Pose offsets[2] = {tube_offset(), jaw_offset()};
    AxisVector tau = AxisVector::Zero(5);
    double per_body[2] = {0.0, 0.0};
    for (int b = 0; b < 2; ++b) {
      const Pose link = kin.link_pose(links[b], q);
      const Vec3 point = compose(link, offsets[b]).position;  // the body's target point
      const Wrench& w = rig.data.body_feedback[static_cast<std::size_t>(b)];
      ASSERT_GT(w.force.norm(), 1e-3) << "body " << b << " has no feedback: test is weak";
      Eigen::Matrix<double, 6, 1> wl;
      wl.head<3>() = w.force;
      wl.tail<3>() = w.torque + (point - link.position).cross(w.force);  // about the link origin
      const AxisVector part = kin.link_jacobian(links[b], q).transpose() * wl;
      tau += part;
      per_body[b] = part.head<3>().cwiseAbs().maxCoeff();
    }
    EXPECT_GT(per_body[1], 5e-3) << "the jaw's share must be visible above the quantisation";
    for (int i = 0; i < 5; ++i) {
      const auto& a = rig.config.axes[static_cast<std::size_t>(i)];
      if (!a.has_drive()) {
        EXPECT_EQ(rig.loop.impedance().sent_torques().torque[i], 0.0) << "axis " << i;
        continue;
      }
      ASSERT_LT(std::abs(tau[i]), 0.5 * a.max_torque) << "test assumes no saturation, axis " << i;
      EXPECT_NEAR(rig.loop.impedance().sent_torques().torque[i], tau[i], 0.5e-3 * a.rated_torque + 1e-12)
          << "period " << k << " axis " << i;
    }
    EXPECT_GT(tau.head<3>().cwiseAbs().maxCoeff(), 0.02) << "torques too small to test";
  }
  EXPECT_EQ(rig.loop.counters().periods_zero_torque, 0u);
}

TEST(ControlLoopLinks, ZeroTorqueWhileTheSampleIsNotValid) {
  NUMEN_REQUIRE_ARTICULATION();  // the trocar instrument's jointed model
  LinkedRig rig;
  rig.period(0);
  ASSERT_GT(rig.loop.impedance().sent_torques().torque.cwiseAbs().maxCoeff(), 0.0);
  rig.emulator.set_responding(false);
  for (int k = 1; k <= 5; ++k) rig.period(k);
  EXPECT_FALSE(rig.loop.last_report().sample_valid);
  EXPECT_TRUE(rig.loop.impedance().sent_torques().torque.isZero());
  EXPECT_GT(rig.loop.counters().periods_zero_torque, 0u);
}

TEST(ControlLoopLinks, ConstructorRejectsBindingsOutOfRange) {
  NUMEN_REQUIRE_ARTICULATION();
  numen::hal::DeviceConfig config = trocar_config();
  SimBus bus{bus_settings()};
  numen::hal::InstrumentDevice device{config};
  const numen::core::Model model = linked_model(true);
  numen::core::Data data = numen::core::make_data(model);
  const auto make = [&](const DeviceBinding& b) { ControlLoop loop(model, data, bus.controller(), device, b); };

  EXPECT_NO_THROW(make(linked_binding()));
  EXPECT_NO_THROW(make(DeviceBinding::rigid()));
  EXPECT_NO_THROW(make(DeviceBinding{}));

  for (int link : {-1, TrocarKinematics::kNumLinks, numen::hal::kMaxLinks}) {
    DeviceBinding b = linked_binding();
    b.links[1].link = link;
    EXPECT_THROW(make(b), std::invalid_argument) << "link " << link;
  }
  for (int body : {-2, 2, 100}) {
    DeviceBinding b = linked_binding();
    b.links[1].body = body;
    EXPECT_THROW(make(b), std::invalid_argument) << "body " << body;
  }
  {
    DeviceBinding b = linked_binding();
    b.links[1].body = -1;  // whichever body is held: valid
    EXPECT_NO_THROW(make(b));
  }
  {
    DeviceBinding b = linked_binding();
    b.links[1].body = b.links[0].body;  // one body on two links: its torque would count twice
    EXPECT_THROW(make(b), std::invalid_argument);
  }
  for (int joint : {-1, 1}) {
    DeviceBinding b = linked_binding();
    b.prescriptions[0].joint = joint;
    EXPECT_THROW(make(b), std::invalid_argument) << "joint " << joint;
  }
  for (int axis : {-1, 5, numen::hal::kMaxAxes}) {
    DeviceBinding b = linked_binding();
    b.prescriptions[0].axis = axis;
    EXPECT_THROW(make(b), std::invalid_argument) << "axis " << axis;
  }
  // A prescription on a joint that is not prescribed.
  const numen::core::Model free_model = linked_model(false);
  numen::core::Data free_data = numen::core::make_data(free_model);
  EXPECT_THROW(ControlLoop(free_model, free_data, bus.controller(), device, linked_binding()),
               std::invalid_argument);
  DeviceBinding no_prescription = linked_binding();
  no_prescription.prescriptions.clear();
  EXPECT_NO_THROW(ControlLoop(free_model, free_data, bus.controller(), device, no_prescription));
}

}  // namespace

namespace {

TEST(ControlLoopLinks, TheHeldBodyFollowsItsOwnLinkAcrossToolSwitches) {
  NUMEN_REQUIRE_ARTICULATION();  // the trocar instrument's jointed model
  // Tool switching with link bindings: body 0 is bound to "tube"; a fallback
  // binding (body -1, link 0) serves a held body without a link of its own.
  DeviceBinding b = linked_binding();
  b.links.push_back(numen::platform::LinkBinding{});  // link 0 → the held body
  LinkedRig rig(b);
  const auto& kin = rig.device.kinematics();
  rig.period(0);
  const AxisVector q = rig.device.last_sample().q;
  // Held body 0 has its own link: the fallback binding is not used.
  const Pose tube = kin.link_pose(TrocarKinematics::kLinkTube, q);
  const Pose off = b.links[0].body_in_link;
  EXPECT_LT((rig.data.target.position - (tube.position + tube.orientation * off.position)).norm(), 1e-12);
  // Switch the hold to body 1: it keeps its own link ("jaw_1") and the target
  // of the held body comes from that binding.
  numen::core::set_held_body(rig.model, rig.data, 1);
  rig.period(1);
  const Pose jaw = kin.link_pose(TrocarKinematics::kLinkJaw1, rig.device.last_sample().q);
  const Pose off1 = b.links[1].body_in_link;
  EXPECT_LT((rig.data.target.position - (jaw.position + jaw.orientation * off1.position)).norm(), 1e-12);
  // Nothing held: the held target is left alone, the bound bodies keep theirs.
  const Pose held_before = rig.data.target;
  numen::core::set_held_body(rig.model, rig.data, -1);
  rig.period(2);
  EXPECT_EQ(rig.data.target.position, held_before.position);
  EXPECT_TRUE(rig.data.body_targets[0].enabled);
  EXPECT_TRUE(rig.data.body_targets[1].enabled);
}

}  // namespace
