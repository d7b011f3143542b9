#pragma once
/// @file multirate/contact.hpp
/// The contacts of a multirate god-object seen by both loops (docs/multirate.md): which contact
/// is the god-object's, the force a contact applied over a step (the impulse hand-back), and the
/// counts the loops' states carry from one to the next.
/// Private to numen::core (core/src/multirate/).

#include <span>
#include <string>

#include "numen/core/data.hpp"
#include "numen/core/model.hpp"

#include "multirate/net.hpp"
#include "scratch/solver_scratch.hpp"

namespace numen::core::detail {

/// True when exactly one side of `c` is a body of the god-object; `on_a` says which.
inline bool god_object_contact(const Contact& c, std::span<const int> device_body,
                               bool& on_a) noexcept {
  on_a = in_god_object(device_body, c.body_a);
  return on_a != in_god_object(device_body, c.body_b);
}

/// The force a contact of the last step applied to its body a over the step (N, world): for
/// the linearly implicit Euler F₀ + K h v₁ + D Δv on the contact's relative velocity
/// v = (v_a + ω_a × r_a) − (v_b + ω_b × r_b) − surface velocity (the linearisation the step
/// solved, integrator.cpp: v₁'s normal part is the step's start value ContactTerm::
/// normal_velocity plus its change; docs/multirate.md), for the symplectic Euler F₀. `a0`, `a1`,
/// `b0`, `b1`: the bodies' states at the step's start and end (b null: static, its surface
/// moving at a constant velocity).
inline Vec3 effective_contact_force(const Contact& c, const ContactTerm& t, bool implicit, double h,
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

/// finalize_model(`m`), a scene-loop model, then the god-object's bodies `god` (scene indices)
/// made one articulation for collision (ArticulationTopology::body_tree): the scene loop never
/// detects their mutual contacts, which are the device step's (write_plane_contacts()) and
/// which, grown by the margin, would fill the contacts' room (kMaxContacts). Returns
/// finalize_model()'s message. Load time (device_loop.cpp).
std::string finalize_scene_loop_model(Model& m, std::span<const int> god);

/// The counts since reset (steps with a contact overflow, a clamped contact stiffness, a sphere
/// behind a net's surface, a body–body crossing, pass-throughs, a non-finite state) from `from` to
/// `to`, each a Data or a StepOutputs: the scene-loop model's Data, its snapshot, the
/// device loop's copy of it, the view, and the next scene-loop model's Data at a tool switch carry
/// the same counts.
template <typename From, typename To>
void copy_counts(const From& from, To& to) noexcept {
  to.contact_overflow_steps = from.contact_overflow_steps;
  to.contact_clamped_steps = from.contact_clamped_steps;
  to.net_crossed_steps = from.net_crossed_steps;
  to.crossed_contact_steps = from.crossed_contact_steps;
  to.pass_throughs = from.pass_throughs;
  to.nonfinite_steps = from.nonfinite_steps;
}

}  // namespace numen::core::detail
