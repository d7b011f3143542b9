/// @file record_lists.cpp
/// Every output's names (record_lists.hpp).

#include "numen/sim/run/record_lists.hpp"

#include "markdown_cell.hpp"
#include "numen/platform/state_frame.hpp"
#include "numen/sim/run/run_figures.hpp"
#include "numen/sim/run/trace_columns.hpp"
#include "numen/sim/study/study_fields.hpp"

namespace numen::sim {

std::vector<RecordList> record_lists() {
  std::vector<RecordList> lists;
  std::vector<std::string> figures;
  for (const RunFigure& f : run_figures()) figures.emplace_back(f.name);
  lists.push_back({"run summary: `numen run --json`, the text summary, numen.run_scene",
                   "run_figures()", std::move(figures)});
  const std::vector<std::string> axis = {"<axis>"};
  const std::vector<std::string> device = {"<device>"};
  lists.push_back({"trace: `numen run --trace` CSV", "trace_columns()",
                   trace_column_names(TraceKind::kCsv, axis, device)});
  std::vector<std::string> stream = {"period", "time_ns", "flags"};
  for (std::string& n : trace_column_names(TraceKind::kStream, axis))
    stream.push_back(std::move(n));
  lists.push_back({"trace: streamed real-bus trace (`numen run --bus can:… --trace`)",
                   "platform::TraceWriter, trace_columns() (streamed)", std::move(stream)});
  lists.push_back(
      {"stability study row: stability_<family>.csv, shard rows, "
       "numen.study_stability",
       "stability_row_fields()", stability_row_names()});
  lists.push_back({"accuracy study row: accuracy.csv, shard rows, numen.study_accuracy",
                   "accuracy_row_fields()", accuracy_row_names()});
  lists.push_back({"passivity study row: passivity.csv, shard rows", "passivity_row_fields()",
                   passivity_row_names()});
  std::vector<std::string> frame;
  for (const platform::StateFrameField& f : platform::kStateFrameFields) frame.emplace_back(f.name);
  for (const platform::StateFrameArray& a : platform::kStateFrameArrays) frame.emplace_back(a.name);
  lists.push_back({"state frame: `numen run --view`, `--record-view`, the viewer page",
                   "platform::kStateFrameFields, platform::kStateFrameArrays", std::move(frame)});
  return lists;
}

std::string format_record_lists_markdown() {
  std::string out = "## Run figures\n\n" + format_run_figures_markdown();
  out += "\n## Trace columns\n\n" + format_trace_columns_markdown();
  out += "\n## Names by output\n\n| output | declaration | names |\n| --- | --- | --- |\n";
  for (const RecordList& l : record_lists()) {
    out += "| ";
    append_markdown_cell(out, l.output);
    out += " | ";
    append_markdown_cell(out, l.declaration);
    out += " | ";
    for (std::size_t i = 0; i < l.names.size(); ++i) {
      out += i ? ", `" : "`";
      append_markdown_cell(out, l.names[i]);
      out += "`";
    }
    out += " |\n";
  }
  return out;
}

}  // namespace numen::sim
