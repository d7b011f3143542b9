#pragma once
/// @file net_surface_frame.hpp
/// Private to numen::core (core/src/net): the frame of a net triangle that carries the fine
/// surface's vertices (net_surface_map.hpp, NetSurfacePoint), and a fine vertex's position from
/// it. No allocation.

#include <cmath>

#include "numen/core/net_surface_map.hpp"
#include "numen/core/types.hpp"

namespace numen::core::detail {

/// The orthonormal frame F = [e_1, e_2, n] of the triangle (a, b, c): e_1 along b − a, n the
/// outward unit normal (b − a) × (c − a), e_2 = n × e_1. False (F untouched) for a degenerate
/// triangle (an edge or the normal of zero or non-finite length).
inline bool net_surface_frame(const Vec3& a, const Vec3& b, const Vec3& c, Mat3& frame) noexcept {
  const Vec3 ab = b - a;
  const Vec3 n = ab.cross(c - a);
  const double l = ab.norm(), ln = n.norm();
  if (!(l > 0.0) || !(ln > 0.0) || !std::isfinite(l) || !std::isfinite(ln)) return false;
  const Vec3 e1 = ab / l, nn = n / ln;
  frame.col(0) = e1;
  frame.col(1) = nn.cross(e1);
  frame.col(2) = nn;
  return true;
}

/// The fine vertex `e` on the triangle at corners (a, b, c) whose frame F is `frame`
/// (net_surface_frame(); null where the triangle has collapsed): Σ w_m x_m + F · offset, the foot
/// point alone without a frame. For the vertices of one triangle, its frame computed once.
inline Vec3 net_surface_point(const NetSurfacePoint& e, const Vec3& a, const Vec3& b, const Vec3& c,
                              const Mat3* frame) noexcept {
  const Vec3 foot = e.weights.x() * a + e.weights.y() * b + e.weights.z() * c;
  return frame ? Vec3(foot + *frame * e.offset) : foot;
}

/// The fine vertex `e` on the triangle at corners (a, b, c): Σ w_m x_m + F · offset; the foot
/// point alone where the triangle has collapsed.
inline Vec3 net_surface_point(const NetSurfacePoint& e, const Vec3& a, const Vec3& b,
                              const Vec3& c) noexcept {
  Mat3 frame;
  return net_surface_point(e, a, b, c, net_surface_frame(a, b, c, frame) ? &frame : nullptr);
}

}  // namespace numen::core::detail
