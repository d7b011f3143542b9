#pragma once
/// @file device_loop.hpp
/// The models of a multirate god-object's two loops and the device loop's step
/// (numen/core/multirate.hpp, docs/multirate.md): the god-object's bodies
/// (god_object_bodies), the model the device loop steps (make_god_object_model), the proximity
/// model the scene loop detects with (make_proximity_model), one device period against the
/// planes (step_god_object).

#include <span>
#include <string>
#include <vector>

#include "numen/core/model.hpp"
#include "numen/core/multirate/planes.hpp"

namespace numen::core {

struct Data;

/// The god-object of held body `body` in `scene`: `body` and every body joined to it by joints
/// (its articulation, ArticulationTopology::body_tree; the default scene's sleeve, tube and
/// jaws), with, for a loop of several devices, the articulation of each body of `others` (the
/// bodies the other devices drive, MultirateSettings::other_devices: a composite god-object, each
/// instrument its own articulation), in index order — the god-object model's bodies in the same
/// order. Empty for a body out of range; a body of `others` out of range is skipped. Load time:
/// allocates.
std::vector<int> god_object_bodies(const Model& scene, int body, std::span<const int> others = {});

/// The model the device loop steps: the god-object of `body` (god_object_bodies(): the held
/// body and its articulation, with their masses, inertias, spheres, materials, coupling gains,
/// and the joints among them and to the world, prescribed ones included), with the scene's
/// materials, integrator, coupling mode, gravity, Baumgarte and solver settings and device
/// feedback, no obstacles, no other body, no nets, step `device_dt` (s, > 0), the device
/// holding the held body (its contacts are the planes', written by write_plane_contacts() into
/// a make_god_object_data()). A net whose rigid
/// component is a body of the god-object is lumped onto it: the body's mass and inertia gain the
/// nodes' (at their rest positions); the net itself stays in the scene loop. Returns "" and
/// fills `out`, or a message naming what refuses: a body out of range, a net on the god-object
/// whose centre of mass is more than 0.1 mm from its component's, an integrator other than the
/// linearly implicit or symplectic Euler (the impulse hand-back needs the step's effective
/// contact force, MultirateGodObject), a device_dt ≤ 0 or not finite, a body of the god-object
/// with a mesh (BodyModel::mesh: the planes stand for its spheres only; the tool's spheres against
/// another body's mesh are planes like any contact). With `others` (several devices,
/// god_object_bodies()), the model holds every device's articulation, each body driven as in the
/// scene (the held body by the target, the others by their body targets, Eq. 6; each body's
/// Eq. 8 gains its device's, Model::extra_feedback), and the bodies of two articulations collide
/// with each other in the device step (step_god_object(): instrument clashes at the device
/// rate); refused: a body of `others` out of range. `others` may also name free bodies the device
/// loop carries (MultirateSettings::carried: driven by nothing). The scene's graspers whose two
/// jaws are in the model grasp here, in the device step (grasp.hpp, their jaws renumbered; the
/// others are left out): docs/multirate-suturing.md, "Grasping in the device loop". Load time: allocates.
std::string make_god_object_model(const Model& scene, int body, double device_dt, Model& out,
                                  std::span<const int> others = {});

/// A Data of a god-object model (make_god_object_model()) with room for its planes' contacts
/// (DataOptions::written_contacts = kMaxContacts: the model itself collides with nothing, its
/// contacts are written by write_plane_contacts(); a Data made without that room drops them, and
/// each step reports kContactOverflow). Throws as make_data(). Load time: allocates.
Data make_god_object_data(const Model& god_object);

/// A copy of `scene` in which every sphere of the god-object of `body` (god_object_bodies()),
/// and every node sphere of a net on it, has its radius grown by `margin` (m, ≥ 0): the scene loop detects the god-object's contacts
/// on it, so that a contact is found, and its plane built, while the sphere is still up to
/// `margin` away from the surface. Returns "" and fills `out`, or a message (body out of range,
/// margin < 0 or not finite). `others`: the other devices' bodies (god_object_bodies()), whose
/// articulations' spheres are grown too. It has no grasper: the device step grasps
/// (make_god_object_model()). Load time: allocates.
std::string make_proximity_model(const Model& scene, int body, double margin, Model& out,
                                 std::span<const int> others = {});

/// One device period of the god-object against the intermediate model: the step of `model` (a
/// god-object model) split at its contacts, write_plane_contacts() its contact stage
/// (step_to_contacts(), step_from_contacts(), step.hpp) — coupling (Eq. 2), the
/// planes' penalty forces with their stiffness and damping implicit, integration, feedback
/// (Eq. 8), checks; then each plane's impulse on the god-object over the period (its effective
/// force, MultirateGodObject) into ContactPlane::impulse, its opposite summed into the plane's
/// carrier's J, and every carrier stepped by dt (PlaneCarrier). A node carrier
/// (PlaneCarrier::node) is stepped instead by linearly implicit Euler with its tie and springs,
/// its links to the other node carriers at the period's start (CarrierLink), its J (the
/// god-object's step took its planes as moving at v₀) and, beyond v₀, its planes' stiffness K and
/// damping C (Σ over its active planes of the contact terms' k n nᵀ and c n nᵀ + μ (I − n nᵀ)):
///   (m + h (D_n + C) + h² (K_n + K)) v₁ = m v₀ + h (F₀ − K_n u₀ + Σ links) + J + h (C + h K) v₀.
/// The caller's sliding ties in `data` (Data::sliding_ties: a needle's puncture ties,
/// MultirateGodObject) are stepped with the god-object. A rolled-back step (non-finite) gives no
/// impulse; the carriers still step. Never allocates, throws or locks.
void step_god_object(const Model& model, ContactPlaneSet& planes, Data& data) noexcept;

}  // namespace numen::core
