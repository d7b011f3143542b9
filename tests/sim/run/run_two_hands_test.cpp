// Two hands through the run harness (issue 54; docs/grasping.md "Peg transfer" and "Two
// instruments in one model"): two devices, each a trocar grasper on its own scripted path, hand
// an object over in mid-air (the shipped peg transfer's first object), and their instruments,
// driven at each other at 0.5 m/s, stop on each other instead of passing through
// (tests/data/tube_clash.toml, written by sim/data/make_peg_transfer.py clash).

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>

#include "build_features.hpp"
#include "numen/core/grasp.hpp"
#include "numen/core/model.hpp"
#include "numen/sim/run/run.hpp"
#include "numen/sim/run/run_summary.hpp"
#include "numen/sim/scene/scene.hpp"
#include "scene_text.hpp"
#include "temp_dir.hpp"

namespace {

int body_named(const numen::core::Model& m, const std::string& name) {
  for (int i = 0; i < m.num_bodies(); ++i)
    if (m.bodies[static_cast<std::size_t>(i)].name == name) return i;
  ADD_FAILURE() << "no body " << name;
  return -1;
}

/// Deepest overlap (m, > 0 overlapping) of a sphere of bodies [a0, a1) with one of [b0, b1).
double deepest_overlap(const numen::core::Model& m, const numen::core::Data& d, int a0, int a1, int b0, int b1) {
  double deepest = -1.0;
  for (int a = a0; a < a1; ++a)
    for (int b = b0; b < b1; ++b) {
      const numen::core::BodyModel& ma = m.bodies[static_cast<std::size_t>(a)];
      const numen::core::BodyModel& mb = m.bodies[static_cast<std::size_t>(b)];
      const numen::core::BodyState& sa = d.bodies[static_cast<std::size_t>(a)];
      const numen::core::BodyState& sb = d.bodies[static_cast<std::size_t>(b)];
      for (int i = 0; i < ma.sphere_count; ++i)
        for (int k = 0; k < mb.sphere_count; ++k) {
          const numen::core::Sphere& p = m.body_spheres[static_cast<std::size_t>(ma.sphere_begin + i)];
          const numen::core::Sphere& q = m.body_spheres[static_cast<std::size_t>(mb.sphere_begin + k)];
          const double gap = (sa.position + sa.orientation * p.center - sb.position - sb.orientation * q.center).norm();
          deepest = std::max(deepest, p.radius + q.radius - gap);
        }
    }
  return deepest;
}

}  // namespace

TEST(RunTwoHands, TwoDevicesHandAnObjectOverInMidAir) {
  NUMEN_REQUIRE_ARTICULATION();
  // The peg transfer's first object: lifted by "left" off its peg, grasped by "right" while left
  // holds it, let go by left, carried and placed by right. From its first grasp to its
  // placement some grasper holds it in every period; both hold it, in mid-air (its underside
  // above the pegs' tops), for a while.
  numen::test::TempDir dir;
  const numen::sim::Scene scene =
      numen::sim::load_scene(dir.write("peg.toml", numen::test::shipped_scene_text("peg_transfer.toml")));
  ASSERT_EQ(numen::sim::num_devices(scene), 2u);
  const int object = body_named(scene.model, "object_1");
  numen::sim::SceneRunner runner(scene);
  const numen::core::Data& d = runner.data();
  int first_grasp = -1, both = 0, placed = -1;
  double lowest_shared = 1.0;
  for (int k = 0; k < 6500 && placed < 0; ++k) {
    runner.period();
    const bool left = d.grasps[0].body == object, right = d.grasps[1].body == object;
    if (first_grasp < 0 && left) first_grasp = k;
    if (d.grasps[1].event == numen::core::GraspEvent::kRelease && !left) {
      placed = k;
      break;
    }
    if (first_grasp >= 0) {
      ASSERT_TRUE(left || right) << "object_1 dropped at period " << k;
    }
    if (left && right) {
      ++both;
      lowest_shared = std::min(lowest_shared, d.bodies[static_cast<std::size_t>(object)].position.z());
    }
  }
  runner.finish();
  std::printf("[   info   ] grasped at %d, held by both for %d periods (lowest %.1f mm), placed at %d\n", first_grasp,
              both, lowest_shared * 1e3, placed);
  ASSERT_GE(first_grasp, 0) << "left never grasped object_1";
  ASSERT_GT(placed, first_grasp) << "right never let it go";
  EXPECT_GT(both, 200) << "periods held by both hands";
  // Mid-air: the object's centre 2 mm above its underside, the pegs' tops at 22 mm.
  EXPECT_GT(lowest_shared - 0.002, 0.022) << "m: handed over above the pegs";
  // Placed round the mirrored peg (+85 mm... its left peg's mirror), resting on the board.
  const numen::core::Vec3 at = d.bodies[static_cast<std::size_t>(object)].position;
  const numen::core::Vec3 start = scene.model.bodies[static_cast<std::size_t>(object)].initial_pose.position;
  EXPECT_NEAR(at.x(), -start.x(), 0.004);
  EXPECT_NEAR(at.y(), start.y(), 0.004);
  const numen::sim::RunSummary s = runner.summary();
  EXPECT_EQ(s.rejected_samples, 0);
  for (const numen::sim::DeviceRunSummary& dev : s.devices) EXPECT_EQ(dev.rejected_samples, 0) << dev.name;
}

TEST(RunTwoHands, TheirInstrumentsClashAtHalfAMetreASecondWithoutPassingThroughEachOther) {
  NUMEN_REQUIRE_ARTICULATION();
  // The two instruments' tips 60 mm apart, driven at each other at 0.5 m/s each: their hands'
  // targets pass each other by 60 mm. The god-objects meet (penalty contacts between the two
  // articulations), stop on each other and never swap sides; their spheres overlap by 1.5 mm at
  // the most (both couplings pulling 30 mm past the other against 2e4 N/m contacts), less than
  // the smallest sphere's radius plus the other's: no sphere passes through another. The
  // summary's deepest contact of any body reports it.
  numen::test::TempDir dir;
  const std::string text = numen::test::with_absolute_dcf_paths(
      [] {
        std::ifstream in(std::string(NUMEN_SOURCE_DIR) + "/tests/data/tube_clash.toml");
        std::ostringstream os;
        os << in.rdbuf();
        return os.str();
      }(),
      std::string(NUMEN_SOURCE_DIR) + "/sim/scenes");
  const numen::sim::Scene scene = numen::sim::load_scene(dir.write("clash.toml", text));
  const numen::core::Model& m = scene.model;
  const int tube_l = body_named(m, "tube_l"), tube_r = body_named(m, "tube_r");
  numen::sim::SceneRunner runner(scene);
  const numen::core::Data& d = runner.data();
  double deepest = -1.0, closest_tips = 1.0;
  bool swapped = false;
  const double dt = m.dt;
  const int periods = static_cast<int>(scene.duration_s / dt);
  for (int k = 0; k < periods; ++k) {
    runner.period();
    // The tips: 40 mm ahead of each tube's centre of mass along its axis.
    const numen::core::Vec3 tip_l = d.bodies[static_cast<std::size_t>(tube_l)].position +
                                    d.bodies[static_cast<std::size_t>(tube_l)].orientation * numen::core::Vec3(0, 0, 0.04);
    const numen::core::Vec3 tip_r = d.bodies[static_cast<std::size_t>(tube_r)].position +
                                    d.bodies[static_cast<std::size_t>(tube_r)].orientation * numen::core::Vec3(0, 0, 0.04);
    swapped = swapped || tip_r.x() <= tip_l.x();
    closest_tips = std::min(closest_tips, tip_r.x() - tip_l.x());
    // Instrument "left" is bodies sleeve_l .. jaw_2_l, "right" sleeve_r .. jaw_2_r.
    deepest = std::max(deepest, deepest_overlap(m, d, tube_l - 1, tube_l + 3, tube_r - 1, tube_r + 3));
  }
  runner.finish();
  const numen::sim::RunSummary s = runner.summary();
  std::printf("[   info   ] clash at 0.5 m/s: tips %.2f mm apart at the closest, deepest overlap %.3f mm "
              "(summary: any body %.3f mm)\n",
              closest_tips * 1e3, deepest * 1e3, s.any_penetration_max_mm);
  EXPECT_FALSE(swapped) << "the instruments passed through each other";
  EXPECT_GT(deepest, 0.0) << "they met";
  EXPECT_LT(deepest, 0.002) << "m of overlap (jaw spheres 1.5 mm, tube spheres 2.5 mm)";
  EXPECT_NEAR(s.any_penetration_max_mm, deepest * 1e3, 0.05);
  EXPECT_EQ(s.exit_status, 0) << numen::sim::format_summary(s);
}
