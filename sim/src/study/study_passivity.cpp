/// @file study_passivity.cpp
/// `numen study passivity` (study_passivity.hpp): the sweep of configurations, the grid and the
/// bisection of each, the CSV files and the text summary. The probe is in
/// study_passivity_probe.cpp, the analytic bounds in study_passivity_bounds.cpp.

#include "numen/sim/study/study_passivity.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "numen/sim/study/study_fields.hpp"

namespace numen::sim {
namespace {

constexpr double kNoBound = std::numeric_limits<double>::infinity();

/// One configuration: everything but K.
struct PassivityConfig {
  PassivityPoint point;
  StudyCase info;
};

/// The sweep (docs/passivity.md "Sweep"), in the order of the one-process run.
std::vector<PassivityConfig> passivity_plan(const PassivityOptions& o) {
  struct Device {
    double b, fc;
  };
  const std::vector<double> periods = {1e-3, 1e-4};
  const std::vector<Device> devices = {{1.0, 0.0}, {0.0, 0.05}, {1.0, 0.05}};
  const std::vector<double> resolutions =
      o.quick ? std::vector<double>{0.0, 1e-5} : std::vector<double>{0.0, 1e-5, 1e-6};
  const std::vector<int> delays = o.quick ? std::vector<int>{0, 1} : std::vector<int>{0, 1, 2};
  // B as a fraction of b (only B = 0 for b = 0).
  const std::vector<double> damping_fractions =
      o.quick ? std::vector<double>{0.0} : std::vector<double>{-0.5, -0.25, 0.0, 0.25, 0.5, 0.75};
  // God-object obstacle stiffness; NaN: the direct wall.
  const std::vector<double> couplings = o.quick ? std::vector<double>{std::nan(""), 1e6}
                                                : std::vector<double>{std::nan(""), 1e3, 1e6, 1e9};
  std::vector<PassivityConfig> out;
  // One configuration, numbered in the plan's order (its study case).
  const auto append = [&out](const PassivityPoint& p, std::string name, const char* parameters) {
    PassivityConfig c;
    c.point = p;
    c.info.index = static_cast<std::int64_t>(out.size());
    c.info.family = "passivity";
    c.info.name = std::move(name);
    c.info.parameters = parameters;
    out.push_back(std::move(c));
  };
  for (double t : periods)
    for (const Device& dev : devices)
      for (double delta : resolutions) {
        // Friction without quantisation and without damping has no finite bound: skipped.
        if (dev.b == 0.0 && delta == 0.0) continue;
        for (int d : delays)
          for (double kw : couplings)
            for (double frac : damping_fractions) {
              if (dev.b == 0.0 && frac != 0.0) continue;
              PassivityPoint p;
              p.period_s = t;
              p.device_damping = dev.b;
              p.coulomb = dev.fc;
              p.resolution = delta;
              p.delay_periods = d;
              p.coupling = std::isnan(kw) ? "wall" : "god-object";
              p.obstacle_stiffness = kw;
              p.damping = frac * dev.b;
              char buf[200];
              std::snprintf(buf, sizeof buf, "T=%g b=%g fc=%g delta=%g d=%d B=%g kw=%g", t, dev.b,
                            dev.fc, delta, d, p.damping, kw);
              append(p, p.coupling, buf);
            }
      }
  // The passivity controller (docs/passivity.md "Passivity controller"), without an energy
  // limit (the paper's observer) and with E_max = 1 µJ: the undelayed and the one-period-delayed
  // device (b = 1 N·s/m, no friction, no quantisation, B = 0), wall and
  // god-object (k_w = 1e6), at each period, appended so that the cases above keep their index.
  for (double e_max : {kNoBound, 1e-6})
    for (double t : periods)
      for (int d : {0, 1})
        for (double kw : {std::nan(""), 1e6}) {
          PassivityPoint p;
          p.period_s = t;
          p.device_damping = 1.0;
          p.delay_periods = d;
          p.coupling = std::isnan(kw) ? "wall" : "god-object";
          p.obstacle_stiffness = kw;
          p.passivity_controller = true;
          p.passivity_energy_limit_j = e_max;
          char buf[200];
          std::snprintf(buf, sizeof buf, "T=%g b=1 fc=0 delta=0 d=%d B=0 kw=%g pc=1 E_max=%g", t,
                        d, kw, e_max);
          append(p, p.coupling + " + passivity controller", buf);
        }
  // The velocity estimators on the damped wall and coupling (docs/passivity.md "Velocity
  // estimators"): B = 0.25 b and 0.5 b (B = 0 does not read v̂), with and without
  // quantisation (with and without friction), no delay, each period; the backward difference's
  // cases are in the sweep above.
  struct Encoder {
    double fc, delta;
  };
  // --quick: the quantised device with friction and B = 0.5 b only.
  const std::vector<Encoder> encoders =
      o.quick ? std::vector<Encoder>{{0.05, 1e-5}}
              : std::vector<Encoder>{{0.0, 0.0}, {0.0, 1e-5}, {0.05, 1e-5}};
  const std::vector<double> estimator_fractions =
      o.quick ? std::vector<double>{0.5} : std::vector<double>{0.25, 0.5};
  for (const char* estimator : {"filter", "foaw"})
    for (double t : periods)
      for (const Encoder& e : encoders)
        for (double kw : {std::nan(""), 1e6})
          for (double frac : estimator_fractions) {
            PassivityPoint p;
            p.period_s = t;
            p.device_damping = 1.0;
            p.coulomb = e.fc;
            p.resolution = e.delta;
            p.coupling = std::isnan(kw) ? "wall" : "god-object";
            p.obstacle_stiffness = kw;
            p.damping = frac;
            p.velocity_estimator = estimator;
            char buf[200];
            std::snprintf(buf, sizeof buf, "T=%g b=1 fc=%g delta=%g d=0 B=%g kw=%g v=%s", t, e.fc,
                          e.delta, p.damping, kw, estimator);
            append(p, p.coupling + " + " + estimator, buf);
          }
  return out;
}

PassivityRow passivity_row_of(const PassivityPoint& p, const PassivityProbe& r, const char* kind,
                              std::int64_t index) {
  PassivityRow row;
  row.period_s = p.period_s;
  row.device_damping = p.device_damping;
  row.coulomb = p.coulomb;
  row.resolution = p.resolution;
  row.delay_periods = p.delay_periods;
  row.coupling = p.coupling;
  row.stiffness = p.stiffness;
  row.damping = p.damping;
  row.obstacle_stiffness = p.obstacle_stiffness;
  row.passivity_controller = p.passivity_controller;
  row.passivity_energy_limit_j = p.passivity_energy_limit_j;
  row.velocity_estimator = p.velocity_estimator;
  row.passive = r.passive;
  row.energy_min_j = r.energy_min_j;
  row.energy_peak_j = r.energy_peak_j;
  row.worst_run = r.worst_run;
  row.contact_passive = r.contact_passive;
  row.contact_energy_min_j = r.contact_energy_min_j;
  row.limit_cycle = r.limit_cycle;
  row.limit_cycle_amplitude_m = r.limit_cycle_amplitude_m;
  row.limit_cycle_hz = r.limit_cycle_hz;
  row.colgate_bound = colgate_bound(p);
  row.abbott_okamura_bound = abbott_okamura_bound(p);
  row.delay_bound = delay_bound(p);
  row.dither_bound = dither_bound(p);
  row.kind = kind;
  row.case_index = index;
  return row;
}

/// Where the bisection starts: the smallest positive finite analytic bound, else 1000 N/m.
double reference_stiffness(const PassivityPoint& p) {
  double k = kNoBound;
  for (double b : {delay_bound(p), abbott_okamura_bound(p), dither_bound(p)})
    if (b > 0.0 && b < k) k = b;
  return std::isfinite(k) ? k : 1e3;
}

/// The passivity controller column of the text table: "–" off, else its E_max ("∞": none).
std::string pc_cell(const PassivityBoundary& b) {
  if (!b.passivity_controller) return "–";
  if (std::isinf(b.passivity_energy_limit_j)) return "∞";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", b.passivity_energy_limit_j);
  return buf;
}

double bound_ratio(double measured, double bound) {
  if (!(bound > 0.0) || std::isinf(bound)) return std::nan("");
  return measured / bound;
}

/// The grid and the bisection of one configuration: rows into `rows`, its boundary returned.
PassivityBoundary measure_config(const PassivityConfig& c, const PassivityOptions& o,
                                 std::vector<PassivityRow>& rows) {
  PassivityPoint p = c.point;
  for (const double k : passivity_grid(o.quick)) {
    p.stiffness = k;
    rows.push_back(passivity_row_of(p, probe_passivity(p), "grid", c.info.index));
  }
  std::vector<PassivityRow> bisection;
  PassivityBoundary b = find_passivity_boundary(c.point, o.tolerance, &bisection);
  for (PassivityRow& r : bisection) {
    r.case_index = c.info.index;
    rows.push_back(std::move(r));
  }
  b.case_index = c.info.index;
  return b;
}

void check_passivity_options(const PassivityOptions& o) {
  check_shard(o.shard);
  if (!(o.tolerance > 0.0 && o.tolerance < 1.0))
    throw std::invalid_argument("passivity: tolerance must be in (0, 1)");
}

}  // namespace

std::vector<double> passivity_grid(bool quick) {
  std::vector<double> k;
  const double step = quick ? 1.0 : 0.5;
  for (double e = 1.0; e <= 7.0 + 1e-9; e += step) k.push_back(std::pow(10.0, e));
  return k;
}

PassivityBoundary find_passivity_boundary(const PassivityPoint& point, double tolerance,
                                          std::vector<PassivityRow>* rows) {
  if (!(tolerance > 0.0 && tolerance < 1.0))
    throw std::invalid_argument("passivity: tolerance must be in (0, 1)");
  PassivityPoint p = point;
  PassivityBoundary b;
  const auto passive = [&](double k) {
    ++b.evaluations;
    p.stiffness = k;
    const PassivityProbe r = probe_passivity(p);
    if (rows) rows->push_back(passivity_row_of(p, r, "bisection", -1));
    return r.passive;
  };
  // Bracket [lo, hi] with lo passive and hi not, from K_ref/4 and 4 K_ref, widened by 4 up to
  // 8 times each way; then bisection on log K until hi/lo <= 1 + tolerance.
  const double ref = reference_stiffness(p);
  double lo = ref / 4.0, hi = ref * 4.0;
  bool lo_ok = passive(lo), hi_ok = !passive(hi);
  for (int i = 0; i < 8 && !lo_ok; ++i) {
    hi = lo;
    hi_ok = true;
    lo /= 4.0;
    lo_ok = passive(lo);
  }
  for (int i = 0; i < 8 && lo_ok && !hi_ok; ++i) {
    lo = hi;
    hi *= 4.0;
    hi_ok = !passive(hi);
  }
  if (!lo_ok) {
    b.k_max = 0.0;
    b.k_not_passive = lo;
  } else if (!hi_ok) {
    b.k_max = kNoBound;
    b.k_passive = hi;
    b.k_not_passive = kNoBound;
  } else {
    while (hi / lo > 1.0 + tolerance) {
      const double mid = std::sqrt(lo * hi);
      (passive(mid) ? lo : hi) = mid;
    }
    b.k_max = std::sqrt(lo * hi);
    b.k_passive = lo;
    b.k_not_passive = hi;
  }
  b.period_s = point.period_s;
  b.device_damping = point.device_damping;
  b.coulomb = point.coulomb;
  b.resolution = point.resolution;
  b.delay_periods = point.delay_periods;
  b.coupling = point.coupling;
  b.damping = point.damping;
  b.obstacle_stiffness = point.obstacle_stiffness;
  b.passivity_controller = point.passivity_controller;
  b.passivity_energy_limit_j = point.passivity_energy_limit_j;
  b.velocity_estimator = point.velocity_estimator;
  b.colgate_bound = colgate_bound(point);
  b.abbott_okamura_bound = abbott_okamura_bound(point);
  b.delay_bound = delay_bound(point);
  b.dither_bound = dither_bound(point);
  b.ratio_colgate = bound_ratio(b.k_max, b.colgate_bound);
  b.ratio_abbott_okamura = bound_ratio(b.k_max, b.abbott_okamura_bound);
  b.ratio_delay = bound_ratio(b.k_max, b.delay_bound);
  b.ratio_dither = bound_ratio(b.k_max, b.dither_bound);
  return b;
}

std::vector<StudyCase> passivity_cases(const PassivityOptions& options) {
  check_passivity_options(options);
  std::vector<StudyCase> out;
  for (const PassivityConfig& c : passivity_plan(options))
    if (options.shard.owns(c.info.index)) out.push_back(c.info);
  return out;
}

PassivityResult run_passivity_study(const PassivityOptions& options) {
  check_passivity_options(options);
  const std::vector<PassivityConfig> configs = passivity_plan(options);
  PassivityResult result;
  result.cases = static_cast<std::int64_t>(configs.size());
  result.shard = options.shard;
  const auto start = std::chrono::steady_clock::now();
  double done = 0.0;
  const double total = static_cast<double>(configs.size());
  for (const PassivityConfig& c : configs) {
    if (!options.shard.owns(c.info.index)) continue;
    result.boundaries.push_back(measure_config(c, options, result.rows));
    done += static_cast<double>(options.shard.count);
    if (options.progress) options.progress(done, total, c.info.name + " " + c.info.parameters);
  }
  result.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

void write_passivity_csv(const PassivityResult& r, const std::string& dir) {
  std::filesystem::create_directories(dir);
  std::ostringstream rows, boundaries;
  rows.precision(6);
  boundaries.precision(6);
  write_fields_csv(rows, r.rows, [](auto& x, auto&& v) { passivity_row_fields(x, v); });
  write_fields_csv(boundaries, r.boundaries,
                   [](auto& x, auto&& v) { passivity_boundary_fields(x, v); });
  write_files_atomically(
      dir, {{"passivity.csv", rows.str()}, {"passivity_boundary.csv", boundaries.str()}});
}

std::string format_passivity_table(const PassivityResult& r) {
  std::string out =
      "| T (s) | b | f_c | Δ (m) | d | coupling | B | k_w | PC E_max (J) | K_max (N/m) | "
      "Colgate | ratio | A&O | ratio | delay | ratio | v̂ |\n"
      "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- "
      "| --- | --- |\n";
  char buf[400];
  for (const PassivityBoundary& b : r.boundaries) {
    std::snprintf(buf, sizeof buf,
                  "| %g | %g | %g | %g | %d | %s | %g | %g | %s | %.4g | %.4g | %.3f | %.4g | "
                  "%.3f | %.4g | %.3f | %s |\n",
                  b.period_s, b.device_damping, b.coulomb, b.resolution, b.delay_periods,
                  b.coupling.c_str(), b.damping, b.obstacle_stiffness,
                  pc_cell(b).c_str(), b.k_max, b.colgate_bound,
                  b.ratio_colgate, b.abbott_okamura_bound, b.ratio_abbott_okamura, b.delay_bound,
                  b.ratio_delay, b.velocity_estimator.c_str());
    out += buf;
  }
  return out;
}

std::vector<std::string> passivity_failures(const PassivityResult& r) {
  std::vector<std::string> out;
  for (const PassivityRow& x : r.rows)
    if (std::isnan(x.energy_min_j) || std::isnan(x.contact_energy_min_j))
      out.push_back("case " + std::to_string(x.case_index) +
                    ": energy is NaN at K = " + std::to_string(x.stiffness));
  for (const PassivityBoundary& b : r.boundaries) {
    const std::string where = "case " + std::to_string(b.case_index) + " (" + b.coupling +
                              ", T=" + std::to_string(b.period_s) + ")";
    if (std::isnan(b.k_max)) out.push_back(where + ": K_max is NaN");
    // Where the theory's assumptions hold, the boundary must reproduce it within 10 %:
    // a direct wall without quantisation and friction (Colgate & Schenkel, with the delay),
    // and one without damping at the count scale (Abbott & Okamura, 2 f_c/Δ).
    // (Not with the passivity controller, nor another estimator than the theory's backward
    // difference: they move the boundary, which is what those cases measure.)
    const bool theory = !b.passivity_controller && b.velocity_estimator == "difference";
    const bool colgate =
        b.coupling == "wall" && b.resolution == 0.0 && b.coulomb == 0.0 && theory;
    if (colgate && !(std::abs(b.ratio_delay - 1.0) <= 0.1))
      out.push_back(where + ": K_max / delay bound = " + std::to_string(b.ratio_delay) +
                    ", outside 1 ± 0.1");
    const bool quantised = b.coupling == "wall" && b.resolution > 0.0 && b.device_damping == 0.0 &&
                           b.delay_periods == 0 && theory;
    if (quantised && !(std::abs(b.ratio_abbott_okamura - 1.0) <= 0.1))
      out.push_back(where + ": K_max / (2 f_c/Δ) = " + std::to_string(b.ratio_abbott_okamura) +
                    ", outside 1 ± 0.1");
  }
  return out;
}

}  // namespace numen::sim
