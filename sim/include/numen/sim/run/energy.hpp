#pragma once
/// @file energy.hpp
/// The mechanical energy of a scene's state, for the energy bounds of the stability study
/// (study_stability.hpp) and of a run's divergence monitor (divergence.hpp): a passive
/// god-object scene never holds more than it started with plus what the hand put in through
/// the coupling (Adams & Hannaford 1999; docs/safety.md, "Divergence").

#include "numen/core/data.hpp"
#include "numen/core/model.hpp"

namespace numen::sim {

/// Stored mechanical energy (J), gravity left out (gravity_potential()): Σ ½ m v² +
/// ½ ωᵀ I_w ω of the bodies, Σ ½ m v² of the net nodes, the coupling springs of the held
/// body (Data::target) and of every enabled body target (½ k_t |e|² + ½ k_r θ², θ on the shortest
/// arc; god-object and first-order modes), ½ k (l − L)² of every net spring and ½ k_tie |x −
/// anchor|² of every tie. The penalty contacts' potential is left out (contact_energy()): contacts
/// are found at the step's start, so a body that enters a surface during a step holds ½ k d² at its
/// first contact that no force put in (a sphere reaching a 1e8 N/m plane at 0.2 m/s with
/// h = 10 ms: 200 J against the coupling's 0.04 J); the stability study and the divergence monitor bound
/// the contacts through the penetration instead, and an unstable contact shows in this energy as soon as it moves the body.
/// Non-finite input gives a non-finite result.
double stored_energy(const core::Model& model, const core::Data& data) noexcept;

/// The bodies' part of stored_energy() (J): their ½ m v² + ½ ωᵀ I_w ω and the coupling springs;
/// their share of gravity_potential(), −Σ m g·x, into `*gravity` (J) when not null.
double body_energy(const core::Model& model, const core::Data& data, double* gravity) noexcept;

/// The part of stored_energy() (J) that belongs to net `n` (Model::nets): its nodes' ½ m v², its
/// springs' ½ k (l − L)² and its ties' ½ k_tie |x − anchor|²; its nodes' share of
/// gravity_potential(), −Σ m g·x, into `*gravity` (J) when not null. stored_energy() and
/// gravity_potential() are the bodies' parts plus the sums of these over the nets. 0 for `n` out
/// of range.
double net_energy(const core::Model& model, const core::Data& data, int n,
                  double* gravity) noexcept;

/// ½ k d² of every body and node contact of the last step (depths at its start; stiffness of
/// the contact's material pair), J.
double contact_energy(const core::Model& model, const core::Data& data) noexcept;

/// Potential of gravity (J) relative to the world origin: −Σ m g·x over the bodies' centres of
/// mass and the net nodes (Model::gravity). Differences of it are what gravity did.
double gravity_potential(const core::Model& model, const core::Data& data) noexcept;

/// ½ k_t |e|² + ½ k_r θ² (J) of coupling gains `g` from body state `s` towards `pose`
/// (θ on the shortest arc, core::rotation_error).
double coupling_potential(const core::CouplingGains& g, const core::BodyState& s,
                          const core::Pose& pose) noexcept;

/// γ_t (v_t − v)·v_t + γ_r (ω_t − ω)·ω_t (W): the power the target's twist `t` puts into the
/// coupling dampers of body state `s` (dE/dt = F·v_t − γ|v_t − v|² for a spring-damper whose
/// end moves at v_t).
double damper_power(const core::CouplingGains& g, const core::BodyState& s,
                    const core::Twist& t) noexcept;

/// The coupling springs act on the bodies (god-object and first-order modes; not direct or
/// admittance coupling).
bool coupling_springs_act(const core::Model& model) noexcept;

/// The coupling target of body `b` this period, where the coupling springs act: the held
/// body's is Data::target (twist Data::target_twist), another body's its enabled
/// Data::body_targets entry (Eq. 6); nullptr for a body without one (or where the springs do
/// not act). `*twist` gets the target's twist.
const core::Pose* coupling_target(const core::Model& model, const core::Data& data, int b,
                                  const core::Twist** twist) noexcept;

}  // namespace numen::sim
