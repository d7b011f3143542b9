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
  // A scene of several devices: each device's figures (DeviceRunSummary).
  if (!s.devices.empty()) {
    nlohmann::ordered_json& devices = j["devices"] = nlohmann::ordered_json::array();
    for (const DeviceRunSummary& d : s.devices) {
      nlohmann::ordered_json o = nlohmann::ordered_json::object();
      o["name"] = d.name;
      o["feedback_force_max_n"] = d.feedback_force_max_n;
      o["feedback_torque_max_nm"] = d.feedback_torque_max_nm;
      o["torque_periods"] = d.torque_periods;
      o["invalid_periods"] = d.invalid_periods;
      o["rejected_samples"] = d.rejected_samples;
      o["rejected_causes"] = d.rejected_causes;
      o["faults"] = d.faults;
      o["lifecycle"] = d.lifecycle;
      o["closed_loop"] = d.closed_loop;
      if (d.closed_loop) {
        o["handle_force_max_n"] = d.handle_force_max_n;
        o["hand_separation_max_mm"] = d.hand_separation_max_mm;
        o["device_port_energy_j"] = d.device_port_energy_j;
      }
      devices.push_back(std::move(o));
    }
  }
  // Scene names, paths and messages may hold bytes that are not UTF-8: replaced by U+FFFD
  // instead of throwing.
  return j.dump(-1, ' ', false, nlohmann::ordered_json::error_handler_t::replace);
}

}  // namespace numen::sim
