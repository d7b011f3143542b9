/// @file study_accuracy.cpp
/// `numen study accuracy`: the grid of runs, the comparisons, the order fits and the CSV files
/// (study_accuracy.hpp). The cases are in study_accuracy_{free_body,wall,scene}.cpp.

#include "numen/sim/study/study_accuracy.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <memory>
#include <sstream>
#include <stdexcept>

#include "numen/sim/input/input_error.hpp"
#include "numen/sim/scene/scene.hpp"
#include "numen/sim/study/study_common.hpp"
#include "numen/sim/study/study_fields.hpp"
#include "study_accuracy_cases.hpp"

namespace numen::sim {
namespace accuracy {

bool second_order(core::Integrator integrator) noexcept {
  return integrator == core::Integrator::kTrapezoidal || integrator == core::Integrator::kTrBdf2;
}

double input_time(core::Integrator integrator, double t, double dt) noexcept {
  return second_order(integrator) ? t + 0.5 * dt : t;
}

core::Model with_scheme(const core::Model& model, core::Integrator integrator, double dt) {
  return study::with_scheme(model, integrator, dt, "accuracy study");
}

double thread_cpu_seconds() noexcept { return study::thread_cpu_seconds(); }

}  // namespace accuracy

namespace {

using accuracy::AccuracyCase;
using accuracy::kSamplePeriod;
using accuracy::Samples;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kClosedFormFloorMm = 1e-9;  // rounding of positions of ~0.1 m over 1e5 steps
constexpr double kClosedFormFloorMrad = 1e-9;
constexpr double kDivergedMm = 1000.0;
// Windows of the recording (trajectory time, s) for the scene cases: where the tool meets
// the organ and tissue (articulated) and where the probe is swept into the post (deformable).
// Contacts begin at 3.7 s (articulated: the jaws reach the tissue) and 2.65 s (deformable:
// the probe's nodes reach the post, 43 node contacts at 3.0 s).
// Horizons: 0.6 s and 0.2 s (the deformable steps cost ~0.5 ms with the study's tight solve:
// its references alone are 3e5 steps), so that the whole study stays near 5 minutes.
constexpr double kArticulatedStart = 3.5;
constexpr double kDeformableStart = 2.65;

/// Angle (rad) between two rotations, q and −q being the same.
double angle_between(const core::Quat& a, const core::Quat& b) noexcept {
  const core::Quat d = a.conjugate() * b;
  return 2.0 * std::atan2(d.vec().norm(), std::abs(d.w()));
}

struct Comparison {
  double pos_max = 0.0, pos_rms = 0.0, rot_max = 0.0, rot_rms = 0.0;  // mm, mrad
};

/// Per sample the largest point and frame error, then max and RMS over the samples.
Comparison compare(const Samples& a, const Samples& b) {
  Comparison c;
  const std::size_t pp = static_cast<std::size_t>(a.points_per_sample);
  const std::size_t fp = static_cast<std::size_t>(a.frames_per_sample);
  const std::size_t n =
      pp > 0 ? a.points.size() / pp : a.frames.size() / std::max<std::size_t>(fp, 1);
  if (a.points.size() != b.points.size() || a.frames.size() != b.frames.size() || n == 0)
    throw std::logic_error("accuracy study: runs with different samples");
  double sp = 0.0, sr = 0.0;
  for (std::size_t j = 0; j < n; ++j) {
    double ep = 0.0, er = 0.0;
    for (std::size_t i = 0; i < pp; ++i) {
      const double e = (a.points[j * pp + i] - b.points[j * pp + i]).norm();
      ep = std::isfinite(e) ? std::max(ep, e) : kNaN;
    }
    for (std::size_t i = 0; i < fp; ++i) {
      const double e = angle_between(a.frames[j * fp + i], b.frames[j * fp + i]);
      er = std::isfinite(e) ? std::max(er, e) : kNaN;
    }
    ep *= 1e3;
    er *= 1e3;
    c.pos_max = std::isnan(ep) || std::isnan(c.pos_max) ? kNaN : std::max(c.pos_max, ep);
    c.rot_max = std::isnan(er) || std::isnan(c.rot_max) ? kNaN : std::max(c.rot_max, er);
    sp += ep * ep;
    sr += er * er;
  }
  c.pos_rms = std::sqrt(sp / static_cast<double>(n));
  c.rot_rms = std::sqrt(sr / static_cast<double>(n));
  return c;
}

std::string dt_label(double dt) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.0e", dt);
  return buf;
}

}  // namespace

std::vector<double> accuracy_default_steps(bool quick) {
  std::vector<double> steps;
  const int max_n = quick ? 100 : 1000;
  for (int decade = 1; decade <= max_n; decade *= 10)
    for (int m : {1, 2, 5})
      if (m * decade <= max_n) steps.push_back(kSamplePeriod / (m * decade));
  return steps;
}

std::vector<core::Integrator> accuracy_default_integrators() {
  return {core::Integrator::kLinearlyImplicitEuler, core::Integrator::kSymplecticEuler,
          core::Integrator::kTrapezoidal, core::Integrator::kTrBdf2};
}

bool accuracy_case_has_closed_form(const std::string& name) { return name == "free-body"; }

namespace {

void check_step(double dt, const char* what) {
  const double n = kSamplePeriod / dt;
  if (!(dt > 0.0) || !std::isfinite(dt) || std::abs(n - std::round(n)) > 1e-6 * n)
    throw InputError("", 0, 0, what,
                     "time step " + std::to_string(dt) + " s must divide the 10 ms sample period");
}

/// Horizon rounded to whole samples (at least one).
double whole_samples(double horizon) {
  return std::max(1.0, std::round(horizon / kSamplePeriod)) * kSamplePeriod;
}

struct CaseSetup {
  std::string name;
  std::size_t position = 0;  // in the list of cases run (study case = position × integrators + i)
  std::unique_ptr<AccuracyCase> c;
  double reference_dt = 1e-6;
};

}  // namespace

const std::vector<std::string>& accuracy_case_names() {
  static const std::vector<std::string> names = {"free-body", "wall", "wall-smoothed",
                                                  "articulated", "deformable"};
  return names;
}

double fit_order(const std::vector<double>& dt, const std::vector<double>& error,
                 const std::vector<bool>& diverged, double max_dt, double min_error, int* used,
                 double* dt_min, double* dt_max) {
  double sx = 0.0, sy = 0.0, sxx = 0.0, sxy = 0.0;
  int n = 0;
  double lo = kNaN, hi = kNaN;
  for (std::size_t i = 0; i < dt.size(); ++i) {
    if (diverged[i] || dt[i] > max_dt * (1.0 + 1e-9) || !std::isfinite(error[i]) ||
        !(error[i] >= min_error) || !(error[i] > 0.0))
      continue;
    const double x = std::log(dt[i]), y = std::log(error[i]);
    sx += x;
    sy += y;
    sxx += x * x;
    sxy += x * y;
    ++n;
    lo = std::isnan(lo) ? dt[i] : std::min(lo, dt[i]);
    hi = std::isnan(hi) ? dt[i] : std::max(hi, dt[i]);
  }
  if (used) *used = n;
  if (dt_min) *dt_min = lo;
  if (dt_max) *dt_max = hi;
  if (n < 3) return kNaN;
  const double den = n * sxx - sx * sx;
  return den > 0.0 ? (n * sxy - sx * sy) / den : kNaN;
}

namespace {

/// What the options ask for, checked: the steps (largest first), the integrators, the cases
/// this build can run and those it left out.
struct AccuracyGrid {
  std::vector<double> steps;
  std::vector<core::Integrator> integrators;
  std::vector<std::string> names;
  std::vector<std::string> skipped;
};

AccuracyGrid accuracy_grid(const AccuracyOptions& options) {
  std::vector<double> steps =
      options.steps.empty() ? accuracy_default_steps(options.quick) : options.steps;
  for (double dt : steps) check_step(dt, "steps");
  std::sort(steps.begin(), steps.end(), std::greater<>());
  std::vector<core::Integrator> integrators = options.integrators;
  if (integrators.empty()) integrators = accuracy_default_integrators();
  std::vector<std::string> names = options.cases.empty() ? accuracy_case_names() : options.cases;
  for (const std::string& n : names) {
    const auto& all = accuracy_case_names();
    if (std::find(all.begin(), all.end(), n) == all.end())
      throw InputError("", 0, 0, "case",
                       "unknown case \"" + n +
                           "\" (free-body, wall, wall-smoothed, articulated, deformable)");
  }
  std::vector<std::string> skipped;
  std::erase_if(names, [&](const std::string& n) {
    const std::string missing = study::missing_parts(n == "articulated", n == "deformable");
    if (missing.empty()) return false;
    if (!options.cases.empty())
      throw InputError("", 0, 0, "case", "case \"" + n + "\" " + missing);
    skipped.push_back(n + ": " + missing);
    return true;
  });
  if (options.reference_dt > 0.0) check_step(options.reference_dt, "reference_dt");
  check_shard(options.shard);
  return {std::move(steps), std::move(integrators), std::move(names), std::move(skipped)};
}

}  // namespace

std::vector<StudyCase> accuracy_cases(const AccuracyOptions& options) {
  const AccuracyGrid g = accuracy_grid(options);
  std::vector<StudyCase> out;
  char buf[96];
  std::snprintf(buf, sizeof buf, " steps=%zu dt=%g..%g", g.steps.size(), g.steps.front(),
                g.steps.back());
  for (std::size_t c = 0; c < g.names.size(); ++c)
    for (std::size_t i = 0; i < g.integrators.size(); ++i) {
      const auto k = static_cast<std::int64_t>(c * g.integrators.size() + i);
      if (options.shard.owns(k))
        out.push_back({k, g.names[c], to_string(g.integrators[i]),
                       std::string("integrator=") + to_string(g.integrators[i]) + buf});
    }
  return out;
}

AccuracyResult run_accuracy_study(const AccuracyOptions& options) {
  AccuracyGrid grid = accuracy_grid(options);
  const std::vector<double>& steps = grid.steps;
  const std::vector<core::Integrator>& integrators = grid.integrators;
  AccuracyResult result;
  result.skipped = std::move(grid.skipped);
  result.cases = static_cast<std::int64_t>(grid.names.size() * integrators.size());
  result.shard = options.shard;
  const auto start = std::chrono::steady_clock::now();
  // Study case k = case position × integrators + integrator position.
  const auto study_case = [&](std::size_t c, std::size_t i) {
    return static_cast<std::int64_t>(c * integrators.size() + i);
  };
  const auto case_wanted = [&](std::size_t c) {
    for (std::size_t i = 0; i < integrators.size(); ++i)
      if (options.shard.owns(study_case(c, i))) return true;
    return false;
  };

  const std::string dir = options.scene_dir.empty()
                              ? std::filesystem::path(default_scene_path()).parent_path().string()
                              : options.scene_dir;
  std::vector<CaseSetup> cases;
  for (std::size_t position = 0; position < grid.names.size(); ++position) {
    if (!case_wanted(position)) continue;  // no integrator of it in this shard
    const std::string& n = grid.names[position];
    CaseSetup s;
    s.name = n;
    s.position = position;
    if (n == "free-body") {
      s.c = accuracy::make_free_body_case();
    } else if (n == "wall") {
      s.c = accuracy::make_wall_case(0.0);
    } else if (n == "wall-smoothed") {
      s.c = accuracy::make_wall_case(accuracy::kWallOnsetDepth);
    } else if (n == "articulated") {
      s.c = accuracy::make_scene_case(dir + "/lattice.toml", kArticulatedStart, 0.6, 40.0);
    } else {
      s.c = accuracy::make_scene_case(dir + "/deformable.toml", kDeformableStart, 0.2, 500.0);
      s.reference_dt = 2e-6;
    }
    // The merge checks a case's reference checks by its name (merge_accuracy_shards()).
    if (s.c->has_closed_form() != accuracy_case_has_closed_form(n))
      throw std::logic_error("accuracy study: case " + n +
                             " disagrees with accuracy_case_has_closed_form()");
    if (options.quick) s.reference_dt = 2e-5;
    if (options.reference_dt > 0.0) s.reference_dt = options.reference_dt;
    cases.push_back(std::move(s));
  }

  const auto horizon_of = [&](const AccuracyCase& c) {
    if (options.horizon_s > 0.0)
      return whole_samples(std::min(options.horizon_s, c.default_horizon()));
    return whole_samples(options.quick ? 0.3 * c.default_horizon() : c.default_horizon());
  };
  // Work estimate (steps × relative cost) for the progress callback.
  double total = 0.0;
  for (const CaseSetup& s : cases) {
    const double w = horizon_of(*s.c) * s.c->step_cost();
    double owned = 0.0;
    for (std::size_t i = 0; i < integrators.size(); ++i)
      owned += options.shard.owns(study_case(s.position, i)) ? 1.0 : 0.0;
    for (double dt : steps) total += w * owned / dt;
    if (!s.c->has_closed_form()) total += w * 3.0 / s.reference_dt;
  }
  double done = 0.0;
  const auto report = [&](const CaseSetup& s, double horizon, double dt, const std::string& label) {
    done += horizon * s.c->step_cost() / dt;
    if (options.progress) options.progress(done, total, s.name + " " + label);
  };

  for (const CaseSetup& s : cases) {
    const double horizon = horizon_of(*s.c);
    Samples reference;
    double floor_mm = kClosedFormFloorMm, floor_mrad = kClosedFormFloorMrad;
    std::string reference_name = "closed-form";
    if (s.c->has_closed_form()) {
      reference = s.c->exact(horizon);
    } else {
      reference = s.c->simulate(core::Integrator::kTrapezoidal, s.reference_dt, horizon);
      report(s, horizon, s.reference_dt, "reference dt=" + dt_label(s.reference_dt));
      const Samples half =
          s.c->simulate(core::Integrator::kTrapezoidal, 0.5 * s.reference_dt, horizon);
      report(s, horizon, 0.5 * s.reference_dt,
             "reference check dt=" + dt_label(0.5 * s.reference_dt));
      const Comparison c = compare(reference, half);
      ReferenceCheck rc;
      rc.case_name = s.name;
      rc.reference_dt = s.reference_dt;
      rc.position_difference_max_mm = c.pos_max;
      rc.orientation_difference_max_mrad = c.rot_max;
      rc.cpu_s = reference.cpu_s + half.cpu_s;
      rc.case_index = study_case(s.position, 0);
      if (options.shard.owns(rc.case_index)) result.references.push_back(rc);
      floor_mm = std::max(c.pos_max, kClosedFormFloorMm);
      floor_mrad = std::max(c.rot_max, kClosedFormFloorMrad);
      reference_name = "trapezoidal dt=" + dt_label(s.reference_dt);
    }
    std::size_t integrator_position = 0;
    for (core::Integrator integ : integrators) {
      const std::int64_t k = study_case(s.position, integrator_position++);
      if (!options.shard.owns(k)) continue;
      std::vector<double> dts, pos, rot;
      std::vector<bool> div;
      AccuracyFit fit;
      fit.case_name = s.name;
      fit.integrator = to_string(integ);
      fit.theoretical_order = accuracy::second_order(integ) ? 2.0 : 1.0;
      fit.error_at_1ms_mm = kNaN;
      fit.cpu_at_1ms = kNaN;
      fit.case_index = k;
      for (double dt : steps) {
        const Samples run = s.c->simulate(integ, dt, horizon);
        report(s, horizon, dt, std::string(to_string(integ)) + " dt=" + dt_label(dt));
        const Comparison c = compare(run, reference);
        AccuracyRow row;
        row.case_name = s.name;
        row.integrator = to_string(integ);
        row.dt_s = dt;
        row.steps = run.steps;
        row.horizon_s = horizon;
        row.position_error_max_mm = c.pos_max;
        row.position_error_rms_mm = c.pos_rms;
        row.orientation_error_max_mrad = c.rot_max;
        row.orientation_error_rms_mrad = c.rot_rms;
        row.cpu_s_per_sim_s = run.cpu_s / horizon;
        row.nonfinite_steps = run.nonfinite_steps;
        row.diverged = run.nonfinite_steps > 0 || !std::isfinite(c.pos_max) ||
                       !std::isfinite(c.rot_max) || c.pos_max > kDivergedMm;
        row.reference = reference_name;
        row.case_index = k;
        if (std::abs(dt - 1e-3) < 1e-12) {
          fit.error_at_1ms_mm = row.diverged ? kNaN : row.position_error_max_mm;
          fit.cpu_at_1ms = row.cpu_s_per_sim_s;
        }
        dts.push_back(dt);
        pos.push_back(c.pos_max);
        rot.push_back(c.rot_max);
        div.push_back(row.diverged);
        result.rows.push_back(row);
      }
      fit.observed_order = fit_order(dts, pos, div, options.fit_max_dt, 10.0 * floor_mm,
                                     &fit.points, &fit.fit_dt_min, &fit.fit_dt_max);
      fit.observed_order_rotation = fit_order(dts, rot, div, options.fit_max_dt, 10.0 * floor_mrad);
      result.fits.push_back(fit);
    }
  }
  result.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

void write_accuracy_csv(const AccuracyResult& r, const std::string& dir) {
  std::filesystem::create_directories(dir);
  std::ostringstream rows, orders, references;  // precision 6, as the files always had
  // The columns are the row's field list (study_fields.hpp); a bool is written 1/0.
  bool first = true;
  for (const std::string& name : accuracy_row_names()) {
    rows << (first ? "" : ",") << name;
    first = false;
  }
  rows << '\n';
  for (const AccuracyRow& x : r.rows) {
    first = true;
    accuracy_row_fields(x, [&](const char*, const auto& v) {
      rows << (first ? "" : ",") << v;
      first = false;
    });
    rows << '\n';
  }
  orders << "case,integrator,observed_order,observed_order_rotation,theoretical_order,points,"
            "fit_dt_min_s,fit_dt_max_s,position_error_max_at_1ms_mm,cpu_s_per_sim_s_at_1ms\n";
  for (const AccuracyFit& x : r.fits)
    orders << x.case_name << ',' << x.integrator << ',' << x.observed_order << ','
           << x.observed_order_rotation << ',' << x.theoretical_order << ',' << x.points << ','
           << x.fit_dt_min << ',' << x.fit_dt_max << ',' << x.error_at_1ms_mm << ',' << x.cpu_at_1ms
           << '\n';
  references << "case,reference_dt_s,half_dt_s,position_difference_max_mm,"
                "orientation_difference_max_mrad,cpu_s\n";
  for (const ReferenceCheck& x : r.references)
    references << x.case_name << ',' << x.reference_dt << ',' << 0.5 * x.reference_dt << ','
               << x.position_difference_max_mm << ',' << x.orientation_difference_max_mrad << ','
               << x.cpu_s << '\n';
  write_files_atomically(dir, {{"accuracy.csv", rows.str()},
                               {"accuracy_orders.csv", orders.str()},
                               {"accuracy_references.csv", references.str()}});
}

std::string format_accuracy_table(const AccuracyResult& r) {
  std::ostringstream os;
  char buf[256];
  os << "| case | integrator | observed order (position) | observed order (orientation) | "
        "theoretical | error max at 1 ms (mm) | CPU s per simulated s at 1 ms |\n"
        "| --- | --- | --- | --- | --- | --- | --- |\n";
  for (const AccuracyFit& f : r.fits) {
    std::snprintf(buf, sizeof buf,
                  "| %s | %s | %.2f (%d steps, %.0e–%.0e s) | %.2f | %.0f | %.3g | %.3g |\n",
                  f.case_name.c_str(), f.integrator.c_str(), f.observed_order, f.points,
                  f.fit_dt_min, f.fit_dt_max, f.observed_order_rotation, f.theoretical_order,
                  f.error_at_1ms_mm, f.cpu_at_1ms);
    os << buf;
  }
  if (!r.references.empty()) {
    os << "\n| case | reference | difference to dt/2: position max (mm) | orientation max (mrad) "
          "|\n"
          "| --- | --- | --- | --- |\n";
    for (const ReferenceCheck& c : r.references) {
      std::snprintf(buf, sizeof buf, "| %s | trapezoidal, dt = %.0e s | %.3g | %.3g |\n",
                    c.case_name.c_str(), c.reference_dt, c.position_difference_max_mm,
                    c.orientation_difference_max_mrad);
      os << buf;
    }
  }
  for (const std::string& s : r.skipped) os << "\nskipped: " << s << "\n";
  return os.str();
}

}  // namespace numen::sim
