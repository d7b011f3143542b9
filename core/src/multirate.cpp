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

/// The scene loop's contact stage: detection, the planes of the god-object's contacts (before
/// any body moves), then those contacts cut back to the god-object's true spheres (the
/// proximity model grew them by the margin): depth − δ, the middle of the overlap δ/2 back
/// towards the god-object; a contact left without depth is dropped.
struct SampleContext {
  ContactPlaneSet* planes;
  int body;
  double margin;
};

void detect_and_build_planes(const Model& model, Data& data, const void* context) noexcept {
  const auto* c = static_cast<const SampleContext*>(context);
  detect_contacts(model, data);
  build_contact_planes(model, data, c->body, *c->planes);
  if (c->margin <= 0.0) return;
  int kept = 0;
  double deepest = 0.0;
  const int n = std::clamp(data.num_contacts, 0, kMaxContacts);
  for (int i = 0; i < n; ++i) {
    Contact k = data.contacts[static_cast<std::size_t>(i)];
    const bool on_a = k.body_a == c->body;
    if (on_a != (k.body_b == c->body)) {
      k.depth -= c->margin;
      if (!(k.depth > 0.0)) continue;
      k.position += (0.5 * c->margin) * (on_a ? k.normal : Vec3(-k.normal));
    }
    deepest = std::max(deepest, k.depth);
    data.contacts[static_cast<std::size_t>(kept++)] = k;
  }
  data.num_contacts = kept;
  data.max_penetration = deepest;
}

/// The force a contact of the last step applied to its body a over the step (N, world): for
/// the linearly implicit Euler F₀ + K h v₁ + D Δv on the contact's relative velocity
/// v = (v_a + ω_a × r_a) − (v_b + ω_b × r_b) − surface velocity (the linearisation the step
/// solved, integrator.cpp: v₁'s normal part is the step's start value ContactTerm::
/// normal_velocity plus its change; docs/multirate.md), for the symplectic Euler F₀. `a0`, `a1`,
/// `b0`, `b1`: the bodies' states at the step's start and end (b null: static, its surface
/// moving at a constant velocity).
Vec3 effective_contact_force(const Contact& c, const ContactTerm& t, bool implicit, double h,
                             const BodyState& a0, const BodyState& a1, const BodyState* b0,
                             const BodyState* b1) noexcept {
  Vec3 f = c.force;
  if (!implicit) return f;
  const auto point_velocity = [](const BodyState& s, const Vec3& r) {
    return Vec3(s.linear_velocity + s.angular_velocity.cross(r));
  };
  Vec3 dv = point_velocity(a1, t.r_a) - point_velocity(a0, t.r_a);
  if (b0 != nullptr && b1 != nullptr) dv -= point_velocity(*b1, t.r_b) - point_velocity(*b0, t.r_b);
  const Vec3& n = c.normal;
  f -= (t.stiffness * h * (t.normal_velocity + n.dot(dv)) + t.damping * n.dot(dv)) * n;
  f -= t.friction * (dv - n.dot(dv) * n);
  return f;
}

/// "" when `body` is a body of `scene`, else the message both model makers give.
std::string body_error(const Model& scene, int body) {
  if (body >= 0 && body < scene.num_bodies()) return "";
  return "multirate: god-object body " + std::to_string(body) + " is not a body of the scene (" +
         std::to_string(scene.num_bodies()) + " bodies)";
}

}  // namespace

std::string make_god_object_model(const Model& scene, int body, double device_dt, Model& out) {
  if (std::string e = body_error(scene, body); !e.empty()) return e;
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
  if (std::string e = body_error(scene, body); !e.empty()) return e;
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
    : body_(body), ratio_(settings.ratio), margin_(settings.margin) {
  if (settings.ratio < 1)
    throw std::invalid_argument("multirate: the rate ratio scene_dt / dt must be >= 1 (got " +
                                std::to_string(settings.ratio) + ")");
  std::string error = make_god_object_model(scene, body, scene.dt, device_model_);
  if (error.empty()) error = make_proximity_model(scene, body, settings.margin, scene_model_);
  if (!error.empty()) throw std::invalid_argument(error);
  scene_model_.dt = scene.dt * settings.ratio;
  // The god-object moves in the scene loop as the device loop moved it: imposed (kDirect, an
  // infinitely heavy body for the scene's implicit solve).
  scene_model_.coupling_mode = CouplingMode::kDirect;
  scene_model_.initial_attached_body = body;
  error = finalize_model(scene_model_);
  if (!error.empty()) throw std::invalid_argument("multirate: scene-loop model: " + error);
  device_ = make_data(device_model_);
  scene_ = make_data(scene_model_);
  device_.bodies[0] = scene_.bodies[static_cast<std::size_t>(body)];
  pending_.assign(scene.bodies.size(), Wrench{});
  base_applied_.assign(scene.bodies.size(), Wrench{});
  scene_before_.assign(scene.bodies.size(), BodyState{});
}

void MultirateGodObject::scene_step() noexcept {
  const auto g = static_cast<std::size_t>(body_);
  const double h = scene_model_.dt;
  // The god-object's pose and twist, imposed over the scene step.
  scene_.target.position = device_.bodies[0].position;
  scene_.target.orientation = device_.bodies[0].orientation;
  scene_.target_twist.linear = device_.bodies[0].linear_velocity;
  scene_.target_twist.angular = device_.bodies[0].angular_velocity;
  scene_.bodies[g] = device_.bodies[0];
  // What each scene body is owed (the device loop's impulses less what the scene's own contact
  // with the god-object gave it), applied over this step.
  for (std::size_t b = 0; b < pending_.size(); ++b) {
    base_applied_[b] = scene_.applied_wrench[b];
    scene_.applied_wrench[b].force += pending_[b].force / h;
    scene_.applied_wrench[b].torque += pending_[b].torque / h;
    pending_[b] = Wrench{};
    scene_before_[b] = scene_.bodies[b];
  }
  SampleContext context{&planes_, body_, margin_};
  step_with_contacts(scene_model_, scene_, &detect_and_build_planes, &context);
  const bool rejected = (scene_.status & kNonFinite) != 0;
  for (std::size_t b = 0; b < pending_.size(); ++b) {
    if (rejected) {  // rolled back: what was owed is still owed
      pending_[b].force = h * (scene_.applied_wrench[b].force - base_applied_[b].force);
      pending_[b].torque = h * (scene_.applied_wrench[b].torque - base_applied_[b].torque);
    }
    scene_.applied_wrench[b] = base_applied_[b];
  }
  // The impulse the scene step's god-object contacts gave each scene body: already received,
  // so no longer owed.
  if (!rejected) {
    const bool implicit = scene_model_.integrator == Integrator::kLinearlyImplicitEuler;
    const int n = std::clamp(scene_.num_contacts, 0, kMaxContacts);
    for (int i = 0; i < n; ++i) {
      const Contact& c = scene_.contacts[static_cast<std::size_t>(i)];
      const ContactTerm& t = scene_.scratch->solver.contact_terms[static_cast<std::size_t>(i)];
      const bool on_a = c.body_a == body_;
      if (!t.active || on_a == (c.body_b == body_) || c.body_a < 0 || c.body_b < 0) continue;
      const auto a = static_cast<std::size_t>(c.body_a);
      const auto b = static_cast<std::size_t>(c.body_b);
      const Vec3 f = effective_contact_force(c, t, implicit, h, scene_before_[a], scene_.bodies[a],
                                             &scene_before_[b], &scene_.bodies[b]);
      // The other body's share: −f if it is b, +f if it is a.
      const Vec3 on_other = on_a ? Vec3(-f) : f;
      const Vec3& r = on_a ? t.r_b : t.r_a;
      Wrench& w = pending_[on_a ? b : a];
      w.force -= h * on_other;
      w.torque -= h * r.cross(on_other);
      ++counters_.scene_contacts;
    }
  }
  scene_.bodies[g] = device_.bodies[0];
  ++counters_.scene_steps;
  counters_.planes_dropped += planes_.dropped;
  counters_.planes_max = std::max<std::int64_t>(counters_.planes_max, planes_.count);
}

void MultirateGodObject::hand_back(const BodyState& before) noexcept {
  if (device_.status & kNonFinite) return;  // rolled back: nothing was applied
  const double h = device_model_.dt;
  const double tau = h * static_cast<double>(period_ % ratio_);
  const bool implicit = device_model_.integrator == Integrator::kLinearlyImplicitEuler;
  const int n = std::clamp(device_.num_contacts, 0, kMaxContacts);
  for (int i = 0; i < n; ++i) {
    const Contact& c = device_.contacts[static_cast<std::size_t>(i)];
    const ContactTerm& t = device_.scratch->solver.contact_terms[static_cast<std::size_t>(i)];
    if (!t.active || c.sphere_b < 0 || c.sphere_b >= planes_.count) continue;
    const ContactPlane& p = planes_.planes[static_cast<std::size_t>(c.sphere_b)];
    if (p.other_body < 0 || p.other_body >= static_cast<int>(pending_.size())) continue;
    // The plane's motion is prescribed over the period: the relative velocity's change is the
    // god-object's alone.
    const Vec3 f = effective_contact_force(c, t, implicit, h, before, device_.bodies[0], nullptr, nullptr);
    // The other body at the sample (the scene step's start), moved on by τ.
    const BodyState& o = scene_before_[static_cast<std::size_t>(p.other_body)];
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
