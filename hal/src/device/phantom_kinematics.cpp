/// @file phantom_kinematics.cpp
/// PHANToM-like arm: R_T = R_b Rz(q0), e = s + l1 R_T Ry(q1) e_x, g = e − l2 R_T Ry(q2) e_z,
/// R_S = R_T Ry(q2) Rz(q3) Ry(q4) Rx(q5) (elbow pitch measured from the turret).

#include "numen/hal/device/phantom_kinematics.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

#include "axis_rotation.hpp"
#include "geometry_check.hpp"
#include "numen/hal/device/axis.hpp"

namespace numen::hal {
namespace {

using core::Quat;
using core::Vec3;
using detail::axis_rotation;

constexpr const char* kPhantomLinkNames[PhantomKinematics::kNumLinks] = {
    "tool", "turret", "upper_arm", "forearm", "stylus"};

double checked_length(double l, const char* field) {
  if (!std::isfinite(l) || l <= 0.0) {
    throw std::invalid_argument(std::string(field) + " must be finite and > 0 (got " +
                                std::to_string(l) + ")");
  }
  return l;
}

}  // namespace

PhantomKinematics::PhantomKinematics(const PhantomGeometry& geometry,
                                     const core::Pose& tool_offset) {
  geometry_.base.position =
      detail::checked_position(geometry.base.position, "phantom.base.position");
  geometry_.base.orientation =
      detail::checked_unit_quaternion(geometry.base.orientation, "phantom.base.orientation");
  geometry_.l1 = checked_length(geometry.l1, "phantom.l1");
  geometry_.l2 = checked_length(geometry.l2, "phantom.l2");
  tool_offset_.position = detail::checked_position(tool_offset.position, "tool_offset.position");
  tool_offset_.orientation =
      detail::checked_unit_quaternion(tool_offset.orientation, "tool_offset.orientation");
}

PhantomKinematics::Frames PhantomKinematics::frames(const AxisVector& q) const noexcept {
  eigen_assert(q.size() == kNumAxes);
  Frames f;
  f.turret = (geometry_.base.orientation * axis_rotation(q[kTurret], Vec3::UnitZ())).normalized();
  f.upper_arm = (f.turret * axis_rotation(q[kShoulder], Vec3::UnitY())).normalized();
  f.forearm = (f.turret * axis_rotation(q[kElbow], Vec3::UnitY())).normalized();
  f.stylus =
      (f.forearm * axis_rotation(q[kGimbalYaw], Vec3::UnitZ()) *
       axis_rotation(q[kGimbalPitch], Vec3::UnitY()) * axis_rotation(q[kStylusRoll], Vec3::UnitX()))
          .normalized();
  f.elbow = geometry_.base.position + geometry_.l1 * (f.upper_arm * Vec3::UnitX());
  f.gimbal = f.elbow - geometry_.l2 * (f.forearm * Vec3::UnitZ());
  return f;
}

core::Pose PhantomKinematics::stylus_pose(const AxisVector& q) const noexcept {
  const Frames f = frames(q);
  core::Pose p;
  p.position = f.gimbal;
  p.orientation = f.stylus;
  return p;
}

core::Pose PhantomKinematics::forward(const AxisVector& q) const noexcept {
  const Frames f = frames(q);
  core::Pose out;
  out.position = f.gimbal + f.stylus * tool_offset_.position;
  out.orientation = (f.stylus * tool_offset_.orientation).normalized();
  return out;
}

Jacobian PhantomKinematics::stylus_fixed_jacobian(const AxisVector& q, const Frames& f,
                                                  const Vec3& origin) const noexcept {
  const Vec3& s = geometry_.base.position;
  const Vec3 z_b = geometry_.base.orientation * Vec3::UnitZ();
  const Vec3 y_t = f.turret * Vec3::UnitY();
  const Quat yawed = f.forearm * axis_rotation(q[kGimbalYaw], Vec3::UnitZ());
  const Vec3 w3 = f.forearm * Vec3::UnitZ();
  const Vec3 w4 = yawed * Vec3::UnitY();
  const Vec3 w5 = yawed * axis_rotation(q[kGimbalPitch], Vec3::UnitY()) * Vec3::UnitX();
  const Vec3 r = origin - f.gimbal;

  Jacobian j(6, kNumAxes);
  j.col(kTurret) << z_b.cross(origin - s), z_b;
  j.col(kShoulder) << y_t.cross(f.elbow - s), Vec3::Zero();  // the forearm translates
  j.col(kElbow) << y_t.cross(origin - f.elbow), y_t;
  j.col(kGimbalYaw) << w3.cross(r), w3;
  j.col(kGimbalPitch) << w4.cross(r), w4;
  j.col(kStylusRoll) << w5.cross(r), w5;
  return j;
}

Jacobian PhantomKinematics::jacobian(const AxisVector& q) const noexcept {
  const Frames f = frames(q);
  return stylus_fixed_jacobian(q, f, f.gimbal + f.stylus * tool_offset_.position);
}

const char* PhantomKinematics::link_name(int link) const noexcept {
  return (link >= 0 && link < kNumLinks) ? kPhantomLinkNames[link] : "";
}

core::Pose PhantomKinematics::link_pose(int link, const AxisVector& q) const noexcept {
  core::Pose p;
  switch (link) {
    case kLinkTurret: {
      p.position = geometry_.base.position;
      p.orientation =
          (geometry_.base.orientation * axis_rotation(q[kTurret], Vec3::UnitZ())).normalized();
      return p;
    }
    case kLinkUpperArm: {
      const Frames f = frames(q);
      p.position = geometry_.base.position;
      p.orientation = f.upper_arm;
      return p;
    }
    case kLinkForearm: {
      const Frames f = frames(q);
      p.position = f.elbow;
      p.orientation = f.forearm;
      return p;
    }
    case kLinkStylus:
      return stylus_pose(q);
    default:
      return forward(q);
  }
}

Jacobian PhantomKinematics::link_jacobian(int link, const AxisVector& q) const noexcept {
  eigen_assert(q.size() == kNumAxes);
  switch (link) {
    case kLinkTurret:
    case kLinkUpperArm: {
      Jacobian j(6, kNumAxes);
      j.setZero();
      j.col(kTurret).tail<3>() = geometry_.base.orientation * Vec3::UnitZ();
      if (link == kLinkUpperArm) {
        j.col(kShoulder).tail<3>() =
            geometry_.base.orientation * (axis_rotation(q[kTurret], Vec3::UnitZ()) * Vec3::UnitY());
      }
      return j;
    }
    case kLinkForearm: {
      const Frames f = frames(q);
      const Vec3 z_b = geometry_.base.orientation * Vec3::UnitZ();
      const Vec3 y_t = f.turret * Vec3::UnitY();
      const Vec3 r = f.elbow - geometry_.base.position;
      Jacobian j(6, kNumAxes);
      j.setZero();
      j.col(kTurret) << z_b.cross(r), z_b;
      j.col(kShoulder) << y_t.cross(r), Vec3::Zero();
      j.col(kElbow) << Vec3::Zero(), y_t;  // turns about its own origin, the elbow
      return j;
    }
    case kLinkStylus: {
      const Frames f = frames(q);
      return stylus_fixed_jacobian(q, f, f.gimbal);
    }
    default:
      return jacobian(q);
  }
}

AxisVector PhantomKinematics::inverse(const core::Pose& pose,
                                      const AxisVector& q_free) const noexcept {
  const double l1 = geometry_.l1;
  const double l2 = geometry_.l2;
  const Quat& rb = geometry_.base.orientation;
  const auto free_or_zero = [&q_free](int i) { return q_free.size() > i ? q_free[i] : 0.0; };

  // Stylus pose = controlled pose · tool_offset⁻¹; gimbal centre in the base frame.
  const Quat r_s = (pose.orientation * tool_offset_.orientation.conjugate()).normalized();
  const Vec3 g_world = pose.position - r_s * tool_offset_.position;
  const Vec3 g = rb.conjugate() * (g_world - geometry_.base.position);

  // Turret: face the target (its yaw is free on the turret axis).
  const double horizontal = std::hypot(g.x(), g.y());
  const double q0 = horizontal > 1e-12 ? std::atan2(g.y(), g.x()) : free_or_zero(kTurret);
  const double rho = g.x() * std::cos(q0) + g.y() * std::sin(q0);  // reach in the turret plane
  const double h = g.z();

  // Clamp the shoulder–gimbal distance into the workspace shell [|l1 − l2|, l1 + l2]; a
  // target at the shoulder itself is taken straight below it.
  const double raw = std::hypot(rho, h);
  const double phi =
      raw > 1e-12 ? std::atan2(h, rho) : -0.5 * std::numbers::pi;  // direction from the shoulder
  const double d = std::clamp(raw, std::abs(l1 - l2), l1 + l2);
  const double gr = d * std::cos(phi);
  const double gh = d * std::sin(phi);

  // Planar two-link solution, elbow above the shoulder–gimbal line: the upper arm is turned by
  // the triangle's shoulder angle β from that line (law of cosines).
  const double cos_beta = d > 1e-12 ? (l1 * l1 + d * d - l2 * l2) / (2.0 * l1 * d) : 0.0;
  const double beta = std::acos(std::clamp(cos_beta, -1.0, 1.0));
  const double alpha1 = phi + beta;  // upper arm angle above the horizontal = −q1
  const double er = l1 * std::cos(alpha1);
  const double eh = l1 * std::sin(alpha1);
  // Forearm direction (g − e)/l2 = (−sin q2, −cos q2) in (reach, height).
  const double q2 = std::atan2(-(gr - er), -(gh - eh));
  const double q1 = -alpha1;

  // Gimbal: R_Fᵀ R_S = Rz(q3) Ry(q4) Rx(q5).
  const Quat r_f = rb * axis_rotation(q0, Vec3::UnitZ()) * axis_rotation(q2, Vec3::UnitY());
  const core::Mat3 m = (r_f.conjugate() * r_s).toRotationMatrix();
  const double cos_pitch = std::hypot(m(0, 0), m(1, 0));
  const double q4 = std::atan2(-m(2, 0), cos_pitch);
  double q3 = 0.0;
  double q5 = 0.0;
  if (cos_pitch > 1e-8) {
    q3 = std::atan2(m(1, 0), m(0, 0));
    q5 = std::atan2(m(2, 1), m(2, 2));
  } else {
    // Gimbal lock: keep the given roll; Rz(q3) Ry(q4) = M Rx(−q5), whose y column is
    // Rz(q3) e_y = (−sin q3, cos q3, 0) whatever q4.
    q5 = free_or_zero(kStylusRoll);
    const core::Mat3 a = m * Eigen::AngleAxisd(-q5, Vec3::UnitX()).toRotationMatrix();
    q3 = std::atan2(-a(0, 1), a(1, 1));
  }

  AxisVector q(kNumAxes);
  q << wrap_angle(q0), wrap_angle(q1), wrap_angle(q2), wrap_angle(q3), q4, wrap_angle(q5);
  return q;
}

}  // namespace numen::hal
