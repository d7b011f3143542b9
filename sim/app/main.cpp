/// @file main.cpp
/// The `numen` command: declares the subcommands (commands.hpp, one file each), parses the
/// command line and runs the one given.
///   numen --version
///   numen run [SCENE] [--duration S] [--trace FILE.csv] [--json] [--realtime] [--coupling MODE]
///             [--bus sim|log:FILE|can:IFACE|serial:PATH[@BAUD]|igtl[:[HOST:]PORT]]
///             [--record FILE.log] [--phase S] [--igtl [HOST:]PORT]
///             [--rt-priority N] [--lock-memory|--no-lock-memory] [--prefault-stack BYTES]
///             [--cpu LIST] [--rt-strict] [--cpu-dma-latency US|--no-cpu-dma-latency]
///             [--spin US] [--scene-rt-priority N] [--scene-cpu LIST] [--scene-spin US]
///   numen device [SCENE] --bus can:IFACE|serial:PATH[@BAUD] [--duration S] [--ready]
///   numen info [SCENE] [--json]
///   numen figures
///   numen view FILE.nmv [--port P] [--host H] [--page DIR]
///   numen scan --bus can:IFACE|serial:PATH[@BAUD] [--listen S] [--timeout S] [--json]
///   numen sdo --bus can:IFACE|serial:PATH[@BAUD] NODE read|write INDEX:SUB [VALUE] [--type T]
///   numen igtl-replay [SCENE] [--host H] [--port P] [--rate HZ] [--duration S] [--realtime]
///                     [--stall-at S --stall S]
///   numen study accuracy [--out DIR] [--quick] [--case NAME]...
///   numen study stability [--out DIR] [--quick] [--family NAME]...
///   numen study passivity [--out DIR] [--quick]
///   numen study accuracy|stability|passivity ... [--shard I/N] [--list]
///   numen study merge DIR [--out DIR]
/// SIGINT / SIGTERM / SIGHUP: while the input loads, the process ends at once (status 128 +
/// signal; nothing is open on a bus yet); once a run or device has started, it ends cleanly
/// (run: zero torque, drives disabled; both: summary). SIGPIPE is ignored: output that cannot
/// be written on stdout is reported (standard_streams.hpp). Exit statuses: docs/inputs.md.

#include <CLI/CLI.hpp>

#include <iostream>
#include <string>

#include "commands.hpp"
#include "numen/version.hpp"
#include "numen/sim/run/run_verdict.hpp"
#include "signals.hpp"
#include "standard_streams.hpp"

namespace {

/// If `word` (the command-line word where `app`, called `command`, expects its subcommand) is
/// not an option and names none of `app`'s subcommands: "unknown subcommand 'word' of numen;
/// the subcommands are: run, device, ..." (CLI11 would say "A subcommand is required", or take
/// it as an extra argument). Empty if `word` is an option or a known subcommand.
std::string unknown_subcommand(CLI::App& app, const std::string& command, const std::string& word) {
  if (word.empty() || word[0] == '-') return {};
  std::string known;
  for (const CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; })) {
    if (sub->check_name(word)) return {};
    known += (known.empty() ? "" : ", ") + sub->get_name();
  }
  return "unknown subcommand '" + word + "' of " + command + "; the subcommands are: " + known;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace numen::app;
  guard_standard_streams();  // first: before any file is opened (standard_streams.hpp)
  CLI::App app{"numen — real-time control core for generalized dynamic god-objects"};
  app.set_version_flag("--version", std::string("numen ") + NUMEN_VERSION,
                       "Print the version (semantic versioning) and exit");
  app.require_subcommand(1);
  const RunCommand run(app);
  const DeviceCommand device(app);
  const InfoCommand info(app);
  const FiguresCommand figures(app);
  const ViewCommand view(app);
  const ScanCommand scan(app);
  const SdoCommand sdo(app);
  const IgtlReplayCommand igtl_replay(app);
  CLI::App* study = app.add_subcommand("study", "Measure the integrators and the device (docs/results.md)");
  study->require_subcommand(1);
  const AccuracyStudyCommand accuracy(*study);
  const StabilityStudyCommand stability(*study);
  const PassivityStudyCommand passivity(*study);
  const MergeStudyCommand merge(*study);

  // A misspelt subcommand is named, with the known ones (numen frobnicate, numen study frob).
  std::string unknown = argc > 1 ? unknown_subcommand(app, "numen", argv[1]) : std::string();
  if (unknown.empty() && argc > 2 && study->check_name(argv[1]))
    unknown = unknown_subcommand(*study, "numen study", argv[2]);
  if (!unknown.empty()) {
    std::cerr << "numen: " << unknown << "\n";
    return numen::sim::code(numen::sim::ExitStatus::kInputRejected);
  }

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version exit 0; every refused value or option is input rejected.
    const int status = app.exit(e);
    return status == 0 ? with_stdout_checked(0)  // --help, --version
                       : numen::sim::code(numen::sim::ExitStatus::kInputRejected);
  }

  if (stability.parsed()) return run_guarded([&] { return stability.execute(); });
  if (accuracy.parsed()) return run_guarded([&] { return accuracy.execute(); });
  if (passivity.parsed()) return run_guarded([&] { return passivity.execute(); });
  if (merge.parsed()) return run_guarded([&] { return merge.execute(); });
  if (figures.parsed()) return run_guarded([&] { return figures.execute(); });
  install_signal_handlers();  // the studies keep the default: a signal ends them at once
  if (view.parsed()) return run_guarded([&] { return view.execute(); });
  if (scan.parsed()) return run_guarded([&] { return scan.execute(); });
  if (sdo.parsed()) return run_guarded([&] { return sdo.execute(); });
  if (igtl_replay.parsed()) return run_guarded([&] { return igtl_replay.execute(); });
  if (info.parsed()) return run_guarded([&] { return info.execute(); });
  if (device.parsed()) return run_guarded([&] { return device.execute(); });
  if (run.parsed()) return run_guarded([&] { return run.execute(); });
  return 0;
}
