#include "numen/platform/device_binding.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace numen::platform {

std::vector<std::uint8_t> explicitly_bound_bodies(const DeviceBinding& binding, int num_bodies) {
  std::vector<std::uint8_t> bound(static_cast<std::size_t>(std::max(num_bodies, 0)), 0);
  for (const LinkBinding& b : binding.links) {
    if (b.body < 0) continue;
    if (b.body >= num_bodies)
      throw std::invalid_argument("device binding: body " + std::to_string(b.body) +
                                  " out of range (" + std::to_string(num_bodies) + " bodies)");
    if (bound[static_cast<std::size_t>(b.body)])
      throw std::invalid_argument("device binding: body " + std::to_string(b.body) +
                                  " is bound to two links");
    bound[static_cast<std::size_t>(b.body)] = 1;
  }
  return bound;
}

int bound_body(const LinkBinding& b, const core::Data& d,
               std::span<const std::uint8_t> explicit_bound) noexcept {
  if (b.body >= 0) return b.body;
  const int body = d.held_body;
  if (body < 0 || static_cast<std::size_t>(body) >= explicit_bound.size()) return -1;
  return explicit_bound[static_cast<std::size_t>(body)] ? -1 : body;
}

void body_target_of(const LinkBinding& b, const core::Pose& link, const core::Twist& link_twist,
                    core::Pose& pose, core::Twist& twist) noexcept {
  pose.position = link.position + link.orientation * b.body_in_link.position;
  pose.orientation = link.orientation * b.body_in_link.orientation;
  twist.angular = link_twist.angular;
  twist.linear = link_twist.linear + link_twist.angular.cross(pose.position - link.position);
}

void set_body_target(core::Data& d, int body, const core::Pose& pose, const core::Twist& twist) noexcept {
  if (body == d.held_body) {
    d.target = pose;
    d.target_twist = twist;
    return;
  }
  core::BodyTarget& t = d.body_targets[static_cast<std::size_t>(body)];
  t.pose = pose;
  t.twist = twist;
  t.enabled = true;
}

int apply_link_target(const LinkBinding& b, const core::Pose& link, const core::Twist& link_twist,
                      core::Data& d, std::span<const std::uint8_t> explicit_bound,
                      core::Vec3* body_point) noexcept {
  const int body = bound_body(b, d, explicit_bound);
  core::Pose pose;
  core::Twist twist;
  body_target_of(b, link, link_twist, pose, twist);
  if (body_point != nullptr) *body_point = pose.position;
  if (body >= 0) set_body_target(d, body, pose, twist);
  return body;
}

void apply_prescription(const AxisPrescription& p, double q, double qdot, core::Data& d) noexcept {
  core::JointPrescription& jp = d.joint_prescribed[static_cast<std::size_t>(p.joint)];
  jp.value = p.scale * q + p.offset;
  jp.rate = p.scale * qdot;
}

}  // namespace numen::platform
