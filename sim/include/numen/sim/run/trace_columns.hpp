#pragma once
/// @file trace_columns.hpp
/// The one column table of a run's per-period traces: name, unit, description, accessor and
/// the traces that carry each column. Both traces write header and rows from it, so a column's
/// name and value cannot drift apart, and a quantity has one name in both:
///   - TraceKind::kCsv: the in-memory trace of a run (`numen run --trace`, Trace::write_csv,
///     one TraceRecord per period): every column.
///   - TraceKind::kStream: the streamed trace of a real-bus run (SceneRunner::stream_trace,
///     platform::TraceWriter, after its period, time_ns and flags): the columns marked
///     `streamed`, in the table's order.
/// Per-axis columns are named prefix + axis name ("axis_torque_yaw"); per-device columns (the
/// devices beside device 0 of a scene of several, CSV only) prefix + device name
/// ("target_x@right"), device 0's columns keeping their names. The names that differed
/// before the table was shared are listed in docs/outputs.md, "Trace columns".

#include <cstddef>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "numen/sim/run/trace.hpp"

namespace numen::sim {

/// The traces written from the column table.
enum class TraceKind {
  kCsv,     ///< Trace::write_csv: every column.
  kStream,  ///< The streamed real-bus trace: the columns marked `streamed`.
};

/// One column, or one column per device axis, of a trace whose rows are TraceRecords.
struct TraceColumn {
  /// Column name; for a per-axis column the prefix of the names (trace_column_names()).
  std::string_view name;
  std::string_view unit;         ///< SI unit or the unit its name ends in; "" for counts, flags.
  std::string_view description;  ///< One line: what the column holds (world frame).
  /// The value of a row (`axis`: the axis index of a per-axis column, else 0). Never
  /// allocates or throws.
  double (*get)(const TraceRecord& row, int axis) noexcept;
  bool per_axis = false;  ///< Repeated once per device axis.
  bool streamed = false;  ///< Also in the streamed trace (TraceKind::kStream).
  /// Repeated once per device beside device 0 (`axis` is then the device's index from 0 for
  /// device 1, into TraceRecord::devices); never streamed.
  bool per_device = false;
};

/// Every column, in the order of Trace::write_csv.
std::span<const TraceColumn> trace_columns() noexcept;

/// Whether `column` is written in traces of `kind`.
constexpr bool in_trace(const TraceColumn& column, TraceKind kind) noexcept {
  return kind == TraceKind::kCsv || column.streamed;
}

/// The header names of the trace `kind`, per-axis columns expanded once per entry of
/// `axis_names` in order, per-device columns once per entry of `device_names` (devices 1 ..
/// N−1). Setup only (allocates).
std::vector<std::string> trace_column_names(TraceKind kind,
                                            std::span<const std::string> axis_names,
                                            std::span<const std::string> device_names = {});

/// Writes the values of one row of the trace `kind`, in the order of trace_column_names() with
/// `num_axes` axes, into `out`; returns how many were written (stops when `out` is full). A
/// per-axis column reads 0 for an axis at or past `row.num_axes`. Never allocates.
std::size_t trace_column_values(TraceKind kind, const TraceRecord& row, int num_axes,
                                std::span<double> out, int num_extra_devices = 0) noexcept;

/// The table as Markdown (`numen figures --all`; docs/outputs.md, "Trace columns", holds it
/// verbatim, tested): a header "| column | unit | traces | what it holds |", a rule and one row
/// per column (per-axis ones as "`axis_torque_<axis>`", per-device ones as "`target_x@<device>`";
/// traces "csv" or "csv, stream"), '|' in
/// descriptions escaped.
std::string format_trace_columns_markdown();

}  // namespace numen::sim
