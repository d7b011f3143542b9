#pragma once
/// @file model/node_contact_copy.hpp
/// Copying a Data's or a StepOutputs' node contacts and the held node springs after them
/// (step_outputs.hpp; the multirate god-object's nets, multirate/net.hpp). Private to numen::core.

#include <algorithm>

namespace numen::core::detail {

/// `from`'s node contacts [0, num_node_contacts) and the held node springs after them (the grasps',
/// the needles' ties, the threads' eyelets: num_node_grasp_springs, num_node_needle_ties,
/// num_node_thread_ties) into `to`, with their counts, as many as both have room for (the
/// contacts first). `From`, `To`: Data or StepOutputs. No allocation.
template <typename From, typename To>
void copy_node_contacts(const From& from, To& to) noexcept {
  const int room = static_cast<int>(std::min(to.node_contacts.size(), from.node_contacts.size()));
  to.num_node_contacts = std::clamp(from.num_node_contacts, 0, room);
  int left = room - to.num_node_contacts;
  const auto take = [&left](int n) noexcept {
    const int k = std::clamp(n, 0, left);
    left -= k;
    return k;
  };
  to.num_node_grasp_springs = take(from.num_node_grasp_springs);
  to.num_node_needle_ties = take(from.num_node_needle_ties);
  to.num_node_thread_ties = take(from.num_node_thread_ties);
  std::copy_n(from.node_contacts.begin(),
              to.num_node_contacts + to.num_node_grasp_springs + to.num_node_needle_ties + to.num_node_thread_ties,
              to.node_contacts.begin());
}

}  // namespace numen::core::detail
