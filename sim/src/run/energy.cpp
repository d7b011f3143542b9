/// @file energy.cpp
/// The mechanical energy of a scene's state (energy.hpp).

#include "numen/sim/run/energy.hpp"

#include <cmath>

#include "numen/core/coupling.hpp"

namespace numen::sim {

using core::Vec3;

double coupling_potential(const core::CouplingGains& g, const core::BodyState& s,
                          const core::Pose& pose) noexcept {
  const double e2 = (pose.position - s.position).squaredNorm();
  const double th2 = core::rotation_error(pose.orientation, s.orientation).squaredNorm();
  return 0.5 * g.k_t * e2 + 0.5 * g.k_r * th2;
}

double damper_power(const core::CouplingGains& g, const core::BodyState& s,
                    const core::Twist& t) noexcept {
  return g.gamma_t * (t.linear - s.linear_velocity).dot(t.linear) +
         g.gamma_r * (t.angular - s.angular_velocity).dot(t.angular);
}

bool coupling_springs_act(const core::Model& model) noexcept {
  return model.coupling_mode == core::CouplingMode::kGodObject ||
         model.coupling_mode == core::CouplingMode::kFirstOrder;
}

const core::Pose* coupling_target(const core::Model& model, const core::Data& data, int b,
                                  const core::Twist** twist) noexcept {
  if (!coupling_springs_act(model)) return nullptr;
  if (b == data.held_body) {
    *twist = &data.target_twist;
    return &data.target;
  }
  const auto k = static_cast<std::size_t>(b);
  if (k >= data.body_targets.size() || !data.body_targets[k].enabled) return nullptr;
  *twist = &data.body_targets[k].twist;
  return &data.body_targets[k].pose;
}

double stored_energy(const core::Model& model, const core::Data& data) noexcept {
  double e = body_energy(model, data, nullptr);
  for (int n = 0; n < model.num_nets(); ++n) e += net_energy(model, data, n, nullptr);
  return e;
}

double body_energy(const core::Model& model, const core::Data& data, double* gravity) noexcept {
  double e = 0.0, u = 0.0;
  for (int i = 0; i < model.num_bodies(); ++i) {
    const auto k = static_cast<std::size_t>(i);
    const core::BodyModel& b = model.bodies[k];
    const core::BodyState& s = data.bodies[k];
    const core::Mat3 r = s.orientation.toRotationMatrix();
    const core::Mat3 iw = r * b.inertia_body * r.transpose();
    e += 0.5 * b.mass * s.linear_velocity.squaredNorm() +
         0.5 * s.angular_velocity.dot(iw * s.angular_velocity);
    u -= b.mass * model.gravity.dot(s.position);
    const core::Twist* twist = nullptr;
    if (const core::Pose* target = coupling_target(model, data, i, &twist))
      e += coupling_potential(b.coupling, s, *target);
  }
  if (gravity != nullptr) *gravity = u;
  return e;
}

double net_energy(const core::Model& model, const core::Data& data, int n,
                  double* gravity) noexcept {
  if (gravity != nullptr) *gravity = 0.0;
  if (n < 0 || n >= model.num_nets()) return 0.0;
  const core::NetModel& net = model.nets[static_cast<std::size_t>(n)];
  const core::BodyState& body = data.bodies[static_cast<std::size_t>(net.body)];
  double e = 0.0, u = 0.0;
  for (int i = net.node_begin; i < net.node_begin + net.node_count; ++i) {
    const auto k = static_cast<std::size_t>(i);
    e += 0.5 * model.node_mass[k] * data.nodes[k].velocity.squaredNorm();
    const Vec3 anchor = body.position + body.orientation * model.node_rest[k];
    e += 0.5 * core::tie_scale(net, i) * net.tie_stiffness * (data.nodes[k].position - anchor).squaredNorm();
    u -= model.node_mass[k] * model.gravity.dot(data.nodes[k].position);
  }
  for (int s = net.spring_begin; s < net.spring_begin + net.structural_count + net.bending_count; ++s) {
    const core::NetSpring& sp = model.net_springs[static_cast<std::size_t>(s)];
    const double l = (data.nodes[static_cast<std::size_t>(sp.node_b)].position -
                      data.nodes[static_cast<std::size_t>(sp.node_a)].position)
                         .norm();
    e += 0.5 * sp.stiffness * (l - sp.rest_length) * (l - sp.rest_length);
  }
  if (gravity != nullptr) *gravity = u;
  return e;
}

double contact_energy(const core::Model& model, const core::Data& data) noexcept {
  double e = 0.0;
  for (int c = 0; c < data.num_contacts; ++c) {
    const core::Contact& ct = data.contacts[static_cast<std::size_t>(c)];
    const double k = model.material_pairs[static_cast<std::size_t>(ct.material_pair)].stiffness;
    e += 0.5 * k * ct.depth * ct.depth;
  }
  for (int c = 0; c < data.num_node_contacts; ++c) {
    const core::NodeContact& ct = data.node_contacts[static_cast<std::size_t>(c)];
    const double k = model.material_pairs[static_cast<std::size_t>(ct.material_pair)].stiffness;
    e += 0.5 * k * ct.depth * ct.depth;
  }
  return e;
}

double gravity_potential(const core::Model& model, const core::Data& data) noexcept {
  double u = 0.0;
  for (int i = 0; i < model.num_bodies(); ++i) {
    const auto k = static_cast<std::size_t>(i);
    u -= model.bodies[k].mass * model.gravity.dot(data.bodies[k].position);
  }
  for (int i = 0; i < model.num_nodes(); ++i) {
    const auto k = static_cast<std::size_t>(i);
    u -= model.node_mass[k] * model.gravity.dot(data.nodes[k].position);
  }
  return u;
}

}  // namespace numen::sim
