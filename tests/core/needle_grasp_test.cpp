// The needle in the graspers' jaws (needle.hpp, grasp.hpp; docs/suturing.md, "The needle"): the
// jaws' 1.5 mm spheres close on the 0.35 mm wire of a 26 mm half-circle needle (78 mg) by the
// grasp rules numen has, hold it at recorded speeds, let it go and take it again, hand it from one
// instrument to the other, and the hand feels what the held needle presses on.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "alloc_counter.hpp"
#include "grasper_rig.hpp"
#include "numen/core/data.hpp"
#include "numen/core/grasp.hpp"
#include "numen/core/model.hpp"
#include "numen/core/needle.hpp"
#include "numen/core/step.hpp"
#include "rotation.hpp"

namespace {

namespace core = numen::core;

using numen::test::kGraspDeg;

/// The height below a grasper's hinge of its jaws' third spheres (8 mm from the hinge) at 25°.
constexpr double kWireBelowHinge = 0.008 * 0.9762960071199334;  // 8 mm · cos 12.5°

/// A 26 mm half-circle needle (numen::core::NeedleSpec's defaults) lying flat (its arc in the
/// world's x–y plane), the middle of its arc at `mid` with the wire there along +x, the arc curving
/// towards +y. Returns its index in Model::needles.
int add_flat_needle(core::Model& m, const core::Vec3& mid) {
  core::NeedleSpec spec;
  const double a = spec.radius * (1.0 - 2.0 / M_PI);  // the arc's middle from its centroid (body +x)
  const core::Quat q = numen::test::rot(-M_PI / 2, core::Vec3::UnitZ());  // body y → world x
  spec.pose = core::Pose{mid - q * core::Vec3(a, 0, 0), q};
  return core::add_needle(m, spec);
}

/// Grasper A (bodies 0–2, joints 0–1) pointing down, its tube at `a_at`, jaws at `a_opening`; the
/// needle's arc middle under A's jaws, 8 mm below the hinge (where its jaws' third spheres close
/// on it at 25°), offset by `needle_offset`; with `second`, grasper B (bodies 3–5, joints 2–3) at
/// `b_at`, its jaws at 60°. Each jaw a line of `jaw_spheres` 1.5 mm spheres 2–11 mm from its hinge:
/// ten (1 mm apart) by default, so that the jaw's surface dips at most 0.09 mm between two of them,
/// a quarter of the wire's radius ("SparseJawSpheresMissTheThinWire" below). Steel on steel 2e4 N/m.
core::Model needle_rig(double gravity, const core::Vec3& a_at, double a_opening, const core::Vec3& needle_offset,
                       bool second = false, const core::Vec3& b_at = core::Vec3::Zero(), int jaw_spheres = 10) {
  core::Model m;
  m.dt = 1e-3;
  m.gravity = core::Vec3(0, 0, -gravity);
  m.material_names = {"steel"};
  m.material_pairs = {core::MaterialPair{2e4, 10.0, 0.5}};
  numen::test::add_grasper(m, a_at, a_opening, 5.0, jaw_spheres);
  if (second) {
    numen::test::add_grasper(m, b_at, 60 * kGraspDeg, 5.0, jaw_spheres);
    m.grasps[1].name = "grasper_b";
  }
  m.initial_held_body = 0;
  add_flat_needle(m, core::Vec3(0, 0, a_at.z() - 0.04 - kWireBelowHinge) + needle_offset);
  EXPECT_EQ(core::finalize_model(m), "");
  return m;
}

/// The needle's body (the last body).
int needle_body(const core::Model& m) { return m.needles[0].body; }

/// The needle's centre of mass in jaw 1's frame (m).
core::Vec3 needle_in_jaw(const core::Model& m, const core::Data& d) {
  const core::BodyState& jaw = d.bodies[1];
  return jaw.orientation.conjugate() * (d.bodies[static_cast<std::size_t>(needle_body(m))].position - jaw.position);
}

}  // namespace

namespace {

/// needle_rig() with gravity, A's jaws open at 60° over the needle lying flat on three 1 mm balls
/// under its arc (60° either side of its middle and 30° towards the tip: clear of the jaws, its
/// centre of mass within them). Finalized.
core::Model needle_on_balls(const core::Vec3& at, int jaw_spheres) {
  core::Model m = needle_rig(9.81, at, 60 * kGraspDeg, core::Vec3::Zero(), false,
                             core::Vec3::Zero(), jaw_spheres);
  const core::NeedleModel n = m.needles[0];
  const core::Pose np = m.bodies[static_cast<std::size_t>(n.body)].initial_pose;
  for (double phi_deg : {-60.0, 60.0, 30.0}) {
    core::Obstacle ball;
    ball.name = "ball";
    ball.type = core::ShapeType::kSphere;
    ball.radius = 0.001;
    const double s_arc = 0.5 * n.length() + n.radius * phi_deg * kGraspDeg;
    ball.pose.position = np.position + np.orientation * core::needle_point(n, s_arc) -
                         core::Vec3(0, 0, n.wire_radius + ball.radius);
    m.obstacles.push_back(ball);
  }
  EXPECT_EQ(core::finalize_model(m), "");
  return m;
}

/// The opening (rad) at which A's jaws, closing from 60° at 100°/s on the needle lying on its balls
/// (needle_on_balls()), the hand still, first grasp it within 0.6 s; −1 if they never do.
double closing_grasp_opening(int jaw_spheres) {
  const core::Vec3 at(0, 0, 0.06);
  const core::Model m = needle_on_balls(at, jaw_spheres);
  core::Data d = core::make_data(m);
  double theta = 60 * kGraspDeg;
  for (int s = 0; s < 600; ++s) {
    const double r = theta > 25 * kGraspDeg ? -100 * kGraspDeg : 0.0;
    numen::test::set_grasper_opening(d, theta, r);
    numen::test::set_grasper_target(d, at, core::Vec3::Zero());
    core::step(m, d);
    theta = std::max(25 * kGraspDeg, theta + r * m.dt);
    if (d.grasps[0].event == core::GraspEvent::kGrasp) return d.grasps[0].opening;
  }
  return -1.0;
}

}  // namespace

TEST(NeedleGrasp, SparseJawSpheresMissTheThinWire) {
  // The jaws of the grasping tests (four 1.5 mm spheres 3 mm apart: their surface dips 1.5 mm
  // between two, four times the wire's radius) close to 25° over the 0.7 mm wire lying on its
  // balls and never touch it with both jaws: under gravity the tube's 1000 N/m coupling lets the
  // 70 g instrument sag 0.69 mm, and the wire falls between the spheres' reach
  // (docs/suturing.md, "The needle in the jaws"). Jaws of ten spheres 1 mm apart (a dip of 0.09
  // mm) close on it as a flat jaw would, below the grasper's 30°.
  EXPECT_LT(closing_grasp_opening(4), 0.0) << "the sparse jaws grasped the thin wire";
  const double dense = closing_grasp_opening(10);
  EXPECT_GT(dense, 25 * kGraspDeg) << "the dense jaws never grasped the wire";
  EXPECT_LT(dense, 30 * kGraspDeg);
  std::printf(
      "jaws closing on the needle's wire: 4 spheres: no grasp; 10 spheres: grasp at %.2f deg\n",
      dense / kGraspDeg);
}

TEST(NeedleGrasp, TheJawsCloseOnTheWireLetItGoAndTakeItAgain) {
  // Gravity. The needle lies flat on three 1 mm balls (needle_on_balls()). The jaws (ten spheres
  // a jaw) close from 60° at 100°/s and grasp the wire below the grasper's 30°. The hand lifts it 10 mm and puts it back (0.5 s each way); the jaws open to 60° (released
  // past 40°: it lies on the balls again); the hand rises 15 mm and comes back (0.3 s each way);
  // the jaws close again (a second grasp of the same needle) and the hand lifts it 10 mm.
  const core::Vec3 at(0, 0, 0.06);
  const core::Model m = needle_on_balls(at, 10);
  const core::NeedleModel& n = m.needles[0];
  const core::Pose& np = m.bodies[static_cast<std::size_t>(n.body)].initial_pose;
  core::Data d = core::make_data(m);
  const int nb = n.body;
  const double z0 = np.position.z();
  double theta = 60 * kGraspDeg;
  const double rate = 100 * kGraspDeg;
  std::vector<double> grasp_openings;
  grasp_openings.reserve(8);
  int release_step = -1, grasp_step_first = -1;
  double lowest_let_go = 1.0, highest_let_go = -1.0;
  // Phases (steps): close 0–600, lift 600–1100, lower 1100–1600, open 1600–2100, away and back
  // 2100–2700, close 2700–3300, lift 3300–3800, hold to 4000.
  auto bump = [](double t, double span, double height, double* v) {  // 0 → height, smooth
    const double u = std::clamp(t / span, 0.0, 1.0);
    *v = (u > 0.0 && u < 1.0) ? height * 0.5 * M_PI / span * std::sin(M_PI * u) : 0.0;
    return height * 0.5 * (1 - std::cos(M_PI * u));
  };
  numen::test::AllocationGuard guard;
  for (int s = 0; s < 4000; ++s) {
    const double t = s * m.dt;
    const double target_theta = (s >= 1600 && s < 2700) ? 60 * kGraspDeg : 25 * kGraspDeg;
    core::Vec3 hand = at, v = core::Vec3::Zero();
    double dv = 0.0;
    if (s >= 600 && s < 1100) hand.z() += bump(t - 0.6, 0.5, 0.01, &dv), v.z() = dv;
    if (s >= 1100 && s < 1600) hand.z() += 0.01 - bump(t - 1.1, 0.5, 0.01, &dv), v.z() = -dv;
    if (s >= 2100 && s < 2400) hand.z() += bump(t - 2.1, 0.3, 0.015, &dv), v.z() = dv;
    if (s >= 2400 && s < 2700) hand.z() += 0.015 - bump(t - 2.4, 0.3, 0.015, &dv), v.z() = -dv;
    if (s >= 3300) hand.z() += bump(t - 3.3, 0.5, 0.01, &dv), v.z() = dv;
    const double r = theta > target_theta + 1e-12 ? -rate : (theta < target_theta - 1e-12 ? rate : 0.0);
    numen::test::set_grasper_opening(d, theta, r);
    numen::test::set_grasper_target(d, hand, v);
    core::step(m, d);
    ASSERT_EQ(d.status & core::kNonFinite, 0u) << s;
    theta = r < 0 ? std::max(target_theta, theta + r * m.dt) : std::min(target_theta, theta + r * m.dt);
    const core::GraspState& g = d.grasps[0];
    if (g.event == core::GraspEvent::kGrasp) {
      if (grasp_openings.empty()) grasp_step_first = s;
      grasp_openings.push_back(g.opening);
      EXPECT_EQ(g.body, nb) << "the jaws grasped the needle";
      EXPECT_EQ(g.num_points, 2 * core::kGripPointsPerJaw);
    }
    if (g.event == core::GraspEvent::kRelease) release_step = s;
    if (s >= 2200 && s < 2700) {  // let go: on the balls
      lowest_let_go = std::min(lowest_let_go, d.bodies[static_cast<std::size_t>(nb)].position.z());
      highest_let_go = std::max(highest_let_go, d.bodies[static_cast<std::size_t>(nb)].position.z());
      EXPECT_FALSE(g.holding()) << s;
    }
  }
  EXPECT_EQ(guard.count(), 0u) << "the steps allocated";
  ASSERT_EQ(grasp_openings.size(), 2u) << "grasped, let go, grasped again";
  for (double o : grasp_openings) {
    EXPECT_GT(o, 25.0 * kGraspDeg)
        << "grasped at " << o / kGraspDeg << "°, where both jaws touch the wire";
    EXPECT_LT(o, 30.0 * kGraspDeg) << "grasped at " << o / kGraspDeg << "°";
  }
  EXPECT_LT(grasp_step_first, 600) << "grasped while the jaws closed, before the lift";
  EXPECT_GT(release_step, 1600);
  EXPECT_LT(release_step, 1800);
  EXPECT_EQ(d.grasps[0].releases, 1);
  EXPECT_EQ(d.grasps[0].slips, 0);
  EXPECT_TRUE(d.grasps[0].holding());
  // Let go, it lay on the balls where it started; taken again, it went up with the hand.
  EXPECT_NEAR(lowest_let_go, z0, 0.2e-3) << "m";
  EXPECT_NEAR(highest_let_go, z0, 0.2e-3) << "m";
  EXPECT_NEAR(d.bodies[static_cast<std::size_t>(nb)].position.z(), z0 + 0.01, 0.5e-3) << "m: lifted again";
}

TEST(NeedleGrasp, HoldsTheNeedleAgainstGravityAtRecordedSpeedsAndDropsItWhenOpened) {
  // The jaws at 25° on the wire from the start. The hand lifts 30 mm in 0.5 s, sways along x at up
  // to 0.3 m/s and 3 m/s² (x = 30 mm e(t) sin(10 t), e = sin²(π t / 2 s): the fastest of the
  // JIGSAWS recordings' tool-tip motion) for 2 s, holds still 0.5 s, then opens at 100°/s: the
  // needle falls free.
  const core::Vec3 start(0, 0, 0.06);
  const core::Model m = needle_rig(9.81, start, 25 * kGraspDeg, core::Vec3::Zero());
  core::Data d = core::make_data(m);
  const int nb = needle_body(m);
  numen::test::set_grasper_target(d, start, core::Vec3::Zero());
  numen::test::set_grasper_opening(d, 25 * kGraspDeg, 0.0);
  core::step(m, d);
  ASSERT_EQ(d.grasps[0].body, nb) << "grasped in the first step";
  const core::Vec3 grasped = needle_in_jaw(m, d);
  double worst = 0.0, fastest = 0.0;
  int dropped = -1, released = -1;
  const int lift = 500, sway = 2000, still = 500, open = 300;
  double theta = 25 * kGraspDeg;
  numen::test::AllocationGuard guard;
  double z_release = 0.0;
  for (int s = 1; s < lift + sway + still + open; ++s) {
    const double t = s * m.dt;
    core::Vec3 at = start, v = core::Vec3::Zero();
    if (s < lift) {
      at.z() += 0.015 * (1 - std::cos(M_PI * t / 0.5));
      v.z() = 0.015 * M_PI / 0.5 * std::sin(M_PI * t / 0.5);
    } else {
      at.z() += 0.03;
      if (s < lift + sway) {
        const double ts = t - lift * m.dt, big_t = sway * m.dt;
        const double e = std::pow(std::sin(M_PI * ts / big_t), 2);
        const double de = M_PI / big_t * std::sin(2 * M_PI * ts / big_t);
        at.x() = 0.03 * e * std::sin(10 * ts);
        v.x() = 0.03 * (de * std::sin(10 * ts) + e * 10 * std::cos(10 * ts));
      }
    }
    const double r = s >= lift + sway + still && theta < 60 * kGraspDeg ? 100 * kGraspDeg : 0.0;
    numen::test::set_grasper_opening(d, theta, r);
    theta = std::min(60 * kGraspDeg, theta + r * m.dt);
    numen::test::set_grasper_target(d, at, v);
    core::step(m, d);
    ASSERT_EQ(d.status & core::kNonFinite, 0u) << s;
    const bool opening = s >= lift + sway + still;  // the jaws turn apart: jaw 1's frame with them
    if (!opening) fastest = std::max(fastest, d.bodies[static_cast<std::size_t>(nb)].linear_velocity.norm());
    if (d.grasps[0].event == core::GraspEvent::kRelease) {
      released = s;
      z_release = d.bodies[static_cast<std::size_t>(nb)].position.z();
    }
    if (!d.grasps[0].holding() && dropped < 0) dropped = s;
    if (!opening) worst = std::max(worst, (needle_in_jaw(m, d) - grasped).norm());
  }
  EXPECT_EQ(guard.count(), 0u) << "a held needle's steps allocated";
  std::printf("needle held at up to %.3f m/s: largest move in the jaw %.4f mm\n", fastest, worst * 1e3);
  EXPECT_GT(fastest, 0.25) << "m/s: the needle went at recorded speeds";
  EXPECT_LT(worst, 0.5e-3) << "m: the needle moved in the jaws";
  EXPECT_GT(worst, 1e-7) << "m: the grip's springs carry it, so they stretch";
  ASSERT_EQ(dropped, released) << "held until the jaws opened past 40°";
  ASSERT_GT(released, lift + sway + still);
  // Let go at rest (but for the opening jaws), it falls at g: ½ g t² in the remaining steps, less
  // what the implicit step's one step of lag takes (within 10 %).
  const double t_fall = (lift + sway + still + open - 1 - released) * m.dt;
  const double fell = z_release - d.bodies[static_cast<std::size_t>(nb)].position.z();
  EXPECT_NEAR(fell, 0.5 * 9.81 * t_fall * t_fall, 0.1 * 0.5 * 9.81 * t_fall * t_fall) << "m fallen";
}

TEST(NeedleGrasp, OneInstrumentHandsTheNeedleToTheOther) {
  // Gravity. A holds the needle 4 mm left of its arc's middle; B, 20 mm higher and 4 mm right,
  // comes down (0.5 s), closes on the wire there (0.35 s), A opens (0.35 s) and rises 30 mm out of
  // the way (0.5 s); B holds it alone (0.5 s). Never dropped; B's grip carries its weight.
  const double R = core::NeedleSpec{}.radius;
  const double y4 = R - std::sqrt(R * R - 0.004 * 0.004);  // the wire's y 4 mm from the middle
  const core::Vec3 a_at(-0.004, y4, 0.06), b_start(0.004, y4, 0.08);
  const core::Model m = needle_rig(9.81, a_at, 25 * kGraspDeg, core::Vec3(0, 0, 0), true, b_start);
  core::Data d = core::make_data(m);
  const int nb = needle_body(m);
  const double rate = 100 * kGraspDeg;
  double theta_a = 25 * kGraspDeg, theta_b = 60 * kGraspDeg, lowest = 1.0;
  const double z0 = m.bodies[static_cast<std::size_t>(nb)].initial_pose.position.z();
  int both = 0, b_grasp = -1, a_release = -1;
  numen::test::AllocationGuard guard;
  for (int s = 0; s < 2200; ++s) {
    core::Vec3 b_at = b_start, b_v = core::Vec3::Zero(), a_now = a_at, a_v = core::Vec3::Zero();
    if (s < 500) {
      b_at.z() -= 0.02 * 0.5 * (1 - std::cos(M_PI * s * m.dt / 0.5));
      b_v.z() = -0.02 * 0.5 * M_PI / 0.5 * std::sin(M_PI * s * m.dt / 0.5);
    } else {
      b_at.z() -= 0.02;
    }
    if (s >= 1200) {
      const double t = std::min(0.5, (s - 1200) * m.dt);
      a_now.z() += 0.03 * 0.5 * (1 - std::cos(M_PI * t / 0.5));
      a_v.z() = t < 0.5 ? 0.03 * 0.5 * M_PI / 0.5 * std::sin(M_PI * t / 0.5) : 0.0;
    }
    const double rb = (s >= 500 && theta_b > 25 * kGraspDeg) ? -rate : 0.0;
    const double ra = (s >= 850 && theta_a < 60 * kGraspDeg) ? rate : 0.0;
    numen::test::set_grasper_opening(d, theta_a, ra, 0);
    numen::test::set_grasper_opening(d, theta_b, rb, 2);
    theta_a = std::min(60 * kGraspDeg, theta_a + ra * m.dt);
    theta_b = std::max(25 * kGraspDeg, theta_b + rb * m.dt);
    numen::test::set_grasper_target(d, a_now, a_v);
    core::BodyTarget& bt = d.body_targets[3];
    bt.pose = core::Pose{b_at, numen::test::rot(M_PI, core::Vec3::UnitX())};
    bt.twist = core::Twist{b_v, core::Vec3::Zero()};
    bt.enabled = true;
    core::step(m, d);
    ASSERT_EQ(d.status & core::kNonFinite, 0u) << s;
    const bool a = d.grasps[0].holding(), b = d.grasps[1].holding();
    ASSERT_TRUE(a || b) << "the needle dropped at step " << s;
    if (a && b) ++both;
    if (d.grasps[1].event == core::GraspEvent::kGrasp) b_grasp = s;
    if (d.grasps[0].event == core::GraspEvent::kRelease) a_release = s;
    lowest = std::min(lowest, d.bodies[static_cast<std::size_t>(nb)].position.z());
  }
  EXPECT_EQ(guard.count(), 0u) << "the hand-over's steps allocated";
  ASSERT_GT(b_grasp, 500) << "B grasped the needle";
  ASSERT_GT(a_release, b_grasp) << "A let go after B took it";
  EXPECT_GT(both, 50) << "steps held by both";
  EXPECT_EQ(d.grasps[1].body, nb);
  EXPECT_FALSE(d.grasps[0].holding());
  EXPECT_GT(lowest, z0 - 1e-3) << "m: the needle sagged in the hand-over";
  EXPECT_NEAR(d.grasps[1].grip_force, m.bodies[static_cast<std::size_t>(nb)].mass * 9.81,
              0.1 * m.bodies[static_cast<std::size_t>(nb)].mass * 9.81)
      << "N: B's grip carries the needle's weight";
}

TEST(NeedleGrasp, TheHandFeelsWhatTheHeldNeedlePressesOn) {
  // No gravity. The needle held at 25°; a 1 mm sphere obstacle 0.5 mm below its wire 4 mm along
  // the arc from the jaws (clear of them). The hand holds still 0.2 s, goes down 1 mm in 0.2 s and holds: the needle
  // presses the sphere, and the device's feedback (Eq. 8, through the grip, the jaws' hinges and
  // the tube's coupling) is the sphere's push on the needle: the god-object's contact felt through
  // what it holds (the paper's tool switching). Before the touch, nothing.
  const core::Vec3 start(0, 0, 0.06);
  core::Model m = needle_rig(0.0, start, 25 * kGraspDeg, core::Vec3::Zero());
  m.feedback = core::FeedbackGains{1000.0, core::damping_from_ratio(0.85, 0.07, 1000.0), 1.0,
                                   core::damping_from_ratio(0.85, 2e-5, 1.0)};
  const core::NeedleModel n = m.needles[0];
  const core::Pose& np = m.bodies[static_cast<std::size_t>(n.body)].initial_pose;
  const core::Vec3 under = np.position + np.orientation * core::needle_point(n, 0.5 * n.length() + 0.004);
  core::Obstacle ball;
  ball.name = "ball";
  ball.type = core::ShapeType::kSphere;
  ball.radius = 0.001;
  ball.pose.position = under - core::Vec3(0, 0, n.wire_radius + ball.radius + 0.0005);
  m.obstacles.push_back(ball);
  ASSERT_EQ(core::finalize_model(m), "");
  core::Data d = core::make_data(m);
  const int nb = n.body;
  numen::test::AllocationGuard guard;
  double before = 0.0;
  core::Vec3 push = core::Vec3::Zero();
  for (int s = 0; s < 1700; ++s) {
    core::Vec3 at = start, v = core::Vec3::Zero();
    const double t = std::clamp((s - 200) * m.dt, 0.0, 0.2);  // still 0.2 s, then down
    at.z() -= 0.001 * 0.5 * (1 - std::cos(M_PI * t / 0.2));
    v.z() = t > 0.0 && t < 0.2 ? -0.001 * 0.5 * M_PI / 0.2 * std::sin(M_PI * t / 0.2) : 0.0;
    numen::test::set_grasper_opening(d, 25 * kGraspDeg, 0.0);
    numen::test::set_grasper_target(d, at, v);
    core::step(m, d);
    ASSERT_EQ(d.status & core::kNonFinite, 0u) << s;
    ASSERT_EQ(d.grasps[0].body, nb) << s;
    push.setZero();
    for (int c = 0; c < d.num_contacts; ++c) {
      const core::Contact& ct = d.contacts[static_cast<std::size_t>(c)];
      if (ct.obstacle == 0 && ct.body_a == nb) push += ct.force;
      EXPECT_FALSE(ct.obstacle == 0 && ct.body_a != nb) << "the jaws touched the ball";
    }
    if (s >= 100 && s < 200) before = std::max(before, d.feedback_wrench.force.norm());  // the hand still
  }
  EXPECT_EQ(guard.count(), 0u);
  std::printf("held needle on the ball: push %.4f N up, feedback %.4f %.4f %.4f N\n", push.z(),
              d.feedback_wrench.force.x(), d.feedback_wrench.force.y(), d.feedback_wrench.force.z());
  EXPECT_LT(before, 1e-3) << "N felt before the needle touched";
  ASSERT_GT(push.z(), 0.1) << "N: the needle presses the ball";
  // Statics: the hand feels the ball's push (nothing else touches the instrument or the needle).
  EXPECT_LT((d.feedback_wrench.force - push).norm(), 0.02 * push.norm()) << "N";
}
