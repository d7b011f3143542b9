// Two instruments in one model (issue 54, the core's part; docs/grasping.md, "Hand-over"): each
// its own god-object (the first through Data::target, the second through its own body target,
// Eq. 6), a hand-over of a held plate in mid-air, and their tubes clashing at 0.5 m/s without
// passing through each other.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "alloc_counter.hpp"
#include "clash_tubes.hpp"
#include "grasper_rig.hpp"
#include "numen/core/data.hpp"
#include "numen/core/grasp.hpp"
#include "numen/core/model.hpp"
#include "numen/core/step.hpp"
#include "rotation.hpp"

namespace {

namespace core = numen::core;

/// Grasper A (bodies 0–2, joints 0–1) at x = −8 mm with its jaws at 25° on the top edge of a
/// 20 g plate 30 mm wide (x), 12 mm tall, 1 mm thick (spheres of 0.5 mm); grasper B (bodies 3–5,
/// joints 2–3) at x = +8 mm, 20 mm higher, its jaws open at 60°. Gravity. A is held through
/// Data::target, B through body 3's own target.
core::Model handover_rig() {
  core::Model m;
  m.dt = 1e-3;
  m.gravity = core::Vec3(0, 0, -9.81);
  m.material_names = {"steel"};
  m.material_pairs = {core::MaterialPair{2e4, 10.0, 0.5}};
  numen::test::add_grasper(m, core::Vec3(-0.008, 0, 0.06), 25 * numen::test::kGraspDeg, 5.0);
  numen::test::add_grasper(m, core::Vec3(0.008, 0, 0.08), 60 * numen::test::kGraspDeg, 5.0);
  m.grasps[1].name = "grasper_b";
  m.initial_held_body = 0;
  core::BodyModel plate;
  plate.name = "plate";
  plate.mass = 0.02;
  const double a = 0.030, c = 0.012, t = 0.001;
  plate.inertia_body =
      core::Vec3(0.02 / 12 * (t * t + c * c), 0.02 / 12 * (a * a + c * c), 0.02 / 12 * (a * a + t * t)).asDiagonal();
  plate.sphere_begin = static_cast<int>(m.body_spheres.size());
  for (int i = 0; i < 31; ++i)
    for (int j = 0; j < 13; ++j)
      m.body_spheres.push_back(core::Sphere{core::Vec3(-0.015 + 0.001 * i, 0, -0.006 + 0.001 * j), 0.0005});
  plate.sphere_count = 31 * 13;
  plate.initial_pose = core::Pose{core::Vec3(0, 0, 0.0065), core::Quat::Identity()};
  m.bodies.push_back(plate);
  EXPECT_EQ(core::finalize_model(m), "");
  return m;
}

/// Body 3's target (grasper B's tube) at `at` moving at `v`, turned down.
void set_b_target(core::Data& d, const core::Vec3& at, const core::Vec3& v) {
  core::BodyTarget& t = d.body_targets[3];
  t.pose = core::Pose{at, numen::test::rot(M_PI, core::Vec3::UnitX())};
  t.twist = core::Twist{v, core::Vec3::Zero()};
  t.enabled = true;
}

}  // namespace

TEST(TwoInstruments, OneHandsAHeldPlateToTheOtherInMidAir) {
  // A holds the plate from the first step. B comes down 20 mm (0.5 s), closes on the plate's other
  // half (0.35 s), A opens (0.35 s), B carries the plate 30 mm along +x (0.5 s; out from between
  // A's open jaws, which straddle its plane) and holds (0.5 s). The plate never drops: held by A,
  // then by both, then by B alone, and it goes with B.
  const core::Model m = handover_rig();
  core::Data d = core::make_data(m);
  const core::Vec3 a_at(-0.008, 0, 0.06);
  const core::Vec3 b_start(0.008, 0, 0.08);
  const double rate = 100 * numen::test::kGraspDeg, deg = numen::test::kGraspDeg;
  double theta_a = 25 * deg, theta_b = 60 * deg;
  double lowest = 1.0;
  int both = 0, b_grasp = -1, a_release = -1;
  numen::test::AllocationGuard guard;
  for (int s = 0; s < 2200; ++s) {
    core::Vec3 b_at = b_start, b_v = core::Vec3::Zero();
    if (s < 500) {
      b_at.z() -= 0.02 * 0.5 * (1 - std::cos(M_PI * s * m.dt / 0.5));
      b_v.z() = -0.02 * 0.5 * M_PI / 0.5 * std::sin(M_PI * s * m.dt / 0.5);
    } else if (s < 1200) {
      b_at.z() -= 0.02;
    } else {
      const double t = std::min(0.5, (s - 1200) * m.dt);
      b_at.z() -= 0.02;
      b_at.x() += 0.03 * 0.5 * (1 - std::cos(M_PI * t / 0.5));
      b_v.x() = t < 0.5 ? 0.03 * 0.5 * M_PI / 0.5 * std::sin(M_PI * t / 0.5) : 0.0;
    }
    const double rb = (s >= 500 && theta_b > 25 * deg) ? -rate : 0.0;
    const double ra = (s >= 850 && theta_a < 60 * deg) ? rate : 0.0;
    numen::test::set_grasper_opening(d, theta_a, ra, 0);
    numen::test::set_grasper_opening(d, theta_b, rb, 2);
    theta_a = std::min(60 * deg, theta_a + ra * m.dt);
    theta_b = std::max(25 * deg, theta_b + rb * m.dt);
    numen::test::set_grasper_target(d, a_at, core::Vec3::Zero());
    set_b_target(d, b_at, b_v);
    core::step(m, d);
    ASSERT_EQ(d.status & core::kNonFinite, 0u) << s;
    const bool a = d.grasps[0].holding(), b = d.grasps[1].holding();
    ASSERT_TRUE(a || b) << "the plate dropped at step " << s;
    if (a && b) ++both;
    if (d.grasps[1].event == core::GraspEvent::kGrasp) b_grasp = s;
    if (d.grasps[0].event == core::GraspEvent::kRelease) a_release = s;
    lowest = std::min(lowest, d.bodies[6].position.z());
  }
  EXPECT_EQ(guard.count(), 0u) << "two instruments' steps allocated";
  ASSERT_GT(b_grasp, 500) << "B grasped the plate";
  ASSERT_GT(a_release, b_grasp) << "A let go after B took it";
  EXPECT_GT(both, 50) << "steps held by both";
  EXPECT_EQ(d.grasps[1].body, 6);
  EXPECT_FALSE(d.grasps[0].holding());
  // Pinched off its centre (8 mm), the plate tilts on each grip by a few hundredths of a radian
  // and the tubes' couplings give under its weight: about 2 mm lower, never dropped.
  EXPECT_GT(lowest, 0.0065 - 0.003) << "m: the plate sagged during the hand-over";
  EXPECT_NEAR(d.bodies[6].position.x(), 0.03, 0.002) << "m: the plate went with B";
  EXPECT_NEAR(d.grasps[1].grip_force, 0.02 * 9.81, 0.1 * 0.02 * 9.81) << "N: B's grip carries the plate's weight";
}

TEST(TwoInstruments, TheirTubesClashAtHalfAMetreASecondWithoutPassingThroughEachOther) {
  // Two instruments' tubes (lines of 2.5 mm spheres, 80 mm long; the left one along x, the right
  // one upright, both centred on x = 0, z = 0, 40 mm apart along y) driven at each other at 0.5 m/s
  // each: their hands' targets cross, the tubes stop on each other (penalty contacts, 2e4 N/m)
  // and never swap sides.
  core::Model m;
  m.dt = 1e-3;
  m.gravity = core::Vec3::Zero();
  m.material_names = {"steel"};
  m.material_pairs = {core::MaterialPair{2e4, 10.0, 0.5}};
  numen::test::add_clash_tubes(m);
  m.initial_held_body = 0;
  ASSERT_EQ(core::finalize_model(m), "");
  core::Data d = core::make_data(m);
  double closest = 1.0;
  bool swapped = false;
  for (int s = 0; s < 200; ++s) {
    const double t = s * m.dt;
    // Each hand moves 0.5 m/s towards and past the other's line for 80 ms (40 mm), then holds.
    numen::test::set_clash_targets(m, d, t);
    core::step(m, d);
    ASSERT_EQ(d.status & core::kNonFinite, 0u) << s;
    const double gap = d.bodies[1].position.y() - d.bodies[0].position.y();
    closest = std::min(closest, gap);
    swapped = swapped || gap < 0.0;
  }
  std::printf("clash at 0.5 m/s: closest axes %.2f mm (5 mm at touch)\n", closest * 1e3);
  EXPECT_FALSE(swapped) << "the tubes passed through each other";
  // The axes stay apart by the spheres' 5 mm less the penalty's give under the two couplings'
  // pull (each hand 20 mm past the clash: 2 × 1000 N/m × 20 mm against 2e4 N/m contacts).
  EXPECT_GT(closest, 0.003) << "m between the tubes' axes";
  EXPECT_LT(closest, 0.005) << "m: they touched";
}
