/// @file collision.cpp
/// PLACEHOLDER owned by the collision work: replaced by the real narrow/broad phase.

#include "numen/core/collision.hpp"

#include "numen/core/data.hpp"
#include "numen/core/model.hpp"

namespace numen::core {

void CollisionScratch::resize(const Model& model) { sphere_world.resize(model.body_spheres.size()); }

void build_static_grid(const std::vector<Sphere>&, double, StaticSphereGrid&) {}

void build_collision_structures(Model&) {}

void detect_contacts(const Model&, Data& data) noexcept { data.num_contacts = 0; }

}  // namespace numen::core
