/// @file study_stability_extreme.cpp
/// Rigid cases of the family "extreme" of `numen study stability` (study_stability.hpp): a target
/// teleporting 1 m and half a turn in one period (free, and through a wall), a target spinning at
/// 100 rad/s about a non-principal axis, and a plate of more spheres on a plane than
/// core::kMaxContacts.

#include <cmath>
#include <numbers>
#include <cstdio>

#include "numen/core/capacity.hpp"
#include "numen/sim/scene/scene.hpp"
#include "numen/sim/study/study_common.hpp"
#include "numen/sim/study/study_stability_cases.hpp"

namespace numen::sim::stability {
namespace {

using core::Mat3;
using core::Quat;
using core::Vec3;


std::vector<double> extreme_steps(const StabilityOptions& o) {
  if (o.quick) return {1e-3, 1e-2};
  return {1e-4, 3e-4, 1e-3, 3e-3, 1e-2};
}

std::int64_t steps_for(double horizon, double h) {
  return std::max<std::int64_t>(1, std::llround(horizon / h));
}

/// Teleport: a 0.1 kg, 10 mm sphere held by k_t (ζ = 0.85; k_r = 1e-3 k_t/200, ζ = 0.85); at
/// t = 50 ms the target jumps from the origin to (1, 0, 0) m and turns by π − 0.1 rad about z.
/// `wall`: the half-space x > 50 mm is solid (k_c = 1e4 N/m, c = 10 N·s/m), so the target ends
/// 0.95 m inside it.
StabilityRow teleport_run(core::Integrator integrator, double h, double k_t, bool wall,
                          const StabilityLimits& limits, double horizon) {
  constexpr double kM = 0.1, kR = 0.01, kWallX = 0.05, kKc = 1e4;
  core::Model base = empty_model(core::MaterialPair{kKc, 10.0, 0.0});
  base.body_spheres = {core::Sphere{Vec3::Zero(), kR}};
  core::BodyModel b;
  b.name = "tool";
  b.mass = kM;
  b.inertia_body = 0.4 * kM * kR * kR * Mat3::Identity();
  b.sphere_begin = 0;
  b.sphere_count = 1;
  b.coupling.k_t = k_t;
  b.coupling.gamma_t = core::damping_from_ratio(0.85, kM, k_t);
  b.coupling.k_r = 1e-3 * k_t / 200.0;
  b.coupling.gamma_r = core::damping_from_ratio(0.85, b.inertia_body(0, 0), b.coupling.k_r);
  base.bodies = {b};
  base.initial_held_body = 0;
  if (wall) {
    core::Obstacle plane;
    plane.name = "wall";
    plane.type = core::ShapeType::kPlane;
    plane.pose.position = Vec3(kWallX, 0.0, 0.0);
    plane.pose.orientation = core::rotation_between(Vec3::UnitZ(), -Vec3::UnitX());  // normal −x
    base.obstacles = {plane};
  }
  const core::Model model = study::with_scheme(base, integrator, h, "stability study");
  core::Data data = core::make_data(model);
  const std::int64_t jump = std::max<std::int64_t>(1, std::llround(0.05 / h));
  const Vec3 to(1.0, 0.0, 0.0);
  const Quat turn(Eigen::AngleAxisd(std::numbers::pi - 0.1, Vec3::UnitZ()));
  // Static penetration: the coupling stretched from the wall contact (x = 40 mm) to 1 m.
  const double static_depth = k_t * (to.x() - (kWallX - kR)) / (k_t + kKc);
  const double bound = wall ? limits.penetration_factor * static_depth : kInf;
  const std::int64_t n = steps_for(horizon, h);
  Monitor monitor(limits, bound, kInf, n, wall ? kM : 0.0, h);
  drive(
      model, data, n,
      [&](std::int64_t k, core::Data& d) noexcept {
        if (k == jump) {
          d.target.position = to;
          d.target.orientation = turn;
        }
      },
      monitor);
  StabilityRow r =
      make_row("extreme", wall ? "teleport-wall" : "teleport-free", integrator, h, kM, k_t, 1.0,
               "jump_m", std::sqrt(std::max(k_t, wall ? kKc + k_t : 0.0) / kM) * h);
  monitor.fill(r);
  return r;
}

/// Spin: a 0.1 kg body with principal inertias (1, 2, 3)·1e-5 kg·m² held at the origin
/// (k_t = 200 N/m) whose target turns at 100 rad/s about (1, 1, 1)/√3 from t = 0 (body at rest):
/// the damper spins it up, k_r (ζ = 0.85 on the middle inertia) keeps the lag small.
StabilityRow spin_run(core::Integrator integrator, double h, double k_r,
                      const StabilityLimits& limits, double horizon) {
  constexpr double kM = 0.1, kW = 100.0;
  core::Model base = empty_model();
  core::BodyModel b;
  b.name = "tool";
  b.mass = kM;
  b.inertia_body = Vec3(1e-5, 2e-5, 3e-5).asDiagonal();
  b.coupling.k_t = 200.0;
  b.coupling.gamma_t = core::damping_from_ratio(0.85, kM, 200.0);
  b.coupling.k_r = k_r;
  b.coupling.gamma_r = core::damping_from_ratio(0.85, 2e-5, k_r);
  base.bodies = {b};
  base.initial_held_body = 0;
  const core::Model model = study::with_scheme(base, integrator, h, "stability study");
  core::Data data = core::make_data(model);
  const Vec3 axis = Vec3(1.0, 1.0, 1.0).normalized();
  const std::int64_t n = steps_for(horizon, h);
  Monitor monitor(limits, kInf, kInf, n);
  drive(
      model, data, n,
      [&](std::int64_t k, core::Data& d) noexcept {
        const double t = static_cast<double>(k) * h;
        d.target.orientation = Quat(Eigen::AngleAxisd(std::fmod(kW * t, 2.0 * std::numbers::pi), axis));
        d.target_twist.angular = kW * axis;
      },
      monitor);
  StabilityRow r = make_row("extreme", "spin-100rad/s", integrator, h, kM, k_r, kW,
                            "target_rate_rad_s", std::sqrt(k_r / 1e-5) * h);
  monitor.fill(r);
  char note[96];
  std::snprintf(note, sizeof note, "final body rate %.1f rad/s",
                data.bodies[0].angular_velocity.norm());
  r.note = note;
  return r;
}

/// Capacity: a 1 kg square plate of n² spheres (radius 5 mm, 10 mm apart), n² > kMaxContacts,
/// lying on a plane (k_c = 1e4 N/m, c = 1 N·s/m per contact) and pushed 5 mm into it by k_t =
/// 2000 N/m (k_r = 50 N·m/rad, ζ = 0.85): every step finds n² contacts and keeps kMaxContacts.
/// Stable also requires the overflow to be counted, step by step (see capacity_run's audit).
StabilityRow capacity_run(core::Integrator integrator, double h, const StabilityLimits& limits,
                          std::int64_t n) {
  constexpr double kM = 1.0, kR = 0.005, kKc = 1e4, kKt = 2000.0, kPushZ = 0.005;
  const int side = static_cast<int>(std::ceil(std::sqrt(core::kMaxContacts + 200.0)));
  const int spheres = side * side;
  core::Model base = empty_model(core::MaterialPair{kKc, 1.0, 0.0});
  const double half = 0.5 * (side - 1) * 2.0 * kR;
  for (int i = 0; i < side; ++i)
    for (int j = 0; j < side; ++j)
      base.body_spheres.push_back(
          core::Sphere{Vec3(i * 2 * kR - half, j * 2 * kR - half, 0.0), kR});
  const double length = side * 2.0 * kR;
  core::BodyModel b;
  b.name = "plate";
  b.mass = kM;
  b.inertia_body =
      Vec3(kM * length * length / 12.0, kM * length * length / 12.0, kM * length * length / 6.0)
          .asDiagonal();
  b.sphere_begin = 0;
  b.sphere_count = spheres;
  b.coupling.k_t = kKt;
  b.coupling.gamma_t = core::damping_from_ratio(0.85, kM, kKt);
  b.coupling.k_r = 50.0;
  b.coupling.gamma_r = core::damping_from_ratio(0.85, b.inertia_body(0, 0), 50.0);
  b.initial_pose.position = Vec3(0.0, 0.0, kR);
  base.bodies = {b};
  core::Obstacle plane;
  plane.name = "floor";
  plane.type = core::ShapeType::kPlane;
  base.obstacles = {plane};
  base.initial_held_body = 0;
  const core::Model model = study::with_scheme(base, integrator, h, "stability study");
  core::Data data = core::make_data(model);
  data.target.position = Vec3(0.0, 0.0, kR - kPushZ);
  const double static_depth = kKt * kPushZ / (kKt + core::kMaxContacts * kKc);
  Monitor monitor(limits, limits.penetration_factor * static_depth, kInf, n, kM, h);
  // The counters, checked after every step: a step that found more contacts than the capacity
  // keeps exactly kMaxContacts, flags kContactOverflow and counts the rest as dropped; the
  // overflow steps add up in Data::contact_overflow_steps. Nothing is lost silently.
  std::int64_t flagged = 0, inconsistent = 0;
  auto audit = [&](const core::Data& d) noexcept {
    const bool overflow = (d.status & core::kContactOverflow) != 0;
    const int found = d.num_contacts + d.contacts_dropped;
    if (overflow != (found > core::kMaxContacts) ||
        (overflow && d.num_contacts != core::kMaxContacts) ||
        (!overflow && d.contacts_dropped != 0) || found > spheres)
      ++inconsistent;
    flagged += overflow;
  };
  const std::int64_t ran = drive(
      model, data, n,
      [&](std::int64_t k, core::Data& d) noexcept {
        if (k > 0) audit(d);
      },
      monitor);
  audit(data);
  if (!monitor.diverged() &&
      (inconsistent > 0 || flagged == 0 || data.contact_overflow_steps != flagged))
    monitor.fail(ran, "overflow-not-counted");
  StabilityRow r = make_row("extreme", "contact-capacity", integrator, h, kM, kKc, spheres,
                            "spheres", std::sqrt(core::kMaxContacts * kKc / kM) * h);
  monitor.fill(r);
  char note[200];
  std::snprintf(
      note, sizeof note,
      "%d spheres, capacity %d: %lld overflow steps of %lld (all counted: %s), %d dropped in the "
      "last step",
      spheres, core::kMaxContacts, static_cast<long long>(data.contact_overflow_steps),
      static_cast<long long>(ran), inconsistent == 0 ? "yes" : "no", data.contacts_dropped);
  r.note = note;
  return r;
}

}  // namespace

void plan_rigid_extreme(const StabilityOptions& o, Plan& plan) {
  const double horizon = o.quick ? 0.3 : 1.0;
  const StabilityLimits limits = o.limits;
  const bool quick = o.quick;
  for (core::Integrator integrator : integrators_of(o))
    for (double h : extreme_steps(o)) {
      for (bool wall : {false, true})
        for (double k_t : {200.0, 2e4})
          plan.add("extreme", wall ? "teleport-wall" : "teleport-free",
                   case_parameters(integrator, {{"h", h}, {"k_t", k_t}}), kExtremeWeight,
                   [=](StabilityResult& r) {
                     r.rows.push_back(teleport_run(integrator, h, k_t, wall, limits, horizon));
                   });
      for (double k_r : {0.05, 5.0})
        plan.add("extreme", "spin-100rad/s", case_parameters(integrator, {{"h", h}, {"k_r", k_r}}),
                 kExtremeWeight, [=](StabilityResult& r) {
                   r.rows.push_back(spin_run(integrator, h, k_r, limits, horizon));
                 });
      const std::int64_t steps = quick ? 20 : std::max<std::int64_t>(100, steps_for(0.5, h));
      plan.add("extreme", "contact-capacity",
               case_parameters(integrator, {{"h", h}, {"steps", static_cast<double>(steps)}}),
               kExtremeWeight, [=](StabilityResult& r) {
                 r.rows.push_back(capacity_run(integrator, h, limits, steps));
               });
    }
}

}  // namespace numen::sim::stability
