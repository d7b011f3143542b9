// Tests of core/joint: the constraint rows C(q) of every joint type, their
// Jacobians G against finite differences, the joint coordinates, the row
// catalogue and the trocar (remote centre of motion) constraint.
#include "numen/core/joint.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <numbers>
#include <random>
#include <string>

#include "alloc_counter.hpp"
#include "numen/core/data.hpp"
#include "numen/core/rigid_body.hpp"
#include "test_constants.hpp"

namespace core = numen::core;
using core::BodyState;
using core::JointModel;
using core::JointRows;
using core::JointType;
using core::Mat3;
using core::Pose;
using core::Quat;
using core::Vec3;
using core::Vec6;

namespace {

using numen::test::kPi;

constexpr std::array<JointType, 6> kJointTypes = {JointType::kFixed,     JointType::kRevolute,
                                                  JointType::kPrismatic, JointType::kCylindrical,
                                                  JointType::kSpherical, JointType::kTrocar};

/// A joint type with its prescribed flag: every variant of the catalogue.
struct Variant {
  JointType type;
  bool prescribed;
};

constexpr std::array<Variant, 8> kVariants = {
    Variant{JointType::kFixed, false},     Variant{JointType::kRevolute, false},
    Variant{JointType::kRevolute, true},   Variant{JointType::kPrismatic, false},
    Variant{JointType::kPrismatic, true},  Variant{JointType::kCylindrical, false},
    Variant{JointType::kSpherical, false}, Variant{JointType::kTrocar, false}};

std::string label(const Variant& v, bool world_parent, int trial) {
  return std::string(core::to_string(v.type)) + (v.prescribed ? " (prescribed)" : "") +
         (world_parent ? ", world parent" : ", body parent") + ", trial " + std::to_string(trial);
}

class Random {
 public:
  explicit Random(unsigned seed) : gen_(seed) {}
  double uniform(double lo, double hi) { return std::uniform_real_distribution<>(lo, hi)(gen_); }
  Vec3 vec(double scale) {
    return Vec3(uniform(-scale, scale), uniform(-scale, scale), uniform(-scale, scale));
  }
  Quat rotation() {
    std::normal_distribution<> n;
    Quat q(n(gen_), n(gen_), n(gen_), n(gen_));
    return q.normalized();
  }
  Pose pose(double scale) { return Pose{vec(scale), rotation()}; }
  BodyState state() {
    BodyState s;
    s.position = vec(1.0);
    s.orientation = rotation();
    s.linear_velocity = vec(1.0);  // never read by the joint functions
    s.angular_velocity = vec(1.0);
    return s;
  }
  Vec6 twist() {
    Vec6 u;
    u << vec(1.0), vec(1.0);
    return u;
  }

 private:
  std::mt19937 gen_;
};

JointModel make_joint(const Variant& v, Random& rng) {
  JointModel j;
  j.name = "j";
  j.type = v.type;
  j.prescribed = v.prescribed;
  j.parent = 0;
  j.child = 1;
  j.frame_parent = rng.pose(0.3);
  j.frame_child = rng.pose(0.3);
  j.num_rows = core::joint_row_count(v.type, v.prescribed);
  return j;
}

/// World pose of the parent joint frame (a_p, q_pj).
Pose parent_frame(const JointModel& j, const BodyState* parent) {
  if (parent == nullptr) return j.frame_parent;
  return Pose{parent->position + parent->orientation * j.frame_parent.position,
              parent->orientation * j.frame_parent.orientation};
}

/// The child state whose joint frame has the world pose `frame` (a_c, q_cj).
BodyState child_with_frame(const JointModel& j, const Pose& frame) {
  BodyState c;
  c.orientation = (frame.orientation * j.frame_child.orientation.conjugate()).normalized();
  c.position = frame.position - c.orientation * j.frame_child.position;
  return c;
}

/// A configuration allowed by the joint, with the motion used to build it.
struct Satisfied {
  BodyState child;
  double angle = 0.0;  ///< Twist about z (revolute, cylindrical), rad.
  double slide = 0.0;  ///< Slide along z (prismatic, cylindrical, trocar), m.
};

/// Builds a child that satisfies the joint: its joint frame is the parent's
/// moved only by the joint's free motion (random angle, slide, ball rotation,
/// trocar pivot + roll + insertion).
Satisfied satisfied_child(const JointModel& j, const BodyState* parent, Random& rng) {
  const Pose p = parent_frame(j, parent);
  const Vec3 z_pj = p.orientation * Vec3::UnitZ();
  Satisfied s;
  Pose c = p;
  switch (j.type) {
    case JointType::kFixed:
      break;
    case JointType::kRevolute:
      s.angle = rng.uniform(-kPi, kPi);
      c.orientation = p.orientation * Quat(Eigen::AngleAxisd(s.angle, Vec3::UnitZ()));
      break;
    case JointType::kPrismatic:
      s.slide = rng.uniform(-0.5, 0.5);
      c.position = p.position + s.slide * z_pj;
      break;
    case JointType::kCylindrical:
      s.angle = rng.uniform(-kPi, kPi);
      s.slide = rng.uniform(-0.5, 0.5);
      c.orientation = p.orientation * Quat(Eigen::AngleAxisd(s.angle, Vec3::UnitZ()));
      c.position = p.position + s.slide * z_pj;
      break;
    case JointType::kSpherical:
      c.orientation = rng.rotation();
      break;
    case JointType::kTrocar: {
      // Any orientation (2 pivot rotations and the roll); the anchor a_c
      // sits on the axis line through a_p, at insertion depth s.
      c.orientation = rng.rotation();
      s.slide = rng.uniform(-0.5, 0.5);
      c.position = p.position - s.slide * (c.orientation * Vec3::UnitZ());
      break;
    }
  }
  s.child = child_with_frame(j, c);
  return s;
}

/// The prescribed value that the satisfied configuration `s` meets.
double prescription_of(const JointModel& j, const Satisfied& s) {
  if (!j.prescribed) return 0.0;
  return j.type == JointType::kRevolute ? s.angle : s.slide;
}

/// The state moved by ε along the twist u = (v, ω): x += ε v, q = exp(ε ω) q.
BodyState displaced(const BodyState& s, const Vec6& u, double eps) {
  BodyState d = s;
  d.position += eps * u.head<3>();
  d.orientation = (core::quat_exp(eps * u.tail<3>()) * s.orientation).normalized();
  return d;
}

core::JointVector evaluate(const JointModel& j, const BodyState* parent, const BodyState& child,
                           double prescribed_value) {
  JointRows rows;
  core::evaluate_joint(j, parent, child, prescribed_value, rows);
  return rows.position_error;
}

/// Central difference of C along the twists (u_parent, u_child).
core::JointVector finite_difference(const JointModel& j, const BodyState* parent,
                                    const BodyState& child, double prescribed_value,
                                    const Vec6& u_parent, const Vec6& u_child) {
  constexpr double eps = 1e-6;
  BodyState pp, pm;
  const BodyState* pp_ptr = nullptr;
  const BodyState* pm_ptr = nullptr;
  if (parent != nullptr) {
    pp = displaced(*parent, u_parent, eps);
    pm = displaced(*parent, u_parent, -eps);
    pp_ptr = &pp;
    pm_ptr = &pm;
  }
  const core::JointVector cp =
      evaluate(j, pp_ptr, displaced(child, u_child, eps), prescribed_value);
  const core::JointVector cm =
      evaluate(j, pm_ptr, displaced(child, u_child, -eps), prescribed_value);
  return (cp - cm) / (2.0 * eps);
}

/// Checks rows of G against finite differences of C: all rows if
/// `angular_too`, else linear rows only. Also checks the zero padding.
void expect_jacobian_matches(const JointModel& j, const BodyState* parent, const BodyState& child,
                             double prescribed_value, Random& rng, bool angular_too, double tol,
                             const std::string& what) {
  JointRows rows;
  core::evaluate_joint(j, parent, child, prescribed_value, rows);
  ASSERT_EQ(rows.count, j.num_rows) << what;
  for (int r = rows.count; r < core::kMaxJointRows; ++r) {
    EXPECT_EQ(rows.position_error(r), 0.0) << what << ", row " << r;
    EXPECT_TRUE(rows.g_child.row(r).isZero(0.0)) << what << ", row " << r;
    EXPECT_TRUE(rows.g_parent.row(r).isZero(0.0)) << what << ", row " << r;
  }
  if (parent == nullptr) {
    EXPECT_TRUE(rows.g_parent.isZero(0.0)) << what;
  }
  for (int k = 0; k < 4; ++k) {
    // Child alone, parent alone, then both together.
    const Vec6 u_child = k == 1 ? Vec6::Zero().eval() : rng.twist();
    const Vec6 u_parent = k == 0 ? Vec6::Zero().eval() : rng.twist();
    const core::JointVector fd =
        finite_difference(j, parent, child, prescribed_value, u_parent, u_child);
    const core::JointVector g = rows.g_child * u_child + rows.g_parent * u_parent;
    for (int r = 0; r < rows.count; ++r) {
      if (!angular_too && core::joint_row_is_angular(j.type, r)) continue;
      EXPECT_NEAR(g(r), fd(r), tol) << what << ", row " << r << ", twist " << k;
    }
  }
}

}  // namespace

TEST(Joint, RowCountsOfTheCatalogue) {
  EXPECT_EQ(core::joint_row_count(JointType::kFixed, false), 6);
  EXPECT_EQ(core::joint_row_count(JointType::kRevolute, false), 5);
  EXPECT_EQ(core::joint_row_count(JointType::kRevolute, true), 6);
  EXPECT_EQ(core::joint_row_count(JointType::kPrismatic, false), 5);
  EXPECT_EQ(core::joint_row_count(JointType::kPrismatic, true), 6);
  EXPECT_EQ(core::joint_row_count(JointType::kCylindrical, false), 4);
  EXPECT_EQ(core::joint_row_count(JointType::kSpherical, false), 3);
  EXPECT_EQ(core::joint_row_count(JointType::kTrocar, false), 2);
  // A prescribed flag on a type that cannot be prescribed: no rows.
  for (JointType t :
       {JointType::kFixed, JointType::kCylindrical, JointType::kSpherical, JointType::kTrocar}) {
    EXPECT_FALSE(core::joint_can_be_prescribed(t)) << core::to_string(t);
    EXPECT_EQ(core::joint_row_count(t, true), 0) << core::to_string(t);
  }
  EXPECT_TRUE(core::joint_can_be_prescribed(JointType::kRevolute));
  EXPECT_TRUE(core::joint_can_be_prescribed(JointType::kPrismatic));
  for (JointType t : kJointTypes) EXPECT_LE(core::joint_row_count(t, false), core::kMaxJointRows);
}

TEST(Joint, AngularRowsFollowTheCatalogueOrder) {
  auto angular = [](JointType t) {
    std::string s;
    for (int r = 0; r < core::kMaxJointRows; ++r) s += core::joint_row_is_angular(t, r) ? 'A' : 'L';
    return s;
  };
  // Rows beyond the (prescribed) count report linear.
  EXPECT_EQ(angular(JointType::kFixed), "LLLAAA");
  EXPECT_EQ(angular(JointType::kRevolute), "LLLAAA");   // 3 linear, 2 swing, twist
  EXPECT_EQ(angular(JointType::kPrismatic), "LLAAAL");  // 2 linear, 3 log, slide
  EXPECT_EQ(angular(JointType::kCylindrical), "LLAALL");
  EXPECT_EQ(angular(JointType::kSpherical), "LLLLLL");
  EXPECT_EQ(angular(JointType::kTrocar), "LLLLLL");
  EXPECT_FALSE(core::joint_row_is_angular(JointType::kFixed, -1));
  EXPECT_FALSE(core::joint_row_is_angular(JointType::kFixed, core::kMaxJointRows));
}

TEST(Joint, NamesAsInSceneFiles) {
  EXPECT_STREQ(core::to_string(JointType::kFixed), "fixed");
  EXPECT_STREQ(core::to_string(JointType::kRevolute), "revolute");
  EXPECT_STREQ(core::to_string(JointType::kPrismatic), "prismatic");
  EXPECT_STREQ(core::to_string(JointType::kCylindrical), "cylindrical");
  EXPECT_STREQ(core::to_string(JointType::kSpherical), "spherical");
  EXPECT_STREQ(core::to_string(JointType::kTrocar), "trocar");
}

TEST(Joint, ConstraintIsZeroAtAllowedConfigurations) {
  Random rng(1);
  for (const Variant& v : kVariants) {
    for (bool world : {false, true}) {
      for (int trial = 0; trial < 50; ++trial) {
        const JointModel j = make_joint(v, rng);
        const BodyState parent = rng.state();
        const BodyState* p = world ? nullptr : &parent;
        const Satisfied s = satisfied_child(j, p, rng);
        JointRows rows;
        core::evaluate_joint(j, p, s.child, prescription_of(j, s), rows);
        ASSERT_EQ(rows.count, j.num_rows);
        EXPECT_TRUE(rows.position_error.isZero(1e-12)) << label(v, world, trial) << "\n"
                                                       << rows.position_error.transpose();
      }
    }
  }
}

TEST(Joint, ConstraintIsNonZeroAwayFromAllowedConfigurations) {
  // Each constrained direction shows up: moving the child joint frame off the
  // allowed set by a small translation or rotation in the parent joint frame
  // gives the expected row values.
  Random rng(2);
  const double delta = 1e-3;
  for (bool world : {false, true}) {
    const BodyState parent = rng.state();
    const BodyState* p = world ? nullptr : &parent;
    JointModel j = make_joint({JointType::kFixed, false}, rng);
    const Pose pf = parent_frame(j, p);
    const Vec3 offset(0.3 * delta, -delta, 2.0 * delta);    // parent joint frame
    const Vec3 rotation(-delta, 0.5 * delta, 0.7 * delta);  // parent joint frame
    const Pose moved{pf.position + pf.orientation * offset,
                     pf.orientation * core::quat_exp(rotation)};
    const BodyState child = child_with_frame(j, moved);
    const core::JointVector c = evaluate(j, p, child, 0.0);
    EXPECT_TRUE(c.head<3>().isApprox(offset, 1e-9)) << c.transpose();
    EXPECT_TRUE(c.segment<3>(3).isApprox(rotation, 1e-9)) << c.transpose();

    j.type = JointType::kRevolute;  // swing rows ≈ x, y of the rotation vector
    j.num_rows = 5;
    const core::JointVector r = evaluate(j, p, child, 0.0);
    EXPECT_TRUE(r.head<3>().isApprox(offset, 1e-9));
    EXPECT_NEAR(r(3), rotation.x(), 1e-5);
    EXPECT_NEAR(r(4), rotation.y(), 1e-5);

    j.type = JointType::kPrismatic;
    const core::JointVector s = evaluate(j, p, child, 0.0);
    EXPECT_TRUE(s.head<2>().isApprox(offset.head<2>(), 1e-9));
    EXPECT_TRUE(s.segment<3>(2).isApprox(rotation, 1e-9));
  }
}

TEST(Joint, JacobianMatchesFiniteDifferencesAtAllowedConfigurations) {
  Random rng(3);
  for (const Variant& v : kVariants) {
    for (bool world : {false, true}) {
      for (int trial = 0; trial < 20; ++trial) {
        const JointModel j = make_joint(v, rng);
        const BodyState parent = rng.state();
        const BodyState* p = world ? nullptr : &parent;
        const Satisfied s = satisfied_child(j, p, rng);
        expect_jacobian_matches(j, p, s.child, prescription_of(j, s), rng, /*angular_too=*/true,
                                1e-7, label(v, world, trial));
      }
    }
  }
}

TEST(Joint, LinearJacobianIsExactAnywhere) {
  Random rng(4);
  for (const Variant& v : kVariants) {
    for (bool world : {false, true}) {
      for (int trial = 0; trial < 20; ++trial) {
        const JointModel j = make_joint(v, rng);
        const BodyState parent = rng.state();
        const BodyState* p = world ? nullptr : &parent;
        const BodyState child = rng.state();  // generally violates the joint
        expect_jacobian_matches(j, p, child, rng.uniform(-0.5, 0.5), rng, /*angular_too=*/false,
                                1e-7, label(v, world, trial));
      }
    }
  }
}

TEST(Joint, AngularJacobianIsFirstOrderInTheError) {
  // Near an allowed configuration (angular error η), G of the angular rows is
  // off by O(η): Baumgarte stabilisation converges.
  Random rng(5);
  for (const Variant& v : kVariants) {
    for (double eta : {1e-2, 1e-4}) {
      const JointModel j = make_joint(v, rng);
      const BodyState parent = rng.state();
      Satisfied s = satisfied_child(j, &parent, rng);
      s.child.orientation =
          (core::quat_exp(eta * rng.vec(1.0).normalized()) * s.child.orientation).normalized();
      JointRows rows;
      core::evaluate_joint(j, &parent, s.child, prescription_of(j, s), rows);
      const Vec6 u_child = rng.twist(), u_parent = rng.twist();
      const core::JointVector fd =
          finite_difference(j, &parent, s.child, prescription_of(j, s), u_parent, u_child);
      const core::JointVector g = rows.g_child * u_child + rows.g_parent * u_parent;
      const double scale = u_child.norm() + u_parent.norm();
      for (int r = 0; r < rows.count; ++r) {
        EXPECT_NEAR(g(r), fd(r), 4.0 * eta * scale) << core::to_string(v.type) << " row " << r;
      }
    }
  }
}

TEST(Joint, RigidMotionOfTheWholeAssemblyLeavesTheConstraintUnchanged) {
  // Both bodies moving as one rigid body (world twist (v0 at the origin, ω)):
  // Ċ = 0 for the linear rows anywhere, for every row where C = 0.
  Random rng(6);
  for (const Variant& v : kVariants) {
    for (int trial = 0; trial < 10; ++trial) {
      const JointModel j = make_joint(v, rng);
      const BodyState parent = rng.state();
      const Vec3 v0 = rng.vec(1.0), w = rng.vec(1.0);
      const auto body_twist = [&](const BodyState& b) {
        Vec6 u;
        u << v0 + w.cross(b.position), w;
        return u;
      };
      for (bool satisfied : {true, false}) {
        const Satisfied s = satisfied_child(j, &parent, rng);
        const BodyState child = satisfied ? s.child : rng.state();
        JointRows rows;
        core::evaluate_joint(j, &parent, child, prescription_of(j, s), rows);
        const core::JointVector cdot =
            rows.g_child * body_twist(child) + rows.g_parent * body_twist(parent);
        for (int r = 0; r < rows.count; ++r) {
          if (!satisfied && core::joint_row_is_angular(v.type, r)) continue;
          EXPECT_NEAR(cdot(r), 0.0, 1e-12) << core::to_string(v.type) << " row " << r;
        }
      }
    }
  }
}

TEST(Joint, CoordinateIsTheAngleOrSlideOfTheConfiguration) {
  Random rng(7);
  for (const Variant& v : kVariants) {
    for (bool world : {false, true}) {
      for (int trial = 0; trial < 30; ++trial) {
        const JointModel j = make_joint(v, rng);
        const BodyState parent = rng.state();
        const BodyState* p = world ? nullptr : &parent;
        const Satisfied s = satisfied_child(j, p, rng);
        const double q = core::joint_coordinate(j, p, s.child);
        const double slide = core::joint_slide(j, p, s.child);
        const std::string what = label(v, world, trial);
        switch (v.type) {
          case JointType::kRevolute:
            EXPECT_NEAR(q, s.angle, 1e-12) << what;
            EXPECT_EQ(slide, 0.0) << what;
            break;
          case JointType::kPrismatic:
            EXPECT_NEAR(q, s.slide, 1e-12) << what;
            EXPECT_EQ(slide, 0.0) << what;
            break;
          case JointType::kCylindrical:
            EXPECT_NEAR(q, s.angle, 1e-12) << what;
            EXPECT_NEAR(slide, s.slide, 1e-12) << what;
            break;
          case JointType::kTrocar:
            EXPECT_EQ(q, 0.0) << what;
            EXPECT_NEAR(slide, s.slide, 1e-12) << what;
            break;
          case JointType::kFixed:
          case JointType::kSpherical:
            EXPECT_EQ(q, 0.0) << what;
            EXPECT_EQ(slide, 0.0) << what;
            break;
        }
      }
    }
  }
}

TEST(Joint, RevoluteAngleIsWrappedToMinusPiPi) {
  Random rng(8);
  const JointModel j = make_joint({JointType::kRevolute, false}, rng);
  const BodyState parent = rng.state();
  const Pose pf = parent_frame(j, &parent);
  for (double angle : {0.0, 1e-9, -1e-9, 1.0, -2.5, 3.1, -3.1, kPi - 1e-9, -kPi + 1e-9, kPi, -kPi,
                       kPi + 0.5, -kPi - 0.5, 2.0 * kPi + 0.25, 7.0}) {
    const Pose cf{pf.position, pf.orientation * Quat(Eigen::AngleAxisd(angle, Vec3::UnitZ()))};
    const double q = core::joint_coordinate(j, &parent, child_with_frame(j, cf));
    EXPECT_GT(q, -kPi) << angle;
    EXPECT_LE(q, kPi) << angle;
    const double diff = std::remainder(q - angle, 2.0 * kPi);
    EXPECT_NEAR(diff, 0.0, 1e-9) << angle << " -> " << q;
  }
  // The quaternion sign does not matter.
  const Pose cf{pf.position, pf.orientation * Quat(Eigen::AngleAxisd(2.0, Vec3::UnitZ()))};
  BodyState child = child_with_frame(j, cf);
  const double q1 = core::joint_coordinate(j, &parent, child);
  child.orientation.coeffs() *= -1.0;
  EXPECT_NEAR(core::joint_coordinate(j, &parent, child), q1, 1e-14);
  EXPECT_NEAR(q1, 2.0, 1e-12);
}

TEST(Joint, PrescribedRowIsTheCoordinateError) {
  Random rng(9);
  const BodyState parent = rng.state();
  {  // Revolute: C = φ − φ*, wrapped to (−π, π].
    const JointModel j = make_joint({JointType::kRevolute, true}, rng);
    const Pose pf = parent_frame(j, &parent);
    const Pose cf{pf.position, pf.orientation * Quat(Eigen::AngleAxisd(3.0, Vec3::UnitZ()))};
    const BodyState child = child_with_frame(j, cf);
    EXPECT_NEAR(evaluate(j, &parent, child, 2.75)(5), 0.25, 1e-12);
    EXPECT_NEAR(evaluate(j, &parent, child, 3.0)(5), 0.0, 1e-12);
    EXPECT_NEAR(evaluate(j, &parent, child, -3.0)(5), 6.0 - 2.0 * kPi, 1e-12);
    EXPECT_NEAR(evaluate(j, &parent, child, 3.0 + 2.0 * kPi)(5), 0.0, 1e-12);
    EXPECT_TRUE(evaluate(j, &parent, child, 1.0).head<5>().isZero(1e-12));
  }
  {  // Prismatic: C = z_pj · d − s*.
    const JointModel j = make_joint({JointType::kPrismatic, true}, rng);
    const Pose pf = parent_frame(j, &parent);
    const Pose cf{pf.position + 0.2 * (pf.orientation * Vec3::UnitZ()), pf.orientation};
    const BodyState child = child_with_frame(j, cf);
    EXPECT_NEAR(evaluate(j, &parent, child, 0.05)(5), 0.15, 1e-12);
    EXPECT_NEAR(evaluate(j, &parent, child, 0.2)(5), 0.0, 1e-12);
    EXPECT_TRUE(evaluate(j, &parent, child, -1.0).head<5>().isZero(1e-12));
  }
}

TEST(Joint, TrocarHoldsTheAxisLineThroughTheRemoteCentre) {
  Random rng(10);
  for (bool world : {false, true}) {
    const JointModel j = make_joint({JointType::kTrocar, false}, rng);
    const BodyState parent = rng.state();
    const BodyState* p = world ? nullptr : &parent;
    const Vec3 centre = parent_frame(j, p).position;
    const Quat pivot = rng.rotation();  // the tool's two pivot angles
    for (double slide : {-0.3, 0.0, 0.12, 0.4}) {
      for (double roll : {0.0, 1.0, -2.9}) {
        const Quat q_cj = pivot * Quat(Eigen::AngleAxisd(roll, Vec3::UnitZ()));
        const Vec3 axis = q_cj * Vec3::UnitZ();
        const Pose on_line{centre - slide * axis, q_cj};
        BodyState child = child_with_frame(j, on_line);
        EXPECT_TRUE(evaluate(j, p, child, 0.0).isZero(1e-12)) << slide << " " << roll;
        EXPECT_NEAR(core::joint_slide(j, p, child), slide, 1e-12);
        // Moving the line sideways by δ: |C| = δ, whatever the direction.
        for (double delta : {1e-4, 0.01, 0.2}) {
          const Vec3 side = axis.cross(rng.vec(1.0)).normalized();
          const Pose off{on_line.position + delta * side, q_cj};
          child = child_with_frame(j, off);
          const core::JointVector c = evaluate(j, p, child, 0.0);
          EXPECT_NEAR(c.head<2>().norm(), delta, 1e-12);
          EXPECT_TRUE(c.tail<4>().isZero(0.0));
          // ... and the insertion depth is unchanged.
          EXPECT_NEAR(core::joint_slide(j, p, child), slide, 1e-12);
        }
      }
    }
  }
}

TEST(Joint, EvaluationIsAllocationFree) {
  Random rng(11);
  std::array<JointModel, kVariants.size()> joints;
  std::array<Satisfied, kVariants.size()> configs;
  const BodyState parent = rng.state();
  for (std::size_t i = 0; i < kVariants.size(); ++i) {
    joints[i] = make_joint(kVariants[i], rng);
    configs[i] = satisfied_child(joints[i], &parent, rng);
  }
  JointRows rows;
  double sink = 0.0;
  {
    numen::test::AllocationGuard guard;
    for (int it = 0; it < 100; ++it) {
      for (std::size_t i = 0; i < joints.size(); ++i) {
        const BodyState* p = (it % 2 == 0) ? &parent : nullptr;
        core::evaluate_joint(joints[i], p, configs[i].child, 0.1, rows);
        sink += rows.position_error.sum() + rows.g_child.sum() + rows.g_parent.sum();
        sink += core::joint_coordinate(joints[i], p, configs[i].child);
        sink += core::joint_slide(joints[i], p, configs[i].child);
      }
    }
    EXPECT_EQ(guard.count(), 0);
  }
  EXPECT_TRUE(std::isfinite(sink));
}
