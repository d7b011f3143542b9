// End-to-end tests of the `numen` command (sim/app/main.cpp and its *_command.cpp) run as a child process: exit
// statuses (docs/inputs.md), signals at each phase, and resident memory that depends neither
// on the control period nor on the run's duration (issue 17, defects 1 and 4).

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "build_features.hpp"
#include "child_process.hpp"
#include "numen/sim/run_figures.hpp"
#include "numen/sim/scene.hpp"
#include "numen/sim/view_recording.hpp"
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

std::string default_scene_text() { return numen::test::read_file(numen::sim::default_scene_path()); }

const std::string kExcerptLine = "file = \"../data/jigsaws_suturing_b002_excerpt.txt\"";

/// The default scene with `edits` applied (from → to, each must match) and its trajectory file
/// given as an absolute path (the copy lives in a temporary directory).
std::string default_scene_copy(const std::vector<std::pair<std::string, std::string>>& edits) {
  std::string text = default_scene_text();
  for (const auto& [from, to] : edits) text = numen::test::replace(text, from, to);
  const std::string dir =
      std::filesystem::path(numen::sim::default_scene_path()).parent_path().string() + "/";
  if (text.find(kExcerptLine) != std::string::npos)
    text = numen::test::replace(text, "file = \"../data/", "file = \"" + dir + "../data/");
  return numen::test::with_absolute_dcf_paths(text, dir);
}

/// The default scene at control period `dt` (s): the simulated bus's latency and compute
/// phase are scaled so that a SYNC round trip fits in the period.
std::string default_scene_at(const std::string& dt) {
  return default_scene_copy({{"dt = 0.001", "dt = " + dt},
                             {"latency = 0.0001", "latency = 1e-6\ncompute_phase = 5e-6"}});
}

// Defect 1: a 30 s recording used to be resampled at dt up front (497 MB at dt = 1e-5, ~23 GB
// at 1e-7). Now the trajectory keeps its 30 Hz knots: the peak RSS of a run does not depend on dt.
TEST(NumenCli, PeakMemoryDoesNotDependOnTheControlPeriod) {
  NUMEN_REQUIRE_ARTICULATION();
  TempDir dir;
  const std::string coarse = dir.write("coarse.toml", default_scene_at("0.001"));
  const std::string fine = dir.write("fine.toml", default_scene_at("1e-5"));
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
  const ChildResult a = run_child({kNumen, "run", "--duration", "0.5"}, dir.path(), 120);
  const ChildResult b = run_child({kNumen, "run", "--duration", "8"}, dir.path(), 300);
  ASSERT_EQ(a.status, 0) << a.out << a.err;
  ASSERT_EQ(b.status, 0) << b.out << b.err;
  std::printf("[   info   ] peak RSS: 0.5 s %ld KiB, 8 s %ld KiB\n", a.max_rss_kib, b.max_rss_kib);
  EXPECT_LT(b.max_rss_kib - a.max_rss_kib, 2 * 1024);
}

// Defect 1: SIGTERM while the input loads (here a trajectory file that is a FIFO nobody writes:
// the loader blocks in open()) ends the process at once, with a message and 128 + SIGTERM.
TEST(NumenCli, StopSignalWhileLoadingEndsTheProcessAtOnce) {
  NUMEN_REQUIRE_ARTICULATION();  // the default scene has joints
  TempDir dir;
  const std::string fifo = (dir / "trajectory.txt").string();
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const std::string scene =
      dir.write("scene.toml", default_scene_copy({{kExcerptLine, "file = \"" + fifo + "\""}}));
  // A non-blocking open for writing succeeds once the child has the FIFO open for reading; the
  // write end stays open (and empty), so the child then waits in read(): still loading.
  int writer = -1;
  ChildSignal term;
  term.signal = SIGTERM;
  term.ready = [&] {
    writer = ::open(fifo.c_str(), O_WRONLY | O_NONBLOCK);
    return writer >= 0;
  };
  const ChildResult r = run_child({kNumen, "run", scene}, dir.path(), 20, term);
  if (writer >= 0) ::close(writer);
  EXPECT_FALSE(r.timed_out) << "SIGTERM was ignored while loading";
  EXPECT_EQ(r.status, 128 + SIGTERM) << r.out << r.err;
  EXPECT_NE(r.err.find("stopped by a signal while loading"), std::string::npos) << r.err;
}

// Once running, SIGTERM ends the run cleanly: the summary is printed and the status is
// 128 + SIGTERM (the run did not do what was asked). The recorder's log file exists once the
// runner is built, i.e. once loading is over.
TEST(NumenCli, StopSignalWhileRunningPrintsTheSummary) {
  NUMEN_REQUIRE_ARTICULATION();
  TempDir dir;
  const std::string log = (dir / "run.log").string();
  ChildSignal term;
  term.signal = SIGTERM;
  term.ready = [&log] { return std::filesystem::exists(log); };
  const ChildResult r =
      run_child({kNumen, "run", "--realtime", "--overrun-limit", "0", "--duration", "60", "--record", log},
                dir.path(), 30, term);  // overruns on a loaded machine count, never latch
  EXPECT_FALSE(r.timed_out);
  EXPECT_EQ(r.status, 128 + SIGTERM) << r.out << r.err;
  EXPECT_NE(r.out.find("exit status 0 (clean)"), std::string::npos) << r.out;
  EXPECT_LT(r.wall_s, 20.0);
}

// Defect 4: --record to a full disk used to report "recorded N frames, 0 dropped" and exit 0.
TEST(NumenCli, RecordingThatLosesFramesExitsWithLostRecords) {
  NUMEN_REQUIRE_ARTICULATION();
  TempDir dir;
  const ChildResult r =
      run_child({kNumen, "run", "--duration", "0.5", "--record", "/dev/full"}, dir.path(), 120);
  EXPECT_EQ(r.status, 5) << r.out << r.err;
  EXPECT_NE(r.out.find("lost records: --record"), std::string::npos) << r.out;
}

// Defect 4: --json carries the verdict; a clean run of the default scene exits 0.
TEST(NumenCli, JsonCarriesTheExitStatus) {
  NUMEN_REQUIRE_ARTICULATION();
  TempDir dir;
  const ChildResult r = run_child({kNumen, "run", "--duration", "0.5", "--json"}, dir.path(), 120);
  EXPECT_EQ(r.status, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("\"exit_status\":0"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("\"exit_reasons\":[]"), std::string::npos) << r.out;
}

// Issue 18: one class per subcommand; each still answers --help, and `numen figures` prints the
// figure table that docs/scenes.md holds.
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

// Defect 4: a refused command-line value is "input rejected" (2), not CLI11's own codes.
TEST(NumenCli, RefusedOptionValueExitsWithInputRejected) {
  TempDir dir;
  const ChildResult r = run_child({kNumen, "run", "--duration", "abc"}, dir.path(), 30);
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
      run_child({kNumen, "run", "--duration", "0.2", "--bus", "log:" + log}, dir.path(), 60);
  EXPECT_EQ(r.status, 2) << r.out << r.err;
  EXPECT_NE(r.err.find(log + ": 2 records, none that the controller reads"), std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("0x181"), std::string::npos) << r.err;
}

// ... and a log that is not a candump log at all is refused at its first bad line.
TEST(NumenCli, ReplayOfGarbageIsALocatedInputError) {
  NUMEN_REQUIRE_ARTICULATION();  // the default scene has joints
  TempDir dir;
  const std::string log = dir.write("garbage.log", "(0.000100) vcan0 181#00000000\nhello\n");
  const ChildResult r =
      run_child({kNumen, "run", "--duration", "0.2", "--bus", "log:" + log}, dir.path(), 60);
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

// `numen run --view` takes [HOST:]PORT only.
TEST(NumenCli, ViewAddressThatIsNotHostPortIsInputRejected) {
  TempDir dir;
  for (const char* v : {"http://x", "8080x", "host:", ":8080", "99999", "notahost:8080"}) {
    const ChildResult r = run_child({kNumen, "run", "--duration", "0.01", "--view", v}, dir.path(), 30);
    EXPECT_EQ(r.status, 2) << v << ": " << r.err;
  }
  // `numen view --host`: a name is not resolved; refused before the file is read or served.
  const ChildResult r =
      run_child({kNumen, "view", "any.nmv", "--host", "notahost", "--port", "0"}, dir.path(), 30);
  EXPECT_EQ(r.status, 2) << r.out << r.err;
  EXPECT_NE(r.err.find("--host"), std::string::npos) << r.err;
  EXPECT_EQ(r.out.find("open http://"), std::string::npos) << r.out;
}

// A view rate above the control rate publishes every period: said on stderr, and the
// recording's scene message carries the rate it got (1/dt), not the one asked.
TEST(NumenCli, ViewRateAboveTheControlRateIsSaidAndRecordedAsTheControlRate) {
  NUMEN_REQUIRE_ARTICULATION();
  TempDir dir;
  const std::string file = (dir.path() / "run.nmv").string();
  const ChildResult r = run_child({kNumen, "run", "--duration", "0.05", "--record-view", file,
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

// Options a run would not apply, or values that do not fit them, are input rejected before
// the run, naming the option (2026-11-25 audit): `--prefault-stack -1` wrapped to SIZE_MAX
// and crashed (SIGSEGV in alloca); the others ran and dropped the option without a word.
TEST(NumenCli, OptionsARunWouldNotApplyAreInputRejected) {
  NUMEN_REQUIRE_ARTICULATION();  // the default scene has joints
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
      {{"--rt-strict"}, "--rt-strict"},        // no real-time step to make fatal
  };
  for (const auto& [extra, key] : cases) {
    std::vector<std::string> args = {kNumen, "run", "--duration", "0.05"};
    args.insert(args.end(), extra.begin(), extra.end());
    const ChildResult r = run_child(args, dir.path(), 30);
    EXPECT_EQ(r.status, 2) << extra.front() << ": " << r.out << r.err;
    EXPECT_NE(r.err.find(key), std::string::npos) << extra.front() << ": " << r.err;
  }
  // `numen view --page` names a folder holding the page.
  const std::string rec = (dir / "run.nmv").string();
  ASSERT_EQ(run_child({kNumen, "run", "--duration", "0.05", "--record-view", rec}, dir.path(), 30).status, 0);
  const ChildResult v =
      run_child({kNumen, "view", rec, "--port", "0", "--page", (dir / "nowhere").string()}, dir.path(), 30);
  EXPECT_EQ(v.status, 2) << v.out << v.err;
  EXPECT_NE(v.err.find("--page"), std::string::npos) << v.err;
  EXPECT_EQ(v.out.find("open http://"), std::string::npos) << v.out;
}

// Defect 1: --trace of a simulated run keeps one record per period; a run whose trace would
// outgrow the budget (kMaxInMemoryTraceBytes) is refused before anything is allocated.
TEST(NumenCli, TraceThatWouldOutgrowItsBudgetIsRefusedBeforeTheRun) {
  NUMEN_REQUIRE_ARTICULATION();  // the default scene has joints
  TempDir dir;
  const ChildResult r = run_child(
      {kNumen, "run", "--duration", "1e6", "--trace", (dir / "t.csv").string()}, dir.path(), 60);
  EXPECT_EQ(r.status, 2) << r.out << r.err;
  EXPECT_NE(r.err.find("--trace: a simulated run keeps one trace record"), std::string::npos)
      << r.err;
  // The trace would take hundreds of GB: a refused run stays at the process's own footprint, 100 MiB
  // (the sanitizers' shadow memory and allocator add ~100 MiB to it: 400 MiB there).
  const long limit_kib = numen::test::under_sanitizer() ? 400 * 1024 : 100 * 1024;
  EXPECT_LT(r.max_rss_kib, limit_kib);
}

// Defect 6: out of memory printed "std::bad_alloc"; it now says what ran out (status 1). The
// process gets 400 MB of address space and a trace of ~1.7 million periods (~600 MB, within
// the trace budget) to reserve.
TEST(NumenCli, OutOfMemoryIsNamed) {
  NUMEN_SKIP_UNDER_SANITIZER_HEAP("the sanitizer reserves terabytes of address space: ulimit -v stops it first");
  NUMEN_REQUIRE_ARTICULATION();
  TempDir dir;
  const std::string cmd = "ulimit -v 400000; exec " + kNumen + " run --duration 1700 --trace " +
                          (dir / "t.csv").string();
  const ChildResult r = run_child({"/bin/sh", "-c", cmd}, dir.path(), 60);
  EXPECT_EQ(r.status, 1) << r.out << r.err;
  EXPECT_NE(r.err.find("numen: out of memory"), std::string::npos) << r.err;
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
// (sim/shipped_files.hpp; the Debian package and `cmake --install` rely on it).
TEST(NumenCli, InstalledExecutableFindsTheDefaultSceneRelativeToItself) {
  NUMEN_REQUIRE_ARTICULATION();
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
  const ChildResult r = run_child({(prefix / "bin/numen").string(), "info", "--json"}, dir.path(), 60);
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  const std::string expected = (prefix / "share/numen/scenes/default.toml").string();
  EXPECT_NE(r.out.find("\"file\":\"" + expected + "\""), std::string::npos) << r.out.substr(0, 300);
}
