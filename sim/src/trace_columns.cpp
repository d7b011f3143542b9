/// @file trace_columns.cpp
/// The column tables of the traces (trace_columns.hpp).

#include "numen/sim/trace_columns.hpp"

namespace numen::sim {
namespace {

using R = TraceRecord;
using P = StreamedPeriod;

constexpr TraceColumn<R> kCsvColumns[] = {
    {"time_s", "s", "Simulated time after the step", [](const R& r, int) noexcept { return r.time_s; }},
    {"attached_body", "", "Held body index (-1: none)",
     [](const R& r, int) noexcept { return static_cast<double>(r.attached_body); }},
    {"sample_valid", "", "1: the period's sample was valid",
     [](const R& r, int) noexcept { return r.sample_valid ? 1.0 : 0.0; }},
    {"target_x", "m", "Device target of the held body's COM frame: x",
     [](const R& r, int) noexcept { return r.target.position.x(); }},
    {"target_y", "m", "... y", [](const R& r, int) noexcept { return r.target.position.y(); }},
    {"target_z", "m", "... z", [](const R& r, int) noexcept { return r.target.position.z(); }},
    {"target_qw", "", "... orientation quaternion w",
     [](const R& r, int) noexcept { return r.target.orientation.w(); }},
    {"target_qx", "", "... x", [](const R& r, int) noexcept { return r.target.orientation.x(); }},
    {"target_qy", "", "... y", [](const R& r, int) noexcept { return r.target.orientation.y(); }},
    {"target_qz", "", "... z", [](const R& r, int) noexcept { return r.target.orientation.z(); }},
    {"tool_x", "m", "Held body's (god-object's) pose: x",
     [](const R& r, int) noexcept { return r.tool.position.x(); }},
    {"tool_y", "m", "... y", [](const R& r, int) noexcept { return r.tool.position.y(); }},
    {"tool_z", "m", "... z", [](const R& r, int) noexcept { return r.tool.position.z(); }},
    {"tool_qw", "", "... orientation quaternion w",
     [](const R& r, int) noexcept { return r.tool.orientation.w(); }},
    {"tool_qx", "", "... x", [](const R& r, int) noexcept { return r.tool.orientation.x(); }},
    {"tool_qy", "", "... y", [](const R& r, int) noexcept { return r.tool.orientation.y(); }},
    {"tool_qz", "", "... z", [](const R& r, int) noexcept { return r.tool.orientation.z(); }},
    {"contacts", "", "All rigid contacts this step",
     [](const R& r, int) noexcept { return static_cast<double>(r.contacts); }},
    {"tool_contacts", "", "Contacts of the tool",
     [](const R& r, int) noexcept { return static_cast<double>(r.tool_contacts); }},
    {"tool_penetration_mm", "mm", "Deepest contact of the tool",
     [](const R& r, int) noexcept { return r.tool_penetration_mm; }},
    {"target_penetration_mm", "mm", "Deepest contact of the target (where the hand is)",
     [](const R& r, int) noexcept { return r.target_penetration_mm; }},
    {"feedback_fx", "N", "Feedback wrench sent (Eq. 8): force x",
     [](const R& r, int) noexcept { return r.feedback.force.x(); }},
    {"feedback_fy", "N", "... force y", [](const R& r, int) noexcept { return r.feedback.force.y(); }},
    {"feedback_fz", "N", "... force z", [](const R& r, int) noexcept { return r.feedback.force.z(); }},
    {"feedback_tx", "N·m", "... torque x",
     [](const R& r, int) noexcept { return r.feedback.torque.x(); }},
    {"feedback_ty", "N·m", "... torque y",
     [](const R& r, int) noexcept { return r.feedback.torque.y(); }},
    {"feedback_tz", "N·m", "... torque z",
     [](const R& r, int) noexcept { return r.feedback.torque.z(); }},
    {"axis_torque_", "N·m or N", "Torque commanded on each axis",
     [](const R& r, int a) noexcept { return r.axis_torque[static_cast<std::size_t>(a)]; }, true},
    {"step_time_us", "us", "Wall time of core::step",
     [](const R& r, int) noexcept { return r.step_time_us; }},
    {"solver_iterations", "", "Iterations of the implicit solve",
     [](const R& r, int) noexcept { return static_cast<double>(r.solver_iterations); }},
    {"joint_drift_mm", "mm", "Largest linear joint error |C| after the step",
     [](const R& r, int) noexcept { return r.joint_drift_mm; }},
    {"joint_angle_drift_mrad", "mrad", "Largest angular joint error |C| after the step",
     [](const R& r, int) noexcept { return r.joint_angle_drift_mrad; }},
    {"joint_reaction_max_n", "N", "Largest |reaction force| of a joint on its child",
     [](const R& r, int) noexcept { return r.joint_reaction_max_n; }},
    {"baumgarte_rhs_max", "m/s or rad/s", "Largest |c| of a joint row: the Baumgarte correction",
     [](const R& r, int) noexcept { return r.baumgarte_rhs_max; }},
    {"solver_residual", "1",
     "Stopping measure of the implicit solve (relative residual ‖r‖/‖b‖; nets without joints: "
     "relative energy-norm error estimate)",
     [](const R& r, int) noexcept { return r.solver_residual; }},
    {"node_contacts", "", "Node contacts of all nets",
     [](const R& r, int) noexcept { return static_cast<double>(r.node_contacts); }},
    {"net_penetration_mm", "mm", "Deepest node contact",
     [](const R& r, int) noexcept { return r.net_penetration_mm; }},
    {"net_tie_stretch_mm", "mm", "Largest |x − a| of a node from its rest position",
     [](const R& r, int) noexcept { return r.net_tie_stretch_mm; }},
    {"net_strain_max", "1", "Largest |l − L|/L of a structural spring",
     [](const R& r, int) noexcept { return r.net_strain_max; }},
    {"emcys", "", "CANopen EMCY messages received this period",
     [](const R& r, int) noexcept { return static_cast<double>(r.emcys); }},
    {"emcy_node", "", "Node of the newest EMCY this period (0: none)",
     [](const R& r, int) noexcept { return static_cast<double>(r.emcy_node); }},
    {"emcy_code", "", "Its error code (0: none; named by CiA 301/402 in the summary's EMCY list)",
     [](const R& r, int) noexcept { return static_cast<double>(r.emcy_code); }},
};

constexpr TraceColumn<P> kStreamColumns[] = {
    {"frames_read", "", "Frames taken from the bus this period",
     [](const P& p, int) noexcept { return static_cast<double>(p.report.frames_read); }},
    {"sample_valid", "", "1: the period's sample was valid",
     [](const P& p, int) noexcept { return p.report.sample_valid ? 1.0 : 0.0; }},
    {"torque_commanded", "", "1: non-zero torque was commanded",
     [](const P& p, int) noexcept { return p.report.torque_commanded ? 1.0 : 0.0; }},
    {"lifecycle", "", "Lifecycle state after the period (hal::LifecycleState value)",
     [](const P& p, int) noexcept { return static_cast<double>(p.report.lifecycle); }},
    {"target_x", "m", "Device target of the held body's COM frame: x",
     [](const P& p, int) noexcept { return p.record.target.position.x(); }},
    {"target_y", "m", "... y", [](const P& p, int) noexcept { return p.record.target.position.y(); }},
    {"target_z", "m", "... z", [](const P& p, int) noexcept { return p.record.target.position.z(); }},
    {"tool_x", "m", "God-object (held body) position: x",
     [](const P& p, int) noexcept { return p.record.tool.position.x(); }},
    {"tool_y", "m", "... y", [](const P& p, int) noexcept { return p.record.tool.position.y(); }},
    {"tool_z", "m", "... z", [](const P& p, int) noexcept { return p.record.tool.position.z(); }},
    {"force_x", "N", "Feedback force sent: x",
     [](const P& p, int) noexcept { return p.record.feedback.force.x(); }},
    {"force_y", "N", "... y", [](const P& p, int) noexcept { return p.record.feedback.force.y(); }},
    {"force_z", "N", "... z", [](const P& p, int) noexcept { return p.record.feedback.force.z(); }},
    {"tau_", "N·m or N", "Torque commanded on each axis (named by the axis)",
     [](const P& p, int a) noexcept {
       return a < p.record.num_axes ? p.record.axis_torque[static_cast<std::size_t>(a)] : 0.0;
     },
     true},
    {"step_us", "us", "Wall time of core::step",
     [](const P& p, int) noexcept { return static_cast<double>(p.report.step_ns) * 1e-3; }},
    {"end_to_end_us", "us", "SYNC sent to the torque writes returned",
     [](const P& p, int) noexcept {
       return static_cast<double>(p.report.output_end_ns - p.report.sync_sent_ns) * 1e-3;
     }},
    {"wakeup_us", "us", "Wake-up time − deadline",
     [](const P& p, int) noexcept {
       return static_cast<double>(p.report.woke_ns - p.report.deadline_ns) * 1e-3;
     }},
    {"emcys", "", "CANopen EMCY messages received this period",
     [](const P& p, int) noexcept { return static_cast<double>(p.record.emcys); }},
    {"emcy_node", "", "Node of the newest EMCY this period (0: none)",
     [](const P& p, int) noexcept { return static_cast<double>(p.record.emcy_node); }},
    {"emcy_code", "", "Its error code (0: none; named by CiA 301/402 in the summary's EMCY list)",
     [](const P& p, int) noexcept { return static_cast<double>(p.record.emcy_code); }},
};

}  // namespace

std::span<const TraceColumn<TraceRecord>> trace_csv_columns() noexcept { return kCsvColumns; }

std::span<const TraceColumn<StreamedPeriod>> trace_stream_columns() noexcept {
  return kStreamColumns;
}

}  // namespace numen::sim
