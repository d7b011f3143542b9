/// @file study_command.cpp
/// `numen study accuracy`, `numen study stability`, `numen study passivity` (docs/accuracy.md,
/// docs/stability.md, docs/passivity.md) and `numen study merge`
/// (shards on a cluster, docs/studies.md).

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <optional>
#include <string>

#include "commands.hpp"
#include "numen/sim/input/input_error.hpp"
#include "numen/sim/run/progress_bar.hpp"
#include "numen/sim/run/run_verdict.hpp"
#include "numen/sim/study/study_accuracy.hpp"
#include "numen/sim/study/study_passivity.hpp"
#include "numen/sim/study/study_shard.hpp"
#include "numen/sim/study/study_stability.hpp"

namespace numen::app {
namespace {

/// `format` (printf's) with `args`, for the one-line reports the commands write with std::cout
/// (standard_streams.hpp: a failed write of std::cout is reported).
template <class... Args>
std::string formatted(const char* format, Args... args) {
  const int n = std::snprintf(nullptr, 0, format, args...);
  if (n <= 0) return {};
  std::string text(static_cast<std::size_t>(n), '\0');
  std::snprintf(text.data(), text.size() + 1, format, args...);
  return text;
}

/// The progress callback of a study, drawn on `bar` (stderr).
std::function<void(double, double, const std::string&)> progress_on(sim::ProgressBar& bar) {
  return [&bar](double done, double total, const std::string& label) {
    bar.update(done, total, label);
  };
}

constexpr const char* kShardHelp =
    "Run shard I of N (I/N, 0 <= I < N): the cases k with k mod N = I, written to "
    "OUT/<study>-shard-I-of-N.json (a shard whose file exists is skipped); without it, "
    "SLURM_ARRAY_TASK_ID/SLURM_ARRAY_TASK_COUNT when set (docs/studies.md)";
constexpr const char* kListHelp =
    "Print the cases (index, family, name, parameters; tab-separated), one per line, and exit; "
    "with a shard, only its cases";

/// The shard of this process: --shard, else the Slurm array variables, else none (the whole
/// study in one process).
std::optional<sim::Shard> shard_of(const std::string& option) {
  if (!option.empty()) return sim::parse_shard(option, "--shard");
  return sim::shard_from_environment([](const char* name) { return std::getenv(name); });
}

void print_cases(const std::vector<sim::StudyCase>& cases) {
  for (const sim::StudyCase& c : cases) std::cout << sim::format_case_line(c) << '\n';
}

/// "shard I/N".
std::string shard_label(const sim::Shard& s) {
  return "shard " + std::to_string(s.index) + "/" + std::to_string(s.count);
}

/// Number of the cases 0 … cases − 1 that belong to `s`.
std::int64_t cases_of(const sim::Shard& s, std::int64_t cases) {
  return cases > s.index ? (cases - s.index + s.count - 1) / s.count : 0;
}

/// Refuses an output directory (`--out`) the study could not write its files into, before the
/// study runs (which takes minutes to hours): an existing path that is not a directory (a file
/// is left as it is, never truncated), a directory that cannot be created, or one without
/// write permission. InputError with key `--out` (status 2). Creates the directory.
void check_output_dir(const std::string& dir) {
  std::error_code ec;
  const std::filesystem::file_status st = std::filesystem::status(dir, ec);
  if (std::filesystem::exists(st) && !std::filesystem::is_directory(st))
    throw sim::InputError("", 0, 0, "--out",
                          dir + " is not a directory (the study writes its files into one)");
  if (!std::filesystem::exists(st)) {
    std::filesystem::create_directories(dir, ec);
    if (ec) throw sim::InputError("", 0, 0, "--out", dir + ": cannot create the directory (" + ec.message() + ")");
  }
  if (::access(dir.c_str(), W_OK | X_OK) != 0)
    throw sim::InputError("", 0, 0, "--out", dir + ": cannot write in this directory");
}

/// The file of `shard` in `out`; prints that it is skipped and returns "" when it exists.
std::string shard_path_or_skip(const std::string& study, const sim::Shard& shard,
                               const std::string& out) {
  const std::filesystem::path path =
      std::filesystem::path(out) / sim::shard_file_name(study, shard);
  if (std::filesystem::exists(path)) {
    std::cout << shard_label(shard) << ": " << path.string() << " exists, skipped\n";
    return "";
  }
  std::filesystem::create_directories(out);
  return path.string();
}

/// The passivity study's summary on stdout; status 1 (listed on stderr) when the result has
/// failures (sim::passivity_failures()).
int report_passivity(const sim::PassivityResult& result, const std::string& out,
                     const char* what) {
  std::cout << sim::format_passivity_table(result);
  std::cout << formatted(
      "%s%zu points of %lld configurations in %.1f s; wrote %s/passivity.csv, "
      "passivity_boundary.csv\n",
      what, result.rows.size(), static_cast<long long>(result.cases), result.wall_s, out.c_str());
  const std::vector<std::string> failures = sim::passivity_failures(result);
  for (const std::string& f : failures) std::cerr << "numen: passivity: " << f << '\n';
  return failures.empty() ? 0 : sim::code(sim::ExitStatus::kError);
}

}  // namespace

AccuracyStudyCommand::AccuracyStudyCommand(CLI::App& study)
    : cli_(study.add_subcommand(
          "accuracy",
          "Work-precision data per integrator: error against CPU time per simulated second")) {
  cli_->add_option("--out", out_,
                   "Directory of accuracy.csv, accuracy_orders.csv, accuracy_references.csv "
                   "(plots: docs/figures/plot_accuracy.py DIR), or of the shard file");
  cli_->add_flag("--quick", quick_,
                 "Coarser grid (1e-2 … 1e-4 s), horizons × 0.3, references at 2e-5 s: seconds");
  cli_->add_option("--case", cases_, "Run only these cases (repeatable)")
      ->check(CLI::IsMember(sim::accuracy_case_names()));
  cli_->add_option("--shard", shard_, kShardHelp);
  cli_->add_flag("--list", list_, kListHelp);
}

int AccuracyStudyCommand::execute() const {
  sim::AccuracyOptions options;
  options.quick = quick_;
  options.cases = cases_;
  const std::optional<sim::Shard> shard = shard_of(shard_);
  if (shard) options.shard = *shard;
  if (list_) {
    print_cases(sim::accuracy_cases(options));
    return 0;
  }
  check_output_dir(out_);
  std::string path;
  if (shard && (path = shard_path_or_skip("accuracy", *shard, out_)).empty()) return 0;
  sim::ProgressBar bar;
  options.progress = progress_on(bar);
  const sim::AccuracyResult result = sim::run_accuracy_study(options);
  bar.finish();
  if (shard) {
    sim::write_file_atomically(path, sim::accuracy_shard_document(result, options));
    std::cout << formatted("%s: %zu runs, %lld of the %lld study cases, in %.1f s; wrote %s\n",
                           shard_label(*shard).c_str(), result.rows.size(),
                           static_cast<long long>(cases_of(*shard, result.cases)),
                           static_cast<long long>(result.cases), result.wall_s, path.c_str());
    return 0;
  }
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
                   "(maps: docs/figures/plot_stability.py DIR), or of the shard file");
  cli_->add_flag("--quick", quick_, "Coarse grids, short runs: seconds");
  cli_->add_option("--family", families_, "Run only these families (repeatable)")
      ->check(CLI::IsMember(sim::stability_family_names()));
  cli_->add_option("--shard", shard_, kShardHelp);
  cli_->add_flag("--list", list_, kListHelp);
}

int StabilityStudyCommand::execute() const {
  sim::StabilityOptions options;
  options.quick = quick_;
  options.families = families_;
  const std::optional<sim::Shard> shard = shard_of(shard_);
  if (shard) options.shard = *shard;
  if (list_) {
    print_cases(sim::stability_cases(options));
    return 0;
  }
  check_output_dir(out_);
  std::string path;
  if (shard && (path = shard_path_or_skip("stability", *shard, out_)).empty()) return 0;
  sim::ProgressBar bar;
  options.progress = progress_on(bar);
  const sim::StabilityResult result = sim::run_stability_study(options);
  bar.finish();
  if (shard) {
    sim::write_file_atomically(path, sim::stability_shard_document(result, options));
    std::cout << formatted("%s: %zu runs, %lld of the %lld cases, in %.1f s; wrote %s\n",
                           shard_label(*shard).c_str(), result.rows.size(),
                           static_cast<long long>(cases_of(*shard, result.cases)),
                           static_cast<long long>(result.cases), result.wall_s, path.c_str());
    return 0;
  }
  sim::write_stability_csv(result, out_);
  std::cout << sim::format_stability_tables(result);
  std::cout << formatted("%zu runs in %.1f s; wrote %s/stability_*.csv\n", result.rows.size(),
                         result.wall_s, out_.c_str());
  return 0;
}

PassivityStudyCommand::PassivityStudyCommand(CLI::App& study)
    : cli_(study.add_subcommand(
          "passivity",
          "Z-width of a 1-DOF impedance device: the largest passive stiffness per configuration "
          "against the analytic bounds")) {
  cli_->add_option("--out", out_,
                   "Directory of passivity.csv and passivity_boundary.csv (figure: "
                   "docs/figures/plot_passivity.py DIR), or of the shard file");
  cli_->add_flag("--quick", quick_, "A coarse sweep: seconds");
  cli_->add_option("--shard", shard_, kShardHelp);
  cli_->add_flag("--list", list_, kListHelp);
}

int PassivityStudyCommand::execute() const {
  sim::PassivityOptions options;
  options.quick = quick_;
  const std::optional<sim::Shard> shard = shard_of(shard_);
  if (shard) options.shard = *shard;
  if (list_) {
    print_cases(sim::passivity_cases(options));
    return 0;
  }
  check_output_dir(out_);
  std::string path;
  if (shard && (path = shard_path_or_skip("passivity", *shard, out_)).empty()) return 0;
  sim::ProgressBar bar;
  options.progress = progress_on(bar);
  const sim::PassivityResult result = sim::run_passivity_study(options);
  bar.finish();
  if (shard) {
    sim::write_file_atomically(path, sim::passivity_shard_document(result, options));
    std::cout << formatted("%s: %zu points, %lld of the %lld configurations, in %.1f s; wrote %s\n",
                           shard_label(*shard).c_str(), result.rows.size(),
                           static_cast<long long>(cases_of(*shard, result.cases)),
                           static_cast<long long>(result.cases), result.wall_s, path.c_str());
    return 0;
  }
  sim::write_passivity_csv(result, out_);
  return report_passivity(result, out_, "");
}

MergeStudyCommand::MergeStudyCommand(CLI::App& study)
    : cli_(study.add_subcommand(
          "merge",
          "Check the shard files of a study in DIR (all N present, same options) and write the "
          "one-process run's CSV files (docs/studies.md)")) {
  cli_->add_option("dir", dir_, "Directory of the shard files (<study>-shard-I-of-N.json)")
      ->required();
  cli_->add_option("--out", out_, "Directory of the CSV files (default: DIR)");
}

int MergeStudyCommand::execute() const {
  // Every shard file is read and checked before anything is written: a set that is refused
  // (status 2) leaves --out as it was, and the CSV files are written as one set.
  const std::string out = out_.empty() ? dir_ : out_;
  const std::string study = sim::study_of_shard_dir(dir_);
  if (study == "stability") {
    const sim::StabilityResult result = sim::merge_stability_shards(dir_);
    check_output_dir(out);
    sim::write_stability_csv(result, out);
    std::cout << sim::format_stability_tables(result);
    std::cout << formatted(
        "merged %zu runs of %lld cases; shards' wall time %.1f s in all; wrote "
        "%s/stability_*.csv\n",
        result.rows.size(), static_cast<long long>(result.cases), result.wall_s, out.c_str());
    return 0;
  }
  if (study == "accuracy") {
    const sim::AccuracyResult result = sim::merge_accuracy_shards(dir_);
    check_output_dir(out);
    sim::write_accuracy_csv(result, out);
    std::cout << sim::format_accuracy_table(result);
    std::cout << formatted(
        "merged %zu runs of %lld study cases (CPU times as measured by each shard); "
        "shards' wall time %.1f s in all; wrote %s/accuracy.csv, accuracy_orders.csv, "
        "accuracy_references.csv\n",
        result.rows.size(), static_cast<long long>(result.cases), result.wall_s, out.c_str());
    return 0;
  }
  if (study == "passivity") {
    const sim::PassivityResult result = sim::merge_passivity_shards(dir_);
    check_output_dir(out);
    sim::write_passivity_csv(result, out);
    return report_passivity(result, out, "merged; shards' wall time in all: ");
  }
  throw std::runtime_error(dir_ + ": shard files of an unknown study \"" + study + "\"");
}

}  // namespace numen::app
