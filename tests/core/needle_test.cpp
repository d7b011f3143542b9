// Tests of core/needle (needle.hpp; docs/suturing.md, "The needle"): the 26 mm half-circle's arc,
// tip, tail and tangent, the closest arc parameter, its spheres along the wire, its mass and
// inertia, the widest wire a grasper closes on, and bad needles refused by name.

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "grasper_rig.hpp"
#include "numen/core/model.hpp"
#include "numen/core/needle.hpp"

namespace {

namespace core = numen::core;

/// A model holding only the default needle (26 mm half circle, 0.35 mm wire, steel), no gravity.
core::Model needle_model(const core::NeedleSpec& spec = core::NeedleSpec{}) {
  core::Model m;
  m.gravity = core::Vec3::Zero();
  m.material_names = {"steel"};
  m.material_pairs = {core::MaterialPair{}};
  m.initial_held_body = -1;
  core::add_needle(m, spec);
  return m;
}

}  // namespace

TEST(Needle, TheTwentySixMillimetreHalfCircleHasItsArcTipTailAndTangent) {
  core::Model m = needle_model();
  ASSERT_EQ(core::finalize_model(m), "");
  ASSERT_EQ(m.num_needles(), 1);
  const core::NeedleModel& n = m.needles[0];
  EXPECT_NEAR(n.length(), 0.026, 1e-12) << "m along the wire, swage to point";
  EXPECT_NEAR(n.radius, 0.026 / M_PI, 1e-12);
  // A half circle: tip and tail a diameter apart, both on the circle, the tangents opposite.
  EXPECT_NEAR((core::needle_tip(n) - core::needle_tail(n)).norm(), 2 * n.radius, 1e-12) << "the chord";
  EXPECT_NEAR((core::needle_tip(n) - n.centre).norm(), n.radius, 1e-12);
  EXPECT_NEAR(core::needle_tangent(n, 0.0).dot(core::needle_tangent(n, n.length())), -1.0, 1e-12);
  // The centroid of the arc is the body frame's origin: the mean of points spaced evenly along it.
  core::Vec3 mean = core::Vec3::Zero();
  const int k = 20000;
  for (int i = 0; i < k; ++i) mean += core::needle_point(n, n.length() * (i + 0.5) / k);
  EXPECT_LT((mean / k).norm(), 1e-9) << "m: the arc's centroid off the body's origin";
  // The tangent: unit, along the derivative of the point, towards the tip.
  for (double s : {0.0, 0.003, 0.013, 0.025}) {
    const core::Vec3 t = core::needle_tangent(n, s);
    const double h = 1e-7;
    const core::Vec3 d = (core::needle_point(n, s + h) - core::needle_point(n, s)) / h;
    EXPECT_NEAR(t.norm(), 1.0, 1e-12);
    EXPECT_LT((d - t).norm(), 1e-5) << s;
    EXPECT_NEAR(t.z(), 0.0, 1e-15) << "in the body's x–y plane";
  }
  // Clamped outside [0, L].
  EXPECT_LT((core::needle_point(n, -1.0) - core::needle_tail(n)).norm(), 1e-15);
  EXPECT_LT((core::needle_point(n, 1.0) - core::needle_tip(n)).norm(), 1e-15);
}

TEST(Needle, TheClosestArcParameterOfAPointOffTheWire) {
  core::NeedleSpec spec;
  spec.arc = 3.0 / 8.0;
  core::Model m = needle_model(spec);
  ASSERT_EQ(core::finalize_model(m), "");
  const core::NeedleModel& n = m.needles[0];
  // A point moved off the arc along its normal (in plane and out of it) comes back to its s.
  for (double s : {0.0, 0.001, 0.009, 0.0195, n.length()}) {
    const core::Vec3 p = core::needle_point(n, s);
    const core::Vec3 radial = (p - n.centre).normalized();
    for (const core::Vec3& off : {core::Vec3(0.002 * radial), core::Vec3(-0.003 * radial),
                                  core::Vec3(0, 0, 0.004), core::Vec3(0.001 * radial + core::Vec3(0, 0, -0.002))})
      EXPECT_NEAR(core::needle_closest_parameter(n, p + off), s, 1e-12) << s;
  }
  // In the gap, the nearer end: just past the tip, the tip; just before the tail, the tail.
  const double R = n.radius;
  auto at_angle = [&](double theta) { return core::Vec3(n.centre + R * core::Vec3(std::cos(theta), std::sin(theta), 0)); };
  EXPECT_EQ(core::needle_closest_parameter(n, at_angle(n.tip_angle + 0.1)), n.length());
  EXPECT_EQ(core::needle_closest_parameter(n, at_angle(n.tail_angle - 0.1)), 0.0);
  EXPECT_EQ(core::needle_closest_parameter(n, at_angle(M_PI - 0.01)), n.length()) << "nearer the tip";
  EXPECT_EQ(core::needle_closest_parameter(n, at_angle(-M_PI + 0.01)), 0.0) << "nearer the tail";
  // And by brute force: the closest of 10 000 arc points, for points around the needle.
  for (int i = 0; i < 50; ++i) {
    const core::Vec3 p(0.01 * std::sin(1.7 * i), 0.012 * std::cos(2.3 * i), 0.003 * std::sin(0.7 * i));
    double best = 0.0, best_d = 1e9;
    for (int k = 0; k <= 10000; ++k) {
      const double s = n.length() * k / 10000.0;
      const double d = (core::needle_point(n, s) - p).norm();
      if (d < best_d) best_d = d, best = s;
    }
    EXPECT_NEAR(core::needle_closest_parameter(n, p), best, n.length() / 10000.0) << i;
  }
}

TEST(Needle, ItsSpheresCoverTheWireOverlappingByAtLeastTheirRadius) {
  core::Model m = needle_model();
  ASSERT_EQ(core::finalize_model(m), "");
  const core::NeedleModel& n = m.needles[0];
  const core::BodyModel& b = m.bodies[static_cast<std::size_t>(n.body)];
  ASSERT_EQ(b.sphere_count, n.sphere_count);
  ASSERT_GE(n.sphere_count, 26 / 0.35);
  for (int i = 0; i < n.sphere_count; ++i) {
    const core::Sphere& s = m.body_spheres[static_cast<std::size_t>(b.sphere_begin + i)];
    EXPECT_EQ(s.radius, n.wire_radius);
    EXPECT_NEAR((s.center - n.centre).norm(), n.radius, 1e-12) << "on the arc";
    EXPECT_NEAR(s.center.z(), 0.0, 1e-15);
    if (i > 0) {
      const core::Sphere& prev = m.body_spheres[static_cast<std::size_t>(b.sphere_begin + i - 1)];
      EXPECT_LE((s.center - prev.center).norm(), n.wire_radius + 1e-12) << "neighbours overlap by ≥ r_w";
    }
  }
  EXPECT_LT((m.body_spheres[static_cast<std::size_t>(b.sphere_begin)].center - core::needle_tail(n)).norm(), 1e-12);
  EXPECT_LT((m.body_spheres[static_cast<std::size_t>(b.sphere_begin + b.sphere_count - 1)].center -
             core::needle_tip(n)).norm(), 1e-12);
}

TEST(Needle, ItsMassIsASteelWiresAndItsInertiaTheArcs) {
  core::Model m = needle_model();
  ASSERT_EQ(core::finalize_model(m), "");
  const core::NeedleModel& n = m.needles[0];
  const core::BodyModel& b = m.bodies[static_cast<std::size_t>(n.body)];
  // ρ π r_w² L = 7800 kg/m³ · π (0.35 mm)² · 26 mm = 78 mg.
  EXPECT_NEAR(b.mass, 7800 * M_PI * 0.35e-3 * 0.35e-3 * 0.026, 1e-12);
  EXPECT_NEAR(b.mass, 78e-6, 0.5e-6);
  // The inertia of point masses spread evenly along the arc, about the origin (its centroid),
  // plus the wire's section (m r_w² / 2 on every axis, as add_needle() takes it).
  core::Mat3 inertia = core::Mat3::Zero();
  const int k = 20000;
  for (int i = 0; i < k; ++i) {
    const core::Vec3 p = core::needle_point(n, n.length() * (i + 0.5) / k);
    inertia += b.mass / k * (p.squaredNorm() * core::Mat3::Identity() - p * p.transpose());
  }
  inertia += 0.5 * b.mass * n.wire_radius * n.wire_radius * core::Mat3::Identity();
  EXPECT_LT((inertia - b.inertia_body).norm(), 1e-6 * b.inertia_body.norm());
  // A given mass is taken as it is.
  core::NeedleSpec heavy;
  heavy.mass = 1e-3;
  core::Model h = needle_model(heavy);
  ASSERT_EQ(core::finalize_model(h), "");
  EXPECT_EQ(h.bodies[0].mass, 1e-3);
}

TEST(Needle, BadNeedlesAreRefusedByName) {
  auto refused = [](void (*edit)(core::NeedleSpec&), const std::string& word) {
    core::NeedleSpec spec;
    spec.name = "sh";
    edit(spec);
    core::Model m = needle_model(spec);
    const std::string err = core::finalize_model(m);
    EXPECT_NE(err.find("needle 'sh'"), std::string::npos) << err;
    EXPECT_NE(err.find(word), std::string::npos) << err;
  };
  refused([](core::NeedleSpec& s) { s.wire_radius = 0.0; }, "wire_radius");
  refused([](core::NeedleSpec& s) { s.wire_radius = -1e-3; }, "wire_radius");
  refused([](core::NeedleSpec& s) { s.radius = 0.3e-3; }, "radius");
  refused([](core::NeedleSpec& s) { s.arc = 1.0; }, "arc");
  refused([](core::NeedleSpec& s) { s.arc = 0.0; }, "arc");
  refused([](core::NeedleSpec& s) { s.puncture_force = 0.0; }, "puncture_force");
  refused([](core::NeedleSpec& s) { s.puncture_force = -2.0; }, "puncture_force");
  core::NeedleSpec ok;
  ok.puncture_force = 1.5;
  core::Model m = needle_model(ok);
  EXPECT_EQ(core::finalize_model(m), "");
  // A body made the needle's by hand without its spheres.
  m.needles[0].sphere_count = 3;
  EXPECT_NE(core::finalize_model(m).find("spheres"), std::string::npos);
}

TEST(Needle, TheWidestWireAGrasperClosesOnIsSetByItsJawsAndCloseAngle) {
  // The test grasper: jaws of 1.5 mm spheres 2, 5, 8 and 11 mm from the hinge, close at 30°: the
  // tip spheres' surfaces are 2 (11 mm sin 15° − 1.5 mm) = 2.69 mm apart there.
  core::Model m;
  m.gravity = core::Vec3::Zero();
  m.material_names = {"steel"};
  m.material_pairs = {core::MaterialPair{}};
  numen::test::add_grasper(m, core::Vec3(0, 0, 0.06), 25 * numen::test::kGraspDeg, 5.0);
  ASSERT_EQ(core::finalize_model(m), "");
  EXPECT_NEAR(core::grasp_widest_wire(m, 0), 2 * (0.011 * std::sin(15 * numen::test::kGraspDeg) - 0.0015), 1e-12);
  // Closing at 10° (the default rule), the jaws' spheres meet before: any wire.
  m.grasps[0].close_angle = 10 * numen::test::kGraspDeg;
  EXPECT_LT(core::grasp_widest_wire(m, 0), 0.0);
}
