// Tests of the multirate god-object with several devices (issue 54; docs/multirate.md, "Several
// devices"): a composite god-object holds every device's articulation, so that one device step
// advances both instruments; their mutual contacts are the device step's (no pass-through at
// 0.5 m/s each with the scene loop at 100 Hz); each device gets its own Eq. 8 feedback; the
// first device holds a body throughout, and its tool switch keeps the other instrument; the
// device period never allocates with two devices.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "alloc_counter.hpp"
#include "clash_tubes.hpp"
#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/multirate.hpp"
#include "numen/core/step.hpp"

namespace {

namespace core = numen::core;

/// Two instruments' tubes (numen::test::add_clash_tubes()): the left one (body 0, the held body)
/// along x at y = −20 mm, the right one (body 1, driven by a second device through its body
/// target, feedback group 1) upright at y = +20 mm;
/// a free 20 g ball (body 2) 60 mm off, and a floor plane 60 mm below. No gravity; step `dt`.
/// Device 0's Eq. 8 saturates at 3 N, device 1's at 2 N.
core::Model two_tubes(double dt) {
  core::Model m;
  m.dt = dt;
  m.gravity = core::Vec3::Zero();
  m.material_names = {"steel"};
  m.material_pairs = {core::MaterialPair{2e4, 10.0, 0.5}};
  numen::test::add_clash_tubes(m);  // bodies 0 and 1
  core::BodyModel ball;
  ball.name = "ball";
  ball.mass = 0.02;
  ball.inertia_body = 2e-6 * core::Mat3::Identity();
  ball.sphere_begin = static_cast<int>(m.body_spheres.size());
  ball.sphere_count = 1;
  m.body_spheres.push_back(core::Sphere{core::Vec3::Zero(), 0.005});
  ball.initial_pose.position = core::Vec3(0.06, 0.0, 0.0);
  m.bodies.push_back(ball);
  core::Obstacle floor;
  floor.name = "floor";
  floor.type = core::ShapeType::kPlane;
  floor.pose.position = core::Vec3(0, 0, -0.06);
  m.obstacles = {floor};
  m.feedback = core::FeedbackGains{300.0, 1.0, 0.5, 0.005, 3.0, 0.3};
  m.extra_feedback = {core::FeedbackGains{300.0, 1.0, 0.5, 0.005, 2.0, 0.3}};
  m.initial_held_body = 0;
  EXPECT_EQ(core::finalize_model(m), "");
  return m;
}

/// Each hand's target at time t (s) (numen::test::set_clash_targets()), device 1's feedback group.
void drive_tubes(const core::Model& m, core::Data& d, double t) {
  numen::test::set_clash_targets(m, d, t);
  d.feedback_group[1] = 1;
}

/// The multirate god-object of two_tubes() with the second device's tube (body 1) in it.
std::unique_ptr<core::MultirateGodObject> two_device_god_object(const core::Model& m, int ratio) {
  core::MultirateSettings settings;
  settings.ratio = ratio;
  settings.margin = 0.005;
  settings.other_devices = {1};
  return std::make_unique<core::MultirateGodObject>(m, 0, settings);
}

}  // namespace

TEST(MultirateDevices, TheGodObjectHoldsEveryDevicesArticulation) {
  const core::Model m = two_tubes(1e-4);
  const std::vector<int> others{1};
  EXPECT_EQ(core::god_object_bodies(m, 0, others), (std::vector<int>{0, 1}));
  EXPECT_EQ(core::god_object_bodies(m, 0), (std::vector<int>{0}));
  core::Model g;
  ASSERT_EQ(core::make_god_object_model(m, 0, 1e-4, g, others), "");
  ASSERT_EQ(g.num_bodies(), 2);
  EXPECT_EQ(g.initial_held_body, 0);
  EXPECT_EQ(g.extra_feedback.size(), 1u) << "each device's Eq. 8 gains";
  core::Model bad;
  const std::vector<int> out_of_range{3};
  EXPECT_NE(core::make_god_object_model(m, 0, 1e-4, bad, out_of_range).find("another device's body 3"),
            std::string::npos);
  // The proximity model grows both instruments' spheres, not the ball's.
  core::Model p;
  ASSERT_EQ(core::make_proximity_model(m, 0, 0.005, p, others), "");
  EXPECT_NEAR(p.body_spheres[0].radius, 0.0075, 1e-15);
  EXPECT_NEAR(p.body_spheres[17].radius, 0.0075, 1e-15);
  EXPECT_NEAR(p.body_spheres[34].radius, 0.005, 1e-15);
}

TEST(MultirateDevices, TheFirstDeviceHoldsABodyThroughout) {
  // The other device's instrument rides in the held body's god-object: nothing held would leave
  // it to the scene loop without its target.
  const core::Model m = two_tubes(1e-4);
  core::MultirateSettings settings;
  settings.ratio = 10;
  settings.other_devices = {1};
  try {
    (void)std::make_unique<core::MultirateGodObject>(m, -1, settings);
    ADD_FAILURE() << "a composite god-object with no body held accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("must hold a body"), std::string::npos) << e.what();
  }
  auto mr = two_device_god_object(m, 10);
  EXPECT_FALSE(mr->select(-1));
  EXPECT_EQ(mr->body(), 0);
  EXPECT_EQ(mr->god_object().size(), 2u);
}

TEST(MultirateDevices, TubesClashAtHalfAMetreASecondInTheDeviceLoopWithoutPassingThrough) {
  // The tubes of tests/core/two_instruments_test.cpp's clash, at a 10 kHz device loop with the
  // scene loop at 100 Hz: between two samples the tubes close by 10 mm, twice the 5 mm gap at
  // touch, so planes one scene period old would let them through; in the device step they meet
  // as in the single-rate step at 10 kHz.
  const core::Model m = two_tubes(1e-4);
  core::Data single = core::make_data(m);
  auto mr = two_device_god_object(m, 100);
  core::Data& d = mr->device_data();
  double closest = 1.0, closest_single = 1.0;
  bool swapped = false;
  int device_clash_periods = 0;
  for (int s = 0; s < 2000; ++s) {
    const double t = s * m.dt;
    drive_tubes(m, single, t);
    core::step(m, single);
    drive_tubes(mr->device_model(), d, t);
    mr->step();
    ASSERT_EQ(d.status & core::kNonFinite, 0u) << s;
    int clashes = 0;
    for (int i = 0; i < d.num_contacts; ++i) clashes += d.contacts[static_cast<std::size_t>(i)].body_b >= 0 ? 1 : 0;
    device_clash_periods += clashes > 0 ? 1 : 0;
    const double gap = d.bodies[1].position.y() - d.bodies[0].position.y();
    closest = std::min(closest, gap);
    closest_single = std::min(closest_single, single.bodies[1].position.y() - single.bodies[0].position.y());
    swapped = swapped || gap < 0.0;
  }
  std::printf("clash at 0.5 m/s, 10 kHz: closest axes %.3f mm multirate (scene 100 Hz), %.3f mm single-rate\n",
              closest * 1e3, closest_single * 1e3);
  EXPECT_FALSE(swapped) << "the tubes passed through each other";
  EXPECT_GT(device_clash_periods, 1000) << "periods the device step found the tubes in contact";
  EXPECT_GT(closest, 0.003) << "m between the tubes' axes";
  EXPECT_LT(closest, 0.005) << "m: they touched";
  EXPECT_NEAR(closest, closest_single, 1e-5) << "m: the device step meets them as the single-rate step";
  // The scene loop imposes both tubes where the device loop left them (kDirect).
  const core::Data& scene = mr->scene_data();
  EXPECT_NEAR(scene.bodies[1].position.y() - scene.bodies[0].position.y(), closest, 0.002);
}

TEST(MultirateDevices, EachDeviceGetsItsOwnFeedback) {
  // At rest after the clash, each hand 20 mm past the other's tube: the couplings pull 20 N
  // against the contact, so each device's Eq. 8 wrench saturates at its own limit (3 N, 2 N) and
  // points back from its tube's target to its tube.
  // The targets and feedback groups come from the run's Data (take_targets()), as a control
  // loop of two devices sets them.
  const core::Model m = two_tubes(1e-4);
  auto mr = two_device_god_object(m, 10);
  core::Data run = core::make_data(m);
  for (int s = 0; s < 2000; ++s) {
    drive_tubes(m, run, s * m.dt);
    mr->take_targets(run);
    mr->step();
  }
  core::Data out = core::make_data(m);
  mr->write_feedback(out);
  EXPECT_NEAR(out.body_feedback[0].force.norm(), 3.0, 1e-9) << "N: device 0's saturation";
  EXPECT_NEAR(out.body_feedback[1].force.norm(), 2.0, 1e-9) << "N: device 1's saturation";
  EXPECT_LT(out.body_feedback[0].force.y(), 0.0) << "device 0 is pushed back along −y";
  EXPECT_GT(out.body_feedback[1].force.y(), 0.0) << "device 1 along +y";
  EXPECT_NEAR(out.feedback_wrench.force.norm(), 3.0, 1e-9) << "N: the held body's device's composite";
}

TEST(MultirateDevices, TwoDevicePeriodsNeverAllocate) {
  const core::Model m = two_tubes(1e-4);
  auto mr = two_device_god_object(m, 10);
  core::Data& d = mr->device_data();
  numen::test::AllocationGuard guard;
  int clashes = 0;
  for (int s = 0; s < 2000; ++s) {
    drive_tubes(mr->device_model(), d, s * m.dt);
    mr->step();
    clashes += d.num_contacts;
  }
  EXPECT_EQ(guard.count(), 0) << "heap allocations in 2 000 device periods, 200 scene periods";
  EXPECT_GT(clashes, 0);
}

TEST(MultirateDevices, AToolSwitchOfTheFirstDeviceKeepsTheOtherInstrument) {
  // Device 0 switches from its tube (body 0) to the ball (body 2, a tool): the new god-object is
  // the ball with device 1's tube, which keeps following its own target through the switch; the
  // released tube continues in the scene loop.
  const core::Model m = two_tubes(1e-4);
  core::MultirateSettings settings;
  settings.ratio = 10;
  settings.margin = 0.005;
  settings.tools = {2};
  settings.other_devices = {1};
  core::MultirateGodObject mr(m, 0, settings);
  core::Data run = core::make_data(m);
  // Every hand holds its body where it starts.
  const auto hold = [&](int body) {
    return core::Pose{m.bodies[static_cast<std::size_t>(body)].initial_pose.position,
                      m.bodies[static_cast<std::size_t>(body)].initial_pose.orientation};
  };
  run.held_body = 0;
  run.target = hold(0);
  run.body_targets[1] = core::BodyTarget{hold(1), core::Twist{}, true};
  double worst = 0.0;
  numen::test::AllocationGuard guard;
  for (int s = 0; s < 1000; ++s) {
    if (s == 500) {
      ASSERT_TRUE(mr.select(2));
      run.held_body = 2;
      run.target = hold(2);
    }
    mr.take_targets(run);
    mr.step();
    if (s >= 500) {
      ASSERT_EQ(mr.god_object().size(), 2u);
      EXPECT_EQ(mr.god_object()[0], 1);
      EXPECT_EQ(mr.god_object()[1], 2);
      worst = std::max(worst, (mr.device_data().bodies[0].position - hold(1).position).norm());
    }
  }
  EXPECT_EQ(guard.count(), 0) << "heap allocations across the switch";
  EXPECT_EQ(mr.counters().switches, 1);
  EXPECT_LT(worst, 1e-4) << "m: device 1's tube left its target at the switch";
}
