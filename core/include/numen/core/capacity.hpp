#pragma once
/// @file capacity.hpp
/// Capacities fixed at compile time (CMake cache variable NUMEN_MAX_CONTACTS).
/// Running out is a reported status (StepStatus::kContactOverflow), never a
/// silent drop and never a heap fallback (DESIGN.md, core).

#ifndef NUMEN_MAX_CONTACTS
#define NUMEN_MAX_CONTACTS 1024
#endif

namespace numen::core {

/// Maximum number of contact points held by Data per step.
inline constexpr int kMaxContacts = NUMEN_MAX_CONTACTS;

}  // namespace numen::core
