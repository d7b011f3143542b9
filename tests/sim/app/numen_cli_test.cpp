// End-to-end tests of the `numen` command (sim/app/main.cpp and its *_command.cpp) run as a child process: exit
// statuses (docs/inputs.md), signals at each phase, and resident memory that depends neither
// on the control period nor on the run's duration (issue 17, defects 1 and 4).

#include <gtest/gtest.h>
#include <netinet/in.h>
#include <nlohmann/json.hpp>
#include <poll.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include "build_features.hpp"
#include "child_process.hpp"
#include "lattice_scene.hpp"
#include "mesh_text.hpp"
#include "numen/hal/transport/candump_log.hpp"
#include "numen/sim/input/jigsaws.hpp"
#include "numen/sim/run/run_figures.hpp"
#include "numen/sim/scene/scene.hpp"
#include "numen/sim/view/view_recording.hpp"
#include "numen/version.hpp"
#include "sanitizer.hpp"
#include "scene_text.hpp"
#include "temp_dir.hpp"

namespace {

using numen::test::ChildResult;
using numen::test::ChildSignal;
using numen::test::run_child;
using numen::test::TempDir;

const std::string kNumen = NUMEN_CLI;

/// The shipped lattice scene (sim/scenes/lattice.toml): the scene of these tests, which need
/// *a* scene with the articulated instrument. A run with no scene runs the default scene, whose
/// deformable organ costs ~60x the lattice's step; only the test of the default scene's lookup
/// below runs without one.
const std::string kLattice = numen::test::lattice_scene_path();

std::string lattice_scene_text() { return numen::test::read_file(kLattice); }

const std::string kExcerptLine = "file = \"../data/jigsaws_suturing_b002_excerpt.txt\"";

/// The lattice scene with `edits` applied (from → to, each must match) and its trajectory file
/// given as an absolute path (the copy lives in a temporary directory).
std::string lattice_scene_copy(const std::vector<std::pair<std::string, std::string>>& edits) {
  std::string text = lattice_scene_text();
  for (const auto& [from, to] : edits) text = numen::test::replace(text, from, to);
  const std::string dir =
      std::filesystem::path(numen::sim::default_scene_path()).parent_path().string() + "/";
  if (text.find(kExcerptLine) != std::string::npos)
    text = numen::test::replace(text, "file = \"../data/", "file = \"" + dir + "../data/");
  return numen::test::with_absolute_dcf_paths(text, dir);
}

/// The lattice scene at control period `dt` (s): the simulated bus's latency and compute
/// phase are scaled so that a SYNC round trip fits in the period.
std::string lattice_scene_at(const std::string& dt) {
  return lattice_scene_copy({{"dt = 0.001", "dt = " + dt},
                             {"latency = 0.0001", "latency = 1e-6\ncompute_phase = 5e-6"}});
}

/// `numen run` of the lattice scene for 0.05 s with each case's options (in `dir`): input
/// rejected (status 2), its stderr holding the case's text (the option's name, or its message).
void expect_lattice_run_refused(
    const TempDir& dir,
    const std::vector<std::pair<std::vector<std::string>, std::string>>& cases) {
  for (const auto& [extra, text] : cases) {
    std::vector<std::string> args = {kNumen, "run", kLattice, "--duration", "0.05"};
    args.insert(args.end(), extra.begin(), extra.end());
    const ChildResult r = run_child(args, dir.path(), 30);
    EXPECT_EQ(r.status, 2) << extra.front() << ": " << r.out << r.err;
    EXPECT_NE(r.err.find(text), std::string::npos) << extra.front() << ": " << r.err;
  }
}

/// True once a record sink (hal::LineFile) writes `name` in `dir`: its temporary file
/// `.NAME.XXXXXX` exists (the run is past loading and its outputs are open).
bool writing(const TempDir& dir, const std::string& name) {
  for (const auto& e : std::filesystem::directory_iterator(dir.path()))
    if (e.path().filename().string().rfind("." + name + ".", 0) == 0) return true;
  return false;
}

// Defect 1: a 30 s recording used to be resampled at dt up front (497 MB at dt = 1e-5, ~23 GB
// at 1e-7). Now the trajectory keeps its 30 Hz knots: the peak RSS of a run does not depend on dt.
TEST(NumenCli, PeakMemoryDoesNotDependOnTheControlPeriod) {
  NUMEN_REQUIRE_ARTICULATION();
  TempDir dir;
  const std::string coarse = dir.write("coarse.toml", lattice_scene_at("0.001"));
  const std::string fine = dir.write("fine.toml", lattice_scene_at("1e-5"));
  const ChildResult a = run_child({kNumen, "run", coarse, "--duration", "0.05"}, dir.path(), 120);
  const ChildResult b = run_child({kNumen, "run", fine, "--duration", "0.05"}, dir.path(), 120);
  ASSERT_EQ(a.status, 0) << a.out << a.err;
  ASSERT_EQ(b.status, 0) << b.out << b.err;
  std::printf("[   info   ] peak RSS: dt 1e-3 %ld KiB, dt 1e-5 %ld KiB\n", a.max_rss_kib,
              b.max_rss_kib);
  EXPECT_LT(b.max_rss_kib - a.max_rss_kib, 20 * 1024);
}

// ... nor on the run's duration: nothing per step is kept (without --trace).
TEST(NumenCli, PeakMemoryDoesNotGrowWithTheDuration) {
  NUMEN_REQUIRE_ARTICULATION();
  TempDir dir;
  // The least of two runs each: a run's peak varies by about 2 MiB from one run to the next on
  // a loaded machine (2 220 KiB once under ctest -j2, with nothing kept per step), as threads
  // touch their allocator arenas; growth with the duration shows in both.
  long peak[2] = {0, 0};
  const char* durations[2] = {"0.5", "8"};
  for (int d = 0; d < 2; ++d)
    for (int round = 0; round < 2; ++round) {
      const ChildResult r = run_child({kNumen, "run", kLattice, "--duration", durations[d]}, dir.path(), 300);
      ASSERT_EQ(r.status, 0) << r.out << r.err;
      peak[d] = round == 0 ? r.max_rss_kib : std::min(peak[d], r.max_rss_kib);
    }
  std::printf("[   info   ] peak RSS (least of two runs): 0.5 s %ld KiB, 8 s %ld KiB\n", peak[0], peak[1]);
  EXPECT_LT(peak[1] - peak[0], 2 * 1024);
}

// Defect 1: SIGTERM while the input loads (here a trajectory file that is a FIFO nobody writes:
// the loader blocks in open()) ends the process at once, with a message and 128 + SIGTERM;
// SIGHUP alike (129).
TEST(NumenCli, StopSignalWhileLoadingEndsTheProcessAtOnce) {
  NUMEN_REQUIRE_ARTICULATION();  // the lattice scene has joints
  TempDir dir;
  const std::string fifo = (dir / "trajectory.txt").string();
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const std::string scene =
      dir.write("scene.toml", lattice_scene_copy({{kExcerptLine, "file = \"" + fifo + "\""}}));
  // A non-blocking open for writing succeeds once the child has the FIFO open for reading; the
  // write end stays open (and empty), so the child then waits in read(): still loading.
  int writer = -1;
  ChildSignal term;
  term.signal = SIGTERM;
  term.ready = [&] {
    writer = ::open(fifo.c_str(), O_WRONLY | O_NONBLOCK);
    return writer >= 0;
  };
  for (const int signal : {SIGTERM, SIGHUP}) {
    term.signal = signal;
    const ChildResult r = run_child({kNumen, "run", scene}, dir.path(), 20, term);
    if (writer >= 0) ::close(writer);
    writer = -1;
    EXPECT_FALSE(r.timed_out) << "signal " << signal << " was ignored while loading";
    EXPECT_EQ(r.status, 128 + signal) << r.out << r.err;
    EXPECT_EQ(r.err, "numen: stopped by a signal while loading (nothing was commanded)\n");
  }
}

/// A paced run of the lattice scene (60 s; overruns on a loaded machine are counted, never
/// latched) with `extra` options, sent `signal` once it is past loading: its --record file in
/// `dir` is open.
ChildResult paced_run_stopped_by(int signal, const TempDir& dir,
                                 const std::vector<std::string>& extra = {}) {
  ChildSignal stop;
  stop.signal = signal;
  stop.ready = [&dir] { return writing(dir, "run.log"); };
  std::vector<std::string> argv = {
      kNumen, "run",        kLattice, "--realtime", "--overrun-limit",
      "0",    "--duration", "60",     "--record",   (dir / "run.log").string()};
  argv.insert(argv.end(), extra.begin(), extra.end());
  return run_child(argv, dir.path(), 30, stop);
}

// Once running, SIGTERM ends the run cleanly: the summary is printed and the status is
// 128 + SIGTERM (the run did not do what was asked); the summary states that status and names
// the signal (it read "exit status 0 (clean)"). The recorder's temporary file exists once the
// runner is built, i.e. once loading is over.
TEST(NumenCli, StopSignalWhileRunningPrintsTheSummary) {
  NUMEN_REQUIRE_ARTICULATION();
  TempDir dir;
  const ChildResult r = paced_run_stopped_by(SIGTERM, dir);
  EXPECT_FALSE(r.timed_out);
  EXPECT_EQ(r.status, 128 + SIGTERM) << r.out << r.err;
  EXPECT_NE(r.out.find("exit status 143 (stopped by a signal): stopped by a signal: SIGTERM (15) "
                       "after "),
            std::string::npos)
      << r.out;
  EXPECT_EQ(r.out.find("exit status 0"), std::string::npos) << r.out;
  EXPECT_LT(r.wall_s, 20.0);
}

// SIGHUP (the terminal or ssh session of a paced run closed) is a stop signal as SIGTERM is:
// the run ends cleanly, prints its summary with status 129 and writes its trace. It used to
// kill the process (status 129 from the default action): no summary, no trace file.
TEST(NumenCli, HangupWhileRunningEndsTheRunCleanly) {
  NUMEN_REQUIRE_ARTICULATION();
  TempDir dir;
  const std::string trace = (dir / "run.csv").string();
  const ChildResult r = paced_run_stopped_by(SIGHUP, dir, {"--trace", trace});
  EXPECT_FALSE(r.timed_out);
  EXPECT_EQ(r.status, 128 + SIGHUP) << r.out << r.err;
  const std::string stopped =
      "  exit status 129 (stopped by a signal): stopped by a signal: SIGHUP (1) after ";
  const std::size_t at = r.out.find(stopped);
  ASSERT_NE(at, std::string::npos) << r.out;
  EXPECT_NE(r.out.find("  trace: " + trace + "\n"), std::string::npos) << r.out;
  // The trace: its header and one record per period the run ran.
  const long periods = std::atol(r.out.c_str() + at + stopped.size());
  const std::string lines = numen::test::read_file(trace);
  EXPECT_EQ(lines.rfind("time_s,", 0), 0u) << lines.substr(0, 100);
  EXPECT_EQ(std::count(lines.begin(), lines.end(), '\n'), periods + 1);
}

// A stop is always heard: an offline run paced at --speed 1e-6 sleeps 10^3 s per period, in
// slices that look at the stop request (sim::ViewPacer::kStopPollNs). It used to sleep in one
// nanosleep and ignore SIGTERM for good.
TEST(NumenCli, StopSignalDuringAHugePacingPeriodIsHeard) {
  NUMEN_REQUIRE_ARTICULATION();
  TempDir dir;
  ChildSignal term;
  term.signal = SIGTERM;
  term.ready = [&dir] { return writing(dir, "run.log"); };
  const ChildResult r = run_child({kNumen, "run", kLattice, "--duration", "1", "--speed", "1e-6", "--record",
                                   (dir / "run.log").string()},
                                  dir.path(), 60, term);
  EXPECT_FALSE(r.timed_out) << "SIGTERM was not heard";
  EXPECT_EQ(r.status, 128 + SIGTERM) << r.out << r.err;
  EXPECT_NE(r.out.find("steps"), std::string::npos) << r.out;  // the summary was printed
  EXPECT_LT(r.wall_s, 30.0);
}

// A refused run leaves every output file as it was: the refusals come before the outputs are
// opened, the path checks touch nothing, and the writers replace a file only when the run
// closes it (hal::LineFile). These runs used to truncate keep.* to 0 bytes before exit 2.
TEST(NumenCli, RefusedRunLeavesItsOutputFilesByteIdentical) {
  NUMEN_REQUIRE_ARTICULATION();
  TempDir dir;
  const std::string before = "previous contents\n\x01\x02 kept\n";
  const std::vector<std::vector<std::string>> runs = {
      {"--duration", "1e7", "--trace", "keep.csv"},      // trace over its budget
      {"--phase", "0.002", "--record", "keep.log"},      // --phase above dt
      {"--phase", "0.002", "--trace", "keep.csv"},
      {"--phase", "0.002", "--record-view", "keep.nmv"},
      {"--duration", "1e-9", "--record", "keep.log", "--trace", "keep.csv"},  // no period
      {"--record", "keep.log", "--trace", "keep.log"},   // two outputs on one file
  };
  for (const std::vector<std::string>& extra : runs) {
    for (const char* name : {"keep.csv", "keep.log", "keep.nmv"}) dir.write(name, before);
    std::vector<std::string> argv = {kNumen, "run", kLattice};
    // The files in `dir` (the child runs in the test's working directory, not in `dir`: a
    // relative keep.* named files the checks below never read).
    for (const std::string& a : extra)
      argv.push_back(a.rfind("keep.", 0) == 0 ? (dir / a).string() : a);
    const ChildResult r = run_child(argv, dir.path(), 60);
    EXPECT_EQ(r.status, 2) << extra[0] << " " << extra[1] << ": " << r.out << r.err;
    for (const char* name : {"keep.csv", "keep.log", "keep.nmv"})
      EXPECT_EQ(numen::test::read_file((dir / name).string()), before) << name << " after " << extra[0];
    for (const auto& e : std::filesystem::directory_iterator(dir.path()))
      EXPECT_NE(e.path().filename().string().rfind(".keep.", 0), 0u)
          << "a temporary file was left behind: " << e.path();
  }
}

// ... and --json carries the same: exit_status 130 for SIGINT, its name, the signal number and
// a reason naming it (it had exit_status 0 and empty exit_reasons).
TEST(NumenCli, StopSignalIsInTheJsonSummary) {
  NUMEN_REQUIRE_ARTICULATION();
  TempDir dir;
  const ChildResult r = paced_run_stopped_by(SIGINT, dir, {"--json"});
  EXPECT_FALSE(r.timed_out);
  ASSERT_EQ(r.status, 128 + SIGINT) << r.out << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j.at("exit_status"), 128 + SIGINT);
  EXPECT_EQ(j.at("exit_status_name"), "stopped by a signal");
  EXPECT_EQ(j.at("stopped"), true);
  EXPECT_EQ(j.at("stop_signal"), SIGINT);
  ASSERT_EQ(j.at("exit_reasons").size(), 1u) << r.out;
  EXPECT_EQ(j.at("exit_reasons")[0].get<std::string>().rfind(
                "stopped by a signal: SIGINT (2) after ", 0),
            0u)
      << r.out;
}

// Defect 4: --record to a full disk used to report "recorded N frames, 0 dropped" and exit 0.
TEST(NumenCli, RecordingThatLosesFramesExitsWithLostRecords) {
  NUMEN_REQUIRE_ARTICULATION();
  TempDir dir;
  const ChildResult r =
      run_child({kNumen, "run", kLattice, "--duration", "0.5", "--record", "/dev/full"}, dir.path(), 120);
  EXPECT_EQ(r.status, 5) << r.out << r.err;
  EXPECT_NE(r.out.find("lost records: --record"), std::string::npos) << r.out;
}

// --record to a full device wrote nothing, yet read "24 924 of 25 159 frames written (249 I/O
// errors)" (offline) and "25 159 of 25 159 written" (paced): stdio had accepted the lines into
// its buffer. A frame now counts as written once write(2) accepted its bytes: none here.
TEST(NumenCli, RecordingToAFullDeviceWritesNoFrame) {
  NUMEN_REQUIRE_ARTICULATION();
  TempDir dir;
  for (const bool paced : {false, true}) {
    std::vector<std::string> args = {kNumen, "run", kLattice, "--duration", "0.3", "--record", "/dev/full",
                                     "--json"};
    if (paced) args.insert(args.end(), {"--realtime", "--overrun-limit", "0"});
    const ChildResult r = run_child(args, dir.path(), 120);
    ASSERT_EQ(r.status, 5) << r.out << r.err;
    const nlohmann::json j = nlohmann::json::parse(r.out);
    EXPECT_GT(j.at("bus_frames_recorded").get<std::int64_t>(), 300) << "paced " << paced;
    EXPECT_EQ(j.at("bus_record_written"), 0) << "paced " << paced;
    EXPECT_GT(j.at("bus_record_io_errors").get<std::int64_t>(), 0) << "paced " << paced;
    const std::string reason = "lost records: --record: 0 of " +
                               std::to_string(j.at("bus_frames_recorded").get<std::int64_t>()) +
                               " frames written";
    EXPECT_EQ(j.at("exit_reasons")[0].get<std::string>().rfind(reason, 0), 0u) << r.out;
  }
}

// Defect 4: --json carries the verdict; a clean run of the lattice scene exits 0.
TEST(NumenCli, JsonCarriesTheExitStatus) {
  NUMEN_REQUIRE_ARTICULATION();
  TempDir dir;
  const ChildResult r = run_child({kNumen, "run", kLattice, "--duration", "0.5", "--json"}, dir.path(), 120);
  EXPECT_EQ(r.status, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("\"exit_status\":0"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("\"exit_reasons\":[]"), std::string::npos) << r.out;
}

/// `numen args…` with its stdout closed (`>&-`), on /dev/full, or into a pipe whose reader has
/// gone: what a lost stdout looks like to numen in each of the three ways.
std::vector<std::pair<std::string, ChildResult>> with_stdout_lost(
    const std::vector<std::string>& args, const TempDir& dir) {
  std::string command = "exec " + kNumen;
  std::vector<std::string> argv = {kNumen};
  for (const std::string& a : args) {
    command += " " + a;
    argv.push_back(a);
  }
  return {
      {"Bad file descriptor", run_child({"/bin/sh", "-c", command + " >&-"}, dir.path(), 120)},
      {"No space left on device",
       run_child({"/bin/sh", "-c", command + " >/dev/full"}, dir.path(), 120)},
      {"Broken pipe", run_child(argv, dir.path(), 120, {}, numen::test::ChildStdout::kBrokenPipe)}};
}

// A run whose summary cannot be written on stdout lost its record: status 5, said on stderr
// with the summary, whose status is the process's. It exited 0 with its output gone (closed
// stdout, /dev/full), or died of SIGPIPE (141) after printing "exit status 0 (clean)" on stderr.
TEST(NumenCli, RunWhoseSummaryStdoutRefusesIsLostRecords) {
  NUMEN_REQUIRE_ARTICULATION();
  TempDir dir;
  for (const bool json : {false, true}) {
    std::vector<std::string> args = {"run", kLattice, "--duration", "0.05"};
    if (json) args.push_back("--json");
    for (const auto& [reason, r] : with_stdout_lost(args, dir)) {
      EXPECT_EQ(r.status, 5) << reason << ": " << r.err;
      const std::string status_line =
          "  exit status 5 (lost records): lost records: stdout: the summary was not written (" +
          reason + ")\n";
      EXPECT_NE(r.err.find(status_line), std::string::npos) << reason << ": " << r.err;
      EXPECT_EQ(r.err.find("exit status 0"), std::string::npos) << reason << ": " << r.err;
      if (!json) {
        EXPECT_EQ(r.err.rfind("numen: stdout: cannot write the summary (" + reason +
                                  "); it follows on stderr\nscene ",
                              0),
                  0u)
            << reason << ": " << r.err;
      }
    }
  }
}

// Any other command whose stdout output cannot be written says so and exits 1 (error): `numen
// info --json` and `numen study … --list` exited 0 with nothing printed.
TEST(NumenCli, OutputThatStdoutRefusesIsAnError) {
  NUMEN_REQUIRE_ARTICULATION();  // the lattice scene has joints
  TempDir dir;
  for (const std::vector<std::string>& args :
       {std::vector<std::string>{"info", kLattice, "--json"},
        std::vector<std::string>{"study", "stability", "--quick", "--family", "coupling", "--list",
                                 "--shard", "0/1"}}) {
    for (const auto& [reason, r] : with_stdout_lost(args, dir)) {
      EXPECT_EQ(r.status, 1) << args[0] << ", " << reason << ": " << r.err;
      EXPECT_EQ(r.err, "numen: stdout: cannot write the output (" + reason + ")\n") << args[0];
    }
  }
}

// Issue 18: one class per subcommand; each still answers --help, and `numen figures` prints the
// figure table that docs/outputs.md holds.
TEST(NumenCli, EverySubcommandParsesAndFiguresPrintsTheTable) {
  TempDir dir;
  for (const std::vector<std::string>& args :
       {std::vector<std::string>{kNumen, "run", "--help"}, {kNumen, "device", "--help"},
        {kNumen, "info", "--help"}, {kNumen, "figures", "--help"}, {kNumen, "view", "--help"},
        {kNumen, "study", "accuracy", "--help"}, {kNumen, "study", "stability", "--help"},
        {kNumen, "scan", "--help"}, {kNumen, "sdo", "--help"}}) {
    const ChildResult r = run_child(args, dir.path(), 30);
    EXPECT_EQ(r.status, 0) << args[1] << ": " << r.err;
  }
  const ChildResult r = run_child({kNumen, "figures"}, dir.path(), 30);
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out, numen::sim::format_run_figures_markdown());
  const ChildResult none = run_child({kNumen}, dir.path(), 30);
  EXPECT_EQ(none.status, 2) << "a subcommand is required: " << none.err;
}

// ---- inputs far larger than what a run replays (docs/inputs.md, "Memory") ----
// Heavy: each writes 200-500 MB into a temporary directory (deleted at the end) and has numen
// read all of it. ctest label `large_input`, run serially (tests/CMakeLists.txt):
//   ctest --test-dir build -L large_input

/// Bytes of `path`'s lines written again and again into `out` until it holds `bytes`.
void repeat_file(const std::string& path, const std::string& out, std::size_t bytes) {
  const std::string text = numen::test::read_file(path);
  std::FILE* f = std::fopen(out.c_str(), "wb");
  ASSERT_NE(f, nullptr) << out;
  for (std::size_t n = 0; n < bytes; n += text.size()) std::fwrite(text.data(), 1, text.size(), f);
  std::fclose(f);
}

// A 500 MB candump log replayed for 2 s used to be loaded whole (~3.4 × the file resident,
// "out of memory" without naming the log under a 4 GB limit). It is streamed now: the peak RSS
// of the replay exceeds that of the same 2 s replayed from a 3 s log by less than 16 MiB
// (the bound: the reader's queue, ~460 KB, and its 128 KiB line buffer; margin for the heap).
TEST(LargeInput, LogReplayMemoryDoesNotGrowWithTheLog) {
  NUMEN_REQUIRE_ARTICULATION();
  NUMEN_SKIP_UNDER_SANITIZER_HEAP("its heap and shadow memory are not the program's (and reading "
                                  "500 MB under it takes minutes)");
  TempDir dir;
  const std::string base = (dir / "base.log").string();
  const ChildResult rec =
      run_child({kNumen, "run", kLattice, "--duration", "3", "--record", base}, dir.path(), 300);
  ASSERT_EQ(rec.status, 0) << rec.out << rec.err;
  // The recording, then 500 MB of another node's frames after it, 10 µs apart.
  const std::string big = (dir / "big.log").string();
  std::int64_t last_ns = 0;
  for (const numen::hal::CandumpRecord& r : numen::hal::load_candump_log(base))
    last_ns = std::max(last_ns, r.timestamp_ns);
  std::filesystem::copy_file(base, big);
  {
    std::FILE* f = std::fopen(big.c_str(), "ab");
    ASSERT_NE(f, nullptr);
    std::vector<char> chunk;
    std::int64_t t_us = last_ns / 1000;
    std::size_t bytes = std::filesystem::file_size(base);
    char line[64];
    while (bytes < 500'000'000) {
      chunk.clear();
      for (int i = 0; i < 100'000; ++i) {
        t_us += 10;
        const int n = std::snprintf(line, sizeof line, "(%010lld.%06lld) sim0 7FF#0102030405060708 R\n",
                                    static_cast<long long>(t_us / 1'000'000),
                                    static_cast<long long>(t_us % 1'000'000));
        chunk.insert(chunk.end(), line, line + n);
      }
      std::fwrite(chunk.data(), 1, chunk.size(), f);
      bytes += chunk.size();
    }
    std::fclose(f);
  }
  const ChildResult small =
      run_child({kNumen, "run", kLattice, "--duration", "2", "--bus", "log:" + base}, dir.path(), 300);
  const ChildResult large =
      run_child({kNumen, "run", kLattice, "--duration", "2", "--bus", "log:" + big}, dir.path(), 300);
  std::filesystem::remove(big);
  ASSERT_EQ(small.status, 0) << small.out << small.err;
  ASSERT_EQ(large.status, 0) << large.out << large.err;
  std::printf("[   info   ] replay of 2 s, peak RSS: %.1f MB log %ld KiB (%.1f s), 500 MB log "
              "%ld KiB (%.1f s)\n",
              static_cast<double>(std::filesystem::file_size(base)) / 1e6, small.max_rss_kib,
              small.wall_s, large.max_rss_kib, large.wall_s);
  EXPECT_LT(large.max_rss_kib - small.max_rss_kib, 16 * 1024);
}

// A ~200 MB JIGSAWS file used to be read whole into memory (407 MB resident). It is read a
// line at a time now: the run keeps the rows it takes (72 bytes each, the knots), never the
// file. Taking 30 s of it costs what the 30 s excerpt costs (< 16 MiB more); taking all of it
// (~165 000 rows, 1.5 h) costs less than 256 bytes per row more (the bound of docs/inputs.md).
TEST(LargeInput, TrajectoryMemoryDoesNotGrowWithTheFile) {
  NUMEN_REQUIRE_ARTICULATION();
  NUMEN_SKIP_UNDER_SANITIZER_HEAP("its quarantine keeps the loader's freed buffers resident: the "
                                  "peak RSS is not the program's");
  TempDir dir;
  const std::string excerpt = numen::sim::jigsaws_excerpt_path().string();
  const std::string big = (dir / "big.txt").string();
  repeat_file(excerpt, big, 200'000'000);
  const std::size_t rows = std::filesystem::file_size(big) /
                           std::filesystem::file_size(excerpt) * 900;
  const std::string big_line = "file = \"" + big + "\"";
  const std::string window = dir.write(
      "window.toml", lattice_scene_copy({{kExcerptLine, big_line + "\nend_time = 29.9"}}));
  const std::string whole = dir.write("whole.toml", lattice_scene_copy({{kExcerptLine, big_line}}));
  const ChildResult a = run_child({kNumen, "run", kLattice, "--duration", "2"}, dir.path(), 300);
  const ChildResult b = run_child({kNumen, "run", window, "--duration", "2"}, dir.path(), 300);
  const ChildResult c = run_child({kNumen, "run", whole, "--duration", "2"}, dir.path(), 300);
  std::filesystem::remove(big);
  ASSERT_EQ(a.status, 0) << a.out << a.err;
  ASSERT_EQ(b.status, 0) << b.out << b.err;
  ASSERT_EQ(c.status, 0) << c.out << c.err;
  std::printf("[   info   ] peak RSS: excerpt %ld KiB (%.1f s), 30 s of 200 MB %ld KiB (%.1f s), "
              "all %zu rows of 200 MB %ld KiB (%.1f s)\n",
              a.max_rss_kib, a.wall_s, b.max_rss_kib, b.wall_s, rows, c.max_rss_kib, c.wall_s);
  EXPECT_LT(b.max_rss_kib - a.max_rss_kib, 16 * 1024);
  EXPECT_LT(c.max_rss_kib - a.max_rss_kib, static_cast<long>(rows * 256 / 1024));
}

// A two-row trajectory (1/30 s: 33 periods) ends the run before the 50-period CANopen start-up:
// it said "no period had a valid sample"; it names the start-up that never finished and the
// periods the run had.
TEST(NumenCli, ARunShorterThanTheStartUpSaysSo) {
  NUMEN_REQUIRE_ARTICULATION();
  TempDir dir;
  const std::string excerpt = numen::test::read_file(
      (std::filesystem::path(numen::sim::default_scene_path()).parent_path() /
       "../data/jigsaws_suturing_b002_excerpt.txt")
          .string());
  const std::size_t second_end = excerpt.find('\n', excerpt.find('\n') + 1);
  const std::string rows = dir.write("two_rows.txt", excerpt.substr(0, second_end + 1));
  const std::string scene =
      dir.write("scene.toml", lattice_scene_copy({{kExcerptLine, "file = \"" + rows + "\""}}));
  const ChildResult r = run_child({kNumen, "run", scene, "--json"}, dir.path(), 60);
  ASSERT_EQ(r.status, 6) << r.out << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  ASSERT_EQ(j.at("exit_reasons").size(), 1u) << r.out;
  const std::string reason = j.at("exit_reasons")[0];
  EXPECT_EQ(reason.rfind("samples rejected: no period had a valid sample: the run's 33 periods "
                         "ended before the CANopen start-up finished (still in phase '",
                         0),
            0u)
      << reason;
}

// A misspelt subcommand is named with the known ones (CLI11 said "A subcommand is required").
TEST(NumenCli, UnknownSubcommandIsNamedWithTheKnownOnes) {
  TempDir dir;
  const ChildResult r = run_child({kNumen, "frobnicate"}, dir.path(), 30);
  EXPECT_EQ(r.status, 2) << r.out << r.err;
  EXPECT_EQ(r.err,
            "numen: unknown subcommand 'frobnicate' of numen; the subcommands are: run, device, "
            "info, figures, view, scan, sdo, igtl-replay, study\n");
  const ChildResult study = run_child({kNumen, "study", "frob", "--quick"}, dir.path(), 30);
  EXPECT_EQ(study.status, 2) << study.out << study.err;
  EXPECT_EQ(study.err,
            "numen: unknown subcommand 'frob' of numen study; the subcommands are: accuracy, "
            "stability, passivity, merge\n");
}

// A negative --overrun-limit got CLI11's bare "Could not convert": the message names the option
// and the range.
TEST(NumenCli, NegativeOverrunLimitNamesTheOptionAndTheRange) {
  TempDir dir;
  for (const char* v : {"-1", "4294967296", "2.5", "x"}) {
    const ChildResult r =
        run_child({kNumen, "run", kLattice, "--duration", "0.01", "--overrun-limit", v}, dir.path(), 30);
    EXPECT_EQ(r.status, 2) << v << ": " << r.out << r.err;
    EXPECT_NE(r.err.find("--overrun-limit: must be a whole number in [0, 4294967295], got '" +
                         std::string(v) + "'"),
              std::string::npos)
        << v << ": " << r.err;
  }
}

// `numen study ... --out FILE` computed the whole study, then failed on the path. The output
// directory is checked first (status 2, naming --out), and an existing file is left as it was.
TEST(NumenCli, StudyOutputThatIsAFileIsRefusedBeforeTheStudy) {
  TempDir dir;
  const std::string file = dir.write("hostname", "keep me\n");
  for (const char* study : {"accuracy", "stability", "passivity"}) {
    const ChildResult r = run_child({kNumen, "study", study, "--quick", "--out", file}, dir.path(), 30);
    EXPECT_EQ(r.status, 2) << study << ": " << r.out << r.err;
    EXPECT_NE(r.err.find("--out: " + file + " is not a directory"), std::string::npos) << r.err;
    EXPECT_EQ(numen::test::read_file(file), "keep me\n");
  }
  const ChildResult nested = run_child(
      {kNumen, "study", "accuracy", "--quick", "--out", file + "/sub"}, dir.path(), 30);
  EXPECT_EQ(nested.status, 2) << nested.out << nested.err;
  EXPECT_NE(nested.err.find("--out: " + file + "/sub: cannot create the directory"),
            std::string::npos)
      << nested.err;
}

// Defect 4: a refused command-line value is "input rejected" (2), not CLI11's own codes.
TEST(NumenCli, RefusedOptionValueExitsWithInputRejected) {
  TempDir dir;
  const ChildResult r = run_child({kNumen, "run", kLattice, "--duration", "abc"}, dir.path(), 30);
  EXPECT_EQ(r.status, 2) << r.out << r.err;
  const ChildResult help = run_child({kNumen, "run", "--help"}, dir.path(), 30);
  EXPECT_EQ(help.status, 0) << help.err;
}

// Defect 4: a replayed bus log that holds no frame of the scene's encoders replayed nothing and
// exited 0; it is now refused before the run (input rejected), naming the file and the ids.
TEST(NumenCli, ReplayOfALogWithoutEncoderFramesIsInputRejected) {
  NUMEN_REQUIRE_ARTICULATION();
  TempDir dir;
  const std::string log = dir.write("other.log", "(0.000100) vcan0 7FF#0102\n(0.000200) vcan0 7FF#0304\n");
  const ChildResult r =
      run_child({kNumen, "run", kLattice, "--duration", "0.2", "--bus", "log:" + log}, dir.path(), 60);
  EXPECT_EQ(r.status, 2) << r.out << r.err;
  EXPECT_NE(r.err.find(log + ": 2 records, none that the controller reads"), std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("0x181"), std::string::npos) << r.err;
}

// ... and a log that is not a candump log at all is refused at its first bad line.
TEST(NumenCli, ReplayOfGarbageIsALocatedInputError) {
  NUMEN_REQUIRE_ARTICULATION();  // the lattice scene has joints
  TempDir dir;
  const std::string log = dir.write("garbage.log", "(0.000100) vcan0 181#00000000\nhello\n");
  const ChildResult r =
      run_child({kNumen, "run", kLattice, "--duration", "0.2", "--bus", "log:" + log}, dir.path(), 60);
  EXPECT_EQ(r.status, 2) << r.out << r.err;
  EXPECT_EQ(r.err.rfind("numen: " + log + ":2:1: ", 0), 0u) << r.err;
}

// `numen sdo` and `numen scan`: bad nodes, addresses, types and values are refused (input
// rejected) with their message before any bus is opened (the port named here does not exist).
TEST(NumenCli, BadSdoArgumentsAreInputRejectedBeforeTheBusIsOpened) {
  // A bus spec this build accepts (a short name: IFNAMSIZ) whose port does not exist.
  if (!numen::hal::kWithSocketCan && !numen::hal::kWithSerial)
    GTEST_SKIP() << "this build has neither SocketCAN nor the serial backend";
  TempDir dir;
  const std::string bus = numen::hal::kWithSocketCan ? "can:nosuchif0" : "serial:/nonexistent/tty";
  struct Case {
    std::vector<std::string> args;
    std::string message;  // what stderr must say
  };
  const std::vector<Case> cases = {
      {{kNumen, "sdo", "--bus", bus, "0", "read", "1000:00"}, "node"},
      {{kNumen, "sdo", "--bus", bus, "128", "read", "1000:00"}, "node"},
      {{kNumen, "sdo", "--bus", bus, "1", "peek", "1000:00"}, "action"},
      {{kNumen, "sdo", "--bus", bus, "1", "read", "1000"}, "'1000' is not INDEX:SUB in hexadecimal"},
      {{kNumen, "sdo", "--bus", bus, "1", "read", "10000:00"}, "'10000:00' is not INDEX:SUB"},
      {{kNumen, "sdo", "--bus", bus, "1", "write", "1017:00", "10"}, "a write needs the value's --type"},
      {{kNumen, "sdo", "--bus", bus, "1", "write", "1017:00", "70000", "--type", "u16"},
       "'70000' does not fit u16 [0, 65535]"},
      {{kNumen, "sdo", "--bus", bus, "1", "write", "1017:00", "-1", "--type", "u8"},
       "'-1' does not fit u8 [0, 255]"},
      {{kNumen, "sdo", "--bus", bus, "1", "write", "1017:00", "abc", "--type", "hex"},
       "'abc' is not an even number of hex digits"},
      {{kNumen, "sdo", "--bus", bus, "1", "read", "1000:00", "5"}, "a read takes no value"},
      {{kNumen, "sdo", "--bus", "sim", "1", "read", "1000:00"}, "expected can:IFACE or serial:PATH"},
      {{kNumen, "scan", "--bus", "sim"}, "expected can:IFACE or serial:PATH"},
      {{kNumen, "scan", "--bus", bus, "--listen", "0"}, "--listen"},
  };
  for (const Case& c : cases) {
    const ChildResult r = run_child(c.args, dir.path(), 30);
    std::string line;
    for (const auto& a : c.args) line += a + " ";
    EXPECT_EQ(r.status, 2) << line << ": " << r.err;
    EXPECT_NE(r.err.find(c.message), std::string::npos) << line << ": " << r.err;
  }
}

// `numen run --view` takes [HOST:]PORT only: each refusal is exit 2 with its message.
TEST(NumenCli, ViewAddressThatIsNotHostPortIsInputRejected) {
  TempDir dir;
  const std::string shape =
      "--view: expected [HOST:]PORT (HOST an IPv4 address, localhost or an IPv6 address in "
      "brackets such as [::1]; PORT in 0-65535), got '";
  const std::string host =
      "--view: HOST must be an IP address or localhost (names are not resolved), got '";
  const std::string brackets =
      "--view: the HOST in brackets must be an IPv6 address (names are not resolved), got '";
  const std::pair<const char*, std::string> cases[] = {
      {"http://x", shape},        {"8080x", shape},
      {"host:", shape},           {":8080", shape},
      {"99999", shape},           {"[::1]", shape},
      {"[::1]8080", shape},       {"[::1:8080", shape},
      {"notahost:8080", host},    {"[127.0.0.1]:80", brackets},
      {"[notahost]:80", brackets}};
  for (const auto& [v, message] : cases) {
    const ChildResult r = run_child({kNumen, "run", kLattice, "--duration", "0.01", "--view", v}, dir.path(), 30);
    EXPECT_EQ(r.status, 2) << v << ": " << r.err;
    EXPECT_EQ(r.err.substr(0, r.err.find('\n')), message + v + "'") << r.err;
  }
  // `numen view --host`: a name is not resolved; refused before the file is read or served.
  const ChildResult r =
      run_child({kNumen, "view", "any.nmv", "--host", "notahost", "--port", "0"}, dir.path(), 30);
  EXPECT_EQ(r.status, 2) << r.out << r.err;
  EXPECT_NE(r.err.find("--host"), std::string::npos) << r.err;
  EXPECT_EQ(r.out.find("open http://"), std::string::npos) << r.out;
}

/// True if a TCP socket can be bound to [::1]:0 here.
bool ipv6_loopback_bindable() {
  const int fd = ::socket(AF_INET6, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return false;
  sockaddr_in6 a{};
  a.sin6_family = AF_INET6;
  a.sin6_addr = in6addr_loopback;
  const bool ok = ::bind(fd, reinterpret_cast<const sockaddr*>(&a), sizeof a) == 0;
  ::close(fd);
  return ok;
}

// `--view '[::1]:0'` (an IPv6 address in brackets, as the URL prints it) was refused while
// `::1:0` was taken: both listen on ::1 and print the URL with the brackets.
TEST(NumenCli, ViewOnABracketedIPv6AddressPrintsItsUrl) {
  NUMEN_REQUIRE_ARTICULATION();
  if (!ipv6_loopback_bindable()) GTEST_SKIP() << "this machine cannot bind ::1 (no IPv6 loopback)";
  TempDir dir;
  for (const char* v : {"[::1]:0", "::1:0"}) {
    const ChildResult r =
        run_child({kNumen, "run", kLattice, "--duration", "0.3", "--view", v}, dir.path(), 60);
    EXPECT_EQ(r.status, 0) << v << ": " << r.err;
    EXPECT_EQ(r.err.rfind("numen: viewer on http://[::1]:", 0), 0u) << v << ": " << r.err;
  }
}

// `numen view` closes the HTTP connections past its 64 that wait longest for their request, and
// says how many when it ends: 70 idle connections from 127.0.0.1 close the first 6.
TEST(NumenCli, ViewSaysHowManyConnectionsItShed) {
  NUMEN_REQUIRE_ARTICULATION();
  TempDir dir;
  const std::string file = (dir.path() / "run.nmv").string();
  const ChildResult recorded = run_child(
      {kNumen, "run", kLattice, "--duration", "0.1", "--record-view", file}, dir.path(), 120);
  ASSERT_EQ(recorded.status, 0) << recorded.err;
  std::vector<int> idle;
  bool first_six_closed = false;
  ChildSignal interrupt;
  interrupt.signal = SIGINT;
  interrupt.ready = [&] {
    const std::string out = numen::test::read_file((dir.path() / "child.out").string());
    const std::string url = "open http://127.0.0.1:";
    const auto at = out.find(url);
    if (at == std::string::npos) return false;
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(static_cast<std::uint16_t>(std::stoi(out.substr(at + url.size()))));
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    for (int i = 0; i < 70; ++i) {
      idle.push_back(::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0));
      if (::connect(idle.back(), reinterpret_cast<const sockaddr*>(&a), sizeof a) != 0) return true;
    }
    // The first 6 see the server's close (bounded: 20 s each): the 70th has been accepted.
    first_six_closed = true;
    for (int i = 0; i < 6; ++i) {
      pollfd p{idle[static_cast<std::size_t>(i)], POLLIN, 0};
      char c = 0;
      first_six_closed =
          first_six_closed && ::poll(&p, 1, 20000) == 1 && ::recv(p.fd, &c, 1, MSG_DONTWAIT) == 0;
    }
    return true;
  };
  const ChildResult r =
      run_child({kNumen, "view", file, "--port", "0"}, dir.path(), 120, interrupt);
  for (const int fd : idle) ::close(fd);
  EXPECT_TRUE(first_six_closed);
  EXPECT_EQ(r.status, 0) << r.out << r.err;
  const std::string last = r.out.substr(r.out.rfind("numen view: "));
  EXPECT_EQ(last,
            "numen view: 0 viewers, 0 frames served, 0 connections closed for bad input, 6 HTTP "
            "connections shed (more than 64 open)\n")
      << r.out;
}

// --wait-for-viewer: without a page the run does not start, says so and exits 1.
TEST(NumenCli, WaitForViewerWithoutAPageEndsBeforeTheRun) {
  NUMEN_REQUIRE_ARTICULATION();
  TempDir dir;
  const ChildResult r = run_child(
      {kNumen, "run", kLattice, "--duration", "0.05", "--view", "0", "--wait-for-viewer=0.3"}, dir.path(), 60);
  EXPECT_EQ(r.status, 1) << r.out << r.err;
  EXPECT_NE(r.err.find("within 0.3 s (--wait-for-viewer): the run did not start"), std::string::npos) << r.err;
  EXPECT_EQ(r.out.find("steps"), std::string::npos) << "no summary: " << r.out;
}

// A view rate above the control rate publishes every period: said on stderr, and the
// recording's scene message carries the rate it got (1/dt), not the one asked.
TEST(NumenCli, ViewRateAboveTheControlRateIsSaidAndRecordedAsTheControlRate) {
  NUMEN_REQUIRE_ARTICULATION();
  TempDir dir;
  const std::string file = (dir.path() / "run.nmv").string();
  const ChildResult r = run_child({kNumen, "run", kLattice, "--duration", "0.05", "--record-view", file,
                                   "--view-rate", "5000"},
                                  dir.path(), 120);
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  EXPECT_NE(r.err.find("--view-rate 5000 is above the device rate (1000 Hz): the stream sends "
                       "every period"),
            std::string::npos)
      << r.err;
  const numen::sim::ViewRecordingReader recording(file);
  EXPECT_EQ(recording.size(), 50u);
  const auto message = nlohmann::json::parse(recording.scene_message());
  EXPECT_DOUBLE_EQ(message["display_rate_hz"].get<double>(), 1000.0);
}

// `numen view` of a file that is not a view recording is input rejected, naming the file, and
// nothing is served.
TEST(NumenCli, ViewOfAFileThatIsNotARecordingIsInputRejected) {
  TempDir dir;
  const std::string file = dir.write("garbage.nmv", "hello, not a recording\n");
  const ChildResult r = run_child({kNumen, "view", file, "--port", "0"}, dir.path(), 30);
  EXPECT_EQ(r.status, 2) << r.out << r.err;
  EXPECT_NE(r.err.find(file), std::string::npos) << r.err;
  EXPECT_EQ(r.out.find("open http://"), std::string::npos) << r.out;
}

// `numen view DIR` said "not a numen view recording": it says it is a directory.
TEST(NumenCli, ViewOfADirectorySaysItIsADirectory) {
  TempDir dir;
  const std::string folder = dir.path().string();
  const ChildResult r = run_child({kNumen, "view", folder, "--port", "0"}, folder, 30);
  EXPECT_EQ(r.status, 2) << r.out << r.err;
  EXPECT_EQ(r.err, "numen: " + folder + ": is a directory, not a numen view recording\n");
  EXPECT_EQ(r.out.find("open http://"), std::string::npos) << r.out;
}

// `numen view` of a recording whose scene message has a known member of the wrong JSON type is
// input rejected (exit 2) naming the file and the key; it printed the json library's
// "[json.exception.type_error.302] ..." with no place and exited 1.
TEST(NumenCli, ViewOfARecordingWithAMemberOfTheWrongTypeNamesTheFileAndTheKey) {
  TempDir dir;
  for (const auto& [scene, key] : std::vector<std::pair<std::string, std::string>>{
           {R"({"format": {}, "version": 1, "layout": {"bodies": 1, "nodes": 0, "axes": 0}})",
            "format"},
           {R"({"format": "numen-view", "version": "1", "layout": {}})", "version"}}) {
    std::string bytes(numen::sim::kViewRecordingMagic, 8);
    for (int i = 0; i < 4; ++i) bytes += static_cast<char>((scene.size() >> (8 * i)) & 0xFF);
    const std::string file = dir.write("typed.nmv", bytes + scene);
    const ChildResult r = run_child({kNumen, "view", file, "--port", "0"}, dir.path(), 30);
    EXPECT_EQ(r.status, 2) << r.out << r.err;
    EXPECT_NE(r.err.find(file + ": " + key + ": byte 12: "), std::string::npos) << r.err;
    EXPECT_EQ(r.err.find("json.exception"), std::string::npos) << r.err;
    EXPECT_EQ(r.out.find("open http://"), std::string::npos) << r.out;
  }
}

// `numen view` of a recording whose scene message is 200 000 nested arrays is input rejected at
// the bracket that opens level 65 (byte 12 + 64); it crashed (SIGSEGV, status 139): the message
// quoting the array dumped it whole, recursively.
TEST(NumenCli, ViewOfARecordingNestedTooDeepIsInputRejected) {
  TempDir dir;
  const std::string scene = std::string(200000, '[') + std::string(200000, ']');
  std::string bytes(numen::sim::kViewRecordingMagic, 8);
  for (int i = 0; i < 4; ++i) bytes += static_cast<char>((scene.size() >> (8 * i)) & 0xFF);
  const std::string file = dir.write("deep.nmv", bytes + scene);
  const ChildResult r = run_child({kNumen, "view", file, "--port", "0"}, dir.path(), 30);
  EXPECT_EQ(r.status, 2) << r.out << r.err;
  EXPECT_EQ(r.err, "numen: " + file +
                       ": byte 76: the scene message is not a numen-view JSON object (arrays and "
                       "objects nested more than 64 deep)\n");
  EXPECT_EQ(r.out.find("open http://"), std::string::npos) << r.out;
}

// Options a run would not apply, or values that do not fit them, are input rejected before
// the run, naming the option (2026-11-25 audit): `--prefault-stack -1` wrapped to SIZE_MAX
// and crashed (SIGSEGV in alloca); the others ran and dropped the option without a word.
TEST(NumenCli, OptionsARunWouldNotApplyAreInputRejected) {
  NUMEN_REQUIRE_ARTICULATION();  // the lattice scene has joints
  TempDir dir;
  const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
      {{"--prefault-stack", "-1"}, "--prefault-stack"},
      {{"--prefault-stack", "18446744073709551615"}, "--prefault-stack"},
      {{"--cpu", "5000"}, "--cpu"},
      {{"--scene-cpu", "-1"}, "--scene-cpu"},
      {{"--duration", "0.0004"}, "--duration"},       // under half a period: no period
      {{"--realtime", "--speed", "2"}, "--speed"},    // paced already
      {{"--realtime", "--scene-cpu", "0"}, "--scene-cpu"},  // no [multirate]: no scene thread
      {{"--record", (dir / "no_dir" / "x.log").string()}, "--record"},
      {{"--view-rate", "30"}, "--view-rate"},  // no stream to set the rate of
      {{"--igtl-organ-rate", "5"}, "--igtl-organ-rate"},  // no OpenIGTLink world (--igtl)
      {{"--igtl-names", "plus"}, "--igtl-names"},  // no OpenIGTLink world to name
      {{"--igtl-names", "slicer"}, "--igtl-names"},  // not a style
      {{"--wait-for-viewer"}, "--wait-for-viewer"},  // no viewer to wait for
      {{"--rt-strict"}, "--rt-strict"},        // no real-time step to make fatal
      {{"--timer-slack", "1"}, "--timer-slack"},  // an offline run has no deadlines
      {{"--spin", "100"}, "--spin"},              // ... and no wait to spin
      {{"--realtime", "--spin", "100"}, "--spin"},  // a spin needs a CPU of its own (--cpu)
      {{"--realtime", "--cpu", "0", "--spin", "1000"}, "--spin"},  // not below dt = 1 ms
      {{"--realtime", "--scene-spin", "100"}, "--scene-spin"},  // no [multirate]: no scene thread
  };
  expect_lattice_run_refused(dir, cases);
  // `numen view --page` names a folder holding the page.
  const std::string rec = (dir / "run.nmv").string();
  ASSERT_EQ(run_child({kNumen, "run", kLattice, "--duration", "0.05", "--record-view", rec}, dir.path(), 30).status, 0);
  const ChildResult v =
      run_child({kNumen, "view", rec, "--port", "0", "--page", (dir / "nowhere").string()}, dir.path(), 30);
  EXPECT_EQ(v.status, 2) << v.out << v.err;
  EXPECT_NE(v.err.find("--page"), std::string::npos) << v.err;
  EXPECT_EQ(v.out.find("open http://"), std::string::npos) << v.out;
}

// Issue 66: bounds a run had not. `--timer-slack 1000000000` was accepted (a paced run woke 60
// times in 60 s), `--speed 1e-9` too (the 0.05 s run would take 5e7 s), `--rt-priority 80`
// without --realtime set SCHED_FIFO on an offline loop that never sleeps, and `--bus
// igtl:127.0.0.1:19098:5` failed only at run time. Each is refused before the run, naming it.
TEST(NumenCli, Issue66BoundsAreInputRejectedNamingTheOption) {
  NUMEN_REQUIRE_ARTICULATION();  // the lattice scene has joints
  TempDir dir;
  const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
      {{"--realtime", "--timer-slack", "1000000000"},
       "--timer-slack: 1000000000 ns must be at most the period dt = 1000000 ns"},
      {{"--speed", "1e-9"}, "--speed: 1e-09 paces the 0.05 s run to 5e+07 s of wall time"},
      {{"--rt-priority", "80"},
       "--rt-priority: gives a paced run's loop thread SCHED_FIFO; this "
       "run is offline"},
      {{"--bus", "igtl:127.0.0.1:19098:5"}, "host '127.0.0.1:19098' is not an IPv6 address"},
  };
  expect_lattice_run_refused(dir, cases);
  // At the bound, accepted (the 2-period run may end before a valid sample: status 6, not 2).
  const ChildResult ok = run_child({kNumen, "run", kLattice, "--duration", "0.002", "--realtime",
                                    "--overrun-limit", "0", "--timer-slack", "1000000"},
                                   dir.path(), 30);
  EXPECT_NE(ok.status, 2) << ok.out << ok.err;
  EXPECT_EQ(ok.err.find("--timer-slack"), std::string::npos) << ok.err;
}

// Issue 66: a paced run took page faults in its first periods unless asked not to
// (--lock-memory, --prefault-stack were off by default; cyclictest -m locks its memory). A paced
// run now locks memory, prefaults 256 KiB of the loop thread's stack and holds a 0 us CPU
// latency request unless told otherwise (--no-lock-memory, --prefault-stack N,
// --no-cpu-dma-latency); the setup lines say what was asked (applied, or FAILED without the
// privilege). An offline run does none of it and refuses the options that would only change it.
TEST(NumenCli, APacedRunLocksMemoryPrefaultsItsStackAndHoldsTheCpuLatency) {
  NUMEN_REQUIRE_ARTICULATION();
  TempDir dir;
  auto setup = [&](const std::vector<std::string>& extra) {
    // 0.1 s: past the managed start-up (50 periods), a clean run
    std::vector<std::string> args = {kNumen, "run", kLattice, "--duration", "0.1", "--json"};
    args.insert(args.end(), extra.begin(), extra.end());
    const ChildResult r = run_child(args, dir.path(), 60);
    EXPECT_EQ(r.status, 0) << r.out << r.err;
    std::vector<std::string> lines;
    if (r.status == 0)
      lines = nlohmann::json::parse(r.out).at("realtime_setup").get<std::vector<std::string>>();
    return lines;
  };
  // The line of `step` ("memory lock"), or "" if there is none.
  auto line = [](const std::vector<std::string>& lines, const std::string& step) {
    for (const std::string& l : lines)
      if (l.rfind(step + ": ", 0) == 0) return l;
    return std::string();
  };
  const std::vector<std::string> paced = setup({"--realtime", "--overrun-limit", "0"});
  EXPECT_EQ(line(paced, "memory lock").find("memory lock: not requested"), std::string::npos)
      << line(paced, "memory lock");
  EXPECT_NE(line(paced, "memory lock").find("mlockall(MCL_CURRENT|MCL_FUTURE)"), std::string::npos);
  EXPECT_EQ(line(paced, "stack prefault").rfind("stack prefault: applied: 262144 bytes touched", 0),
            0u)
      << line(paced, "stack prefault");
  EXPECT_NE(line(paced, "cpu latency"), "");
  const std::vector<std::string> left =
      setup({"--realtime", "--overrun-limit", "0", "--no-lock-memory", "--prefault-stack", "0",
             "--no-cpu-dma-latency"});
  EXPECT_EQ(line(left, "memory lock"), "memory lock: not requested");
  EXPECT_EQ(line(left, "stack prefault"), "stack prefault: not requested");
  EXPECT_EQ(line(left, "cpu latency"), "");
  EXPECT_TRUE(setup({}).empty());  // offline: nothing asked, nothing reported
  for (const std::vector<std::string>& extra : {std::vector<std::string>{"--no-lock-memory"},
                                                {"--no-cpu-dma-latency"},
                                                {"--cpu-dma-latency", "10"}}) {
    const std::string& key = extra.front();
    std::vector<std::string> args = {kNumen, "run", kLattice, "--duration", "0.01"};
    args.insert(args.end(), extra.begin(), extra.end());
    const ChildResult r = run_child(args, dir.path(), 30);
    EXPECT_EQ(r.status, 2) << key << ": " << r.out << r.err;
    EXPECT_NE(r.err.find(key + ": "), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("this run is offline"), std::string::npos) << r.err;
  }
  const ChildResult both = run_child({kNumen, "run", kLattice, "--duration", "0.01", "--realtime",
                                      "--lock-memory", "--no-lock-memory"},
                                     dir.path(), 30);
  EXPECT_EQ(both.status, 2) << both.out << both.err;
}

// The defects issue: the load's warnings were printed only in the summary, at the end of the run
// (a 30-minute paced run's user saw them after it). They are on stderr when the scene has loaded,
// before the run's summary (here on stderr too: --json), and still in the summary.
TEST(NumenCli, LoadWarningsArePrintedWhenTheSceneLoadsAndKeptInTheSummary) {
  NUMEN_REQUIRE_ARTICULATION();
  TempDir dir;
  const std::string scene = dir.write(
      "stiff.toml", lattice_scene_copy({{"stiffness = 2.0e4     # N/m per sphere contact",
                                         "stiffness = 1.0e9"}}));
  const ChildResult r = run_child({kNumen, "run", scene, "--duration", "0.01", "--json"}, dir.path(), 60);
  const std::size_t at_load = r.err.find("numen: warning: ");
  const std::size_t summary = r.err.find("scene lattice");
  ASSERT_NE(at_load, std::string::npos) << r.err;
  ASSERT_NE(summary, std::string::npos) << r.err;
  EXPECT_LT(at_load, summary) << r.err;
  EXPECT_NE(r.err.find("contact_max_omega_dt", at_load), std::string::npos) << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  ASSERT_FALSE(j.at("warnings").empty());
  EXPECT_NE(j.at("warnings").at(0).get<std::string>().find("contact_max_omega_dt"), std::string::npos);
}

// `numen info` prints the scene's step timed at load against its period (docs/realtime.md,
// "Before a paced run").
TEST(NumenCli, InfoPrintsTheStepTimedAtLoad) {
  NUMEN_REQUIRE_ARTICULATION();
  TempDir dir;
  const ChildResult r = run_child({kNumen, "info", kLattice}, dir.path(), 60);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("step at load: median "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("steps, against the 1000 us period ("), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("\n  load: "), std::string::npos) << r.out;  // the load's wall clock
  // --json carries the same figures.
  const ChildResult j = run_child({kNumen, "info", kLattice, "--json"}, dir.path(), 60);
  ASSERT_EQ(j.status, 0) << j.err;
  const nlohmann::json info = nlohmann::json::parse(j.out);
  const nlohmann::json& step = info.at("step_at_load");
  EXPECT_EQ(step.at("steps").get<int>(), 20);
  EXPECT_GT(step.at("median_us").get<double>(), 0.0);
  EXPECT_GE(step.at("max_us").get<double>(), step.at("median_us").get<double>());
  EXPECT_EQ(step.at("period_s").get<double>(), 0.001);
  EXPECT_FALSE(step.at("multirate").get<bool>());
  EXPECT_TRUE(info.contains("stages")) << "the rest of the info is kept";
  EXPECT_GT(info.at("load").at("wall_s").get<double>(), 0.0);
  EXPECT_EQ(info.at("load").at("nets_simplified").get<int>(), 0);
}

// An organ from a fine mesh file: numen info says its net was simplified (from how many vertices
// and triangles, to how many nodes), the fine surface on it and how far it stands off the net.
TEST(NumenCli, InfoPrintsTheFineSurfaceOfASimplifiedOrgan) {
  NUMEN_REQUIRE_DEFORMABLE();
  TempDir dir;
  dir.write("fine.obj", numen::test::fine_ellipsoid_obj(4));
  const std::string scene =
      dir.write("organ.toml", numen::test::with_organ_mesh_file("fine.obj", "nodes = 500"));
  const ChildResult r = run_child({kNumen, "info", scene}, dir.path(), 60);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("  mesh net organ: 996 triangles, 500 nodes, "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("    simplified from its mesh file (2562 vertices, 5120 triangles) to 500 "
                       "nodes (nodes) in "),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("fine surface 2562 vertices, 5120 triangles, up to "), std::string::npos)
      << r.out;
  const ChildResult j = run_child({kNumen, "info", scene, "--json"}, dir.path(), 60);
  ASSERT_EQ(j.status, 0) << j.err;
  const nlohmann::json load = nlohmann::json::parse(j.out).at("meshes").at(0).at("net_load");
  EXPECT_TRUE(load.at("simplified").get<bool>());
  EXPECT_EQ(load.at("fine_vertices").get<int>(), 2562);
  EXPECT_GT(load.at("fine_max_distance_m").get<double>(), 0.0);
}

// Defect 1: --trace of a simulated run keeps one record per period; a run whose trace would
// outgrow the budget (kMaxInMemoryTraceBytes) is refused before anything is allocated.
TEST(NumenCli, TraceThatWouldOutgrowItsBudgetIsRefusedBeforeTheRun) {
  NUMEN_REQUIRE_ARTICULATION();  // the lattice scene has joints
  TempDir dir;
  const ChildResult r = run_child(
      {kNumen, "run", kLattice, "--duration", "1e6", "--trace", (dir / "t.csv").string()}, dir.path(), 60);
  EXPECT_EQ(r.status, 2) << r.out << r.err;
  EXPECT_NE(r.err.find("--trace: a simulated run keeps one trace record"), std::string::npos)
      << r.err;
  // The trace would take hundreds of GB: a refused run stays at the process's own footprint, 100 MiB
  // (the sanitizers' shadow memory and allocator add ~100 MiB to it: 400 MiB there).
  const long limit_kib = numen::test::under_sanitizer() ? 400 * 1024 : 100 * 1024;
  EXPECT_LT(r.max_rss_kib, limit_kib);
}

// Defect 6: out of memory printed "std::bad_alloc"; it now says what ran out (status 1). The
// process gets 400 MB of address space and a trace of ~1.7 million periods (~730 MB, within
// the trace budget) to reserve.
TEST(NumenCli, OutOfMemoryIsNamed) {
  NUMEN_SKIP_UNDER_SANITIZER_HEAP("the sanitizer reserves terabytes of address space: ulimit -v stops it first");
  NUMEN_REQUIRE_ARTICULATION();
  TempDir dir;
  const std::string cmd = "ulimit -v 400000; exec " + kNumen + " run " + kLattice + " --duration 1700 --trace " +
                          (dir / "t.csv").string();
  const ChildResult r = run_child({"/bin/sh", "-c", cmd}, dir.path(), 60);
  EXPECT_EQ(r.status, 1) << r.out << r.err;
  EXPECT_NE(r.err.find("numen: out of memory"), std::string::npos) << r.err;
}

// Defects 1 and 3 of the mesh reader, end to end: a PLY whose header says 2 vertices over a body
// of 4 vertices and 4 faces aborted numen inside Assimp (SIGABRT, status 134); a glTF whose
// buffer is ../../../../../../etc/passwd loaded that file's bytes as vertices and exited 0. Both
// are now input rejected (2), the located message the whole of stderr.
TEST(NumenCli, MeshFilesThatCrashedOrLeakedAreInputRejected) {
  TempDir dir;
  const std::string crash = dir.write("crash.ply", numen::test::ascii_ply("2", "4"));
  const std::string leak =
      dir.write("leak.gltf", numen::test::tet_gltf("../../../../../../etc/passwd"));
  for (const auto& [mesh, message] :
       {std::pair<std::string, std::string>{
            crash,
            "the PLY header's elements take 6 lines (vertex 2, face 4), "
            "the body after end_header has 8"},
        {leak,
         "buffers[0].uri \"../../../../../../etc/passwd\" has a \"..\" segment: a glTF's buffers "
         "and images are read only from data: URIs and relative paths inside the mesh file's "
         "folder"}}) {
    const std::string name = std::filesystem::path(mesh).filename().string();
    const std::string text = numen::test::with_mesh_obstacle("file = \"" + name + "\"\n");
    const std::string scene = dir.write(name + ".toml", text);
    const ChildResult r = run_child({kNumen, "run", scene}, dir.path(), 60);
    EXPECT_EQ(r.status, 2) << name << ": " << r.out << r.err;
    EXPECT_EQ(r.err, "numen: " + scene + ":" + std::to_string(numen::test::line_of(text, name)) +
                         ":8: obstacle[0].file: " + mesh + ": " + message + "\n");
  }
}

// Defect 5: out of memory while Assimp read a mesh was reported as the mesh file's fault
// ("…: cannot read the mesh file (Assimp: std::bad_alloc)", status 2). It is now numen's out of
// memory (status 1). The process gets 120 MB of address space (numen itself maps ~30 MB): the
// scene with the tetrahedron as a PLY loads under it, the same scene with a PLY of 3 million faces
// (24 MB; Assimp's parse takes ~64 bytes a face) does not.
TEST(NumenCli, OutOfMemoryWhileReadingAMeshIsNamed) {
  NUMEN_SKIP_UNDER_SANITIZER_HEAP(
      "the sanitizer reserves terabytes of address space: ulimit -v stops it first");
  TempDir dir;
  dir.write("tet.ply", numen::test::ascii_ply("4", "4"));
  {
    std::string faces;
    for (int i = 0; i < 100000; ++i) faces += "3 0 2 1\n";
    std::ofstream big(dir / "big.ply", std::ios::binary);
    big << numen::test::ascii_ply("4", "3000000", "0 0 0\n1 0 0\n0 1 0\n0 0 1\n");
    for (int i = 0; i < 30; ++i) big << faces;
  }
  const auto run_under_limit = [&](const std::string& mesh) {
    const std::string scene =
        dir.write(mesh + ".toml", numen::test::with_mesh_obstacle("file = \"" + mesh + "\"\n"));
    return run_child({"/bin/sh", "-c", "ulimit -v 120000; exec " + kNumen + " info " + scene},
                     dir.path(), 120);
  };
  const ChildResult small = run_under_limit("tet.ply");
  ASSERT_EQ(small.status, 0) << "the limit is too low for numen itself: " << small.out << small.err;
  const ChildResult r = run_under_limit("big.ply");
  EXPECT_EQ(r.status, 1) << r.out << r.err;
  EXPECT_EQ(
      r.err,
      "numen: out of memory (the scene, its trajectory or a log is too large for this machine)\n");
}

}  // namespace

// `numen --version` prints the project's version (numen/version.hpp, semantic versioning)
// and exits 0 without a subcommand.
TEST(NumenCli, VersionFlagPrintsTheProjectVersion) {
  TempDir dir;
  const ChildResult r = run_child({kNumen, "--version"}, dir.path(), 30);
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  EXPECT_EQ(r.out, "numen 0.1.0\n");
  EXPECT_EQ(r.out, std::string("numen ") + NUMEN_VERSION + "\n");
}

// An installed numen (<prefix>/bin/numen) finds the shipped default scene in
// <prefix>/share/numen relative to itself, not in the source tree it was built from
// (sim/input/shipped_files.hpp; the Debian package and `cmake --install` rely on it).
TEST(NumenCli, InstalledExecutableFindsTheDefaultSceneRelativeToItself) {
  NUMEN_REQUIRE_ARTICULATION();
  NUMEN_REQUIRE_DEFORMABLE();  // the default scene's organ
  TempDir dir;
  namespace fs = std::filesystem;
  const fs::path prefix = dir / "prefix";
  const fs::path source_scenes = fs::path(numen::sim::default_scene_path()).parent_path();
  fs::create_directories(prefix / "bin");
  fs::create_directories(prefix / "share/numen/scenes");
  fs::create_directories(prefix / "share/numen/data");
  fs::copy_file(kNumen, prefix / "bin/numen");
  fs::copy_file(source_scenes / "default.toml", prefix / "share/numen/scenes/default.toml");
  fs::copy(source_scenes / "devices", prefix / "share/numen/scenes/devices");  // its node DCFs
  fs::copy_file(source_scenes / "../data/jigsaws_suturing_b002_excerpt.txt",
                prefix / "share/numen/data/jigsaws_suturing_b002_excerpt.txt");
  fs::copy_file(source_scenes / "../data/organ_lobe.obj", prefix / "share/numen/data/organ_lobe.obj");
  const ChildResult r = run_child({(prefix / "bin/numen").string(), "info", "--json"}, dir.path(), 60);
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  const std::string expected = (prefix / "share/numen/scenes/default.toml").string();
  EXPECT_NE(r.out.find("\"file\":\"" + expected + "\""), std::string::npos) << r.out.substr(0, 300);
}

// Issue 56: what a user's scene leaves out is said, not silent. A device with motors but no
// [device.feedback] (the lattice scene without its table) warns on stderr and in the summary;
// a scene made to be stepped by its caller (the shipped probe.toml: no trajectory) is refused by
// `numen run` with the located error that says so.
TEST(NumenCli, RunSaysWhatTheSceneLeavesOut) {
  NUMEN_REQUIRE_ARTICULATION();
  TempDir dir;
  std::string text = lattice_scene_copy({});
  const auto from = text.find("[device.feedback]");
  ASSERT_NE(from, std::string::npos);
  text.erase(from, text.find("max_torque = 0.3", from) - from);
  text = numen::test::replace(text, "max_torque = 0.3 ", "# max_torque = 0.3 ");
  const std::string scene = dir.write("nofeedback.toml", text);
  const ChildResult r = run_child({kNumen, "run", scene, "--duration", "0.05"}, dir.path(), 120);
  EXPECT_EQ(r.status, 0) << r.err;
  const std::string warning =
      "no feedback: device \"laparoscopic_trainer\" has motors (drives on pivot_x, pivot_y, depth) "
      "but no [device.feedback]: feedback_wrench stays 0 and the drives are sent no torque";
  EXPECT_NE(r.err.find("numen: warning: " + warning), std::string::npos) << r.err;
  EXPECT_NE(r.out.find("  warning: " + warning), std::string::npos) << r.out;

  const std::string probe =
      (std::filesystem::path(numen::sim::default_scene_path()).parent_path() / "probe.toml").string();
  const ChildResult p = run_child({kNumen, "run", probe}, dir.path(), 30);
  EXPECT_EQ(p.status, 2);
  EXPECT_NE(p.err.find(probe + ":1:1: trajectory: missing: `numen run` needs a [trajectory]"),
            std::string::npos) << p.err;
}
