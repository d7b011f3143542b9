#pragma once
/// @file capacity.hpp
/// Capacities fixed at compile time (CMake cache variables NUMEN_MAX_CONTACTS,
/// NUMEN_MAX_NODE_CONTACTS).
/// Running out is a reported status (StepStatus::kContactOverflow), never a
/// silent drop and never a heap fallback (DESIGN.md, core).

#ifndef NUMEN_MAX_CONTACTS
#define NUMEN_MAX_CONTACTS 1024
#endif

#ifndef NUMEN_MAX_NODE_CONTACTS
#define NUMEN_MAX_NODE_CONTACTS 4096
#endif

namespace numen::core {

/// Maximum number of contact points held by Data per step.
inline constexpr int kMaxContacts = NUMEN_MAX_CONTACTS;

/// Maximum number of node contact points (deformable nets) held by Data per
/// step; Data holds none for a model without nets.
inline constexpr int kMaxNodeContacts = NUMEN_MAX_NODE_CONTACTS;

}  // namespace numen::core
