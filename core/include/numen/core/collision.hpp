#pragma once
/// @file collision.hpp
/// Collision stage: sphere sets of dynamic bodies against static obstacles
/// (plane, box, sphere, capsule, sphere set) and against each other.

#include <cstdint>
#include <vector>

#include "numen/core/types.hpp"

namespace numen::core {

struct Model;
struct Data;

/// Scratch of the collision stage, sized once by resize().
struct CollisionScratch {
  std::vector<Vec3> sphere_world;  ///< World centres of Model::body_spheres (m).
  /// Sizes every buffer for `model`. Allocates: make_data() only.
  void resize(const Model& model);
};

/// Builds the broad-phase structures of `model` (static sphere grid, obstacle
/// bounds). Called by finalize_model(); allocates.
void build_collision_structures(Model& model);

/// Fills data.contacts[0, data.num_contacts) with the geometry of every
/// penetrating sphere pair. Overflow beyond kMaxContacts sets
/// StepStatus::kContactOverflow and counts data.contacts_dropped. No allocation.
void detect_contacts(const Model& model, Data& data) noexcept;

}  // namespace numen::core
