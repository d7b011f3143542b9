#pragma once
/// @file collision_scratch.hpp
/// Private to numen::core (core/src/scratch; tests reach it through numen_core_internal):
/// the collision stage's scratch (collision.hpp, net_collision.hpp) — world sphere
/// centres, body AABBs, the sort-and-sweep order kept between steps, the grid query
/// stamps. Held in DataScratch (data_scratch.hpp) behind Data::scratch, sized once by
/// make_data().

#include <cstdint>
#include <vector>

#include "numen/core/types.hpp"

namespace numen::core {

struct Model;

/// A sphere pair of two bodies held back at a detect_contacts() call: its centres were past
/// each other and its contact kept the normal of its approach (collision.hpp, "Crossing").
struct SpherePairRecord {
  std::int32_t sphere_a = -1;   ///< Index into Model::body_spheres (the lower body's).
  std::int32_t sphere_b = -1;   ///< Same, the other body's.
  Vec3 normal = Vec3::UnitZ();  ///< The normal it was held back along (from b towards a, world).
  bool matched = false;         ///< Found in contact again by the next call.
};

/// Scratch of the collision stage, sized once by resize().
struct CollisionScratch {
  std::vector<Vec3> sphere_world;                    ///< World centres of Model::body_spheres (m).
  std::vector<double> sphere_x, sphere_y, sphere_z;  ///< Same centres as flat arrays (m).
  std::vector<double> sphere_r;           ///< Radii of Model::body_spheres (m), copied by resize().
  std::vector<Vec3> body_aabb_min;        ///< Tight world AABB of each body's spheres (m);
  std::vector<Vec3> body_aabb_max;        ///< inverted (+inf, −inf) for a body without spheres.
  std::vector<std::int32_t> sweep_order;  ///< Bodies with spheres, sorted by body_aabb_min.x;
                                          ///< kept between steps (coherent insertion sort).
  std::vector<std::int32_t> near_a;       ///< Body–body: spheres of each body near the other's
  std::vector<std::int32_t> near_b;       ///< AABB; size = largest sphere count of a body.
  std::vector<std::int32_t> mesh_bodies;  ///< Bodies with a mesh (BodyModel::mesh), index order.
  std::vector<std::uint32_t> entry_stamp;  ///< Per static grid entry: last query that tested it.
  std::uint32_t stamp = 0;  ///< Current query id (wraps: the stamps are then cleared).
  /// Body–body sphere pairs held back at this call (`pairs`, written by the body–body phase)
  /// and at the last one (`pairs_prev`); swapped at the end of each call. Capacity
  /// cross_contact_capacity() each (capacity.hpp); a pair beyond it is not remembered.
  std::vector<SpherePairRecord> pairs, pairs_prev;
  int num_pairs = 0, num_pairs_prev = 0;
  int pair_cursor = 0;  ///< Where the next look-up in pairs_prev starts (after the last match).
  /// Sizes every buffer for `model`. Allocates: make_data() only.
  void resize(const Model& model);
};

}  // namespace numen::core
