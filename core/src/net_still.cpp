/// @file net_still.cpp
/// Still neighbourhoods of an organ's net (detail/net_still.hpp).

#include "detail/net_still.hpp"

#include <bit>
#include <cstddef>
#include <cstdint>

#include "detail/data_scratch.hpp"
#include "detail/net_rest.hpp"
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
  const std::int32_t* order = model.node_sweep_order.data();
  const std::int32_t* high = s.sweep_springs.high.data();
  const std::int32_t* low_begin = s.spring_low_begin.data();
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
    for (int v = begin; v < end; ++v) {
      const auto i = static_cast<std::size_t>(v);
      const std::uint64_t diff = differing_bits(nodes[i].position, position[i]) |
                                 differing_bits(nodes[i].velocity, velocity[i]);
      flags[i] = static_cast<std::uint8_t>(
          none | (diff != 0 ? kStateChangedBit | kNearChangeBit : 0));
      position[i] = nodes[i].position;
      velocity[i] = nodes[i].velocity;
    }
    // kNearChangeBit where a neighbour changed: through the changed nodes' own springs
    // (Model::node_springs) where the model lists them (most of an organ is still, so few
    // nodes changed), else each spring once from its earlier node.
    if (!model.node_spring_begin.empty()) {
      const std::int32_t* spring_begin = model.node_spring_begin.data();
      const std::int32_t* springs = model.node_springs.data();
      const NetSpring* net_springs = model.net_springs.data();
      for (int v = begin; v < end; ++v) {
        if (!(flags[static_cast<std::size_t>(v)] & kStateChangedBit)) continue;
        const auto i = static_cast<std::size_t>(v);
        for (std::int32_t q = spring_begin[i]; q < spring_begin[i + 1]; ++q) {
          const NetSpring& e = net_springs[springs[q]];
          flags[static_cast<std::size_t>(e.node_a == v ? e.node_b : e.node_a)] |= kNearChangeBit;
        }
      }
      any = true;
      continue;
    }
    static_assert(kStateChangedBit << 1 == kNearChangeBit);
    for (int p = begin; p < end; ++p) {
      const auto a = static_cast<std::size_t>(order[p]);
      const std::uint8_t changed_a = flags[a] & kStateChangedBit;
      std::uint8_t near_a = 0;
      for (std::int32_t j = low_begin[p]; j < low_begin[p + 1]; ++j) {
        const auto b = static_cast<std::size_t>(high[j]);
        near_a |= flags[b] & kStateChangedBit;
        flags[b] |= static_cast<std::uint8_t>(changed_a << 1);
      }
      flags[a] |= static_cast<std::uint8_t>(near_a << 1);
    }
    any = true;
  }
  s.pass_stored = true;
  return any;
}

}  // namespace numen::core::detail
