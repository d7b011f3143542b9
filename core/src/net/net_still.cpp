/// @file net_still.cpp
/// Still neighbourhoods of an organ's net (net/net_still.hpp).

#include "net/net_still.hpp"

#include <bit>
#include <cstddef>
#include <cstdint>

#include "scratch/data_scratch.hpp"
#include "net/net_rest.hpp"
#include "numen/core/data.hpp"

namespace numen::core::detail {
namespace {

/// The bits where a and b differ, or-ed over their three doubles: 0 when they are the same
/// doubles bit for bit (+0 and −0 differ, a NaN equals itself). No branch.
std::uint64_t differing_bits(const Vec3& a, const Vec3& b) noexcept {
  return (std::bit_cast<std::uint64_t>(a.x()) ^ std::bit_cast<std::uint64_t>(b.x())) |
         (std::bit_cast<std::uint64_t>(a.y()) ^ std::bit_cast<std::uint64_t>(b.y())) |
         (std::bit_cast<std::uint64_t>(a.z()) ^ std::bit_cast<std::uint64_t>(b.z()));
}

}  // namespace

bool mark_still_nodes(const Model& model, Data& data) noexcept {
  NetScratch& s = data.scratch->net;
  std::uint8_t* flags = s.still_flags.data();
  const NodeNeighbours neighbours(model);
  bool any = false;
  for (const NetModel& net : model.nets) {
    const int begin = net.node_begin, end = net.node_begin + net.node_count;
    if (!net_can_rest(model, net)) {
      for (int v = begin; v < end; ++v)
        flags[static_cast<std::size_t>(v)] = kStateChangedBit | kNearChangeBit;
      continue;
    }
    const NodeState* nodes = data.nodes.data();
    Vec3* position = s.pass_position.data();
    Vec3* velocity = s.pass_velocity.data();
    const std::uint8_t none = s.pass_stored ? 0 : kStateChangedBit | kNearChangeBit;
    int changed = 0;
    for (int v = begin; v < end; ++v) {
      const auto i = static_cast<std::size_t>(v);
      const std::uint64_t diff = differing_bits(nodes[i].position, position[i]) |
                                 differing_bits(nodes[i].velocity, velocity[i]);
      flags[i] =
          static_cast<std::uint8_t>(none | (diff != 0 ? kStateChangedBit | kNearChangeBit : 0));
      changed += (flags[i] & kStateChangedBit) != 0;
      position[i] = nodes[i].position;
      velocity[i] = nodes[i].velocity;
    }
    // kNearChangeBit where a neighbour changed, through the changed nodes' own springs: most of
    // an organ is still, so few nodes changed (one branch per node, none per spring). Where
    // most changed (a net moving as a whole: a material organ under the tool), each unchanged
    // node looks at its neighbours instead — the same bits over fewer springs.
    if (2 * changed <= net.node_count) {
      for (int v = begin; v < end; ++v) {
        if (!(flags[static_cast<std::size_t>(v)] & kStateChangedBit)) continue;
        neighbours.for_each(v, [&](std::size_t j) { flags[j] |= kNearChangeBit; });
      }
    } else if (changed < net.node_count) {
      for (int v = begin; v < end; ++v) {
        if (flags[static_cast<std::size_t>(v)] & kStateChangedBit) continue;
        bool near = false;
        neighbours.for_each(v, [&](std::size_t j) { near |= (flags[j] & kStateChangedBit) != 0; });
        if (near) flags[static_cast<std::size_t>(v)] |= kNearChangeBit;
      }
    }
    any = true;
  }
  s.pass_stored = true;
  return any;
}

}  // namespace numen::core::detail
