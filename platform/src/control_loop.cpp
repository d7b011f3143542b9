/// @file control_loop.cpp

#include "numen/platform/control_loop.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <span>
#include <stdexcept>
#include <string>

#include "numen/core/joint.hpp"
#include "numen/hal/device/admittance_device.hpp"

namespace numen::platform {

namespace {

// The device's control period when it is the model's step (Model::dt, the one source of the
// period: the scene copies it into DeviceConfig::control_period_s); throws otherwise.
std::int64_t period_of(const hal::DeviceConfig& config, const core::Model& model) {
  const auto period = static_cast<std::int64_t>(std::llround(config.control_period_s * 1e9));
  if (period != static_cast<std::int64_t>(std::llround(model.dt * 1e9)))
    throw std::invalid_argument("device '" + config.name + "': control_period_s " +
                                std::to_string(config.control_period_s) +
                                " s is not the model's step dt " + std::to_string(model.dt) +
                                " s (one period steps the model once)");
  return period;
}

}  // namespace

ControlLoop::ControlLoop(const core::Model& model, core::Data& data, hal::Bus& bus,
                         hal::InstrumentDevice& device, DeviceBinding binding,
                         const ControlLoopSettings& settings)
    : ControlLoop(model, data,
                  std::span<const LoopDevice>(std::array<LoopDevice, 1>{LoopDevice{
                      &bus, &device, std::move(binding),
                      static_cast<const hal::ImpedanceSettings&>(settings)}}),
                  settings) {}

ControlLoop::ControlLoop(const core::Model& model, core::Data& data,
                         std::span<const LoopDevice> devices, const ControlLoopSettings& settings)
    : ControlLoop(model, data, std::make_unique<DeviceRig>(devices), settings) {}

ControlLoop::ControlLoop(const core::Model& model, core::Data& data,
                         hal::AdmittanceDevice& device, const ControlLoopSettings& settings)
    : ControlLoop(model, data, std::make_unique<DeviceRig>(device), settings) {}

ControlLoop::ControlLoop(const core::Model& model, core::Data& data,
                         std::unique_ptr<DeviceRig> owned, const ControlLoopSettings& settings)
    : ControlLoop(model, data, *owned, settings) {
  owned_rig_ = std::move(owned);
}

ControlLoop::ControlLoop(const core::Model& model, core::Data& data, DeviceRig& rig,
                         const ControlLoopSettings& settings)
    : rig_(&rig),
      stats_(std::make_unique<LoopStatistics>(period_of(
          rig.kind() == DeviceKind::kAdmittance ? rig.admittance()->config()
                                                : rig.instrument(0)->config(),
          model))),
      num_devices_(rig.size()),
      stages_(rig.kind() == DeviceKind::kAdmittance ? admittance_period_stages()
                                                    : impedance_period_stages()) {
  if (rig.kind() == DeviceKind::kAdmittance) {
    if (model.coupling_mode != core::CouplingMode::kAdmittance)
      throw std::invalid_argument("admittance device '" + rig.admittance()->config().name +
                                  "': the model's coupling mode must be admittance");
    init_context(0, model, data, rig.device(0), settings);
    periods_[0].bound_body.fill(-1);
    return;
  }
  bind_all(model, data, settings);
}

ControlLoop::~ControlLoop() = default;

void ControlLoop::bind_all(const core::Model& model, core::Data& data,
                           const ControlLoopSettings& settings) {
  // Every device's bodies: bound at most once over the loop (explicitly_bound_bodies() throws
  // for a body bound twice), the held body by one rigid binding at most.
  DeviceBinding all;
  int rigid_user = -1;
  for (std::size_t i = 0; i < num_devices_; ++i) {
    const DeviceBinding& binding = rig_->binding(i);
    const std::vector<LinkBinding>& links =
        is_default_rigid(binding) ? DeviceBinding::rigid().links : binding.links;
    for (const LinkBinding& b : links) {
      all.links.push_back(b);
      if (b.body >= 0) continue;
      if (rigid_user >= 0 && rigid_user != static_cast<int>(i))
        throw std::invalid_argument(
            "control loop: devices " + std::to_string(rigid_user) + " and " + std::to_string(i) +
            " both drive the held body (a link binding of body -1" +
            (is_default_rigid(binding)
                 ? ": device " + std::to_string(i) +
                       "'s binding is empty, which is the rigid binding, link 0 -> the held "
                       "body; bind it to a body of its own)"
                 : std::string(")")));
      rigid_user = static_cast<int>(i);
    }
  }
  for (std::size_t i = 0; i < num_devices_; ++i) {
    init_context(i, model, data, rig_->device(i), settings);
    bind(i, model, data, *rig_->instrument(i), rig_->binding(i));
  }
  const std::vector<std::uint8_t> bound = explicitly_bound_bodies(all, model.num_bodies());
  for (std::size_t i = 0; i < num_devices_; ++i) contexts_[i].explicit_bound = bound;
  // Each body's feedback is its driver's (core::Data::feedback_group): a body bound by a
  // device is that device's, any other (the held body when it has no binding of its own) the
  // rigid binding's device's — so one device's load never scales another's feedback.
  std::fill(data.feedback_group.begin(), data.feedback_group.end(), std::max(rigid_user, 0));
  for (std::size_t i = 0; i < num_devices_; ++i)
    for (const LinkBinding& b : contexts_[i].binding.links)
      if (b.body >= 0) data.feedback_group[static_cast<std::size_t>(b.body)] = static_cast<int>(i);
  // ... taken about each device's own tool (core::Data::feedback_point, written every period).
  if (data.feedback_point.size() < num_devices_)
    data.feedback_point.resize(num_devices_,
                               core::Vec3::Constant(std::numeric_limits<double>::quiet_NaN()));
}

void ControlLoop::bind(std::size_t i, const core::Model& model, core::Data& data,
                       const hal::InstrumentDevice& instrument, DeviceBinding binding) {
  PeriodContext& c = contexts_[i];
  c.binding = std::move(binding);
  if (is_default_rigid(c.binding)) c.binding.links = DeviceBinding::rigid().links;  // see there
  const DeviceBinding& wiring = c.binding;
  const std::string who = num_devices_ > 1 ? "device " + std::to_string(i) + " binding: "
                                           : std::string("device binding: ");
  if (wiring.links.size() > static_cast<std::size_t>(kMaxLinkBindings))
    throw std::invalid_argument(who + std::to_string(wiring.links.size()) +
                                " link bindings (at most " + std::to_string(kMaxLinkBindings) + ")");
  const int links = instrument.kinematics().num_links();
  for (const LinkBinding& b : wiring.links) {
    if (b.link < 0 || b.link >= links || b.link >= hal::kMaxLinks)
      throw std::invalid_argument(who + "link " + std::to_string(b.link) +
                                  " out of range (the device has " + std::to_string(links) + ")");
    if (b.body < -1 || b.body >= model.num_bodies())
      throw std::invalid_argument(who + "body " + std::to_string(b.body) + " out of range");
  }
  for (const AxisPrescription& p : wiring.prescriptions) {
    if (p.joint < 0 || p.joint >= model.num_joints() ||
        !model.joints[static_cast<std::size_t>(p.joint)].prescribed)
      throw std::invalid_argument(who + "joint " + std::to_string(p.joint) +
                                  " is not a prescribed joint");
    if (p.axis < 0 || p.axis >= instrument.num_axes())
      throw std::invalid_argument(who + "axis " + std::to_string(p.axis) + " out of range");
  }
  c.explicit_bound = explicitly_bound_bodies(wiring, model.num_bodies());
  // The glide after stale samples lasts the device's soft start (at least a period when there
  // is one).
  const double soft_start = instrument.config().soft_start_s;
  c.rejoin_steps = std::isfinite(soft_start) && soft_start > 0.0 && model.dt > 0.0
                       ? std::max(1, static_cast<int>(std::lround(soft_start / model.dt)))
                       : 0;
  PeriodData& period = periods_[i];
  period.bound_body.fill(-1);
  // Until the device has a target, the prescribed joints hold their starting coordinates (the
  // managed stack's start-up has no encoder values for its first periods).
  for (const AxisPrescription& p : wiring.prescriptions) {
    const core::JointModel& jm = model.joints[static_cast<std::size_t>(p.joint)];
    const core::BodyState* parent =
        jm.parent >= 0 ? &data.bodies[static_cast<std::size_t>(jm.parent)] : nullptr;
    data.joint_prescribed[static_cast<std::size_t>(p.joint)] = core::JointPrescription{
        core::joint_coordinate(jm, parent, data.bodies[static_cast<std::size_t>(jm.child)]), 0.0};
  }
  // ... and a body bound to a link holds its starting pose (a target at rest where it is).
  // Without one, such a body other than the held one has no target before the first sample: in
  // direct coupling it is then left to its joints alone, and a body jointed both to the world and
  // to the imposed held body (the default scene's trocar sleeve) is over-constrained — a singular
  // solve and a rolled-back, non-finite step in every period before the first sample.
  for (const LinkBinding& b : wiring.links) {
    if (b.body < 0 || b.body == data.held_body) continue;
    const core::BodyState& start = data.bodies[static_cast<std::size_t>(b.body)];
    core::BodyTarget& t = data.body_targets[static_cast<std::size_t>(b.body)];
    t.pose.position = start.position;
    t.pose.orientation = start.orientation;
    t.twist = core::Twist{};
    t.enabled = true;
  }
  period.tau = hal::AxisVector::Zero(instrument.num_axes());
}

void ControlLoop::init_context(std::size_t i, const core::Model& model, core::Data& data,
                               hal::Device& device, const ControlLoopSettings& settings) {
  PeriodContext& c = contexts_[i];
  c.model = &model;
  c.data = &data;
  c.device = &device;
  c.stepper = &core_stepper_;
  c.supervise_overruns = settings.supervise_overruns;
  c.place_pending = settings.place_at_first_sample;
  c.rejoin_after_stale = settings.rejoin_after_stale;
  c.stats = stats_.get();
  c.index = static_cast<int>(i);
  c.records = std::span<const PeriodData>(periods_.data(), num_devices_);
}

void ControlLoop::begin_period(std::int64_t now_ns, std::int64_t deadline_mono_ns,
                               std::int64_t woke_mono_ns) noexcept {
  for (std::size_t i = 0; i < num_devices_; ++i)
    begin_device_period(contexts_[i], periods_[i], now_ns, deadline_mono_ns, woke_mono_ns);
}

const PeriodReport& ControlLoop::end_period(std::int64_t now_ns, PeriodObserver* observer) noexcept {
  for (std::size_t i = 0; i < num_devices_; ++i) ++contexts_[i].counters.periods;
  for (const PeriodStageEntry& stage : stages_) {
    for (std::size_t i = 0; i < num_devices_; ++i) {
      stage.run(contexts_[i], periods_[i], now_ns);
      if (observer != nullptr) observer->after_stage(stage, periods_[i]);
    }
  }
  return periods_[0].report;
}

void ControlLoop::set_stepper(Stepper* stepper) noexcept {
  for (PeriodContext& c : contexts_) c.stepper = stepper != nullptr ? stepper : &core_stepper_;
}

RearmResult ControlLoop::rearm() noexcept {
  RearmResult first = RearmResult::kNotLatched;
  bool accepted = false;
  for (std::size_t i = 0; i < num_devices_; ++i) {
    const RearmResult r = contexts_[i].device->rearm();
    if (i == 0) first = r;
    accepted = accepted || r == RearmResult::kAccepted;
  }
  return accepted ? RearmResult::kAccepted : first;
}

bool ControlLoop::rearm_pending() const noexcept {
  for (std::size_t i = 0; i < num_devices_; ++i)
    if (contexts_[i].device->rearm_pending()) return true;
  return false;
}

hal::LifecycleResult ControlLoop::activate() noexcept {
  hal::LifecycleResult result = hal::LifecycleResult::kOk;
  for (std::size_t i = 0; i < num_devices_; ++i) {
    PeriodContext& c = contexts_[i];
    const hal::LifecycleResult r = c.device->activate();
    if (r == hal::LifecycleResult::kOk && c.first_active_period < 0)
      c.first_active_period = static_cast<std::int64_t>(c.counters.periods) - 1;
    if (r != hal::LifecycleResult::kOk && result == hal::LifecycleResult::kOk) result = r;
  }
  return result;
}

void ControlLoop::shutdown() noexcept {
  for (std::size_t i = 0; i < num_devices_; ++i) contexts_[i].device->shutdown();
}

bool ControlLoop::drives_disabled() const noexcept {
  for (std::size_t i = 0; i < num_devices_; ++i)
    if (!contexts_[i].device->drives_disabled()) return false;
  return true;
}

}  // namespace numen::platform
