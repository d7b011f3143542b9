#pragma once
/// @file trace_columns.hpp
/// The columns of a run's per-period traces, one table per trace: name, unit, description and
/// accessor of each column. The header line and every row are written from the same table, so
/// a column's name and value cannot drift apart.
///   - trace_csv_columns(): the in-memory trace of a simulated run (Trace::write_csv, one
///     TraceRecord per period).
///   - trace_stream_columns(): the streamed trace of a real-bus run (SceneRunner::stream_trace,
///     platform::TraceWriter; values from the period's TraceRecord and PeriodReport).

#include <cstddef>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "numen/platform/control_loop.hpp"
#include "numen/sim/trace.hpp"

namespace numen::sim {

/// One column, or one column per device axis, of a trace whose rows are read from `Source`.
template <typename Source>
struct TraceColumn {
  /// Column name; for a per-axis column the prefix of the names (trace_column_names()).
  std::string_view name;
  std::string_view unit;         ///< SI unit or the unit its name ends in; "" for counts, flags.
  std::string_view description;  ///< One line: what the column holds (world frame).
  /// The value of a row (`axis`: the axis index of a per-axis column, else 0). Never
  /// allocates or throws.
  double (*get)(const Source& row, int axis) noexcept;
  bool per_axis = false;  ///< Repeated once per device axis.
};

/// One period of a streamed trace: the record of the period and what the control loop did.
struct StreamedPeriod {
  const TraceRecord& record;
  const platform::PeriodReport& report;
};

/// Columns of Trace::write_csv. Per-axis columns are named prefix + axis index
/// ("axis_torque_0").
std::span<const TraceColumn<TraceRecord>> trace_csv_columns() noexcept;

/// Columns of the streamed real-bus trace. Per-axis columns are named prefix + axis name
/// ("tau_yaw"). Besides these, platform::TraceWriter writes period, time_ns and flags.
std::span<const TraceColumn<StreamedPeriod>> trace_stream_columns() noexcept;

/// The header names of `columns`, per-axis columns expanded once per entry of `axis_suffixes`
/// (axis indices or names) in order. Setup only (allocates).
template <typename Source>
std::vector<std::string> trace_column_names(std::span<const TraceColumn<Source>> columns,
                                            std::span<const std::string> axis_suffixes) {
  std::vector<std::string> names;
  for (const TraceColumn<Source>& c : columns) {
    if (!c.per_axis) {
      names.emplace_back(c.name);
      continue;
    }
    for (const std::string& a : axis_suffixes) names.push_back(std::string(c.name) + a);
  }
  return names;
}

/// Writes the values of one row, in the order of trace_column_names() with `num_axes` axes,
/// into `out`; returns how many were written (stops when `out` is full). Never allocates.
template <typename Source>
std::size_t trace_column_values(std::span<const TraceColumn<Source>> columns, const Source& row,
                                int num_axes, std::span<double> out) noexcept {
  std::size_t n = 0;
  for (const TraceColumn<Source>& c : columns) {
    const int repeat = c.per_axis ? num_axes : 1;
    for (int a = 0; a < repeat && n < out.size(); ++a) out[n++] = c.get(row, a);
  }
  return n;
}

}  // namespace numen::sim
