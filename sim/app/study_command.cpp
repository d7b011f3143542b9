/// @file study_command.cpp
/// `numen study accuracy` and `numen study stability` (docs/results.md).

#include <cstdio>
#include <iostream>

#include "commands.hpp"
#include "numen/sim/progress_bar.hpp"
#include "numen/sim/study_accuracy.hpp"
#include "numen/sim/study_stability.hpp"

namespace numen::app {
namespace {

/// The progress callback of a study, drawn on `bar` (stderr).
std::function<void(double, double, const std::string&)> progress_on(sim::ProgressBar& bar) {
  return [&bar](double done, double total, const std::string& label) {
    bar.update(done, total, label);
  };
}

}  // namespace

AccuracyStudyCommand::AccuracyStudyCommand(CLI::App& study)
    : cli_(study.add_subcommand(
          "accuracy",
          "Work-precision data per integrator: error against CPU time per simulated second")) {
  cli_->add_option("--out", out_,
                   "Directory of accuracy.csv, accuracy_orders.csv, accuracy_references.csv "
                   "(plots: docs/figures/plot_accuracy.py DIR)");
  cli_->add_flag("--quick", quick_,
                 "Coarser grid (1e-2 … 1e-4 s), horizons × 0.3, references at 2e-5 s: seconds");
  cli_->add_option("--case", cases_, "Run only these cases (repeatable)")
      ->check(CLI::IsMember(sim::accuracy_case_names()));
}

int AccuracyStudyCommand::execute() const {
  sim::AccuracyOptions options;
  options.quick = quick_;
  options.cases = cases_;
  sim::ProgressBar bar;
  options.progress = progress_on(bar);
  const sim::AccuracyResult result = sim::run_accuracy_study(options);
  bar.finish();
  sim::write_accuracy_csv(result, out_);
  std::cout << sim::format_accuracy_table(result);
  std::cout << "wrote " << out_ << "/accuracy.csv, accuracy_orders.csv, "
            << "accuracy_references.csv\n";
  return 0;
}

StabilityStudyCommand::StabilityStudyCommand(CLI::App& study)
    : cli_(study.add_subcommand(
          "stability", "Stiff and extreme cases: a verdict per run (stable, or diverged at step N)")) {
  cli_->add_option("--out", out_,
                   "Directory of stability_<family>.csv and stability_boundary.csv "
                   "(maps: docs/figures/plot_stability.py DIR)");
  cli_->add_flag("--quick", quick_, "Coarse grids, short runs: seconds");
  cli_->add_option("--family", families_, "Run only these families (repeatable)")
      ->check(CLI::IsMember(sim::stability_family_names()));
}

int StabilityStudyCommand::execute() const {
  sim::StabilityOptions options;
  options.quick = quick_;
  options.families = families_;
  sim::ProgressBar bar;
  options.progress = progress_on(bar);
  const sim::StabilityResult result = sim::run_stability_study(options);
  bar.finish();
  sim::write_stability_csv(result, out_);
  std::cout << sim::format_stability_tables(result);
  std::printf("%zu runs in %.1f s; wrote %s/stability_*.csv\n", result.rows.size(), result.wall_s,
              out_.c_str());
  return 0;
}

}  // namespace numen::app
