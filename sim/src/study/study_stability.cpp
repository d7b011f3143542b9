/// @file study_stability.cpp
/// `numen study stability`: the families in order, the CSV files and the verdict tables
/// (study_stability.hpp). The cases are in study_stability_{rigid,extreme,articulation,scene}.cpp,
/// the energy meter and the verdict monitor in study_stability_energy.cpp.

#include "numen/sim/study/study_stability.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <sstream>
#include <stdexcept>
#include <tuple>

#include "numen/sim/input/input_error.hpp"
#include "numen/sim/scene/scene.hpp"
#include "numen/sim/study/study_common.hpp"
#include "numen/sim/study/study_fields.hpp"
#include "numen/sim/study/study_stability_cases.hpp"

namespace numen::sim {
namespace {

bool wanted(const StabilityOptions& o, const char* family) {
  return o.families.empty() ||
         std::find(o.families.begin(), o.families.end(), family) != o.families.end();
}

std::string num(double v) {
  if (std::isnan(v)) return "nan";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.9g", v);
  return buf;
}

/// Quotes a CSV field if it holds a comma or a quote.
std::string field(const std::string& s) {
  if (s.find_first_of(",\"") == std::string::npos) return s;
  std::string q = "\"";
  for (char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c);
  return q + "\"";
}

/// A member of a row as a CSV cell: numbers by num(), flags 1 or 0, text by field().
std::string cell(double v) { return num(v); }
std::string cell(std::int64_t v) { return std::to_string(v); }
std::string cell(bool v) { return v ? "1" : "0"; }
std::string cell(const std::string& v) { return field(v); }

/// A Markdown table header on a new line: `lead` (two columns, "| a | b |"), one column per label,
/// and the separator line.
void table_header(std::ostringstream& os, const char* lead, const std::vector<std::string>& labels) {
  os << "\n" << lead;
  for (const std::string& l : labels) os << " " << l << " |";
  os << "\n| --- | --- |";
  for (std::size_t i = 0; i < labels.size(); ++i) os << " --- |";
  os << "\n";
}

/// Family "scenes": one line per swept stiffness, scene and integrator, one column per
/// stiffness: "stable, <tool penetration> mm" or "**diverged** (<reason>)".
std::string format_scene_stiffness_table(const StabilityResult& r) {
  std::vector<double> ks;
  std::vector<std::pair<std::string, std::string>> lines;  // (case, integrator)
  for (const StabilityRow& row : r.rows) {
    if (row.family != "scenes") continue;
    if (std::find(ks.begin(), ks.end(), row.stiffness) == ks.end()) ks.push_back(row.stiffness);
    const auto line = std::make_pair(row.case_name, row.integrator);
    if (std::find(lines.begin(), lines.end(), line) == lines.end()) lines.push_back(line);
  }
  if (lines.empty()) return "";
  std::sort(ks.begin(), ks.end());
  std::ostringstream os;
  char buf[160];
  std::vector<std::string> labels;
  for (double k : ks) labels.push_back(num(k) + " N/m");
  table_header(os, "| swept, scene | integrator |", labels);
  for (const auto& [name, integrator] : lines) {
    os << "| " << name << " | " << integrator << " |";
    for (double k : ks) {
      const StabilityRow* hit = nullptr;
      for (const StabilityRow& row : r.rows)
        if (row.family == "scenes" && row.case_name == name && row.integrator == integrator &&
            row.stiffness == k)
          hit = &row;
      if (hit == nullptr)
        std::snprintf(buf, sizeof buf, " |");
      else if (hit->stable)
        std::snprintf(buf, sizeof buf, " stable, %.2g mm |", 1e3 * hit->penetration_max_m);
      else
        std::snprintf(buf, sizeof buf, " **diverged** (%s) |", hit->reason.c_str());
      os << buf;
    }
    os << "\n";
  }
  return os.str();
}

}  // namespace

StabilityRow stability::make_row(const char* family, const char* case_name,
                                 core::Integrator integrator, double h, double mass_kg,
                                 double stiffness, double parameter, const char* parameter_name,
                                 double omega_dt) {
  StabilityRow r;
  r.family = family;
  r.case_name = case_name;
  r.integrator = to_string(integrator);
  r.dt_s = h;
  r.mass_kg = mass_kg;
  r.stiffness = stiffness;
  r.parameter = parameter;
  r.parameter_name = parameter_name;
  r.omega_dt = omega_dt;
  return r;
}

const std::vector<std::string>& stability_family_names() {
  static const std::vector<std::string> names = {"coupling", "contact", "articulation", "extreme",
                                                 "boundary", "scenes"};
  return names;
}

void stability::Plan::add(const char* family, std::string name, std::string parameters,
                          double weight, std::function<void(StabilityResult&)> run) {
  PlannedCase c;
  c.info.index = static_cast<std::int64_t>(cases.size());
  c.info.family = family;
  c.info.name = std::move(name);
  c.info.parameters = std::move(parameters);
  c.weight = weight;
  c.run = std::move(run);
  cases.push_back(std::move(c));
}

std::string stability::case_parameters(
    core::Integrator integrator, std::initializer_list<std::pair<const char*, double>> values) {
  std::string s = std::string("integrator=") + to_string(integrator);
  char buf[64];
  for (const auto& [key, v] : values) {
    std::snprintf(buf, sizeof buf, " %s=%.6g", key, v);
    s += buf;
  }
  return s;
}

stability::Plan stability::plan_study(const StabilityOptions& options) {
  for (const std::string& f : options.families) {
    const auto& all = stability_family_names();
    if (std::find(all.begin(), all.end(), f) == all.end())
      throw InputError(
          "", 0, 0, "family",
          "unknown family \"" + f +
              "\" (coupling, contact, articulation, extreme, boundary, scenes)");
  }
  check_shard(options.shard);
  Plan plan;
  const std::string no_joints = study::missing_parts(true, false);
  const bool articulation = wanted(options, "articulation") && no_joints.empty();
  if (wanted(options, "articulation") && !no_joints.empty()) {
    if (!options.families.empty())
      throw InputError("", 0, 0, "family", "family \"articulation\" " + no_joints);
    plan.skipped.push_back("articulation: " + no_joints);
  }
  const std::string dir = options.scene_dir.empty()
                              ? std::filesystem::path(default_scene_path()).parent_path().string()
                              : options.scene_dir;
  if (wanted(options, "coupling")) plan_coupling(options, plan);
  if (wanted(options, "contact")) plan_contact(options, plan);
  if (articulation) plan_articulation(options, plan);
  if (wanted(options, "extreme")) {
    plan_rigid_extreme(options, plan);
    plan_scene_extreme(options, dir, plan);
  }
  if (wanted(options, "boundary")) plan_boundary(options, plan);
  if (wanted(options, "scenes")) plan_scene_stiffness(options, dir, plan);
  return plan;
}

std::vector<StudyCase> stability_cases(const StabilityOptions& options) {
  std::vector<StudyCase> out;
  for (const stability::PlannedCase& c : stability::plan_study(options).cases)
    if (options.shard.owns(c.info.index)) out.push_back(c.info);
  return out;
}

StabilityResult run_stability_study(const StabilityOptions& options) {
  stability::Plan plan = stability::plan_study(options);
  StabilityResult result;
  result.skipped = std::move(plan.skipped);
  result.cases = static_cast<std::int64_t>(plan.cases.size());
  result.shard = options.shard;
  const auto start = std::chrono::steady_clock::now();
  double total = 0.0, done = 0.0;
  for (const stability::PlannedCase& c : plan.cases)
    if (options.shard.owns(c.info.index)) total += c.weight;
  for (const stability::PlannedCase& c : plan.cases) {
    if (!options.shard.owns(c.info.index)) continue;
    const std::size_t rows = result.rows.size(), boundaries = result.boundaries.size();
    c.run(result);
    for (std::size_t i = rows; i < result.rows.size(); ++i)
      result.rows[i].case_index = c.info.index;
    for (std::size_t i = boundaries; i < result.boundaries.size(); ++i)
      result.boundaries[i].case_index = c.info.index;
    done = std::min(total, done + c.weight);
    if (options.progress) options.progress(done, total, c.info.name + " " + c.info.parameters);
  }
  result.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

const std::string& stability_csv_header() {
  static const std::string h = [] {
    std::string line;
    for (const std::string& n : stability_row_names()) line += (line.empty() ? "" : ",") + n;
    return line;
  }();
  return h;
}

void write_stability_csv(const StabilityResult& result, const std::string& dir) {
  std::filesystem::create_directories(dir);
  std::map<std::string, std::ostringstream> families;  // stability_<family>.csv, by family
  for (const StabilityRow& r : result.rows) {
    auto it = families.find(r.family);
    if (it == families.end()) {
      it = families.emplace(r.family, std::ostringstream()).first;
      it->second << stability_csv_header() << '\n';
    }
    std::ostringstream& f = it->second;
    bool first = true;
    stability_row_fields(r, [&](const char*, const auto& v) {
      f << (first ? "" : ",") << cell(v);
      first = false;
    });
    f << '\n';
  }
  OutputFiles files;
  for (const auto& [family, text] : families)
    files.emplace_back("stability_" + family + ".csv", text.str());
  if (!result.boundaries.empty()) {
    std::ostringstream f;
    f << "zeta,omega_dt,energy_ratio_max,growth_ratio,theory_omega_dt,measured_growth_omega_dt,"
         "measured_verdict_omega_dt,verdict_theory_omega_dt\n";
    for (const StabilityBoundary& b : result.boundaries)
      for (std::size_t i = 0; i < b.omega_dt.size(); ++i)
        f << num(b.zeta) << ',' << num(b.omega_dt[i]) << ',' << num(b.energy_ratio[i]) << ','
          << num(b.growth_ratio[i]) << ',' << num(b.theory_omega_dt) << ','
          << num(b.measured_growth_omega_dt) << ',' << num(b.measured_verdict_omega_dt) << ','
          << num(b.verdict_theory_omega_dt) << '\n';
    files.emplace_back("stability_boundary.csv", f.str());
  }
  write_files_atomically(dir, files);
}

std::string format_stability_tables(const StabilityResult& r) {
  std::ostringstream os;
  char buf[512];
  // Grid families: counts per case and integrator, and the first diverged runs' reasons.
  struct Count {
    int stable = 0, diverged = 0;
    double min_diverged_omega_dt = stability::kInf, max_stable_omega_dt = 0.0;
    std::map<std::string, int> reasons;
  };
  std::map<std::pair<std::string, std::string>, Count> counts;
  std::vector<std::pair<std::string, std::string>> order;
  for (const StabilityRow& row : r.rows) {
    if (row.family == "extreme" || row.family == "scenes") continue;
    const auto key = std::make_pair(row.case_name, row.integrator);
    if (counts.find(key) == counts.end()) order.push_back(key);
    Count& c = counts[key];
    (row.stable ? c.stable : c.diverged)++;
    if (!row.stable) {
      ++c.reasons[row.reason];
      c.min_diverged_omega_dt = std::min(c.min_diverged_omega_dt, row.omega_dt);
    } else {
      c.max_stable_omega_dt = std::max(c.max_stable_omega_dt, row.omega_dt);
    }
  }
  if (!order.empty()) {
    os << "| case | integrator | runs | stable | diverged (reasons) | smallest ω h diverged | "
          "largest ω h stable |\n| --- | --- | --- | --- | --- | --- | --- |\n";
    for (const auto& key : order) {
      const Count& c = counts[key];
      std::string reasons;
      for (const auto& [why, n] : c.reasons)
        reasons += (reasons.empty() ? "" : ", ") + why + " " + std::to_string(n);
      std::snprintf(buf, sizeof buf, "| %s | %s | %d | %d | %d%s%s%s | %s | %.3g |\n",
                    key.first.c_str(), key.second.c_str(), c.stable + c.diverged, c.stable,
                    c.diverged, reasons.empty() ? "" : " (", reasons.c_str(),
                    reasons.empty() ? "" : ")",
                    c.diverged ? num(c.min_diverged_omega_dt).c_str() : "—", c.max_stable_omega_dt);
      os << buf;
    }
  }
  // Articulation: joint drift per integrator and step across the mass ratios.
  std::vector<double> ratios;
  std::vector<std::pair<std::string, double>> lines;
  for (const StabilityRow& row : r.rows) {
    if (row.family != "articulation") continue;
    if (std::find(ratios.begin(), ratios.end(), row.parameter) == ratios.end())
      ratios.push_back(row.parameter);
    const auto line = std::make_pair(row.integrator, row.dt_s);
    if (std::find(lines.begin(), lines.end(), line) == lines.end()) lines.push_back(line);
  }
  if (!lines.empty()) {
    std::sort(ratios.begin(), ratios.end());
    std::vector<std::string> labels;
    for (double q : ratios) labels.push_back("ratio " + num(q));
    table_header(os, "| integrator | h (s) |", labels);
    for (const auto& [integrator, h] : lines) {
      std::snprintf(buf, sizeof buf, "| %s | %.0e |", integrator.c_str(), h);
      os << buf;
      for (double q : ratios)
        for (const StabilityRow& row : r.rows)
          if (row.family == "articulation" && row.integrator == integrator && row.dt_s == h &&
              row.parameter == q) {
            if (row.stable)
              std::snprintf(buf, sizeof buf, " stable, drift %.2g µm |", 1e6 * row.drift_max_m);
            else
              std::snprintf(buf, sizeof buf, " diverged at %lld (%s) |",
                            static_cast<long long>(row.diverged_step), row.reason.c_str());
            os << buf;
          }
      os << "\n";
    }
  }
  // Extreme cases: one line per case, stiffness and integrator, one column per time step.
  std::vector<double> steps;
  std::vector<std::tuple<std::string, double, std::string>> cases;
  for (const StabilityRow& row : r.rows) {
    if (row.family != "extreme") continue;
    if (std::find(steps.begin(), steps.end(), row.dt_s) == steps.end()) steps.push_back(row.dt_s);
    const auto c = std::make_tuple(row.case_name, row.stiffness, row.integrator);
    if (std::find(cases.begin(), cases.end(), c) == cases.end()) cases.push_back(c);
  }
  auto same = [](double a, double b) { return a == b || (std::isnan(a) && std::isnan(b)); };
  if (!cases.empty()) {
    std::sort(steps.begin(), steps.end());
    os << "\n| case | stiffness | integrator |";
    for (double h : steps) os << " h = " << num(h) << " s |";
    os << "\n| --- | --- | --- |";
    for (std::size_t i = 0; i < steps.size(); ++i) os << " --- |";
    os << "\n";
    for (const auto& [name, stiffness, integrator] : cases) {
      std::snprintf(buf, sizeof buf, "| %s | %s | %s |", name.c_str(),
                    std::isnan(stiffness) ? "—" : num(stiffness).c_str(), integrator.c_str());
      os << buf;
      for (double h : steps) {
        const StabilityRow* hit = nullptr;
        for (const StabilityRow& row : r.rows)
          if (row.family == "extreme" && row.case_name == name && same(row.stiffness, stiffness) &&
              row.integrator == integrator && row.dt_s == h)
            hit = &row;
        if (hit == nullptr) {
          os << " |";
        } else if (hit->stable) {
          if (std::isnan(hit->energy_ratio_max))
            os << " stable |";
          else {
            std::snprintf(buf, sizeof buf, " stable, E %.2g |", hit->energy_ratio_max);
            os << buf;
          }
        } else {
          std::snprintf(buf, sizeof buf, " **diverged** at %lld (%s) |",
                        static_cast<long long>(hit->diverged_step), hit->reason.c_str());
          os << buf;
        }
      }
      os << "\n";
    }
    os << "\nNotes (h = 1 ms unless only another step ran):\n\n";
    for (const auto& [name, stiffness, integrator] : cases) {
      const StabilityRow* pick = nullptr;
      for (const StabilityRow& row : r.rows)
        if (row.family == "extreme" && row.case_name == name && same(row.stiffness, stiffness) &&
            row.integrator == integrator && (pick == nullptr || row.dt_s == 1e-3))
          pick = &row;
      if (pick != nullptr && !pick->note.empty())
        os << "- " << name << (std::isnan(stiffness) ? "" : " (stiffness " + num(stiffness) + ")")
           << ", " << integrator << ", h = " << num(pick->dt_s) << " s: " << pick->note << "\n";
    }
  }
  os << format_scene_stiffness_table(r);
  if (!r.boundaries.empty()) {
    os << "\n| ζ | theory: largest stable ω h | measured (no energy growth) | error | verdict "
          "limit 2 (1 − 1/energy_factor): theory | measured by the verdict |\n| --- | --- | --- | "
          "--- | --- | --- |\n";
    for (const StabilityBoundary& b : r.boundaries) {
      std::snprintf(
          buf, sizeof buf, "| %.2f | %.5f | %.5f | %+.2e | %s | %.5f |\n", b.zeta,
          b.theory_omega_dt, b.measured_growth_omega_dt,
          (b.measured_growth_omega_dt - b.theory_omega_dt) / b.theory_omega_dt,
          std::isnan(b.verdict_theory_omega_dt) ? "—" : num(b.verdict_theory_omega_dt).c_str(),
          b.measured_verdict_omega_dt);
      os << buf;
    }
  }
  for (const std::string& s : r.skipped) os << "\nskipped: " << s << "\n";
  return os.str();
}

}  // namespace numen::sim
