#pragma once
/// @file fine_surface_organ.hpp
/// A fine surface mapped by hand onto a loaded net (core::add_net_surface(),
/// net_surface_map.hpp), for the tests of what draws it (tests/sim/view): the scene keys that
/// create fine surfaces at load are not what these tests check. The fine surface is an
/// icosphere of `subdivisions` around the net's rest nodes (centred on their mean, of their
/// mean distance from it), each fine vertex embedded on the net triangle whose centre is
/// nearest in direction (brute force: the net is a convex icosphere-like organ). Header-only.

#include <array>
#include <cstddef>
#include <string>
#include <vector>

#include "numen/core/mesh.hpp"
#include "numen/core/model.hpp"
#include "numen/core/net_surface_map.hpp"

namespace numen::test {

/// Maps an icosphere of `subdivisions` (icosphere 3: 642 vertices, 1280 triangles) onto net
/// `net` of `model` as described in the file comment. Returns add_net_surface()'s message
/// ("" on success). Allocates.
inline std::string map_fine_icosphere_onto_net(core::Model& model, int net, int subdivisions) {
  const core::NetModel& nm = model.nets[static_cast<std::size_t>(net)];
  core::Vec3 centre = core::Vec3::Zero();
  for (int i = nm.node_begin; i < nm.node_begin + nm.node_count; ++i)
    centre += model.node_rest[static_cast<std::size_t>(i)];
  centre /= nm.node_count;
  double radius = 0.0;
  for (int i = nm.node_begin; i < nm.node_begin + nm.node_count; ++i)
    radius += (model.node_rest[static_cast<std::size_t>(i)] - centre).norm();
  radius /= nm.node_count;
  core::TriangleMesh fine = core::make_icosphere(radius, subdivisions);
  for (core::Vec3& v : fine.vertices) v += centre;
  std::vector<core::Vec3> face_direction;  // net-local triangle → its centre's direction
  for (int f = nm.face_begin; f < nm.face_begin + nm.face_count; ++f) {
    core::Vec3 c = core::Vec3::Zero();
    for (int k : model.net_faces[static_cast<std::size_t>(f)]) c += model.node_rest[static_cast<std::size_t>(k)];
    face_direction.push_back((c / 3.0 - centre).normalized());
  }
  std::vector<int> nearest;
  for (const core::Vec3& v : fine.vertices) {
    const core::Vec3 d = (v - centre).normalized();
    int best = 0;
    for (int f = 1; f < static_cast<int>(face_direction.size()); ++f)
      if (face_direction[static_cast<std::size_t>(f)].dot(d) > face_direction[static_cast<std::size_t>(best)].dot(d))
        best = f;
    nearest.push_back(best);
  }
  return core::add_net_surface(model, net, fine.vertices, fine.triangles, nearest);
}

}  // namespace numen::test
