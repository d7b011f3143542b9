#pragma once
/// @file sliding_tie.hpp
/// A point of a body held on a line of the world that moves: a spring and a damper across the
/// line and viscous friction along it, stepped with the bodies (its stiffness and damping in the
/// linearly implicit step's matrix). What a needle's puncture point is to the needle where the
/// tissue is not in the same step (needle_puncture.hpp: the multirate device loop, whose needle
/// the scene loop's tissue holds; docs/multirate-suturing.md, "A needle in the device loop").
///
/// With x the body's point (world), v its velocity, p the anchor and w its velocity, a the unit
/// axis of the line, P = I − a aᵀ:
///   F = k P (p − x) + c P (w − v) + f a aᵀ (w − v)                      (on the body, at x)
/// The linearly implicit Euler step (integrator.cpp) takes F at the step's start on the body's
/// explicit wrench and, for the rest of the step, its Jacobian W = h C + h² K in the matrix with
/// K = k P, C = c P + f a aᵀ — W = β I + α a aᵀ with β = h c + h² k, α = h f − β, the form of a
/// contact's (α along one direction, β isotropic) — and h² K (w − v₀) on the right-hand side:
/// the anchor moves at w over the step. The symplectic Euler takes F alone.

#include <array>

#include "numen/core/types.hpp"

namespace numen::core {

struct Model;
struct Data;

/// Room of Data::sliding_ties.
inline constexpr int kMaxSlidingTies = 8;

/// One sliding tie (Data::sliding_ties): written by the caller before the step, `force` by it.
struct SlidingTie {
  int body = -1;                          ///< The body (Model::bodies); -1 or out of range: ignored.
  Vec3 local_point = Vec3::Zero();        ///< Its point x in the body frame (m from its COM).
  Vec3 anchor = Vec3::Zero();             ///< p at the step's start (m, world).
  Vec3 anchor_velocity = Vec3::Zero();    ///< w over the step (m/s, world).
  Vec3 axis = Vec3::UnitZ();              ///< a (unit, world): the line's direction.
  double stiffness = 0.0;                 ///< k across the line (N/m, ≥ 0).
  double damping = 0.0;                   ///< c across the line (N·s/m, ≥ 0).
  double friction = 0.0;                  ///< f along the line (N·s/m, ≥ 0).
  /// Written by the step: F on the body at the step's start (N, world); the anchor's side gets
  /// its opposite (the caller's to hand over).
  Vec3 force = Vec3::Zero();
};

/// Each sliding tie's force at the step's start (Data::sliding_ties, [0, num_sliding_ties)) on
/// its body's explicit wrench (Data::body_wrench: the force at x, its moment about the COM), and
/// into SlidingTie::force. Part of the body forces stage (compute_forces()). No allocation.
void apply_sliding_ties(const Model& model, Data& data) noexcept;

}  // namespace numen::core
