/// @file control_loop.cpp

#include "numen/platform/control_loop.hpp"

#include <cmath>
#include <span>
#include <stdexcept>
#include <string>

#include "numen/core/joint.hpp"

namespace numen::platform {

namespace {

std::int64_t period_of(const hal::DeviceConfig& config) {
  return static_cast<std::int64_t>(std::llround(config.control_period_s * 1e9));
}

}  // namespace

ControlLoop::ControlLoop(const core::Model& model, core::Data& data, hal::Bus& bus,
                         hal::InstrumentDevice& device, DeviceBinding binding,
                         const ControlLoopSettings& settings)
    : owned_(hal::make_device(device, bus, period_of(device.config()),
                              static_cast<const hal::ImpedanceSettings&>(settings))),
      stats_(std::make_unique<LoopStatistics>(period_of(device.config()))),
      stages_(impedance_period_stages()) {
  init_context(model, data, *owned_, settings);
  context_.binding = std::move(binding);
  if (context_.binding.links.empty())
    context_.binding.links = DeviceBinding::rigid().links;  // see DeviceBinding
  const DeviceBinding& wiring = context_.binding;
  if (wiring.links.size() > static_cast<std::size_t>(kMaxLinkBindings))
    throw std::invalid_argument("device binding: " + std::to_string(wiring.links.size()) +
                                " link bindings (at most " + std::to_string(kMaxLinkBindings) + ")");
  const int links = device.kinematics().num_links();
  for (const LinkBinding& b : wiring.links) {
    if (b.link < 0 || b.link >= links || b.link >= hal::kMaxLinks)
      throw std::invalid_argument("device binding: link " + std::to_string(b.link) +
                                  " out of range (the device has " + std::to_string(links) + ")");
    if (b.body < -1 || b.body >= model.num_bodies())
      throw std::invalid_argument("device binding: body " + std::to_string(b.body) + " out of range");
  }
  for (const AxisPrescription& p : wiring.prescriptions) {
    if (p.joint < 0 || p.joint >= model.num_joints() ||
        !model.joints[static_cast<std::size_t>(p.joint)].prescribed)
      throw std::invalid_argument("device binding: joint " + std::to_string(p.joint) +
                                  " is not a prescribed joint");
    if (p.axis < 0 || p.axis >= device.num_axes())
      throw std::invalid_argument("device binding: axis " + std::to_string(p.axis) + " out of range");
  }
  context_.explicit_bound = explicitly_bound_bodies(wiring, model.num_bodies());
  period_.bound_body.fill(-1);
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
    if (b.body < 0 || b.body == data.attached_body) continue;
    const core::BodyState& start = data.bodies[static_cast<std::size_t>(b.body)];
    core::BodyTarget& t = data.body_targets[static_cast<std::size_t>(b.body)];
    t.pose.position = start.position;
    t.pose.orientation = start.orientation;
    t.twist = core::Twist{};
    t.enabled = true;
  }
  period_.tau = hal::AxisVector::Zero(device.num_axes());
}

ControlLoop::ControlLoop(const core::Model& model, core::Data& data,
                         hal::AdmittanceDevice& device, const ControlLoopSettings& settings)
    : stats_(std::make_unique<LoopStatistics>(period_of(device.config()))),
      stages_(admittance_period_stages()) {
  if (model.coupling_mode != core::CouplingMode::kAdmittance)
    throw std::invalid_argument("admittance device '" + device.config().name +
                                "': the model's coupling mode must be admittance");
  init_context(model, data, device, settings);
  period_.bound_body.fill(-1);
}

void ControlLoop::init_context(const core::Model& model, core::Data& data, hal::Device& device,
                               const ControlLoopSettings& settings) {
  context_.model = &model;
  context_.data = &data;
  context_.device = &device;
  context_.stepper = &core_stepper_;
  context_.supervise_overruns = settings.supervise_overruns;
  context_.stats = stats_.get();
}

void ControlLoop::begin_period(std::int64_t now_ns, std::int64_t deadline_mono_ns,
                               std::int64_t woke_mono_ns) noexcept {
  begin_device_period(context_, period_, now_ns, deadline_mono_ns, woke_mono_ns);
}

const PeriodReport& ControlLoop::end_period(std::int64_t now_ns, PeriodObserver* observer) noexcept {
  ++context_.counters.periods;
  for (const PeriodStageEntry& stage : stages_) {
    stage.run(context_, period_, now_ns);
    if (observer != nullptr) observer->after_stage(stage, period_);
  }
  return period_.report;
}

RearmResult ControlLoop::rearm() noexcept { return context_.device->rearm(); }

hal::LifecycleResult ControlLoop::activate() noexcept {
  const hal::LifecycleResult r = context_.device->activate();
  if (r == hal::LifecycleResult::kOk && context_.first_active_period < 0) {
    context_.first_active_period = static_cast<std::int64_t>(context_.counters.periods) - 1;
  }
  return r;
}

void ControlLoop::shutdown() noexcept { context_.device->shutdown(); }

bool ControlLoop::drives_disabled() const noexcept { return context_.device->drives_disabled(); }

}  // namespace numen::platform
