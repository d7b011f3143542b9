#pragma once
/// @file record_lists.hpp
/// Every output's names, read from the one declaration each output is written from
/// (`numen figures --all`): the run figures (run_figures.hpp: the JSON summary, the text
/// summary's placeholders, numen.run_scene's dict), the trace columns (trace_columns.hpp: the
/// CSV of `--trace` and the streamed real-bus trace) and the study rows (study_fields.hpp:
/// the studies' CSV files, shard files and numen.study_* dicts) and the state frame
/// (platform/state_frame.hpp: the viewer's frames, live and recorded). Setup only (allocates).

#include <string>
#include <string_view>
#include <vector>

namespace numen::sim {

/// The names one output writes, in its order.
struct RecordList {
  std::string_view output;         ///< What writes them ("trace: streamed real-bus trace").
  std::string_view declaration;    ///< The declaration they come from ("trace_columns()").
  std::vector<std::string> names;  ///< Per-axis columns with the axis as "<axis>".
};

/// Every output's names: run figures, the CSV trace, the streamed trace (with the writer's
/// period, time_ns, flags first), the stability row, the accuracy row, the passivity row, the
/// state frame (its header fields, then its arrays).
std::vector<RecordList> record_lists();

/// `numen figures --all` (Markdown): "## Run figures" and format_run_figures_markdown(),
/// "## Trace columns" and format_trace_columns_markdown(), then "## Names by output": one
/// row per record_lists() entry, "| output | declaration | names |".
std::string format_record_lists_markdown();

}  // namespace numen::sim
