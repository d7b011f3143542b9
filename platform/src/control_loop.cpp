/// @file control_loop.cpp

#include "numen/platform/control_loop.hpp"

#include <span>
#include <stdexcept>
#include <string>

#include "numen/core/feedback.hpp"
#include "numen/core/step.hpp"
#include "numen/hal/canopen.hpp"
#include "numen/platform/monotonic_clock.hpp"

namespace numen::platform {

ControlLoop::ControlLoop(const core::Model& model, core::Data& data, hal::Bus& bus,
                         hal::InstrumentDevice& device, DeviceBinding binding)
    : model_(&model), data_(&data), bus_(&bus), device_(&device), binding_(std::move(binding)) {
  if (binding_.links.empty()) binding_.links = DeviceBinding::rigid().links;  // see DeviceBinding
  const int links = device.kinematics().num_links();
  for (const LinkBinding& b : binding_.links) {
    if (b.link < 0 || b.link >= links || b.link >= hal::kMaxLinks)
      throw std::invalid_argument("device binding: link " + std::to_string(b.link) +
                                  " out of range (the device has " + std::to_string(links) + ")");
    if (b.body < -1 || b.body >= model.num_bodies())
      throw std::invalid_argument("device binding: body " + std::to_string(b.body) + " out of range");
  }
  for (const AxisPrescription& p : binding_.prescriptions) {
    if (p.joint < 0 || p.joint >= model.num_joints() ||
        !model.joints[static_cast<std::size_t>(p.joint)].prescribed)
      throw std::invalid_argument("device binding: joint " + std::to_string(p.joint) +
                                  " is not a prescribed joint");
    if (p.axis < 0 || p.axis >= device.num_axes())
      throw std::invalid_argument("device binding: axis " + std::to_string(p.axis) + " out of range");
  }
  explicit_bound_.assign(static_cast<std::size_t>(model.num_bodies()), 0);
  for (const LinkBinding& b : binding_.links) {
    if (b.body < 0) continue;
    if (explicit_bound_[static_cast<std::size_t>(b.body)])
      throw std::invalid_argument("device binding: body " + std::to_string(b.body) +
                                  " is bound to two links");
    explicit_bound_[static_cast<std::size_t>(b.body)] = 1;
  }
  link_origin_.assign(binding_.links.size(), core::Vec3::Zero());
  body_target_.assign(binding_.links.size(), core::Vec3::Zero());
  bound_body_.assign(binding_.links.size(), -1);
}

void ControlLoop::apply_targets(const hal::DeviceSample& sample) noexcept {
  core::Data& d = *data_;
  for (std::size_t k = 0; k < binding_.links.size(); ++k) {
    const LinkBinding& b = binding_.links[k];
    int body = b.body < 0 ? d.attached_body : b.body;
    // The attached body follows its own link if it has one; the "attached"
    // binding (body -1) serves only a held body without one (tool switching).
    if (b.body < 0 && body >= 0 && explicit_bound_[static_cast<std::size_t>(body)]) body = -1;
    bound_body_[k] = body;
    const core::Pose& link = sample.link_targets[static_cast<std::size_t>(b.link)];
    const core::Twist& lt = sample.link_twists[static_cast<std::size_t>(b.link)];
    core::Pose pose;
    pose.position = link.position + link.orientation * b.body_in_link.position;
    pose.orientation = link.orientation * b.body_in_link.orientation;
    core::Twist twist;
    twist.angular = lt.angular;
    twist.linear = lt.linear + lt.angular.cross(pose.position - link.position);
    link_origin_[k] = link.position;
    body_target_[k] = pose.position;
    if (body < 0) continue;
    if (body == d.attached_body) {
      d.target = pose;
      d.target_twist = twist;
    } else {
      core::BodyTarget& t = d.body_targets[static_cast<std::size_t>(body)];
      t.pose = pose;
      t.twist = twist;
      t.enabled = true;
    }
  }
  for (const AxisPrescription& p : binding_.prescriptions) {
    core::JointPrescription& jp = d.joint_prescribed[static_cast<std::size_t>(p.joint)];
    jp.value = p.scale * sample.q(p.axis) + p.offset;
    jp.rate = p.scale * sample.qdot(p.axis);
  }
}

bool ControlLoop::send_feedback(std::int64_t now_ns) noexcept {
  const core::Data& d = *data_;
  for (core::Wrench& w : link_wrench_) w = core::Wrench{};
  bool any = false;
  for (std::size_t k = 0; k < binding_.links.size(); ++k) {
    const int body = bound_body_[k];
    if (body < 0) continue;
    any = true;
    const core::Wrench w = core::carry_wrench(d.body_feedback[static_cast<std::size_t>(body)],
                                              body_target_[k], link_origin_[k]);  // Eq. 9
    core::Wrench& acc = link_wrench_[static_cast<std::size_t>(binding_.links[k].link)];
    acc.force += w.force;
    acc.torque += w.torque;
  }
  if (!any) return false;
  const auto n = static_cast<std::size_t>(device_->kinematics().num_links());
  report_.command_status =
      device_->command_links(std::span<const core::Wrench>(link_wrench_.data(), n), *bus_, now_ns);
  return true;
}

void ControlLoop::begin_period(std::int64_t now_ns) noexcept {
  // CiA 301 SYNC counter runs 1..240 when used.
  sync_counter_ = static_cast<std::uint8_t>(sync_counter_ >= 240 ? 1 : sync_counter_ + 1);
  if (bus_->write(hal::make_sync(now_ns, sync_counter_)) != hal::IoStatus::kOk)
    ++counters_.sync_write_failures;
}

const PeriodReport& ControlLoop::end_period(std::int64_t now_ns) noexcept {
  report_ = PeriodReport{};
  ++counters_.periods;
  report_.frames_read = device_->poll(*bus_);
  const hal::DeviceSample sample = device_->sample(now_ns);
  report_.sample_valid = sample.valid;
  report_.target_ready = sample.ready;
  if (sample.ready) apply_targets(sample);

  const std::int64_t t0 = monotonic_now_ns();
  core::step(*model_, *data_);
  report_.step_ns = monotonic_now_ns() - t0;
  step_time_.record(report_.step_ns);

  // Torque only from a sample checked this period: a stale or rejected sample
  // keeps the last good target for the god-object, but the drives get zero
  // torque until fresh plausible data arrive (no "hold the last command").
  if (!(sample.valid && send_feedback(now_ns))) {
    ++counters_.periods_zero_torque;
    report_.command_status = device_->command_zero(*bus_, now_ns);
  }
  if (report_.command_status != hal::IoStatus::kOk) ++counters_.command_failures;
  return report_;
}

}  // namespace numen::platform
