/// @file divergence.cpp
/// The divergence monitor of a run (divergence.hpp).

#include "numen/sim/run/divergence.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "numen/core/coupling.hpp"
#include "numen/core/step_stages.hpp"
#include "numen/sim/run/energy.hpp"

namespace numen::sim {

using core::Vec3;

namespace {

/// The speed bound's measure of a motion: |v| + |ω| r (m/s), r a body's bounding radius.
double reach_speed(const Vec3& linear, const Vec3& angular, double r) noexcept {
  return linear.norm() + angular.norm() * r;
}

/// reach_speed() of body k's state.
double body_speed(const core::Model& model, const core::Data& data, std::size_t k) noexcept {
  const core::BodyState& s = data.bodies[k];
  return reach_speed(s.linear_velocity, s.angular_velocity, model.bodies[k].bounding_radius);
}

}  // namespace

DivergenceMonitor::DivergenceMonitor(const core::Model& model, const core::Data& data,
                                     const DivergenceLimits& limits)
    : limits_(limits),
      net_radius_m_(model.nets.size(), 0.0),
      base_stretch_m_(model.nets.size(), 0.0),
      net_energy_(model.nets.size(), 0.0),
      prev_bodies_(data.bodies),
      prev_targets_(data.bodies.size()),
      prev_coupled_(data.bodies.size(), 0) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  Vec3 lo = Vec3::Constant(kInf), hi = Vec3::Constant(-kInf);
  auto grow = [&](const Vec3& a, const Vec3& b) {
    if (!a.allFinite() || !b.allFinite()) return;  // planes and other unbounded obstacles
    lo = lo.cwiseMin(a);
    hi = hi.cwiseMax(b);
  };
  for (int i = 0; i < model.num_bodies(); ++i) {
    const auto k = static_cast<std::size_t>(i);
    const Vec3 r = Vec3::Constant(model.bodies[k].bounding_radius);
    grow(data.bodies[k].position - r, data.bodies[k].position + r);
  }
  for (const core::Obstacle& o : model.obstacles) grow(o.aabb_min, o.aabb_max);
  for (const core::NodeState& n : data.nodes) grow(n.position, n.position);
  scene_size_m_ = hi.x() >= lo.x() ? (hi - lo).norm() : 0.0;
  // The scene's height: the box's extent along gravity (Σ |ĝ_i| (hi_i − lo_i)).
  const double g = model.gravity.norm();
  const double height = g > 0.0 && hi.x() >= lo.x()
                            ? (model.gravity.cwiseAbs() / g).dot(hi - lo)
                            : 0.0;
  fall_speed_mps_ = std::sqrt(2.0 * g * height);
  for (std::size_t n = 0; n < model.nets.size(); ++n) {
    const core::NetModel& net = model.nets[n];
    for (int i = net.node_begin; i < net.node_begin + net.node_count; ++i)
      net_radius_m_[n] = std::max(net_radius_m_[n], model.node_rest[static_cast<std::size_t>(i)].norm());
  }
}

void DivergenceMonitor::latch(const char* cause, int body, int net, double value, double limit,
                              std::int64_t period, double time_s) noexcept {
  latched_.cause = cause;
  latched_.body = body;
  latched_.net = net;
  latched_.value = value;
  latched_.limit = limit;
  latched_.period = period;
  latched_.time_s = time_s;
}

double DivergenceMonitor::input_work(const core::Model& model, const core::Data& data) const noexcept {
  double jump = 0.0, power = 0.0;
  for (int b = 0; b < model.num_bodies(); ++b) {
    const auto k = static_cast<std::size_t>(b);
    const core::Twist* twist = nullptr;
    const core::Pose* target = coupling_target(model, data, b, &twist);
    if (target == nullptr) continue;
    const core::CouplingGains& g = model.bodies[k].coupling;
    jump += coupling_potential(g, prev_bodies_[k], *target);
    if (prev_coupled_[k]) jump -= coupling_potential(g, prev_bodies_[k], prev_targets_[k]);
    power += damper_power(g, prev_bodies_[k], *twist);
  }
  return std::max(0.0, jump + model.dt * std::max(0.0, power));
}

double step_response_speed(const core::Model& model, const core::Data& data, int b,
                           const core::Pose& from, const core::Pose& to,
                           const core::Twist& twist) noexcept {
  const auto k = static_cast<std::size_t>(b);
  const core::BodyModel& body = model.bodies[k];
  const core::CouplingGains& g = body.coupling;
  const double h = model.dt;
  // What the target's own twist does not explain: a hand moving at v moves the target by v h.
  const double jump = std::max(0.0, (to.position - from.position).norm() - twist.linear.norm() * h);
  double v = jump * std::min(std::sqrt(std::max(0.0, g.k_t) / body.mass), 1.0 / h);
  const Vec3 theta = core::rotation_error(to.orientation, from.orientation);
  const double angle = theta.norm();
  const double turn = std::max(0.0, angle - twist.angular.norm() * h);
  if (turn > 0.0 && g.k_r > 0.0) {
    const Vec3 u = theta / angle;
    const core::Mat3 r = data.bodies[k].orientation.toRotationMatrix();
    const double inertia = u.dot(r * body.inertia_body * r.transpose() * u);
    if (inertia > 0.0)
      v += turn * std::min(std::sqrt(g.k_r / inertia), 1.0 / h) * body.bounding_radius;
  }
  return v;
}

void DivergenceMonitor::remember(const core::Data& data) noexcept {
  std::copy(data.bodies.begin(), data.bodies.end(), prev_bodies_.begin());  // same size
  prev_held_ = data.held_body;
}

void DivergenceMonitor::rebase(const core::Model& model, const core::Data& data) noexcept {
  // The contacts' potential at the base (½ k d², depths at the step's start) belongs to what
  // the scene starts with: a tool that starts inside an obstacle is pushed out by it.
  contact0_ = contact_energy(model, data);
  energy0_ = stored_energy(model, data) + contact0_;
  gravity0_ = gravity_potential(model, data);
  work_in_ = 0.0;
  // A net pressed into an obstacle at the start is stretched by it before anything moves:
  // twice that stretch is allowed on top of the net's size (the push-out overshoots).
  for (std::size_t n = 0; n < model.nets.size(); ++n) {
    const core::NetModel& net = model.nets[n];
    const core::BodyState& body = data.bodies[static_cast<std::size_t>(net.body)];
    for (int i = net.node_begin; i < net.node_begin + net.node_count; ++i) {
      const auto k = static_cast<std::size_t>(i);
      const double stretch =
          (data.nodes[k].position - (body.position + body.orientation * model.node_rest[k])).norm();
      if (std::isfinite(stretch)) base_stretch_m_[n] = std::max(base_stretch_m_[n], stretch);
    }
  }
  // ... and the fastest it can push a body: all of it into the lightest colliding body.
  double lightest = std::numeric_limits<double>::infinity();
  for (const core::BodyModel& b : model.bodies)
    if (b.sphere_count > 0) lightest = std::min(lightest, b.mass);
  if (std::isfinite(lightest) && std::isfinite(contact0_))
    push_speed_mps_ = std::max(push_speed_mps_, std::sqrt(2.0 * contact0_ / lightest));
}

void DivergenceMonitor::end_startup(const core::Model& model, const core::Data& data) noexcept {
  // What the push-out left moving keeps its room (10 x its speed); the start's contact energy
  // no longer counts.
  double fastest = 0.0;
  for (std::size_t k = 0; k < data.bodies.size(); ++k) {
    const double v = body_speed(model, data, k);
    if (std::isfinite(v)) fastest = std::max(fastest, v);
  }
  push_speed_mps_ = fastest;
  rebase(model, data);  // E_0 and W_in from here; the push speed of the contacts now
}

bool DivergenceMonitor::observe(const core::Model& model, const core::Data& data,
                                std::int64_t period, double time_s,
                                bool organs_unchanged) noexcept {
  if (latched_.cause != nullptr) return false;
  // ---- energy against what the hand put in ----
  const bool springs = coupling_springs_act(model);
  if (prev_held_ != data.held_body) {  // the first period, or a new held body: the base
    rebase(model, data);
  } else if (springs) {
    work_in_ += input_work(model, data);
  }
  // ---- speeds against the hand's and gravity's ----
  const int held = data.held_body;
  if (held >= 0) {
    const auto h = static_cast<std::size_t>(held);
    const double r = model.bodies[h].bounding_radius;
    const double v = reach_speed(data.target_twist.linear, data.target_twist.angular, r);
    if (std::isfinite(v)) hand_speed_max_mps_ = std::max(hand_speed_max_mps_, v);
  }
  for (std::size_t k = 0; k < data.body_targets.size(); ++k) {
    const core::BodyTarget& t = data.body_targets[k];
    if (!t.enabled) continue;
    const double v = reach_speed(t.twist.linear, t.twist.angular, model.bodies[k].bounding_radius);
    if (std::isfinite(v)) hand_speed_max_mps_ = std::max(hand_speed_max_mps_, v);
  }
  // A target that steps (samples held through a link outage, then the hand where it is now)
  // swings the coupling spring: a mass on a spring k stepped by Δ peaks at Δ √(k/m).
  if (springs && prev_held_ == data.held_body) {
    for (int b = 0; b < model.num_bodies(); ++b) {
      const auto k = static_cast<std::size_t>(b);
      const core::Twist* twist = nullptr;
      const core::Pose* target = coupling_target(model, data, b, &twist);
      if (target == nullptr || !prev_coupled_[k]) continue;
      const double v = step_response_speed(model, data, b, prev_targets_[k], *target, *twist);
      if (std::isfinite(v)) hand_speed_max_mps_ = std::max(hand_speed_max_mps_, v);
    }
  }
  const double speed_limit = speed_limit_mps();
  bool breach = false;
  for (int b = 0; b < model.num_bodies() && !breach; ++b) {
    const double v = body_speed(model, data, static_cast<std::size_t>(b));
    speed_ratio_max_ = std::max(speed_ratio_max_, v / speed_limit);
    if (v > speed_limit) {
      latch("body speed", b, -1, v, speed_limit, period, time_s);
      breach = true;
    }
  }
  // ---- nodes: speeds and ties ----
  // A state whose step measured its nets (core::measure_nets(): NetOutput's largest node speed
  // and tie stretch; the energy the forces stage found at the step's start, one step behind) is
  // judged from those, O(nets); any other node by node,
  // except the organs (nets on anchored bodies) of a state the caller says they are unchanged
  // in (organs_unchanged: a multirate run's device periods between two scene samples), which
  // keep the last judgement.
  const bool measured = (data.stages_run & core::kStageMeasureNets) != 0;
  const bool skip_organs = !measured && organs_unchanged && net_energy_taken_;
  const auto organ = [&](const core::NetModel& net) {
    return model.bodies[static_cast<std::size_t>(net.body)].anchored;
  };
  for (std::size_t n = 0; n < model.nets.size() && !breach; ++n) {
    const core::NetModel& net = model.nets[n];
    if (skip_organs && organ(net)) continue;
    const core::BodyState& body = data.bodies[static_cast<std::size_t>(net.body)];
    const double stretch_limit =
        limits_.stretch_factor * net_radius_m_[n] + 2.0 * base_stretch_m_[n];
    const auto judge = [&](double speed, double stretch) {
      speed_ratio_max_ = std::max(speed_ratio_max_, speed / speed_limit);
      if (speed > speed_limit) {
        latch("node speed", net.body, static_cast<int>(n), speed, speed_limit, period, time_s);
        return true;
      }
      if (stretch_limit > 0.0) stretch_ratio_max_ = std::max(stretch_ratio_max_, stretch / stretch_limit);
      if (stretch_limit > 0.0 && stretch > stretch_limit) {
        latch("tie stretch", net.body, static_cast<int>(n), stretch, stretch_limit, period, time_s);
        return true;
      }
      return false;
    };
    if (measured) {
      breach = judge(data.nets[n].max_node_speed, data.nets[n].max_tie_stretch);
      continue;
    }
    for (int i = net.node_begin; i < net.node_begin + net.node_count && !breach; ++i) {
      const auto k = static_cast<std::size_t>(i);
      const Vec3 anchor = body.position + body.orientation * model.node_rest[k];
      breach = judge(data.nodes[k].velocity.norm(), (data.nodes[k].position - anchor).norm());
    }
  }
  if (springs && !breach) {
    // What the scene holds now, gravity's potential taken from its value at the base: a
    // passive scene keeps it below E₀ + W_in (what it started with plus the hand's work).
    double gravity = 0.0;
    double held_energy = body_energy(model, data, &gravity);
    held_energy += gravity - gravity0_;
    for (int n = 0; n < model.num_nets(); ++n) {
      const auto k = static_cast<std::size_t>(n);
      if (measured) {
        const core::NetOutput& out = data.nets[k];
        net_energy_[k] = out.start_energy;  // the energy of the state the step started from
      } else if (!skip_organs || !organ(model.nets[k])) {
        double net_gravity = 0.0;
        net_energy_[k] = net_energy(model, data, n, &net_gravity) + net_gravity;
      }
      held_energy += net_energy_[k];
    }
    net_energy_taken_ = true;
    const double budget = std::max(energy0_ + work_in_, limits_.energy_floor_j);
    const double ratio = held_energy / budget;
    if (std::isfinite(ratio)) energy_ratio_max_ = std::max(energy_ratio_max_, ratio);
    if (ratio > limits_.energy_factor) {
      latch("energy", held, -1, held_energy, limits_.energy_factor * budget, period, time_s);
      breach = true;
    }
  }
  remember(data);
  if (springs) {
    for (int b = 0; b < model.num_bodies(); ++b) {
      const auto k = static_cast<std::size_t>(b);
      const core::Twist* twist = nullptr;
      const core::Pose* target = coupling_target(model, data, b, &twist);
      prev_coupled_[k] = target != nullptr ? 1 : 0;
      if (target != nullptr) prev_targets_[k] = *target;
    }
  }
  return breach;
}

}  // namespace numen::sim
