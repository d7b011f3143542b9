/// @file thread_test.cpp
/// The suture thread (core/include/numen/core/thread.hpp): settings refused by name, stretch
/// under end tension, a clamped cantilever against Euler–Bernoulli, the catenary, stability at
/// three time steps, the tie to a light body, instrument contact without pass-through, an
/// eyelet's friction, self contact (and a thread that never meets itself stepping as without
/// it), the break, a non-finite step rolled back and counted, a Newton iteration that ran out
/// flagged, the stage plan, zero allocation.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <numbers>

#include "alloc_counter.hpp"
#include "numen/core/data.hpp"
#include "numen/core/mesh.hpp"
#include "numen/core/mesh_shape.hpp"
#include "numen/core/model.hpp"
#include "numen/core/step.hpp"
#include "numen/core/step_stages.hpp"
#include "numen/core/thread.hpp"
#include "thread_scenes.hpp"

namespace numen {
namespace {

using core::Vec3;

double axial_stiffness(const core::ThreadModel& t) {  // E A (N)
  return t.young_modulus * std::numbers::pi * t.radius * t.radius;
}

TEST(Thread, RefusesBadSettingsByName) {
  struct Case {
    const char* key;
    std::function<void(core::ThreadModel&)> edit;
  };
  const Case cases[] = {
      {"length", [](core::ThreadModel& t) { t.length = 0.0; }},
      {"length", [](core::ThreadModel& t) { t.length = -0.1; }},
      {"segments", [](core::ThreadModel& t) { t.segments = 0; }},
      {"radius", [](core::ThreadModel& t) { t.radius = 0.0; }},
      {"young_modulus", [](core::ThreadModel& t) { t.young_modulus = -1.0; }},
      {"density", [](core::ThreadModel& t) { t.density = 0.0; }},
      {"damping", [](core::ThreadModel& t) { t.damping = -1e-3; }},
      {"break_strain", [](core::ThreadModel& t) { t.break_strain = 0.0; }},
      {"self_friction", [](core::ThreadModel& t) { t.self_friction = -0.1; }},
      {"tie_end.body", [](core::ThreadModel& t) { t.tie_end.body = 3; }},
  };
  for (const Case& c : cases) {
    core::Model m;
    m.material_pairs = {core::MaterialPair{}};
    m.initial_held_body = -1;
    core::ThreadModel t;
    t.name = "suture";
    c.edit(t);
    m.threads.push_back(t);
    const std::string err = core::finalize_model(m);
    EXPECT_NE(err.find(std::string("thread 0 (suture): ") + c.key), std::string::npos) << err;
    EXPECT_EQ(m.stage_plan, 0u);
  }
}

TEST(Thread, StagePlanOnlyWithThreads) {
  core::Model none;
  none.material_pairs = {core::MaterialPair{}};
  none.initial_held_body = -1;
  ASSERT_EQ(core::finalize_model(none), "");
  EXPECT_EQ(none.stage_plan & core::kStageThreads, 0u);
  const core::Model with = test::thread_model(core::ThreadModel{});
  EXPECT_NE(with.stage_plan & core::kStageThreads, 0u);
  core::Data d = core::make_data(with);
  core::step(with, d);
  EXPECT_EQ(d.stages_run, with.stage_plan);
}

// A 200-segment thread tied at one end, pulled at the other by 2 N: stretch F / (E A).
TEST(Thread, StretchUnderTwoNewtonsIsHookes) {
  core::ThreadModel t;
  t.segments = 200;
  const core::Model m = test::thread_model(t);
  core::Data d = core::make_data(m);
  d.threads[0].external_force.back() = Vec3(2.0, 0.0, 0.0);
  for (int i = 0; i < 200; ++i) core::step(m, d);
  const double expected = 2.0 / axial_stiffness(t);
  const double length = (d.threads[0].position.back() - d.threads[0].position.front()).norm();
  EXPECT_NEAR(length / t.length - 1.0, expected, 0.01 * expected);
  EXPECT_NEAR(d.threads[0].output.max_tension, 2.0, 0.02);
  EXPECT_LE(d.threads[0].output.max_stretch, 0.01);  // the figure
}

// A clamped 20 mm cantilever under its own weight: tip deflection q L⁴ / (8 E I).
TEST(Thread, CantileverDeflectionIsEulerBernoullis) {
  core::ThreadModel t;
  t.length = 0.02;
  t.segments = 40;
  const core::Model m = test::thread_model(t, [](core::Model& mm) {
    mm.gravity = Vec3(0.0, 0.0, -9.81);
    mm.threads[0].tie_start.clamped = true;
    mm.threads[0].tie_start.direction = Vec3::UnitX();
  });
  core::Data d = core::make_data(m);
  for (int i = 0; i < 3000; ++i) core::step(m, d);
  const double r = t.radius;
  const double q = t.density * std::numbers::pi * r * r * 9.81;
  const double ei = t.young_modulus * std::numbers::pi * std::pow(r, 4) / 4.0;
  const double expected = q * std::pow(t.length, 4) / (8.0 * ei);
  const double tip = -d.threads[0].position.back().z();
  EXPECT_NEAR(tip, expected, 0.05 * expected) << "tip " << tip << " m, expected " << expected;
}

// Both ends pinned 0.1 m apart, a 0.15 m thread made heavy (bending negligible): the catenary.
TEST(Thread, SagIsTheCatenarys) {
  core::ThreadModel t;
  t.density *= 1e3;  // the bending length (E I / q)^(1/3) from 0.13 m to 13 mm
  t.damping *= 1e3;  // the same terminal speed
  const double span = 0.1;
  const core::Model m = test::thread_model(t, [&](core::Model& mm) {
    mm.gravity = Vec3(0.0, 0.0, -9.81);
    mm.threads[0].tie_end.body = -1;
    mm.threads[0].tie_end.point = Vec3(span, 0.0, 0.0);
  });
  core::Data d = core::make_data(m);
  // Start as a V of the thread's length between the two points.
  const double drop = std::sqrt(std::pow(0.5 * t.length, 2) - std::pow(0.5 * span, 2));
  for (std::size_t i = 0; i < d.threads[0].position.size(); ++i) {
    const double f = static_cast<double>(i) / t.segments;
    d.threads[0].position[i] = Vec3(f * span, 0.0, -drop * (1.0 - std::abs(2.0 * f - 1.0)));
  }
  for (int i = 0; i < 3000; ++i) core::step(m, d);
  // L = 2 a sinh(D / 2a), sag = a (cosh(D / 2a) − 1), by bisection on a.
  double lo = 1e-4, hi = 10.0;
  for (int i = 0; i < 200; ++i) {
    const double a = 0.5 * (lo + hi);
    (2.0 * a * std::sinh(span / (2.0 * a)) > t.length ? lo : hi) = a;
  }
  const double expected = lo * (std::cosh(span / (2.0 * lo)) - 1.0);
  double sag = 0.0;
  for (const Vec3& x : d.threads[0].position) sag = std::max(sag, -x.z());
  EXPECT_NEAR(sag, expected, 0.02 * expected) << "sag " << sag << " m, catenary " << expected;
}

// A thread pinned at one end falls from horizontal and swings for 0.5 s: bounded at each step.
TEST(Thread, StableAtTenthOneAndTenMilliseconds) {
  for (const double dt : {1e-4, 1e-3, 1e-2}) {
    core::ThreadModel t;
    t.segments = 200;
    const core::Model m = test::thread_model(t, [&](core::Model& mm) {
      mm.dt = dt;
      mm.gravity = Vec3(0.0, 0.0, -9.81);
    });
    core::Data d = core::make_data(m);
    double worst = 0.0;
    for (int i = 0; i < static_cast<int>(0.5 / dt); ++i) {
      core::step(m, d);
      worst = std::max(worst, d.threads[0].output.max_stretch);
      ASSERT_EQ(d.status & core::kNonFinite, 0u) << "dt " << dt << " step " << i;
    }
    EXPECT_LT(worst, 0.01) << "dt " << dt;
    EXPECT_FALSE(d.threads[0].broken_segment >= 0);
    EXPECT_LT(d.threads[0].position.back().z(), -0.05) << "dt " << dt << ": it fell";
  }
}

// A 0.5 g needle (a free body) tied by a clamped end to a thread pulled taut to 1 % stretch:
// the tie's implicit coupling keeps it bounded (its elastic energy bounds its speed).
TEST(Thread, LightBodyTiedToTautThreadStaysBounded) {
  core::ThreadModel t;
  t.segments = 200;
  core::Model m = test::thread_model(t, [&](core::Model& mm) {
    const int needle = test::add_thread_test_body(mm, 5e-4, 8.5e-8, Vec3::Zero(), 0.0);
    core::ThreadModel& th = mm.threads[0];
    th.tie_start.body = needle;
    th.tie_start.point = Vec3::Zero();
    th.tie_start.clamped = true;
    th.tie_end.body = -1;
    th.tie_end.point = Vec3(1.01 * th.length, 0.0, 0.0);
  });
  core::Data d = core::make_data(m);
  const double k = axial_stiffness(t) / t.length;
  const double energy = 0.5 * k * std::pow(0.01 * t.length, 2);
  const double v_bound = std::sqrt(2.0 * energy / 5e-4);
  double v_max = 0.0;
  for (int i = 0; i < 1000; ++i) {
    core::step(m, d);
    ASSERT_EQ(d.status & core::kNonFinite, 0u) << "step " << i;
    v_max = std::max(v_max, d.bodies[0].linear_velocity.norm());
  }
  EXPECT_GT(v_max, 0.1 * v_bound);  // it was pulled
  EXPECT_LT(v_max, 1.05 * v_bound) << "v_max " << v_max << " bound " << v_bound;
}

/// A taut thread between two world points along x at z 0 and an instrument-size sphere (2.5 mm)
/// driven up through it at `speed` m/s (imposed, kDirect) for 10 mm.
struct SweptThread {
  core::Model model;
  core::Data data;
  explicit SweptThread(double speed) : speed(speed) {
    core::ThreadModel t;
    t.length = 0.1;
    t.segments = 200;
    model = test::thread_model(t, [&](core::Model& mm) {
      mm.coupling_mode = core::CouplingMode::kDirect;
      test::add_thread_test_body(mm, 0.05, 1e-5, Vec3(0.05, 0.0, -z0), radius);
      mm.initial_held_body = 0;
      mm.threads[0].tie_end.body = -1;
      mm.threads[0].tie_end.point = Vec3(1.002 * t.length, 0.0, 0.0);
    });
    data = core::make_data(model);
  }
  /// One step; false once the sphere's centre is past the thread (a node within the sphere's
  /// x-extent at or below the centre).
  bool step() {
    const double z = data.bodies[0].position.z() + speed * model.dt;
    data.target.position = Vec3(0.05, 0.0, z);
    data.target_twist.linear = Vec3(0.0, 0.0, speed);
    core::step(model, data);
    const Vec3 c = data.bodies[0].position;
    for (const Vec3& x : data.threads[0].position)
      if (std::abs(x.x() - c.x()) < radius && x.z() <= c.z()) return false;
    return true;
  }
  double speed;
  static constexpr double radius = 2.5e-3;
  static constexpr double z0 = 5e-3;
};

TEST(Thread, InstrumentAtHalfMetrePerSecondPushesThreadNeverCrosses) {
  SweptThread s(0.5);
  int steps = static_cast<int>((SweptThread::z0 + 10e-3) / (0.5 * s.model.dt));
  int touching = 0;
  for (int i = 0; i < steps; ++i) {
    ASSERT_TRUE(s.step()) << "the sphere crossed the thread at step " << i;
    touching += s.data.threads[0].output.body_contacts > 0;
    ASSERT_EQ(s.data.status & core::kNonFinite, 0u);
  }
  EXPECT_GT(touching, steps / 2);
  double top = -1.0;
  for (const Vec3& x : s.data.threads[0].position) top = std::max(top, x.z());
  EXPECT_GT(top, 9e-3);  // pushed up with the sphere
}

// A thread pulled through a fixed eyelet at 10 mm/s around a right angle, held back by 1 N at
// its free end: the eyelet's friction is μ |F_n| against the sliding, and it is the tension step.
TEST(Thread, EyeletFrictionIsCoulombs) {
  core::ThreadModel t;
  t.length = 0.1;
  t.segments = 100;
  const double mu = 0.3;
  core::Model m = test::thread_model(t, [&](core::Model& mm) {
    mm.coupling_mode = core::CouplingMode::kDirect;
    const int puller = test::add_thread_test_body(mm, 0.05, 1e-5, Vec3(0.05, 0.0, 0.05), 0.0);
    mm.initial_held_body = puller;
    core::ThreadModel& th = mm.threads[0];
    th.tie_start.body = -2;  // free, held back by a force
    th.start = Vec3(-0.05, 0.0, 0.0);
    th.tie_end.body = puller;
    th.tie_end.point = Vec3::Zero();
  });
  core::Data d = core::make_data(m);
  core::ThreadState& s = d.threads[0];
  // Bend it round the eyelet: along x to (−R, 0, 0), a quarter circle of radius R (5 mm) to
  // (0, 0, R), then up z; the eyelet at the circle's middle.
  const double R = 5e-3, arc = 0.5 * std::numbers::pi * R, leg = 0.045;
  const Vec3 centre(-R, 0.0, R);
  for (std::size_t i = 0; i < s.position.size(); ++i) {
    const double l = static_cast<double>(i) * m.threads[0].rest_segment;
    if (l < leg) {
      s.position[i] = Vec3(l - leg - R, 0.0, 0.0);
    } else if (l < leg + arc) {
      const double a = (l - leg) / R;  // angle turned
      s.position[i] = centre + R * Vec3(std::sin(a), 0.0, -std::cos(a));
    } else {
      s.position[i] = Vec3(0.0, 0.0, R + l - leg - arc);
    }
  }
  d.bodies[0].position = s.position.back();
  s.external_force.front() = Vec3(-1.0, 0.0, 0.0);
  s.eyelets[0].position = centre + R * Vec3(std::sqrt(0.5), 0.0, -std::sqrt(0.5));
  s.eyelets[0].active = true;
  s.eyelets[0].friction = mu;
  s.eyelets[0].stiffness = 1e4;
  const double speed = 0.01;
  for (int i = 0; i < 1000; ++i) {
    d.target.position = d.bodies[0].position + Vec3(0.0, 0.0, speed * m.dt);
    d.target_twist.linear = Vec3(0.0, 0.0, speed);
    core::step(m, d);
  }
  const core::ThreadEyeletOutput& e = s.output.eyelets[0];
  EXPECT_GT(e.normal_force, 1.0);
  EXPECT_NEAR(std::abs(e.friction_force), mu * e.normal_force, 0.01 * mu * e.normal_force);
  // The tensions either side of the eyelet differ by the friction.
  const auto tension = [&](int seg) {
    const auto a = static_cast<std::size_t>(seg);
    return axial_stiffness(t) * ((s.position[a + 1] - s.position[a]).norm() / m.threads[0].rest_segment - 1.0);
  };
  const double step = tension(e.segment + 3) - tension(e.segment - 3);
  EXPECT_NEAR(step, std::abs(e.friction_force), 0.1 * std::abs(e.friction_force))
      << "pull side " << tension(e.segment + 3) << " N, held side " << tension(e.segment - 3) << " N";
  EXPECT_NEAR(tension(e.segment - 3), 1.0, 0.05);
  EXPECT_LT(s.position.front().z(), 1e-3);  // still on the held side
  EXPECT_GT(s.position.front().x(), -leg - R + 0.005);  // it slid through (10 mm pulled)
}

/// The strands rig: one thread laid along four corners so that its strands cross 1 mm apart
/// (the upper along y at z = 1 mm, the lower along x at z = 0), both ends tied to the world,
/// the upper strand's nodes 25–35 pressed down by `push` (N) each; `edit` changes the thread
/// (its length, segments and start are the rig's) and the model.
struct CrossingStrands {
  core::Model model;
  core::Data data;
};
CrossingStrands crossing_strands(double push, const std::function<void(core::ThreadModel&, core::Model&)>& edit) {
  const Vec3 corners[] = {Vec3(0.0, -0.03, 1e-3), Vec3(0.0, 0.02, 1e-3), Vec3(0.02, 0.02, 0.0),
                          Vec3(0.02, 0.0, 0.0), Vec3(-0.03, 0.0, 0.0)};
  double total = 0.0;
  for (int c = 0; c < 4; ++c) total += (corners[c + 1] - corners[c]).norm();
  core::ThreadModel t;
  t.length = total;
  t.segments = 140;
  t.start = corners[0];
  CrossingStrands r;
  r.model = test::thread_model(t, [&](core::Model& mm) {  // both ends tied
    mm.threads[0].tie_end.body = -1;
    mm.threads[0].tie_end.point = corners[4];
    edit(mm.threads[0], mm);
  });
  r.data = core::make_data(r.model);
  core::ThreadState& s = r.data.threads[0];
  for (std::size_t i = 0; i < s.position.size(); ++i) {  // the nodes along the corners
    double l = static_cast<double>(i) * r.model.threads[0].rest_segment;
    int c = 0;
    for (; c < 3 && l > (corners[c + 1] - corners[c]).norm(); ++c) l -= (corners[c + 1] - corners[c]).norm();
    s.position[i] = corners[c] + l * (corners[c + 1] - corners[c]).normalized();
  }
  for (std::size_t i = 25; i < 36; ++i) s.external_force[i] = Vec3(0.0, 0.0, -push);
  return r;
}

// A soft thread (bending negligible) tied at both ends and laid over itself, one strand along y
// 1 mm above another along x, the upper strand pressed down by 10 µN a node through a viscous
// medium: the strands touch and never pass (docs/thread.md: a crossing faster than ~r a step
// is not yet held).
TEST(Thread, SelfContactKeepsStrandsApart) {
  CrossingStrands rig = crossing_strands(1e-5, [](core::ThreadModel& t, core::Model&) {
    t.young_modulus = 1e7;
    t.damping = 1.0;  // a viscous medium: the strands meet at ~10 mm/s (10 µm a step)
  });
  const core::Model& m = rig.model;
  core::Data& d = rig.data;
  const core::ThreadState& s = d.threads[0];
  int touching = 0;
  for (int i = 0; i < 300; ++i) {
    core::step(m, d);
    // Where the strands cross seen from above (the node pair closest in x, y): the upper strand
    // is above the lower.
    double closest = 1.0, dz = 0.0;
    std::size_t pa = 0, pb = 0;
    for (std::size_t a = 0; a < 50; ++a)
      for (std::size_t b = 95; b < s.position.size(); ++b)
        if (const double r = (s.position[a] - s.position[b]).head<2>().norm(); r < closest) {
          closest = r;
          dz = s.position[a].z() - s.position[b].z();
          pa = a; pb = b;
        }
    ASSERT_GT(dz, 0.0) << "step " << i << ": the upper strand went through the lower: nodes " << pa << " " << s.position[pa].transpose() << " and " << pb << " " << s.position[pb].transpose() << " self " << s.output.self_contacts;
    touching += s.output.self_contacts > 0;
    if (s.output.self_contacts > 0) {
      ASSERT_GE(s.output.iterations, 2) << "step " << i << ": its contacts need a second iterate";
    }
  }
  EXPECT_GT(touching, 100);
}

// A thread with self contact on that never comes near itself steps exactly as it does with self
// contact off: its pull at the end swings it sideways and settles, and where the first Newton
// iterate has converged and no pair of its segments is a candidate, that iterate is the step (one
// banded solve, not two).
TEST(Thread, SelfContactWithoutCandidatesStepsAsWithoutIt) {
  core::ThreadModel t;
  t.segments = 100;
  t.damping = 0.1;
  core::Model with = test::thread_model(t);
  t.self_contact = false;
  core::Model without = test::thread_model(t);
  ASSERT_TRUE(with.threads[0].self_contact);
  core::Data a = core::make_data(with);
  core::Data b = core::make_data(without);
  a.threads[0].external_force.back() = Vec3(0.05, 0.02, 0.0);
  b.threads[0].external_force.back() = a.threads[0].external_force.back();
  int one_solve = 0;
  for (int i = 0; i < 2000; ++i) {
    core::step(with, a);
    core::step(without, b);
    ASSERT_EQ(a.threads[0].output.self_contacts, 0) << "step " << i;
    ASSERT_EQ(a.threads[0].output.iterations, b.threads[0].output.iterations) << "step " << i;
    for (std::size_t k = 0; k < a.threads[0].position.size(); ++k)
      ASSERT_EQ(a.threads[0].position[k], b.threads[0].position[k]) << "step " << i << ", node " << k;
    one_solve += a.threads[0].output.iterations == 1;
  }
  EXPECT_GT(one_solve, 1000) << "steps whose first iterate converged";
  EXPECT_LT(one_solve, 2000) << "the swing's first steps take more than one";
}

// Pulled apart at 0.5 m/s past its break strain, the thread breaks once, says so, and stays finite.
TEST(Thread, BreaksPastItsLimitAndSaysSo) {
  core::ThreadModel t;
  t.length = 0.05;
  t.segments = 50;
  t.break_strain = 0.05;
  core::Model m = test::thread_model(t, [&](core::Model& mm) {
    mm.coupling_mode = core::CouplingMode::kDirect;
    mm.initial_held_body = test::add_thread_test_body(mm, 0.05, 1e-5, Vec3(0.05, 0.0, 0.0), 0.0);
    mm.threads[0].tie_end.body = 0;
  });
  core::Data d = core::make_data(m);
  int breaks = 0;
  for (int i = 0; i < 100; ++i) {
    d.target.position = d.bodies[0].position + Vec3(0.5 * m.dt, 0.0, 0.0);
    d.target_twist.linear = Vec3(0.5, 0.0, 0.0);
    core::step(m, d);
    breaks += d.threads[0].output.broke;
    ASSERT_EQ(d.status & core::kNonFinite, 0u);
  }
  EXPECT_EQ(breaks, 1);
  EXPECT_GE(d.threads[0].broken_segment, 0);
  EXPECT_LT(d.threads[0].output.max_stretch, 0.05);
}

// A thread that goes non-finite (a NaN force on a node) is rolled back to its last positions at
// rest by its own stage: the step says so (kNonFinite) and is counted with the rejected ones
// (Data::nonfinite_steps), though the bodies' check finds nothing to reject; the next step is clean.
TEST(Thread, ANonFiniteStepIsRolledBackAndCounted) {
  core::ThreadModel t;
  t.segments = 20;
  t.length = 0.02;
  core::Model m = test::thread_model(t);
  core::Data d = core::make_data(m);
  for (int i = 0; i < 5; ++i) core::step(m, d);
  const Vec3 before = d.threads[0].position.back();
  d.threads[0].external_force.back() = Vec3(std::nan(""), 0.0, 0.0);
  core::step(m, d);
  EXPECT_NE(d.status & core::kNonFinite, 0u);
  EXPECT_EQ(d.nonfinite_steps, 1);
  EXPECT_EQ(d.threads[0].position.back(), before) << "rolled back";
  d.threads[0].external_force.back().setZero();
  core::step(m, d);
  EXPECT_EQ(d.status & core::kNonFinite, 0u);
  EXPECT_EQ(d.nonfinite_steps, 1);
}

// Newton's iteration says whether it met its tolerance (ThreadOutput::converged): a thread
// falling under gravity meets it every step; two strands of a slack thread at its default drag
// pressed on each other (the rig of SelfContactKeepsStrandsApart without its viscous medium, the
// knot's self contact of 1e5 N/m) run out of iterations on some steps (docs/thread.md, "A
// knot": the drag alone regularises a light, slack thread's directions), and each step flagged
// took all six.
TEST(Thread, ANewtonIterationThatRunsOutIsFlagged) {
  {
    core::ThreadModel t;
    t.segments = 50;
    t.length = 0.05;
    const core::Model m = test::thread_model(t, [](core::Model& mm) { mm.gravity = Vec3(0.0, 0.0, -9.81); });
    core::Data d = core::make_data(m);
    for (int i = 0; i < 300; ++i) {
      core::step(m, d);
      ASSERT_TRUE(d.threads[0].output.converged) << "step " << i;
      ASSERT_LE(d.threads[0].output.iterations, 4) << "step " << i;
    }
  }
  CrossingStrands rig =
      crossing_strands(1e-4, [](core::ThreadModel&, core::Model& mm) { mm.material_pairs[0].stiffness = 1e5; });
  int ran_out = 0;
  for (int i = 0; i < 300; ++i) {
    core::step(rig.model, rig.data);
    const core::ThreadState& s = rig.data.threads[0];
    ASSERT_EQ(rig.data.status & core::kNonFinite, 0u) << "step " << i;
    if (s.output.converged) continue;
    ++ran_out;
    EXPECT_EQ(s.output.iterations, 6) << "step " << i;
  }
  std::printf("[thread] strands pressed at the default drag: %d of 300 steps ran out of Newton iterations\n",
              ran_out);
  EXPECT_GT(ran_out, 0);
}

// A thread dropped on a mesh obstacle and on a sphere set lies on them, not through them
// (thread.hpp "Couplings": its nodes against every obstacle shape): the 3-0 thread, 20 segments,
// free, 2 mm over a 20 mm box given as a mesh, and over a bed of 2 mm spheres 2 mm apart whose
// tops are at z = 0; gravity; 1 s.
TEST(Thread, LiesOnAMeshAndOnASphereSetNotThroughThem) {
  const auto dropped = [](bool mesh) {
    core::ThreadModel t;
    t.segments = 20;
    t.length = 0.02;
    t.start = Vec3(-0.01, 0.0, 0.002);
    t.direction = Vec3::UnitX();
    core::Model m = test::thread_model(t, [&](core::Model& mm) {
      mm.gravity = Vec3(0.0, 0.0, -9.81);
      mm.threads[0].tie_start.body = -2;  // free
      core::Obstacle o;
      o.name = mesh ? "block" : "bed";
      if (mesh) {
        core::MeshShape shape;
        EXPECT_EQ(core::build_mesh_shape(core::make_box(Vec3(0.01, 0.01, 0.01), 2), shape), "");
        mm.meshes.push_back(std::move(shape));
        o.type = core::ShapeType::kMesh;
        o.mesh = 0;
        o.pose.position = Vec3(0.0, 0.0, -0.01);
      } else {
        o.type = core::ShapeType::kSphereSet;
        o.sphere_begin = 0;
        for (int i = -7; i <= 7; ++i)
          for (int j = -2; j <= 2; ++j) mm.static_spheres.push_back({Vec3(0.002 * i, 0.002 * j, -0.002), 0.002});
        o.sphere_count = static_cast<int>(mm.static_spheres.size());
      }
      mm.obstacles.push_back(o);
    });
    core::Data d = core::make_data(m);
    int contacts = 0;
    std::uint64_t allocations = 0;
    for (int i = 0; i < 1000; ++i) {
      test::AllocationGuard guard;
      core::step(m, d);
      allocations += guard.count();
      EXPECT_EQ(d.status & core::kNonFinite, 0u) << "step " << i;
      contacts = d.threads[0].output.obstacle_contacts;
    }
    EXPECT_EQ(allocations, 0u) << (mesh ? "mesh" : "sphere set");
    // How deep any node's sphere is in the obstacle.
    double deepest = 0.0;
    const double r = m.threads[0].radius;
    for (const Vec3& x : d.threads[0].position) {
      if (mesh) deepest = std::max(deepest, r - x.z());  // the box's top at z = 0
      else
        for (const core::Sphere& sp : m.static_spheres) deepest = std::max(deepest, r + sp.radius - (x - sp.center).norm());
    }
    double lowest = 1e9;
    for (const Vec3& x : d.threads[0].position) lowest = std::min(lowest, x.z());
    std::printf("on the %s: %d contacts, lowest node %.4f mm, deepest %.4f mm\n", mesh ? "mesh" : "sphere set",
                contacts, 1e3 * lowest, 1e3 * deepest);
    EXPECT_GE(contacts, 15) << (mesh ? "mesh" : "sphere set");
    EXPECT_LT(deepest, 0.2 * r) << (mesh ? "mesh" : "sphere set");
    EXPECT_GT(lowest, -0.001) << "not fallen through";
  };
  dropped(true);
  dropped(false);
}

// Stepping a thread with a tie to a body, contacts with a sphere and an obstacle, an eyelet
// and self contact with friction allocates nothing.
TEST(Thread, StepsWithoutAllocating) {
  core::ThreadModel t;
  t.segments = 200;
  t.self_friction = 0.3;
  core::Model m = test::thread_model(t, [&](core::Model& mm) {
    mm.gravity = Vec3(0.0, 0.0, -9.81);
    const int b = test::add_thread_test_body(mm, 0.05, 1e-5, Vec3(0.05, 0.0, -0.0026), 2.5e-3);
    mm.bodies[static_cast<std::size_t>(b)].anchored = true;
    core::Obstacle floor;
    floor.type = core::ShapeType::kPlane;
    floor.pose.position = Vec3(0.0, 0.0, -0.01);
    mm.obstacles.push_back(floor);
  });
  core::Data d = core::make_data(m);
  d.threads[0].eyelets[0].active = true;
  d.threads[0].eyelets[0].position = Vec3(0.1, 0.0, 0.0);
  d.threads[0].eyelets[0].friction = 0.2;
  for (int i = 0; i < 100; ++i) core::step(m, d);  // warm up: contacts found
  int contacts = 0;
  test::AllocationGuard guard;
  for (int i = 0; i < 400; ++i) {
    core::step(m, d);
    contacts += d.threads[0].output.obstacle_contacts + d.threads[0].output.body_contacts;
  }
  EXPECT_EQ(guard.count(), 0);
  EXPECT_GT(contacts, 0);
}

}  // namespace
}  // namespace numen
