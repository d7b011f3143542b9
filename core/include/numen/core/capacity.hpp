#pragma once
/// @file capacity.hpp
/// Capacities fixed at compile time (CMake cache variables NUMEN_MAX_CONTACTS,
/// NUMEN_MAX_NODE_CONTACTS).
/// Running out is a reported status (StepStatus::kContactOverflow), never a
/// silent drop and never a heap fallback (docs/architecture.md, Conventions).

#ifndef NUMEN_MAX_CONTACTS
#define NUMEN_MAX_CONTACTS 1024
#endif

#ifndef NUMEN_MAX_NODE_CONTACTS
#define NUMEN_MAX_NODE_CONTACTS 4096
#endif

namespace numen::core {

struct Model;

/// Maximum number of contact points held by Data per step.
inline constexpr int kMaxContacts = NUMEN_MAX_CONTACTS;

/// Maximum number of node contact points (deformable nets) held by Data per
/// step; Data holds none for a model without nets.
inline constexpr int kMaxNodeContacts = NUMEN_MAX_NODE_CONTACTS;

/// Contact points `model` can produce in one step, i.e. the room make_data()
/// gives the per-contact solver scratch (SolverScratch::contact_terms):
/// kMaxContacts when a body can touch an obstacle (at least one obstacle) or
/// another body (two bodies in different articulations:
/// ArticulationTopology::body_tree), else 0 — a scene without anything to
/// collide allocates no contact scratch and step() skips contact detection
/// (a caller that writes its own contacts asks Data for room:
/// DataOptions::written_contacts). Whether the bodies carry spheres is not looked at. Data::contacts itself is a fixed
/// array inside Data (no heap). Finalized model; no allocation.
int contact_capacity(const Model& model) noexcept;

/// Body–body contact points `model` can produce in one step (room of
/// SolverScratch::cross_contacts): kMaxContacts when two bodies lie in
/// different articulations, else 0. No allocation.
int cross_contact_capacity(const Model& model) noexcept;

}  // namespace numen::core
