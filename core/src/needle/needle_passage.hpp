#pragma once
/// @file needle/needle_passage.hpp
/// What the multirate scene loop asks of the needles' passages (needle_puncture.hpp;
/// docs/multirate-suturing.md, "A needle in the device loop"). Private to numen::core.

namespace numen::core {
struct Model;
struct Data;
struct NeedleModel;
struct NeedleState;
}  // namespace numen::core

namespace numen::core::detail {

/// Whether sphere `sphere` (from the needle's first) of needle `n` is inside the net of its
/// passage `st`: its arc parameter within [s_entry − 2 r_w, s_exit + 2 r_w] (s_exit = L without an
/// exit, s_entry = 0 once the entry is let go at the tail); false without a passage.
bool needle_sphere_inside(const NeedleModel& n, const NeedleState& st, int sphere) noexcept;

/// Drops this step's penalty node contacts between each needle's spheres inside the net of its
/// passage and that net, as tie_needles() does, on the passages as the last step left them: the
/// scene loop calls it before it builds the node planes, so that the device loop gets no plane
/// on the part of a needle that is inside the tissue (the puncture ties hold it there). No
/// allocation.
void drop_needles_inside_contacts(const Model& model, Data& data) noexcept;

/// The puncture of needle `needle` (Model::needles) that another's test found (NeedleModel::
/// puncture_on_request: the multirate device loop's, on the tip's contacts it renders, whose
/// force along the tangent was `tip_force`, N): as find_punctures() makes it, the entry at the
/// deepest of this step's tip triangle contacts (`data`'s node contacts) within the puncture
/// angle; NeedleState::puncture_contact_force and puncture_tip_force are `tip_force` (the
/// device loop's contacts did not give way). False, changing nothing, for a needle already in a
/// passage or without such a contact (the request stands: the next step tries again). No
/// allocation.
bool puncture_on_request(const Model& model, Data& data, int needle, double tip_force) noexcept;

}  // namespace numen::core::detail
