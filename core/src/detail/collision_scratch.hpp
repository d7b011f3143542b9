#pragma once
/// @file collision_scratch.hpp
/// Private to numen::core (core/src/detail; tests reach it through numen_core_internal):
/// the collision stage's scratch (collision.hpp, net_collision.hpp) — world sphere
/// centres, body AABBs, the sort-and-sweep order kept between steps, the grid query
/// stamps. Held in DataScratch (data_scratch.hpp) behind Data::scratch, sized once by
/// make_data().

#include <cstdint>
#include <vector>

#include "numen/core/types.hpp"

namespace numen::core {

struct Model;

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
  /// Sizes every buffer for `model`. Allocates: make_data() only.
  void resize(const Model& model);
};

}  // namespace numen::core
