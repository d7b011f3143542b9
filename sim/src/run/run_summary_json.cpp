/// @file run_summary_json.cpp
/// The JSON summary of a run (`numen run --json`), written from the figure table.

#include <string>

#include <nlohmann/json.hpp>

#include "numen/sim/run/run_figures.hpp"
#include "numen/sim/run/run_summary.hpp"

namespace numen::sim {

std::string format_summary_json(const RunSummary& s) {
  nlohmann::ordered_json j = nlohmann::ordered_json::object();  // keys in the table's order
  for (const RunFigure& f : run_figures()) {
    if (f.present != nullptr && !f.present(s)) continue;
    // "a.b.c": j["a"]["b"]["c"].
    nlohmann::ordered_json* node = &j;
    std::string_view rest = f.name;
    for (std::size_t dot = rest.find('.'); dot != std::string_view::npos; dot = rest.find('.')) {
      node = &(*node)[std::string(rest.substr(0, dot))];
      rest.remove_prefix(dot + 1);
    }
    nlohmann::ordered_json& value = (*node)[std::string(rest)];
    const FigureValue v = f.get(s);
    switch (v.kind) {
      case FigureKind::kReal: value = v.real; break;  // non-finite numbers are written as null
      case FigureKind::kCount: value = v.count; break;
      case FigureKind::kFlag: value = v.flag; break;
      case FigureKind::kText: value = std::string(v.text); break;
      case FigureKind::kTextList: value = *v.list; break;
    }
  }
  // Scene names, paths and messages may hold bytes that are not UTF-8: replaced by U+FFFD
  // instead of throwing.
  return j.dump(-1, ' ', false, nlohmann::ordered_json::error_handler_t::replace);
}

}  // namespace numen::sim
