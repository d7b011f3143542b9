/// @file rigid_body.cpp
/// Rigid-body kinematics and inertia helpers (paper Eq. 1).

#include "numen/core/rigid_body.hpp"

#include <cmath>

#include <Eigen/LU>

#include "numen/core/data.hpp"
#include "numen/core/model.hpp"

namespace numen::core {

Mat3 skew(const Vec3& v) noexcept {
  Mat3 m;
  m << 0.0, -v.z(), v.y(),  //
      v.z(), 0.0, -v.x(),   //
      -v.y(), v.x(), 0.0;
  return m;
}

Mat3 world_inertia(const Mat3& rotation, const Mat3& inertia_body) noexcept {
  return rotation * inertia_body * rotation.transpose();
}

Mat3 world_inertia(const Quat& q, const Mat3& inertia_body) noexcept {
  return world_inertia(q.toRotationMatrix(), inertia_body);
}

Mat3 world_inertia_inverse(const Quat& q, const Mat3& inertia_body_inv) noexcept {
  const Mat3 r = q.toRotationMatrix();
  return r * inertia_body_inv * r.transpose();
}

Quat quat_exp(const Vec3& rotation_vector) noexcept {
  const double theta = rotation_vector.norm();
  const double half = 0.5 * theta;
  // sin(θ/2)/θ, with its Taylor series ½ (1 − θ²/24 + θ⁴/1920) near 0.
  double s;
  if (theta < 1e-4) {
    const double t2 = theta * theta;
    s = 0.5 * (1.0 - t2 / 24.0 + t2 * t2 / 1920.0);
  } else {
    s = std::sin(half) / theta;
  }
  return Quat(std::cos(half), s * rotation_vector.x(), s * rotation_vector.y(),
              s * rotation_vector.z());
}

Vec3 quat_log(const Quat& q_in) noexcept {
  double w = q_in.w();
  Vec3 v = q_in.vec();
  if (w < 0.0) {  // q and −q are the same rotation: take the shortest arc.
    w = -w;
    v = -v;
  }
  const double s = v.norm();
  const double n = std::sqrt(s * s + w * w);
  if (!(n > 0.0)) return Vec3::Zero();
  // θ u = (θ / s) v with θ = 2 atan2(s, w). Near s = 0, atan2(s, w)/s → 1/w
  // (w ≈ n > 0): use the series (1/w)(1 − s²/(3w²)) to avoid 0/0.
  double factor;
  if (s < 1e-8 * n) {
    factor = 2.0 / w * (1.0 - (s * s) / (3.0 * w * w));
  } else {
    factor = 2.0 * std::atan2(s, w) / s;
  }
  return factor * v;
}

Quat integrate_orientation(const Quat& q0, const Vec3& omega_world, double h) noexcept {
  Quat q1 = quat_exp(h * omega_world) * q0;
  q1.normalize();
  return q1;
}

Vec3 gyroscopic_torque(const Mat3& inertia_world, const Vec3& omega) noexcept {
  return -omega.cross(inertia_world * omega);
}

Vec3 implicit_gyroscopic_velocity(const Mat3& rotation, const Mat3& inertia_body,
                                  const Vec3& omega_world, double h) noexcept {
  const Vec3 wb = rotation.transpose() * omega_world;
  const Vec3 iw = inertia_body * wb;
  const Vec3 f = h * wb.cross(iw);
  // J = I_b + h ([ω_b]× I_b − [I_b ω_b]×), [ω_b]× I_b formed column by column.
  Mat3 wb_ib;
  for (int j = 0; j < 3; ++j) wb_ib.col(j) = wb.cross(inertia_body.col(j));
  const Mat3 jac = inertia_body + h * (wb_ib - skew(iw));
  // J⁻¹ = adj(J) / det J; the determinant is taken from the same cofactors.
  Mat3 jac_inv;
  double det = 0.0;
  bool invertible = false;
  jac.computeInverseAndDetWithCheck(jac_inv, det, invertible, 1e-300);
  if (!invertible || !std::isfinite(det)) return omega_world;
  const Vec3 wb1 = wb - jac_inv * f;
  return rotation * wb1;
}

Vec3 implicit_gyroscopic_velocity(const Quat& q, const Mat3& inertia_body,
                                  const Vec3& omega_world, double h) noexcept {
  return implicit_gyroscopic_velocity(q.toRotationMatrix(), inertia_body, omega_world, h);
}

double kinetic_energy(const BodyModel& body, const BodyState& state) noexcept {
  const Mat3 iw = world_inertia(state.orientation, body.inertia_body);
  return 0.5 * body.mass * state.linear_velocity.squaredNorm() +
         0.5 * state.angular_velocity.dot(iw * state.angular_velocity);
}

bool state_is_finite(const BodyState& state) noexcept {
  return state.position.allFinite() && state.orientation.coeffs().allFinite() &&
         state.linear_velocity.allFinite() && state.angular_velocity.allFinite();
}

void apply_external_forces(const Model& model, Data& data) noexcept {
  const std::size_t n = data.bodies.size();
  for (std::size_t i = 0; i < n; ++i) {
    Wrench& w = data.body_wrench[i];
    w.force = model.bodies[i].mass * model.gravity + data.applied_wrench[i].force;
    w.torque = data.applied_wrench[i].torque;
  }
}

}  // namespace numen::core
