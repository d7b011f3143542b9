// Tests of the scripted hand's servo in a scene file (`[trajectory.servo]`, each segment's
// `servo_target`; sim/device/hand_servo.hpp, docs/scenes.md "The hand's servo"): its spans and
// their targets, the suturing scene's two sighted drivers, and the located errors.

#include <gtest/gtest.h>

#include <string>

#include "build_features.hpp"
#include "numen/sim/scene/scene.hpp"
#include "scene_text.hpp"
#include "temp_dir.hpp"

namespace {

using numen::core::Vec3;
using numen::test::kMiniScene;
using numen::test::replace;

/// kMiniScene with a servo watching `body`, its first segment (the line, 0.5 s) aiming at
/// (10, 0, 0) mm and its second (the hold, 0.25 s) at (10, 0, 1) mm; `keys` added to the table.
std::string with_servo(const std::string& body = "tool", const std::string& keys = "") {
  std::string text =
      replace(kMiniScene, "duration = 0.5\n", "duration = 0.5\nservo_target = [0.01, 0.0, 0.0]\n");
  text = replace(text, "duration = 0.25\n", "duration = 0.25\nservo_target = [0.01, 0.0, 0.001]\n");
  return text + "\n[trajectory.servo]\nbody = \"" + body + "\"\n" + keys;
}

TEST(SceneServo, EachSegmentWithATargetIsASpanFromThePreviousTarget) {
  numen::test::TempDir dir;
  const numen::sim::Scene s = numen::sim::load_scene(
      dir.write("s.toml", with_servo("tool", "latency = 0.01\npoint = [0.0, 0.0, 0.002]\n")));
  ASSERT_TRUE(s.servo.has_value());
  EXPECT_EQ(s.servo->body_name, "tool");
  EXPECT_DOUBLE_EQ(s.servo->settings.latency_s, 0.01);
  EXPECT_DOUBLE_EQ(s.servo->settings.time_constant_s,
                   numen::sim::HandServoSettings{}.time_constant_s);
  EXPECT_DOUBLE_EQ(s.servo->settings.max_offset_m, numen::sim::HandServoSettings{}.max_offset_m);
  EXPECT_FALSE(s.servo->settings.predict);
  const numen::sim::Scene p = numen::sim::load_scene(dir.write("p.toml", with_servo("tool", "predict = true\n")));
  EXPECT_TRUE(p.servo->settings.predict);
  ASSERT_EQ(s.servo->spans.size(), 2u);
  for (const numen::sim::HandServoSpan& span : s.servo->spans) {
    EXPECT_EQ(span.body, 0) << "the table's body";
    EXPECT_EQ(span.point, Vec3(0.0, 0.0, 0.002)) << "the table's point";
  }
  EXPECT_DOUBLE_EQ(s.servo->spans[0].t0_s, 0.0);
  EXPECT_DOUBLE_EQ(s.servo->spans[0].t1_s, 0.5);
  EXPECT_EQ(s.servo->spans[0].target_start, Vec3(0.01, 0.0, 0.0))
      << "no target before: it starts at its own";
  EXPECT_EQ(s.servo->spans[0].target_end, Vec3(0.01, 0.0, 0.0));
  EXPECT_DOUBLE_EQ(s.servo->spans[1].t0_s, 0.5);
  EXPECT_DOUBLE_EQ(s.servo->spans[1].t1_s, 0.75);
  EXPECT_EQ(s.servo->spans[1].target_start, Vec3(0.01, 0.0, 0.0))
      << "from the previous segment's target";
  EXPECT_EQ(s.servo->spans[1].target_end, Vec3(0.01, 0.0, 0.001));
  const numen::sim::Scene blind = numen::sim::load_scene(dir.write("blind.toml", kMiniScene));
  EXPECT_FALSE(blind.servo.has_value()) << "no servo table: the hand follows its script blind";
}

// A segment may watch another body or point than the table's: its span is its own, not continued
// from the previous target.
TEST(SceneServo, ASegmentMayWatchItsOwnBodyAndPoint) {
  numen::test::TempDir dir;
  std::string text = with_servo("tool");
  text = replace(text, "servo_target = [0.01, 0.0, 0.001]\n",
                 "servo_target = [0.01, 0.0, 0.001]\nservo_body = \"floor_ball\"\nservo_point = "
                 "[0.0, 0.0, 0.001]\n");
  text +=
      "\n[[body]]\nname = \"floor_ball\"\nmass = 0.01\nmaterial = \"steel\"\nposition = [0.0, "
      "0.05, 0.0]\n"
      "spheres = [[0.0, 0.0, 0.0, 0.005]]\n";
  const numen::sim::Scene s = numen::sim::load_scene(dir.write("s.toml", text));
  ASSERT_TRUE(s.servo.has_value());
  ASSERT_EQ(s.servo->spans.size(), 2u);
  EXPECT_EQ(s.servo->spans[0].body, 0);
  EXPECT_EQ(s.servo->spans[1].body, 1);
  EXPECT_EQ(s.servo->spans[1].point, Vec3(0.0, 0.0, 0.001));
  EXPECT_EQ(s.servo->spans[1].target_start, Vec3(0.01, 0.0, 0.001))
      << "another point: from its own target";
  EXPECT_EQ(s.servo->body_name, "tool, floor_ball");
  const std::string unknown =
      replace(text, "servo_body = \"floor_ball\"", "servo_body = \"ghost\"");
  const numen::sim::InputError e = numen::test::load_error(dir, unknown);
  EXPECT_EQ(e.key(), "trajectory.segment[1].servo_body");
  const std::string alone =
      replace(kMiniScene, "duration = 0.5\n", "duration = 0.5\nservo_body = \"tool\"\n");
  EXPECT_EQ(numen::test::load_error(dir, alone).key(), "trajectory.segment[0].servo_body");
}

// The targets are points of the path's frame: a [trajectory.placement] places them as the path.
TEST(SceneServo, APlacementPlacesTheTargetsAsThePath) {
  numen::test::TempDir dir;
  const std::string text = replace(with_servo(), "[trajectory]\n",
                                   "[trajectory]\nplacement = { position = [0.0, 0.0, 0.05] }\n");
  const numen::sim::Scene s = numen::sim::load_scene(dir.write("s.toml", text));
  ASSERT_TRUE(s.servo.has_value());
  EXPECT_NEAR((s.servo->spans[1].target_end - Vec3(0.01, 0.0, 0.051)).norm(), 0.0, 1e-12);
}

TEST(SceneServo, BadKeysAreLocatedErrors) {
  numen::test::TempDir dir;
  const std::string file = (dir / "bad.toml").string();
  {  // a target without the table
    const std::string text =
        replace(kMiniScene, "duration = 0.5\n", "duration = 0.5\nservo_target = [0.0, 0.0, 0.0]\n");
    numen::test::expect_located(
        numen::test::load_error(dir, text), file, numen::test::line_of(text, "servo_target"), 16,
        "trajectory.segment[0].servo_target", "needs the trajectory's [trajectory.servo]");
  }
  {  // a body the scene has not
    const std::string text = with_servo("needle");
    numen::test::expect_located(numen::test::load_error(dir, text), file,
                                numen::test::line_of(text, "body = \"needle\""), 8,
                                "trajectory.servo.body", "no body named \"needle\"");
  }
  {  // a table whose segments never aim
    const std::string text = kMiniScene + "\n[trajectory.servo]\nbody = \"tool\"\n";
    numen::test::expect_located(numen::test::load_error(dir, text), file,
                                numen::test::line_of(text, "body = \"tool\""), 8,
                                "trajectory.servo.body", "no segment");
  }
  {  // gains out of range, a typo
    const std::string late = with_servo("tool", "latency = 2.0\n");
    numen::test::expect_located(numen::test::load_error(dir, late), file,
                                numen::test::line_of(late, "latency = 2.0"), 11,
                                "trajectory.servo.latency", "must be in [0, 1]");
    const std::string flat = with_servo("tool", "time_constant = 0.0\n");
    EXPECT_EQ(numen::test::load_error(dir, flat).key(), "trajectory.servo.time_constant");
    const std::string none = with_servo("tool", "max_offset = -0.001\n");
    EXPECT_EQ(numen::test::load_error(dir, none).key(), "trajectory.servo.max_offset");
    const std::string typo = with_servo("tool", "latncy = 0.01\n");
    EXPECT_NE(std::string(numen::test::load_error(dir, typo).what()).find("latncy"),
              std::string::npos);
  }
  {  // a servo that is not a table
    const std::string text =
        replace(kMiniScene, "source = \"scripted\"", "source = \"scripted\"\nservo = 1");
    EXPECT_EQ(numen::test::load_error(dir, text).key(), "trajectory.servo");
  }
}

// In a multirate run the servo watches the run's view of both loops, written every device period
// (docs/multirate-suturing.md, "A needle in the device loop": the suturing scene's drivers there).
TEST(SceneServo, AMultirateSceneKeepsItsServo) {
  numen::test::TempDir dir;
  const std::string text =
      replace(with_servo(), "gravity = [0.0, 0.0, 0.0]\n",
              "gravity = [0.0, 0.0, 0.0]\n\n[multirate]\nscene_dt = 0.01\nmargin = 0.01\n");
  const numen::sim::Scene s = numen::sim::load_scene(dir.write("mr.toml", text));
  ASSERT_TRUE(s.multirate.has_value());
  ASSERT_TRUE(s.servo.has_value());
  EXPECT_EQ(s.servo->body_name, "tool");
}

// The suturing scene's two drivers look at the needle they hold (its arc centre) and, coming to
// take it, at their own instrument.
TEST(SceneServo, TheSuturingScenesDriversWatchTheNeedlesArcCentre) {
  NUMEN_REQUIRE_ARTICULATION();
  NUMEN_REQUIRE_DEFORMABLE();
  numen::test::TempDir dir;
  const numen::sim::Scene s =
      numen::sim::load_scene(dir.write("s.toml", numen::test::shipped_scene_text("suturing.toml")));
  ASSERT_EQ(s.extra_devices.size(), 1u);
  ASSERT_TRUE(s.servo.has_value());
  ASSERT_TRUE(s.extra_devices[0].servo.has_value());
  ASSERT_EQ(s.model.needles.size(), 1u);
  for (const numen::sim::HandServoSpec* spec : {&*s.servo, &*s.extra_devices[0].servo}) {
    int on_needle = 0;
    for (const numen::sim::HandServoSpan& span : spec->spans)
      if (span.body == s.model.needles[0].body) {
        ++on_needle;
        EXPECT_NEAR((span.point - s.model.needles[0].centre).norm(), 0.0, 1e-6)
            << "the arc's centre";
      }
    EXPECT_GT(on_needle, 0) << "each holds the needle by sight somewhere";
  }
}

}  // namespace
