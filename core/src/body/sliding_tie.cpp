/// @file sliding_tie.cpp
/// The sliding ties' forces at the step's start (sliding_tie.hpp); their terms in the linearised
/// step are integrator.cpp's.

#include "numen/core/sliding_tie.hpp"

#include <algorithm>

#include "numen/core/data.hpp"
#include "numen/core/model.hpp"

namespace numen::core {

void apply_sliding_ties(const Model& model, Data& data) noexcept {
  const int n = std::clamp(data.num_sliding_ties, 0, kMaxSlidingTies);
  for (int i = 0; i < n; ++i) {
    SlidingTie& t = data.sliding_ties[static_cast<std::size_t>(i)];
    t.force.setZero();
    if (t.body < 0 || t.body >= model.num_bodies()) continue;
    const BodyState& b = data.bodies[static_cast<std::size_t>(t.body)];
    const Vec3 r = b.orientation * t.local_point;
    const Vec3 d = t.anchor - (b.position + r);
    const Vec3 dv = t.anchor_velocity - (b.linear_velocity + b.angular_velocity.cross(r));
    const Vec3& a = t.axis;
    t.force = t.stiffness * (d - a.dot(d) * a) + t.damping * (dv - a.dot(dv) * a) + t.friction * a.dot(dv) * a;
    Wrench& w = data.body_wrench[static_cast<std::size_t>(t.body)];
    w.force += t.force;
    w.torque += r.cross(t.force);
  }
}

}  // namespace numen::core
