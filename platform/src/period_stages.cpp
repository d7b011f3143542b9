/// @file period_stages.cpp
/// The stages of a control period (period_stages.hpp) and PeriodData's writer table.

#include "numen/platform/period_stages.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include "numen/core/feedback.hpp"
#include "numen/core/rigid_body.hpp"
#include "numen/platform/monotonic_clock.hpp"

namespace numen::platform {

const char* to_string(PeriodStage stage) noexcept {
  switch (stage) {
    case PeriodStage::kNone:
      return "none";
    case PeriodStage::kBegin:
      return "begin";
    case PeriodStage::kRead:
      return "read";
    case PeriodStage::kSupervise:
      return "supervise";
    case PeriodStage::kBind:
      return "bind";
    case PeriodStage::kStep:
      return "step";
    case PeriodStage::kMap:
      return "map";
    case PeriodStage::kSend:
      return "send";
    case PeriodStage::kFinish:
      return "finish";
  }
  return "unknown";
}

namespace {

constexpr std::uint16_t bit(PeriodStage s) noexcept { return static_cast<std::uint16_t>(s); }

std::size_t offset_in(const PeriodData& p, const void* member) noexcept {
  return static_cast<std::size_t>(static_cast<const char*>(member) -
                                  reinterpret_cast<const char*>(&p));
}

std::array<PeriodField, 38> make_period_fields() noexcept {
  const PeriodData p;
#define NUMEN_FIELD(member, writers) \
  PeriodField{#member, offset_in(p, &(p.member)), sizeof(p.member), static_cast<std::uint16_t>(writers)}
  using S = PeriodStage;
  return {{
      NUMEN_FIELD(state, bit(S::kRead)),
      NUMEN_FIELD(supervision, bit(S::kSupervise)),
      NUMEN_FIELD(link_origin, bit(S::kBind)),
      NUMEN_FIELD(body_point, bit(S::kBind)),
      NUMEN_FIELD(bound_body, bit(S::kBind)),
      NUMEN_FIELD(link_wrench, bit(S::kMap)),
      NUMEN_FIELD(tau, bit(S::kMap)),
      NUMEN_FIELD(wrench, bit(S::kBind) | bit(S::kMap)),
      NUMEN_FIELD(held_pose, bit(S::kMap)),
      NUMEN_FIELD(command, bit(S::kMap)),
      NUMEN_FIELD(output, bit(S::kSend)),
      NUMEN_FIELD(report.frames_read, bit(S::kRead)),
      NUMEN_FIELD(report.sample_valid, bit(S::kRead)),
      NUMEN_FIELD(report.target_ready, bit(S::kRead)),
      NUMEN_FIELD(report.step_ns, bit(S::kStep)),
      NUMEN_FIELD(report.command_status, bit(S::kSend)),
      NUMEN_FIELD(report.torque_commanded, bit(S::kSend)),
      NUMEN_FIELD(report.feedback, bit(S::kSend)),
      NUMEN_FIELD(report.driven, bit(S::kBind)),
      NUMEN_FIELD(report.controlword, bit(S::kSend)),
      NUMEN_FIELD(report.sample_faults, bit(S::kRead)),
      NUMEN_FIELD(report.soft_start_ramp, bit(S::kSend)),
      NUMEN_FIELD(report.deadline_ns, bit(S::kBegin)),
      NUMEN_FIELD(report.woke_ns, bit(S::kBegin)),
      NUMEN_FIELD(report.sync_sent_ns, bit(S::kBegin)),
      NUMEN_FIELD(report.input_begin_ns, bit(S::kRead)),
      NUMEN_FIELD(report.input_end_ns, bit(S::kRead)),
      NUMEN_FIELD(report.step_begin_ns, bit(S::kStep)),
      NUMEN_FIELD(report.step_end_ns, bit(S::kStep)),
      NUMEN_FIELD(report.output_begin_ns, bit(S::kMap)),
      NUMEN_FIELD(report.output_end_ns, bit(S::kSend)),
      NUMEN_FIELD(report.overrun, bit(S::kFinish)),
      NUMEN_FIELD(report.lifecycle, bit(S::kFinish)),
      NUMEN_FIELD(report.startup, bit(S::kSupervise)),
      NUMEN_FIELD(report.entered_safe_stop, bit(S::kSupervise)),
      NUMEN_FIELD(report.fault_cause, bit(S::kFinish)),
      NUMEN_FIELD(report.activated, bit(S::kSupervise)),
      NUMEN_FIELD(report, 0),  // the whole report: its fields are listed above
  }};
#undef NUMEN_FIELD
}

constexpr std::array<PeriodStageEntry, 7> kImpedanceStages{{
    {PeriodStage::kRead, "read_device", &read_device},
    {PeriodStage::kSupervise, "supervise_device", &supervise_device},
    {PeriodStage::kBind, "bind_link_targets", &bind_link_targets},
    {PeriodStage::kStep, "step_dynamics", &step_dynamics},
    {PeriodStage::kMap, "map_link_wrenches", &map_link_wrenches},
    {PeriodStage::kSend, "send_command", &send_command},
    {PeriodStage::kFinish, "finish_period", &finish_period},
}};

constexpr std::array<PeriodStageEntry, 7> kAdmittanceStages{{
    {PeriodStage::kRead, "read_device", &read_device},
    {PeriodStage::kSupervise, "supervise_device", &supervise_device},
    {PeriodStage::kBind, "bind_measured_wrench", &bind_measured_wrench},
    {PeriodStage::kStep, "step_dynamics", &step_dynamics},
    {PeriodStage::kMap, "map_held_pose", &map_held_pose},
    {PeriodStage::kSend, "send_command", &send_command},
    {PeriodStage::kFinish, "finish_period", &finish_period},
}};

}  // namespace

std::span<const PeriodField> period_data_fields() noexcept {
  static const std::array<PeriodField, 38> fields = make_period_fields();
  return fields;
}

std::span<const PeriodStageEntry> impedance_period_stages() noexcept { return kImpedanceStages; }
std::span<const PeriodStageEntry> admittance_period_stages() noexcept { return kAdmittanceStages; }

void begin_device_period(PeriodContext& c, PeriodData& p, std::int64_t now_ns,
                         std::int64_t deadline_mono_ns, std::int64_t woke_mono_ns) noexcept {
  PeriodReport& r = p.report;
  const std::int64_t t = monotonic_now_ns();
  r.woke_ns = woke_mono_ns >= 0 ? woke_mono_ns : t;
  r.deadline_ns = deadline_mono_ns >= 0 ? deadline_mono_ns : r.woke_ns;
  if (r.deadline_ns > r.woke_ns) r.deadline_ns = r.woke_ns;
  if (c.device->begin_period(now_ns) != hal::IoStatus::kOk) ++c.counters.sync_write_failures;
  r.sync_sent_ns = monotonic_now_ns();
}

void read_device(PeriodContext& c, PeriodData& p, std::int64_t now_ns) noexcept {
  PeriodReport& r = p.report;
  r.input_begin_ns = monotonic_now_ns();
  const hal::DeviceState& state = c.device->read(now_ns);
  r.input_end_ns = monotonic_now_ns();
  p.state = &state;
  r.frames_read = state.frames_read;
  r.sample_valid = state.valid;
  r.target_ready = state.ready;
  r.sample_faults = state.faults;
  if (state.read_error) ++c.counters.read_errors;
}

void supervise_device(PeriodContext& c, PeriodData& p, std::int64_t now_ns) noexcept {
  PeriodReport& r = p.report;
  // report.overrun is still the previous period's verdict (finish writes this one's).
  p.supervision = c.device->supervise(now_ns, c.supervise_overruns && r.overrun);
  r.entered_safe_stop = p.supervision.entered_safe_stop;
  r.activated = p.supervision.activated;
  r.startup = p.supervision.startup;
  if (r.activated && c.first_active_period < 0)
    c.first_active_period = static_cast<std::int64_t>(c.counters.periods) - 1;
}

namespace {

// The target body `body` has in `d` (the held body's is Data::target).
core::Pose body_target_pose(const core::Data& d, int body) noexcept {
  return body == d.held_body ? d.target : d.body_targets[static_cast<std::size_t>(body)].pose;
}
core::Twist body_target_twist(const core::Data& d, int body) noexcept {
  return body == d.held_body ? d.target_twist : d.body_targets[static_cast<std::size_t>(body)].twist;
}

// The samples came back valid after stale ones (ControlLoopSettings::rejoin_after_stale): the
// targets held until now are where the glide starts; the feedback ramps in again.
void begin_rejoin(PeriodContext& c, const core::Data& d) noexcept {
  c.stale_seen = false;
  for (std::size_t k = 0; k < c.binding.links.size(); ++k) {
    const int body = bound_body(c.binding.links[k], d, c.explicit_bound);
    c.rejoin_from[k] = body >= 0 ? body_target_pose(d, body) : core::Pose{};
  }
  for (std::size_t a = 0; a < c.binding.prescriptions.size() && a < c.rejoin_from_q.size(); ++a)
    c.rejoin_from_q[a] =
        d.joint_prescribed[static_cast<std::size_t>(c.binding.prescriptions[a].joint)].value;
  c.rejoin_k = c.rejoin_steps > 0 ? 0 : -1;
  c.device->ramp_feedback_again();
  ++c.rejoin.rejoins;
  c.rejoin.last_period = static_cast<std::int64_t>(c.counters.periods) - 1;
}

// One period of the glide: each bound body's target (and prescribed value) from where it was
// held to the sample's just applied, on r = 3s² − 2s³ of s = k / steps; the twist the glide's
// rate plus r times the sample's. The first period measures the gap.
void glide_targets(PeriodContext& c, PeriodData& p) noexcept {
  core::Data& d = *c.data;
  const bool first = c.rejoin_k == 0;
  const double steps = static_cast<double>(c.rejoin_steps);
  const double s = static_cast<double>(++c.rejoin_k) / steps;
  const double r = s * s * (3.0 - 2.0 * s);
  const double rate = 6.0 * s * (1.0 - s) / (steps * c.model->dt);  // dr/dt, 1/s
  for (std::size_t k = 0; k < c.binding.links.size(); ++k) {
    const int body = p.bound_body[k];
    if (body < 0) continue;
    const core::Pose live = body_target_pose(d, body);
    const core::Twist live_twist = body_target_twist(d, body);
    const core::Pose& from = c.rejoin_from[k];
    const core::Vec3 gap = live.position - from.position;
    const Eigen::AngleAxisd turn(live.orientation * from.orientation.conjugate());
    if (first) {
      c.rejoin.gap_max_m = std::max(c.rejoin.gap_max_m, gap.norm());
      c.rejoin.gap_max_rad = std::max(c.rejoin.gap_max_rad, std::abs(turn.angle()));
    }
    core::Pose pose{from.position + r * gap,
                    from.orientation.slerp(r, live.orientation).normalized()};
    core::Twist twist;
    twist.linear = r * live_twist.linear + rate * gap;
    twist.angular = r * live_twist.angular + rate * turn.angle() * turn.axis();
    set_body_target(d, body, pose, twist);
    p.body_point[k] = pose.position;
  }
  for (std::size_t a = 0; a < c.binding.prescriptions.size() && a < c.rejoin_from_q.size(); ++a) {
    core::JointPrescription& jp =
        d.joint_prescribed[static_cast<std::size_t>(c.binding.prescriptions[a].joint)];
    const double gap = jp.value - c.rejoin_from_q[a];
    jp.value = c.rejoin_from_q[a] + r * gap;
    jp.rate = r * jp.rate + rate * gap;
  }
  if (c.rejoin_k >= c.rejoin_steps) c.rejoin_k = -1;
}

}  // namespace

void bind_link_targets(PeriodContext& c, PeriodData& p, std::int64_t now_ns) noexcept {
  (void)now_ns;
  const hal::DeviceState& state = *p.state;
  if (c.rejoin_after_stale && state.ready && (state.faults & hal::SampleFault::kStale) != 0)
    c.stale_seen = true;
  if (!state.ready) return;  // a rejected sample keeps the last good target
  core::Data& d = *c.data;
  if (c.rejoin_after_stale && c.stale_seen && state.valid) begin_rejoin(c, d);
  // This device's composite feedback is taken and saturated about its controlled frame (link
  // 0, the tool), where its limits are rated (core::Data::feedback_point).
  if (const auto g = static_cast<std::size_t>(c.index); g < d.feedback_point.size())
    d.feedback_point[g] = state.link_poses[0].position;
  for (std::size_t k = 0; k < c.binding.links.size(); ++k) {
    const LinkBinding& b = c.binding.links[k];
    const auto l = static_cast<std::size_t>(b.link);
    p.link_origin[k] = state.link_poses[l].position;
    p.bound_body[k] = apply_link_target(b, state.link_poses[l], state.link_twists[l], d,
                                        c.explicit_bound, &p.body_point[k]);
  }
  for (const AxisPrescription& a : c.binding.prescriptions)
    apply_prescription(a, state.q(a.axis), state.qdot(a.axis), d);
  if (c.rejoin_k >= 0) glide_targets(c, p);
  if (c.place_pending) {
    // A live input's first sample (ControlLoopSettings::place_at_first_sample): each bound
    // body is brought to its target, where the instrument lies, before the step.
    for (std::size_t k = 0; k < c.binding.links.size(); ++k) {
      const int body = p.bound_body[k];
      if (body < 0) continue;
      const bool held = body == d.held_body;
      const core::BodyTarget& t = d.body_targets[static_cast<std::size_t>(body)];
      const core::Pose& pose = held ? d.target : t.pose;
      const core::Twist& twist = held ? d.target_twist : t.twist;
      core::BodyState& s = d.bodies[static_cast<std::size_t>(body)];
      s.position = pose.position;
      s.orientation = pose.orientation;
      s.linear_velocity = twist.linear;
      s.angular_velocity = twist.angular;
    }
    c.place_pending = false;
    c.placed_period = static_cast<std::int64_t>(c.counters.periods) - 1;
  }
}

void bind_measured_wrench(PeriodContext& c, PeriodData& p, std::int64_t now_ns) noexcept {
  (void)now_ns;
  core::Data& d = *c.data;
  const core::Model& m = *c.model;
  const int a = d.held_body;
  const bool held = a >= 0 && a < m.num_bodies();
  const bool active =
      c.device->lifecycle() == hal::LifecycleState::kActive && !c.device->shutting_down();
  p.report.driven = active && held;
  if (p.report.driven) {
    // The last accepted reading (held up to the timeout), in the world, about the held body's COM.
    d.device_wrench = core::carry_wrench(p.state->wrench, p.state->wrench_point,
                                         d.bodies[static_cast<std::size_t>(a)].position);
    p.wrench = d.device_wrench;
    return;
  }
  // The brake: halves the held body's twist every step (stable in both integrators:
  // h·b/m = 0.5): −0.5 m v / h, −0.5 I_w ω / h.
  p.wrench = core::Wrench{};
  d.device_wrench = core::Wrench{};
  if (!held) return;
  const core::BodyModel& bm = m.bodies[static_cast<std::size_t>(a)];
  const core::BodyState& s = d.bodies[static_cast<std::size_t>(a)];
  const double k = 0.5 / m.dt;
  d.device_wrench.force = -k * bm.mass * s.linear_velocity;
  d.device_wrench.torque =
      -k * (core::world_inertia(s.orientation, bm.inertia_body) * s.angular_velocity);
}

void step_dynamics(PeriodContext& c, PeriodData& p, std::int64_t now_ns) noexcept {
  (void)now_ns;
  PeriodReport& r = p.report;
  if (c.index > 0) {  // one step a period (device 0's): the others take its stamps
    const PeriodReport& lead = c.records[0].report;
    r.step_begin_ns = lead.step_begin_ns;
    r.step_end_ns = lead.step_end_ns;
    r.step_ns = lead.step_ns;
    return;
  }
  r.step_begin_ns = monotonic_now_ns();
  c.stepper->step(*c.model, *c.data);
  r.step_end_ns = monotonic_now_ns();
  r.step_ns = r.step_end_ns - r.step_begin_ns;
  c.step_time.record(r.step_ns);
}

void map_link_wrenches(PeriodContext& c, PeriodData& p, std::int64_t now_ns) noexcept {
  (void)now_ns;
  p.report.output_begin_ns = monotonic_now_ns();
  const hal::DeviceState& state = *p.state;
  const core::Data& d = *c.data;
  // Σ of the bound bodies' Eq. 8 wrenches per link, each carried to its link's origin (Eq. 9).
  for (core::Wrench& w : p.link_wrench) w = core::Wrench{};
  for (std::size_t k = 0; k < c.binding.links.size(); ++k) {
    const int body = p.bound_body[k];
    if (body < 0) continue;
    const core::Wrench w = core::carry_wrench(d.body_feedback[static_cast<std::size_t>(body)],
                                              p.body_point[k], p.link_origin[k]);
    core::Wrench& acc = p.link_wrench[static_cast<std::size_t>(c.binding.links[k].link)];
    acc.force += w.force;
    acc.torque += w.torque;
  }
  // τ = Σ_l J_lᵀ w_l with the Jacobians of this period's state: computed as it is, NaN
  // included (the device's write() trips on a non-finite τ); a link without a driven body has
  // w = 0.
  const auto links = static_cast<std::size_t>(state.num_links);
  const std::span<const core::Wrench> w(p.link_wrench.data(), links);
  if (!hal::all_finite(w)) ++c.counters.non_finite_wrenches;
  hal::torques_from_link_wrenches(std::span<const hal::Jacobian>(state.link_jacobians.data(), links),
                                  w, p.tau);
  // The wrench the drives are asked to render, about link 0's origin (Eq. 9).
  p.wrench = core::Wrench{};
  const core::Vec3 origin0 = state.link_poses[0].position;
  for (std::size_t l = 0; l < links; ++l) {
    const core::Wrench carried =
        core::carry_wrench(p.link_wrench[l], state.link_poses[l].position, origin0);
    p.wrench.force += carried.force;
    p.wrench.torque += carried.torque;
  }
  p.command.torques = std::span<const double>(p.tau.data(), static_cast<std::size_t>(p.tau.size()));
  p.command.pose = nullptr;
}

void map_held_pose(PeriodContext& c, PeriodData& p, std::int64_t now_ns) noexcept {
  (void)now_ns;
  p.report.output_begin_ns = monotonic_now_ns();
  const core::Data& d = *c.data;
  const int a = d.held_body;
  p.command.torques = {};
  p.command.pose = nullptr;
  if (a < 0 || a >= c.model->num_bodies()) return;  // none held: the set-points are held
  const core::BodyState& s = d.bodies[static_cast<std::size_t>(a)];
  p.held_pose = core::Pose{s.position, s.orientation};
  p.command.pose = &p.held_pose;
}

namespace {

bool in_safe_state(hal::LifecycleState s) noexcept {
  return s == hal::LifecycleState::kSafeStop || s == hal::LifecycleState::kFault;
}

// The fault policy between the loop's devices (docs/safety.md "Several devices"): the first
// other device in its safe state after this period's supervision, −1 for none.
int peer_in_safe_state(const PeriodContext& c) noexcept {
  for (std::size_t j = 0; j < c.records.size(); ++j) {
    if (static_cast<int>(j) != c.index && in_safe_state(c.records[j].supervision.lifecycle))
      return static_cast<int>(j);
  }
  return -1;
}

}  // namespace

void send_command(PeriodContext& c, PeriodData& p, std::int64_t now_ns) noexcept {
  PeriodReport& r = p.report;
  const int peer = peer_in_safe_state(c);
  if (peer >= 0 && c.device->lifecycle() == hal::LifecycleState::kActive)
    c.device->latch_safe_state(hal::FaultCause::kPeerFault, static_cast<std::uint8_t>(peer));
  c.device->hold_activation(peer >= 0);
  const hal::DeviceOutput& out = c.device->write(p.command, now_ns);
  r.output_end_ns = monotonic_now_ns();
  p.output = &out;
  r.command_status = out.status;
  r.soft_start_ramp = out.ramp;
  r.controlword = out.controlword;
  r.torque_commanded = out.torque_commanded;
  // What the drives render: zero when gated, the soft start's r times the wrench otherwise.
  if (out.gated) {
    r.feedback = core::Wrench{};
  } else if (out.ramp < 1.0) {
    r.feedback.force = p.wrench.force * out.ramp;
    r.feedback.torque = p.wrench.torque * out.ramp;
  } else {
    r.feedback = p.wrench;
  }
}

void finish_period(PeriodContext& c, PeriodData& p, std::int64_t now_ns) noexcept {
  (void)now_ns;
  PeriodReport& r = p.report;
  // Outside the timed step, after every device's commands (stage by stage: all sent).
  if (c.index == 0) c.stepper->finish(*c.model, *c.data);
  r.lifecycle = c.device->lifecycle();    // after the write: a non-finite τ trips it
  const hal::FaultRecord* f = c.device->first_fault();
  r.fault_cause = f != nullptr ? f->cause : hal::FaultCause::kNone;
  const auto period = static_cast<std::int64_t>(c.counters.periods) - 1;
  if (!r.torque_commanded) ++c.counters.periods_zero_torque;
  if (r.torque_commanded && c.first_torque_period < 0) c.first_torque_period = period;
  if (r.command_status != hal::IoStatus::kOk) ++c.counters.command_failures;
  r.overrun = c.index == 0 ? c.stats->record_period(loop_period_times(c.records)).overrun
                           : c.records[0].report.overrun;
}

PeriodTimes loop_period_times(std::span<const PeriodData> records) noexcept {
  const PeriodReport& first = records.front().report;
  const PeriodReport& last = records.back().report;
  PeriodTimes t = first.times();
  t.sync_sent_ns = last.sync_sent_ns;
  t.input_end_ns = last.input_end_ns;
  t.output_end_ns = last.output_end_ns;
  return t;
}

}  // namespace numen::platform
