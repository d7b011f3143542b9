/// @file study_stability_scene.cpp
/// Scene cases of the family "extreme" of `numen study stability` (study_stability.hpp):
///  - "deformable-jump": the deformable probe of sim/scenes/deformable.toml (gravity off) whose
///    target jumps 10 cm towards the post in one period (core driven directly);
///  - "trocar-zero-insertion": the articulated trocar instrument of sim/scenes/lattice.toml, whose
///    hand pulls the tip back to the trocar point (insertion depth d → 1 µm, below the encoder's
///    10 µm count: the controller reads d = 0, the pivot's singular point where the tip no longer
///    moves with the pivot angles) while the shaft keeps wobbling ±0.3 rad at 2 Hz, then holds it;
///    run through the whole control loop (SceneRunner: SimBus, encoders,
///    InstrumentDevice checks, ControlLoop, core, Jᵀ F torques);
///  - "bus-nonfinite": the same loop while the encoders send, for 30 periods, what NaN, +Inf and
///    −Inf become on the wire (hal::value_to_counts: the offset counts and the int32 extremes);
///  - "core-target-nonfinite": NaN / ±Inf written straight into core::Data's target pose and twist
///    for 20 steps (what the core does if anything non-finite ever got through);
///  - "organ-plunge" (study_stability_organ.cpp): the organ of sim/scenes/default.toml (given by
///    its material), plunged into; "organ-plunge-per-spring" its surface net given the constants
///    per spring it had before (kShippedPerSpringOrgan).
/// The loop cases' verdict: every period core::Data finite (bodies, nodes, target, feedback) and
/// no rollback, nothing non-finite reaching the core (no kInvalidTarget), drive torques finite and
/// within each axis's max_torque, zero in every period whose input was bad; tool speeds below
/// 10 m/s and 1000 rad/s (the hand moves at < 1 m/s and < 10 rad/s) and joint drift below 5 mm in
/// place of the energy bound (the loop's input work is not metered).

#include <cmath>
#include <numbers>
#include <cstdio>
#include <limits>
#include <memory>
#include <optional>
#include <tuple>

#include "numen/hal/canopen/canopen.hpp"
#include "numen/hal/device/axis.hpp"
#include "numen/hal/device/sample_check.hpp"
#include "numen/sim/run/run.hpp"
#include "numen/sim/scene/scene.hpp"
#include "numen/sim/study/study_common.hpp"
#include "numen/sim/study/study_stability_cases.hpp"

namespace numen::sim::stability {
namespace {

using core::Quat;
using core::Vec3;

constexpr double kMaxSpeed = 10.0;              // m/s
constexpr double kMaxAngularSpeed = 1000.0;     // rad/s
constexpr double kLoopDriftBound = 0.005;       // m
constexpr double kLoopPenetrationBound = 0.01;  // m

bool data_finite(const core::Data& d) noexcept {
  bool ok = d.target.position.allFinite() && d.target.orientation.coeffs().allFinite() &&
            d.target_twist.linear.allFinite() && d.target_twist.angular.allFinite() &&
            d.feedback_wrench.force.allFinite() && d.feedback_wrench.torque.allFinite();
  for (const core::BodyState& s : d.bodies)
    ok = ok && s.position.allFinite() && s.orientation.coeffs().allFinite() &&
         s.linear_velocity.allFinite() && s.angular_velocity.allFinite();
  for (const core::BodyTarget& t : d.body_targets)
    ok = ok && t.pose.position.allFinite() && t.pose.orientation.coeffs().allFinite();
  for (const core::NodeState& n : d.nodes)
    ok = ok && n.position.allFinite() && n.velocity.allFinite();
  return ok;
}

/// "stiffest coupling ω h = … (body)": the largest √(k/m) h of the bodies' translational and
/// rotational coupling springs (smallest principal inertia) and of the nets' ties.
std::string stiffest(const core::Model& model) {
  double best = 0.0;
  std::string what = "none";
  for (const core::BodyModel& b : model.bodies) {
    const double i_min = b.inertia_body.diagonal().minCoeff();
    const double wt = std::sqrt(b.coupling.k_t / b.mass), wr = std::sqrt(b.coupling.k_r / i_min);
    if (wt > best) best = wt, what = b.name + " translation";
    if (wr > best) best = wr, what = b.name + " rotation";
  }
  for (const core::NetModel& net : model.nets)
    for (int i = net.node_begin; i < net.node_begin + net.node_count; ++i) {
      const double w =
          std::sqrt(core::tie_scale(net, i) * net.tie_stiffness / model.node_mass[static_cast<std::size_t>(i)]);
      if (w > best) best = w, what = net.name + " tie";
    }
  char buf[128];
  std::snprintf(buf, sizeof buf, "stiffest coupling omega h = %.3g (%s)", best * model.dt,
                what.c_str());
  return buf;
}

StabilityRow scene_row(const char* name, core::Integrator integrator, double h) {
  StabilityRow r = make_row("extreme", name, integrator, h, kNaN, kNaN, kNaN, "", kNaN);
  r.energy_ratio_max = kNaN;
  return r;
}

// ---- deformable probe, 10 cm jump ----

/// The symplectic Euler's two limits for a net (docs/deformable.md, "Symplectic Euler"): the
/// largest h √(λ/m) of a node with the Gershgorin bound λ ≤ k_tie + 2 Σ k of its springs, and
/// h Σγ_tie |ρ⊥|² / I_r + h² Σk_tie |ρ⊥|² / (2 I_r) of the rigid component turning against its net
/// about each principal axis (I_r = I I_net / (I + I_net)), and the explicit damping of a node,
/// h (γ_tie + 2 Σ γ of its springs) / m (Gershgorin bound; v ← v (1 − h γ/m) needs h γ/m < 2);
/// all must stay below 2.
std::tuple<double, double, double> symplectic_net_limits(const core::Model& model, double h) {
  std::vector<double> k_sum(static_cast<std::size_t>(model.num_nodes()), 0.0);
  std::vector<double> g_sum(k_sum.size(), 0.0);
  for (const core::NetSpring& sp : model.net_springs) {
    k_sum[static_cast<std::size_t>(sp.node_a)] += sp.stiffness;
    k_sum[static_cast<std::size_t>(sp.node_b)] += sp.stiffness;
    g_sum[static_cast<std::size_t>(sp.node_a)] += sp.damping;
    g_sum[static_cast<std::size_t>(sp.node_b)] += sp.damping;
  }
  double node = 0.0, turn = 0.0, damp = 0.0;
  for (const core::NetModel& net : model.nets) {
    const core::BodyModel& body = model.bodies[static_cast<std::size_t>(net.body)];
    for (int axis = 0; axis < 3; ++axis) {
      const Vec3 e = Vec3::Unit(axis);
      double i_net = 0.0, s_k = 0.0, s_g = 0.0;
      for (int i = net.node_begin; i < net.node_begin + net.node_count; ++i) {
        const auto k = static_cast<std::size_t>(i);
        const Vec3 rho = model.node_rest[k];
        const double r2 = (rho - rho.dot(e) * e).squaredNorm();
        i_net += model.node_mass[k] * r2;
        s_k += core::tie_scale(net, i) * net.tie_stiffness * r2;
        s_g += core::tie_scale(net, i) * net.tie_damping * r2;
      }
      const double inertia = body.inertia_body(axis, axis);
      const double i_r = inertia * i_net / (inertia + i_net);
      if (i_r > 0.0) turn = std::max(turn, h * s_g / i_r + h * h * s_k / (2.0 * i_r));
    }
    for (int i = net.node_begin; i < net.node_begin + net.node_count; ++i) {
      const auto k = static_cast<std::size_t>(i);
      node =
          std::max(node, h * std::sqrt((core::tie_scale(net, i) * net.tie_stiffness + 2.0 * k_sum[k]) /
                                       model.node_mass[k]));
      damp = std::max(damp, h * (core::tie_scale(net, i) * net.tie_damping + 2.0 * g_sum[k]) /
                                model.node_mass[k]);
    }
  }
  return {node, turn, damp};
}

StabilityRow deformable_run(const Scene& scene, core::Integrator integrator, double h,
                            const StabilityLimits& limits, double horizon) {
  core::Model base = scene.model;
  base.gravity = Vec3::Zero();
  const int held = base.initial_held_body;
  // The post: the first capsule. The probe starts 10 cm from its axis (perpendicular to it, on the
  // side where the scene places the probe) and 2 mm off-centre, as the scene's pass; the target
  // then jumps onto the post's axis.
  const core::BodyModel& tool = base.bodies[static_cast<std::size_t>(held)];
  Vec3 post = Vec3::Zero(), axis = Vec3::UnitZ();
  for (const core::Obstacle& o : base.obstacles)
    if (o.type == core::ShapeType::kCapsule) {
      post = o.pose.position;
      axis = o.pose.orientation * Vec3::UnitZ();
      break;
    }
  Vec3 away = tool.initial_pose.position - post;
  away -= away.dot(axis) * axis;
  away = away.norm() > 1e-9 ? away.normalized() : axis.unitOrthogonal();
  const Vec3 side = 0.002 * axis.cross(away).normalized();
  const Vec3 hit = post + side;
  base.bodies[static_cast<std::size_t>(held)].initial_pose.position = hit + 0.1 * away;
  const core::Model model = study::with_scheme(base, integrator, h, "stability study");
  core::Data data = core::make_data(model);
  const core::BodyState start = data.bodies[static_cast<std::size_t>(held)];
  // Static penetration F/k with the whole coupling force of the jump, k_t · 10 cm, on one node
  // contact (an upper bound: it spreads over several).
  double k_contact = kInf;
  for (const core::MaterialPair& p : model.material_pairs)
    k_contact = std::min(k_contact, p.stiffness);
  const double static_depth =
      model.bodies[static_cast<std::size_t>(held)].coupling.k_t * 0.1 / k_contact;
  double tool_mass = model.bodies[static_cast<std::size_t>(held)].mass;
  for (const core::NetModel& net : model.nets) tool_mass += net.mass;
  const auto n = std::max<std::int64_t>(1, std::llround(horizon / h));
  const std::int64_t jump = std::max<std::int64_t>(1, std::llround(0.05 / h));
  Monitor monitor(limits, limits.penetration_factor * static_depth, kInf, n, tool_mass, h);
  drive(
      model, data, n,
      [&](std::int64_t k, core::Data& d) noexcept {
        d.target.position = k >= jump ? hit : start.position;
        d.target.orientation = start.orientation;
        d.target_twist = core::Twist{};
      },
      monitor);
  StabilityRow r = scene_row("deformable-jump", integrator, h);
  r.mass_kg = model.bodies[static_cast<std::size_t>(held)].mass;
  r.stiffness = model.nets.empty() ? kNaN : model.nets[0].tie_stiffness;
  r.parameter = 0.1;
  r.parameter_name = "jump_m";
  monitor.fill(r);
  double strain = 0.0;
  for (const core::NetOutput& o : data.nets) strain = std::max(strain, o.max_strain);
  const auto [node_limit, turn_limit, damping_limit] = symplectic_net_limits(model, h);
  char note[256];
  std::snprintf(
      note, sizeof note,
      "%d node contacts at the end, max strain %.3g; symplectic limits (< 2): node "
      "omega h <= %.2g, core turning against the net %.2g, node damping h gamma/m <= %.2g",
      data.num_node_contacts, strain, node_limit, turn_limit, damping_limit);
  r.note = note;
  return r;
}

// ---- the control loop cases ----

/// Checks one period of a loop run; returns the reason of a failure or nullptr. `input_bad`:
/// this period's encoder input was bad (no torque may be commanded); `previous_bad`: the last
/// period's was (the drives, which receive a period's command at the next SYNC, must hold 0).
const char* loop_check(const SceneRunner& runner, const Scene& scene, bool input_bad,
                       bool previous_bad) {
  const core::Data& d = runner.data();
  if (!data_finite(d) || d.nonfinite_steps > 0) return "non-finite";
  if ((d.status & core::kInvalidTarget) != 0) return "input";  // something non-finite got in
  const hal::AxisVector& tau = runner.instrument().last_torques();
  for (int i = 0; i < tau.size(); ++i) {
    const double limit = scene.device.axes[static_cast<std::size_t>(i)].max_torque;
    if (!std::isfinite(tau[i]) || std::abs(tau[i]) > limit * (1.0 + 1e-9) + 1e-12) return "torque";
  }
  if (input_bad && runner.last_report().torque_commanded) return "torque";
  if (previous_bad && !tau.isZero(0.0)) return "torque";
  for (const core::BodyState& s : d.bodies)
    if (s.linear_velocity.norm() > kMaxSpeed || s.angular_velocity.norm() > kMaxAngularSpeed)
      return "speed";
  if (d.max_joint_drift > kLoopDriftBound) return "drift";
  if (d.max_penetration > kLoopPenetrationBound) return "penetration";
  return nullptr;
}

/// Runs `periods` periods of `runner`; `before(k)` returns true when period k's input is bad.
template <class Before>
void run_loop(SceneRunner& runner, const Scene& scene, std::int64_t periods, Before&& before,
              StabilityRow& row) {
  double pen = 0.0, drift = 0.0;
  bool bad_prev = false;
  for (std::int64_t k = 0; k < periods; ++k) {
    const bool bad = before(k);
    runner.period();
    pen = std::max(pen, runner.data().max_penetration);
    drift = std::max(drift, runner.data().max_joint_drift);
    const char* why = loop_check(runner, scene, bad, bad_prev);
    bad_prev = bad;
    row.steps = k + 1;
    if (why != nullptr) {
      row.stable = false;
      row.diverged_step = k + 1;
      row.reason = why;
      break;
    }
  }
  if (row.diverged_step < 0) row.stable = true;
  row.penetration_max_m = pen;
  row.penetration_bound_m = kLoopPenetrationBound;
  row.drift_max_m = drift;
  row.nonfinite_steps = runner.data().nonfinite_steps;
}

Scene with_integrator(const Scene& scene, core::Integrator integrator) {
  Scene s = scene;
  s.model = study::with_scheme(scene.model, integrator, scene.model.dt, "stability study");
  return s;
}

StabilityRow trocar_run(const Scene& base_scene, core::Integrator integrator, double duration) {
  Scene scene = with_integrator(base_scene, integrator);
  const hal::TrocarGeometry& trocar = scene.device.trocar;
  const Vec3 pc = trocar.point;
  const double d0 = (scene.trajectory[0].pose.position - pc).norm();
  constexpr double kPeriod = 0.01, kPull = 1.5, kWobble = 0.3, kHz = 2.0, kMinDepth = 1e-6;
  std::vector<core::Pose> poses;
  for (double t = 0.0; t <= duration + 1e-9; t += kPeriod) {
    const double tau = std::clamp(t / kPull, 0.0, 1.0);
    // Down to 1 µm (a tenth of the depth encoder's 10 µm count: it reads 0): at exactly 0 the tip
    // position no longer gives the shaft direction and the simulated hand's inverse kinematics
    // would switch to the recorded orientation (a 0.04 rad step the encoder check rejects).
    const double s =
        kMinDepth +
        (d0 - kMinDepth) * (1.0 - tau * tau * tau * (10.0 - 15.0 * tau + 6.0 * tau * tau));
    const double w = 2.0 * std::numbers::pi * kHz * t;
    const Quat shaft = trocar.orientation *
                       Quat(Eigen::AngleAxisd(kWobble * std::sin(w), Vec3::UnitX())) *
                       Quat(Eigen::AngleAxisd(kWobble * std::cos(w), Vec3::UnitY()));
    core::Pose p;
    p.position = pc + s * (shaft * Vec3::UnitZ());
    p.orientation = shaft;
    poses.push_back(p);
  }
  scene.trajectory = Trajectory(kPeriod, poses);
  SceneRunner runner(scene);
  const auto periods = std::llround(duration / scene.model.dt);
  StabilityRow r = scene_row("trocar-zero-insertion", integrator, scene.model.dt);
  double depth_min = kInf, torque_ratio = 0.0;
  run_loop(
      runner, scene, periods,
      [&](std::int64_t) {
        const hal::DeviceSample& smp = runner.device().last_sample();
        if (runner.periods() > 0 && smp.ready) depth_min = std::min(depth_min, smp.q[2]);
        const hal::AxisVector& tau = runner.instrument().last_torques();
        for (int i = 0; i < tau.size(); ++i)
          torque_ratio =
              std::max(torque_ratio, std::abs(tau[i]) /
                                         scene.device.axes[static_cast<std::size_t>(i)].max_torque);
        return false;
      },
      r);
  r.parameter = 0.0;
  r.parameter_name = "insertion_m";
  const RunSummary sum = runner.summary();
  char fault[128] = "";
  if (!sum.first_fault.empty())
    std::snprintf(fault, sizeof fault, ", first fault %s (axis %d, %.3g s)",
                  sum.first_fault.c_str(), sum.first_fault_id, sum.first_fault_time_s);
  char note[360];
  std::snprintf(
      note, sizeof note,
      "smallest depth read %.2g m; %llu samples rejected (%llu jump, %llu out of range); "
      "lifecycle %s%s; torque on in %lld of %lld periods, largest abs(tau)/max_torque %.2f; %s",
      depth_min, static_cast<unsigned long long>(runner.device().counters().values_rejected),
      static_cast<unsigned long long>(runner.device().counters().rejected_jump),
      static_cast<unsigned long long>(runner.device().counters().rejected_out_of_range),
      hal::to_string(runner.last_report().lifecycle), fault,
      static_cast<long long>(r.steps - sum.zero_torque_periods), static_cast<long long>(r.steps),
      torque_ratio, stiffest(scene.model).c_str());
  r.note = note;
  return r;
}

StabilityRow bus_run(const Scene& base_scene, core::Integrator integrator, double duration) {
  const Scene scene = with_integrator(base_scene, integrator);
  SceneRunner runner(scene);
  const auto periods = std::llround(duration / scene.model.dt);
  const std::int64_t first = periods / 2, last = first + 30;
  const auto period_ns = std::llround(scene.model.dt * 1e9);
  const double values[3] = {std::numeric_limits<double>::quiet_NaN(),
                            std::numeric_limits<double>::infinity(),
                            -std::numeric_limits<double>::infinity()};
  StabilityRow r = scene_row("bus-nonfinite", integrator, scene.model.dt);
  run_loop(
      runner, scene, periods,
      [&](std::int64_t k) {
        const bool bad = k >= first && k < last;
        runner.instrument().emulator().set_responding(!bad);
        if (bad) {  // the encoders' answers to this period's SYNC, stamped like theirs
          const std::int64_t at = k * period_ns + scene.bus.latency_ns;
          runner.bus().set_time_ns(at);
          const double v = values[(k - first) % 3];
          for (const hal::AxisConfig& a : scene.device.axes)
            runner.bus().device().write(
                hal::encode_position_pdo(a.encoder_cob_id, hal::value_to_counts(a, v), at));
        }
        return bad;
      },
      r);
  r.parameter = static_cast<double>(last - first);
  r.parameter_name = "bad_periods";
  const hal::DeviceCounters& c = runner.device().counters();
  char note[320];
  std::snprintf(
      note, sizeof note,
      "rejected: %llu out of range, %llu jump, %llu non-finite; torque off in %lld of %lld "
      "periods; lifecycle %s; %s",
      static_cast<unsigned long long>(c.rejected_out_of_range),
      static_cast<unsigned long long>(c.rejected_jump),
      static_cast<unsigned long long>(c.rejected_non_finite),
      static_cast<long long>(runner.summary().zero_torque_periods), static_cast<long long>(r.steps),
      hal::to_string(runner.last_report().lifecycle), stiffest(scene.model).c_str());
  r.note = note;
  return r;
}

/// NaN / ±Inf straight into core::Data for 20 steps (and the encoder sample check given them).
StabilityRow core_target_run(const Scene& scene, core::Integrator integrator) {
  const core::Model model =
      study::with_scheme(scene.model, integrator, scene.model.dt, "stability study");
  core::Data data = core::make_data(model);
  const core::Pose hold = data.target;
  const double values[3] = {std::numeric_limits<double>::quiet_NaN(),
                            std::numeric_limits<double>::infinity(),
                            -std::numeric_limits<double>::infinity()};
  StabilityRow r = scene_row("core-target-nonfinite", integrator, model.dt);
  std::int64_t invalid = 0;
  constexpr std::int64_t kSteps = 200, kFirst = 100, kLast = 120;
  for (std::int64_t k = 0; k < kSteps; ++k) {
    const bool bad = k >= kFirst && k < kLast;
    data.target = hold;
    data.target_twist = core::Twist{};
    if (bad) {
      const double v = values[k % 3];
      data.target.position.x() = v;
      data.target.orientation.w() = v;
      data.target_twist.angular.y() = v;
    }
    core::step(model, data);
    if ((data.status & core::kInvalidTarget) != 0) ++invalid;
    r.steps = k + 1;
    // The state must stay finite (the input is not state: target is the caller's to fix).
    bool ok = data.nonfinite_steps == 0 && data.feedback_wrench.force.allFinite();
    for (const core::BodyState& s : data.bodies)
      ok = ok && s.position.allFinite() && s.linear_velocity.allFinite() &&
           s.orientation.coeffs().allFinite() && s.angular_velocity.allFinite();
    if (!ok) {
      r.stable = false;
      r.diverged_step = k + 1;
      r.reason = "non-finite";
      break;
    }
  }
  // The encoder check rejects the same values before they become targets.
  hal::AxisCheckLimits lim;
  lim.min = -1.0;
  lim.max = 1.0;
  lim.max_speed = 10.0;
  lim.max_age_ns = 3'000'000;
  bool check_rejects = true;
  for (double v : values)
    check_rejects =
        check_rejects && hal::check_sample(lim, v, 0, 0, nullptr) == hal::SampleFault::kNonFinite;
  if (r.diverged_step < 0) {
    r.stable = invalid == kLast - kFirst && check_rejects;
    if (!r.stable) {
      r.diverged_step = kFirst + 1;
      r.reason = "input";
    }
  }
  r.nonfinite_steps = data.nonfinite_steps;
  r.parameter = static_cast<double>(kLast - kFirst);
  r.parameter_name = "bad_steps";
  char note[160];
  std::snprintf(note, sizeof note,
                "%lld steps flagged kInvalidTarget (coupling skipped); check_sample(NaN, ±Inf) = "
                "non-finite: %s",
                static_cast<long long>(invalid), check_rejects ? "yes" : "no");
  r.note = note;
  return r;
}

}  // namespace

void plan_scene_extreme(const StabilityOptions& o, const std::string& dir, Plan& plan) {
  const std::string no_nets = study::missing_parts(false, true);
  const std::string no_joints = study::missing_parts(true, false);  // lattice.toml's trocar
  if (!no_nets.empty()) {
    plan.skipped.push_back("deformable-jump: " + no_nets);
    plan.skipped.push_back("organ-plunge: " + no_nets);
    plan.skipped.push_back("organ-plunge-per-spring: " + no_nets);
  }
  if (!no_joints.empty()) {
    for (const char* c : {"trocar-zero-insertion", "bus-nonfinite", "core-target-nonfinite"})
      plan.skipped.push_back(std::string(c) + ": " + no_joints);
  }
  // Loaded once, shared by the cases (each run copies what it changes).
  const std::shared_ptr<const Scene> deformable =
      no_nets.empty() ? std::make_shared<const Scene>(study::load_replayed_scene(dir + "/deformable.toml"))
                      : nullptr;
  // The default (organ) scene's instrument has joints, but the case takes only its organ and tube.
  const std::shared_ptr<const Scene> organ =
      no_nets.empty() && no_joints.empty()
          ? std::make_shared<const Scene>(study::load_replayed_scene(dir + "/default.toml"))
          : nullptr;
  if (no_nets.empty() && !no_joints.empty()) {
    plan.skipped.push_back("organ-plunge: " + no_joints);
    plan.skipped.push_back("organ-plunge-per-spring: " + no_joints);
  }
  const std::shared_ptr<const Scene> trocar =
      no_joints.empty() ? std::make_shared<const Scene>(study::load_replayed_scene(dir + "/lattice.toml"))
                        : nullptr;
  const std::vector<double> steps =
      o.quick ? std::vector<double>{1e-3} : std::vector<double>{1e-4, 1e-3, 1e-2};
  const StabilityLimits limits = o.limits;
  const double jump_s = o.quick ? 0.15 : 0.5, trocar_s = o.quick ? 2.0 : 3.0,
               bus_s = o.quick ? 0.3 : 1.0;
  for (core::Integrator integrator : integrators_of(o)) {
    for (double h : deformable ? steps : std::vector<double>{})
      plan.add("extreme", "deformable-jump", case_parameters(integrator, {{"h", h}}),
               20.0 * kSceneWeight / 5.0, [=](StabilityResult& r) {
                 r.rows.push_back(deformable_run(*deformable, integrator, h, limits, jump_s));
               });
    for (double h : organ ? steps : std::vector<double>{})
      plan.add("extreme", "organ-plunge", case_parameters(integrator, {{"h", h}}),
               20.0 * kSceneWeight / 5.0, [=](StabilityResult& r) {
                 r.rows.push_back(organ_run(*organ, integrator, h, limits, jump_s));
               });
    for (double h : organ ? steps : std::vector<double>{})
      plan.add("extreme", "organ-plunge-per-spring", case_parameters(integrator, {{"h", h}}),
               20.0 * kSceneWeight / 5.0, [=](StabilityResult& r) {
                 r.rows.push_back(organ_run(*organ, integrator, h, limits, jump_s,
                                            &kShippedPerSpringOrgan));
               });
    if (!trocar) continue;
    plan.add(
        "extreme", "trocar-zero-insertion", case_parameters(integrator, {}), kSceneWeight,
        [=](StabilityResult& r) { r.rows.push_back(trocar_run(*trocar, integrator, trocar_s)); });
    plan.add("extreme", "bus-nonfinite", case_parameters(integrator, {}), kSceneWeight,
             [=](StabilityResult& r) { r.rows.push_back(bus_run(*trocar, integrator, bus_s)); });
    plan.add("extreme", "core-target-nonfinite", case_parameters(integrator, {}), kSceneWeight,
             [=](StabilityResult& r) { r.rows.push_back(core_target_run(*trocar, integrator)); });
  }
}

}  // namespace numen::sim::stability
