#pragma once
/// @file soft_peer_mapping.hpp
/// numen's net constants in the terms of Bullet's position-based soft body (docs/soft_peer.md,
/// "How the models were mapped"). Bullet (btSoftBody, the Positions solver preset) has no
/// forces of springs: each step it moves the nodes by their velocities, then `n` times
/// (Config::piterations) projects every link, anchor and contact in turn, and takes the
/// velocity as the displacement over the step. The mappings below make one isolated element
/// behave, in that scheme, as numen's linearly implicit Euler step of the same element:
///  - a link of stiffness fraction kLST removes kLST of its stretch per iteration, so
///    (1 − kLST)^n of it remains after the step; numen's implicit step of a spring k between
///    nodes of reduced mass μ leaves μ / (μ + k dt²) of a stretch held by a constant force, so
///    the choice (1 − kLST)^n = μ / (μ + k dt²) gives the link the static stiffness k (its
///    damping γ has no counterpart: Bullet's links are undamped);
///  - an anchor of influence s on a fixed body (Config::kAHR = K) moves its node, per
///    iteration, by −s (x − q) − s K (x − a) (q: position at the start of the step, a: the
///    anchor point), a spring and a damper at once; for a node of mass m tied by k_tie, γ_tie,
///    numen's step gives v' = (m v − k_tie dt u) / (m + γ_tie dt + k_tie dt²) (u = x − a), and
///    the n iterations give the same linear map exactly when K = k_tie dt / γ_tie and
///    (1 − s (1 + K))^n = m / (m + γ_tie dt + k_tie dt²).
/// All quantities SI (N/m, N·s/m, kg, s).

namespace numen::soft_peer {

/// The link stiffness fraction kLST ∈ (0, 1] for a spring of stiffness `k` (N/m, ≥ 0) between
/// nodes of reduced mass `mu` = m_a m_b / (m_a + m_b) (kg, > 0) at step `dt` (s, > 0) with
/// `iterations` (≥ 1) position iterations: 1 − (μ / (μ + k dt²))^(1/n). 0 for k = 0.
double link_stiffness_fraction(double k, double mu, double dt, int iterations);

/// Bullet's anchor constants for one node.
struct AnchorMapping {
  double hardness = 0.0;   ///< Config::kAHR (global per soft body): k_tie dt / γ_tie.
  double influence = 0.0;  ///< The anchor's influence s ∈ (0, 1].
};

/// The anchor of a node of mass `m` (kg, > 0) tied by `k_tie` (N/m, > 0) and `gamma_tie`
/// (N·s/m, > 0: Bullet's anchor always damps the node's motion over the step) at step `dt`
/// (s, > 0) with `iterations` (≥ 1). The influence is below 1 / (1 + K) ≤ 1 for any such tie.
/// Throws std::invalid_argument when an argument is out of range.
AnchorMapping anchor_mapping(double k_tie, double gamma_tie, double m, double dt, int iterations);

/// The linear map of one step of an isolated node tied to a fixed point (displacement u from
/// it, velocity v, along one axis): v' = retain · v − pull · u / dt. numen's linearly implicit
/// Euler step of the tie gives retain = m / D, pull = k_tie dt² / D, D = m + γ_tie dt + k_tie dt².
struct TieStep {
  double retain = 0.0;  ///< Fraction of the velocity kept.
  double pull = 0.0;    ///< Fraction of the displacement removed, as a velocity over dt.
};

/// numen's step of the tie (TieStep's formula).
TieStep numen_tie_step(double k_tie, double gamma_tie, double m, double dt);

/// Bullet's step of the anchor (`hardness` K, `influence` s, `iterations` n) on an isolated
/// node: retain = a^n, pull = s K (1 − a^n) / (1 − a), a = 1 − s (1 + K).
TieStep bullet_anchor_step(double hardness, double influence, int iterations);

}  // namespace numen::soft_peer
