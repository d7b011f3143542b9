#pragma once
/// @file types.hpp
/// Small fixed-size value types shared by every layer. SI units, world frame
/// unless a name says otherwise. Quaternions are Hamilton (w, x, y, z), unit
/// norm; q and -q are the same rotation (docs/architecture.md, Conventions).

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace numen::core {

using Vec3 = Eigen::Vector3d;     ///< 3-vector (m, m/s, N, rad/s, ... by context).
using Mat3 = Eigen::Matrix3d;     ///< 3x3 matrix (rotation, inertia kg·m², ...).
using Vec6 = Eigen::Matrix<double, 6, 1>;  ///< Stacked (linear; angular) 6-vector.
using Mat6 = Eigen::Matrix<double, 6, 6>;  ///< 6x6 block (mass, Jacobian blocks).
/// Unit quaternion, Hamilton convention. Component order: constructed as Quat(w, x, y, z)
/// (Eigen's constructor), stored and read by coeffs() as (x, y, z, w) — the order of the Python
/// module's arrays; scene files write [w, x, y, z] (docs/scenes.md "Drive it from your own
/// program"). The identity is Quat::Identity(): Quat(0, 0, 0, 1), (x, y, z, w) read as the
/// constructor's (w, x, y, z), is a half turn about z, taken without a word (Data::target).
using Quat = Eigen::Quaterniond;

/// Rigid pose of a frame in the world: position (m) and orientation (frame → world; Quat's
/// component orders above). Which frame is stated where a Pose is declared: Data::target is the
/// held body's centre-of-mass frame, a trajectory sample the instrument's tool frame.
struct Pose {
  Vec3 position = Vec3::Zero();
  Quat orientation = Quat::Identity();
};

/// Spatial velocity of a frame, both parts in world coordinates:
/// linear velocity of the frame origin (m/s) and angular velocity (rad/s).
struct Twist {
  Vec3 linear = Vec3::Zero();
  Vec3 angular = Vec3::Zero();
};

/// Force (N) and torque (N·m), world coordinates. The point the torque is
/// taken about is stated where a Wrench is declared (usually a body's COM).
struct Wrench {
  Vec3 force = Vec3::Zero();
  Vec3 torque = Vec3::Zero();
};

/// The rotation of least angle that turns direction `from` onto direction `to` (neither needs
/// unit length; both non-zero); for opposite directions, a half turn about an axis perpendicular
/// to them. Eigen's `Quaternion::FromTwoVectors` (Eigen/Geometry), compiled once here (types.cpp)
/// instead of in every file that calls it: its opposite-direction branch instantiates a
/// `JacobiSVD` (tests/core/collision_test.cpp alone at -O1: 10.4 s of compiler time with this
/// function, 23.0 s with `FromTwoVectors`).
Quat rotation_between(const Vec3& from, const Vec3& to);

}  // namespace numen::core
