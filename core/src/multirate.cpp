/// @file multirate.cpp
/// The intermediate contact model of a multirate god-object (multirate.hpp, docs/multirate.md).

#include "numen/core/multirate.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "numen/core/collision.hpp"
#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/step.hpp"

#include "detail/data_scratch.hpp"

namespace numen::core {
namespace {

struct PlaneContext {
  const ContactPlaneSet* planes;
  double elapsed;
};

void write_planes(const Model& model, Data& data, const void* context) noexcept {
  const auto* c = static_cast<const PlaneContext*>(context);
  write_plane_contacts(model, *c->planes, c->elapsed, data);
}

/// The scene loop's contact stage: detection, then the planes of the god-object's contacts
/// (before any body moves).
struct SampleContext {
  ContactPlaneSet* planes;
  int body;
};

void detect_and_build_planes(const Model& model, Data& data, const void* context) noexcept {
  const auto* c = static_cast<const SampleContext*>(context);
  detect_contacts(model, data);
  build_contact_planes(model, data, c->body, *c->planes);
}

}  // namespace

std::string make_god_object_model(const Model& scene, int body, double device_dt, Model& out) {
  if (body < 0 || body >= scene.num_bodies())
    return "multirate: god-object body " + std::to_string(body) + " is not a body of the scene (" +
           std::to_string(scene.num_bodies()) + " bodies)";
  if (!(device_dt > 0.0) || !std::isfinite(device_dt))
    return "multirate: the device period must be > 0 s and finite (got " + std::to_string(device_dt) + ")";
  for (const JointModel& j : scene.joints)
    if (j.parent == body || j.child == body)
      return "multirate: god-object body '" + scene.bodies[static_cast<std::size_t>(body)].name +
             "' is in a joint (articulated god-objects are not multirate yet)";
  if (!scene.nets.empty()) return "multirate: scenes with deformable nets are not multirate yet";
  if (scene.integrator != Integrator::kLinearlyImplicitEuler &&
      scene.integrator != Integrator::kSymplecticEuler)
    return "multirate: the god-object's integrator must be the linearly implicit or the "
           "symplectic Euler (the impulse hand-back needs the step's effective contact force)";
  const BodyModel& b = scene.bodies[static_cast<std::size_t>(body)];
  Model m;
  m.dt = device_dt;
  m.gravity = scene.gravity;
  m.integrator = scene.integrator;
  m.coupling_mode = scene.coupling_mode;
  m.bodies = {b};
  m.bodies[0].sphere_begin = 0;
  m.body_spheres.assign(scene.body_spheres.begin() + b.sphere_begin,
                        scene.body_spheres.begin() + b.sphere_begin + b.sphere_count);
  m.material_names = scene.material_names;
  m.material_pairs = scene.material_pairs;
  m.feedback = scene.feedback;
  m.initial_attached_body = 0;
  m.solver = scene.solver;
  m.caller_contacts = true;
  std::string error = finalize_model(m);
  if (!error.empty()) return "multirate: god-object model: " + error;
  out = std::move(m);
  return "";
}

std::string make_proximity_model(const Model& scene, int body, double margin, Model& out) {
  if (body < 0 || body >= scene.num_bodies())
    return "multirate: god-object body " + std::to_string(body) + " is not a body of the scene (" +
           std::to_string(scene.num_bodies()) + " bodies)";
  if (!(margin >= 0.0) || !std::isfinite(margin))
    return "multirate: the contact margin must be >= 0 m and finite (got " + std::to_string(margin) + ")";
  Model m = scene;
  const BodyModel& b = m.bodies[static_cast<std::size_t>(body)];
  for (int s = b.sphere_begin; s < b.sphere_begin + b.sphere_count; ++s)
    m.body_spheres[static_cast<std::size_t>(s)].radius += margin;
  std::string error = finalize_model(m);
  if (!error.empty()) return "multirate: proximity model: " + error;
  out = std::move(m);
  return "";
}

void build_contact_planes(const Model& scene, const Data& data, int body, ContactPlaneSet& out) noexcept {
  out.count = 0;
  out.dropped = 0;
  if (body < 0 || body >= scene.num_bodies()) return;
  const BodyModel& bm = scene.bodies[static_cast<std::size_t>(body)];
  const BodyState& g = data.bodies[static_cast<std::size_t>(body)];
  const int n = std::clamp(data.num_contacts, 0, kMaxContacts);
  for (int i = 0; i < n; ++i) {
    const Contact& c = data.contacts[static_cast<std::size_t>(i)];
    const bool on_a = c.body_a == body;
    const bool on_b = c.body_b == body;
    if (on_a == on_b) continue;  // not the god-object's, or between two of its own spheres
    const int sphere = on_a ? c.sphere_a : c.sphere_b;
    if (sphere < bm.sphere_begin || sphere >= bm.sphere_begin + bm.sphere_count) continue;
    if (out.count >= kMaxContactPlanes) {
      ++out.dropped;
      continue;
    }
    const Sphere& s = scene.body_spheres[static_cast<std::size_t>(sphere)];
    const Vec3 centre = g.position + g.orientation * s.center;
    const Vec3 normal = on_a ? c.normal : Vec3(-c.normal);
    ContactPlane& p = out.planes[static_cast<std::size_t>(out.count++)];
    p.sphere = sphere - bm.sphere_begin;
    p.normal = normal;
    p.point = centre - (s.radius - c.depth) * normal;  // the other side's surface point
    p.material_pair = c.material_pair;
    p.other_body = on_a ? c.body_b : c.body_a;
    p.velocity.setZero();
    if (p.other_body >= 0) {
      const BodyState& o = data.bodies[static_cast<std::size_t>(p.other_body)];
      p.velocity = o.linear_velocity + o.angular_velocity.cross(p.point - o.position);
    }
  }
}

void write_plane_contacts(const Model& model, const ContactPlaneSet& planes, double elapsed,
                          Data& data) noexcept {
  data.num_contacts = 0;
  data.max_penetration = 0.0;
  data.contacts_dropped = 0;
  if (model.num_bodies() < 1) return;
  const BodyModel& bm = model.bodies[0];
  const BodyState& g = data.bodies[0];
  const int np = static_cast<int>(model.material_pairs.size());
  const int n = std::clamp(planes.count, 0, kMaxContactPlanes);
  for (int i = 0; i < n; ++i) {
    const ContactPlane& p = planes.planes[static_cast<std::size_t>(i)];
    if (p.sphere < 0 || p.sphere >= bm.sphere_count || p.material_pair < 0 || p.material_pair >= np)
      continue;
    const Sphere& s = model.body_spheres[static_cast<std::size_t>(bm.sphere_begin + p.sphere)];
    const Vec3 centre = g.position + g.orientation * s.center;
    const Vec3 point = p.point + elapsed * p.velocity;
    const double depth = p.normal.dot(point - centre) + s.radius;
    if (!(depth > 0.0)) continue;
    if (data.num_contacts >= kMaxContacts) {
      ++data.contacts_dropped;
      continue;
    }
    Contact& c = data.contacts[static_cast<std::size_t>(data.num_contacts++)];
    c.body_a = 0;
    c.body_b = -1;
    c.obstacle = -1;
    c.sphere_a = bm.sphere_begin + p.sphere;
    c.material_pair = p.material_pair;
    c.position = centre - (s.radius - 0.5 * depth) * p.normal;  // middle of the overlap
    c.normal = p.normal;
    c.depth = depth;
    c.force.setZero();
    c.surface_velocity = p.velocity;
    c.sphere_b = i;  // the plane
    data.max_penetration = std::max(data.max_penetration, depth);
  }
  if (data.contacts_dropped > 0) {
    data.status |= kContactOverflow;
    ++data.contact_overflow_steps;
  }
}

void step_god_object(const Model& model, const ContactPlaneSet& planes, double elapsed,
                     Data& data) noexcept {
  const PlaneContext context{&planes, elapsed};
  step_with_contacts(model, data, &write_planes, &context);
}

MultirateGodObject::MultirateGodObject(const Model& scene, int body, const MultirateSettings& settings)
    : body_(body), ratio_(settings.ratio) {
  if (settings.ratio < 1)
    throw std::invalid_argument("multirate: the rate ratio scene_dt / dt must be >= 1 (got " +
                                std::to_string(settings.ratio) + ")");
  std::string error = make_god_object_model(scene, body, scene.dt, device_model_);
  if (error.empty()) error = make_proximity_model(scene, body, settings.margin, scene_model_);
  if (!error.empty()) throw std::invalid_argument(error);
  scene_model_.dt = scene.dt * settings.ratio;
  error = finalize_model(scene_model_);
  if (!error.empty()) throw std::invalid_argument("multirate: scene-loop model: " + error);
  device_ = make_data(device_model_);
  scene_ = make_data(scene_model_);
  scene_.passive_contact_body = body;
  set_attached_body(scene_model_, scene_, -1);  // the device drives the god-object model only
  device_.bodies[0] = scene_.bodies[static_cast<std::size_t>(body)];
  pending_.assign(scene.bodies.size(), Wrench{});
  base_applied_.assign(scene.bodies.size(), Wrench{});
}

void MultirateGodObject::scene_step() noexcept {
  const auto g = static_cast<std::size_t>(body_);
  scene_.bodies[g] = device_.bodies[0];
  const double h = scene_model_.dt;
  for (std::size_t b = 0; b < pending_.size(); ++b) {
    base_applied_[b] = scene_.applied_wrench[b];
    scene_.applied_wrench[b].force += pending_[b].force / h;
    scene_.applied_wrench[b].torque += pending_[b].torque / h;
    pending_[b] = Wrench{};
  }
  SampleContext context{&planes_, body_};
  step_with_contacts(scene_model_, scene_, &detect_and_build_planes, &context);
  for (std::size_t b = 0; b < pending_.size(); ++b) scene_.applied_wrench[b] = base_applied_[b];
  scene_.bodies[g] = device_.bodies[0];  // the scene loop does not move the god-object
  ++counters_.scene_steps;
  counters_.planes_dropped += planes_.dropped;
  counters_.planes_max = std::max<std::int64_t>(counters_.planes_max, planes_.count);
}

void MultirateGodObject::hand_back(const BodyState& before) noexcept {
  if (device_.status & kNonFinite) return;  // rolled back: nothing was applied
  const double h = device_model_.dt;
  const double tau = h * static_cast<double>(period_ % ratio_);
  const BodyState& after = device_.bodies[0];
  const bool implicit = device_model_.integrator == Integrator::kLinearlyImplicitEuler;
  const int n = std::clamp(device_.num_contacts, 0, kMaxContacts);
  for (int i = 0; i < n; ++i) {
    const Contact& c = device_.contacts[static_cast<std::size_t>(i)];
    const ContactTerm& t = device_.scratch->solver.contact_terms[static_cast<std::size_t>(i)];
    if (!t.active || c.sphere_b < 0 || c.sphere_b >= planes_.count) continue;
    const ContactPlane& p = planes_.planes[static_cast<std::size_t>(c.sphere_b)];
    if (p.other_body < 0 || p.other_body >= static_cast<int>(pending_.size())) continue;
    Vec3 f = c.force;
    if (implicit) {  // F₀ + K h v₁ + D Δv at the contact point (docs/multirate.md)
      const Vec3 v1 = after.linear_velocity + after.angular_velocity.cross(t.r_a);
      const Vec3 dv = v1 - (before.linear_velocity + before.angular_velocity.cross(t.r_a));
      const Vec3& nrm = c.normal;
      f -= (t.stiffness * h * nrm.dot(v1) + t.damping * nrm.dot(dv)) * nrm;
      f -= t.friction * (dv - nrm.dot(dv) * nrm);
    }
    const BodyState& o = scene_.bodies[static_cast<std::size_t>(p.other_body)];
    const Vec3 com = o.position + tau * o.linear_velocity;
    Wrench& w = pending_[static_cast<std::size_t>(p.other_body)];
    w.force -= h * f;
    w.torque -= h * (c.position - com).cross(f);
  }
}

void MultirateGodObject::step() noexcept {
  if (period_ % ratio_ == 0) scene_step();
  const BodyState before = device_.bodies[0];
  step_god_object(device_model_, planes_, device_model_.dt * static_cast<double>(period_ % ratio_),
                  device_);
  hand_back(before);
  ++counters_.device_steps;
  ++period_;
}

}  // namespace numen::core
