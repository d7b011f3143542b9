/// @file study_passivity_test.cpp
/// `numen study passivity` (sim/src/study/study_passivity*.cpp, docs/passivity.md): the measured
/// boundary against Colgate & Schenkel (no friction, no quantisation) and Abbott & Okamura
/// (no damping), the god-object coupling inside its bound against a direct wall of the
/// obstacle's stiffness, the passivity controller on a delayed wall, the CSV columns, the shard
/// merge and the refused options.

#include "numen/sim/study/study_passivity.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

#include "child_process.hpp"
#include "numen/sim/input/input_error.hpp"
#include "numen/sim/study/study_fields.hpp"
#include "numen/sim/study/study_shard.hpp"
#include "temp_dir.hpp"

namespace numen::sim {
namespace {

using test::read_file;
using test::TempDir;

PassivityPoint wall(double period, double b, double fc, double delta) {
  PassivityPoint p;
  p.period_s = period;
  p.device_damping = b;
  p.coulomb = fc;
  p.resolution = delta;
  p.coupling = "wall";
  return p;
}

TEST(StudyPassivity, BoundaryWithoutFrictionOrQuantisationIsColgates) {
  // Two (b, T) pairs: 2b/T = 2000 N/m at 1 kHz and 1e4 N/m at 10 kHz.
  for (const auto& [b, t] : {std::pair{1.0, 1e-3}, std::pair{0.5, 1e-4}}) {
    const PassivityBoundary r = find_passivity_boundary(wall(t, b, 0.0, 0.0), 0.01);
    const double bound = 2.0 * b / t;
    EXPECT_DOUBLE_EQ(r.colgate_bound, bound);
    EXPECT_NEAR(r.k_max / bound, 1.0, 0.1) << "b=" << b << " T=" << t << " K_max=" << r.k_max;
    EXPECT_LT(r.k_passive, r.k_not_passive);
  }
}

TEST(StudyPassivity, BoundaryWithoutDampingIsAbbottOkamuras) {
  for (const auto& [t, delta] : {std::pair{1e-3, 1e-5}, std::pair{1e-4, 1e-6}}) {
    const PassivityBoundary r = find_passivity_boundary(wall(t, 0.0, 0.05, delta), 0.01);
    const double bound = 2.0 * 0.05 / delta;
    EXPECT_DOUBLE_EQ(r.abbott_okamura_bound, bound);
    EXPECT_NEAR(r.k_max / bound, 1.0, 0.1) << "T=" << t << " Δ=" << delta << " K_max=" << r.k_max;
  }
}

TEST(StudyPassivity, DelayShrinksTheBoundAsColgatesConditionWithTheDelaySays) {
  PassivityPoint p = wall(1e-3, 1.0, 0.0, 0.0);
  p.delay_periods = 1;
  EXPECT_DOUBLE_EQ(delay_bound(p), 1.0 / (0.5e-3 + 1e-3));  // b / (T/2 + dT)
  EXPECT_EQ(delay_bound_frequency(p), 0.0);
  const PassivityBoundary r = find_passivity_boundary(p, 0.01);
  EXPECT_NEAR(r.ratio_delay, 1.0, 0.1) << r.k_max;
}

TEST(StudyPassivity, GodObjectInsideItsBoundIsPassiveAtAnyObstacleStiffnessADirectWallIsNot) {
  // b = 0.2 N·s/m at 1 kHz: Colgate's bound 400 N/m; the coupling K = 200 N/m, B = 0.
  for (double kw : {1e3, 1e6, 1e9}) {
    PassivityPoint go = wall(1e-3, 0.2, 0.0, 0.0);
    go.coupling = "god-object";
    go.stiffness = 200.0;
    go.obstacle_stiffness = kw;
    const PassivityProbe g = probe_passivity(go);
    EXPECT_TRUE(g.passive) << "k_w=" << kw << " E_min=" << g.energy_min_j;
    EXPECT_TRUE(g.contact_passive) << "k_w=" << kw << " E_min=" << g.contact_energy_min_j;
    EXPECT_FALSE(g.limit_cycle) << "k_w=" << kw << " amplitude " << g.limit_cycle_amplitude_m;
    PassivityPoint direct = wall(1e-3, 0.2, 0.0, 0.0);
    direct.stiffness = kw;
    const PassivityProbe w = probe_passivity(direct);
    EXPECT_FALSE(w.passive) << "k_w=" << kw;
    EXPECT_FALSE(w.contact_passive) << "k_w=" << kw;
    if (kw >= 1e6) {  // far beyond the bound: the pressed wall throws the hand out
      EXPECT_TRUE(w.limit_cycle) << "k_w=" << kw;
      EXPECT_GT(w.limit_cycle_amplitude_m, 1e-3) << "k_w=" << kw;  // 4.5 mm, 1.6e9 m (diverged)
      EXPECT_GT(w.limit_cycle_hz, 0.0) << "k_w=" << kw;
    }
  }
}

// The passivity controller in the probe (hal::PassivityController, docs/passivity.md
// "Passivity controller"): the paper's observer leaves the boundary where it is (it books a
// held spring as passive); with an energy limit of 1 µJ it damps the energy a one-period delay
// releases, and the delayed wall's K_max rises from b/(T/2 + T) to 2b/T, not beyond.
TEST(StudyPassivity, PassivityControllerLiftsTheDelayedWallToColgatesBoundNotBeyond) {
  PassivityPoint p = wall(1e-3, 1.0, 0.0, 0.0);
  p.delay_periods = 1;
  p.passivity_controller = true;
  const PassivityBoundary paper = find_passivity_boundary(p, 0.01);
  EXPECT_NEAR(paper.k_max / delay_bound(p), 1.0, 0.02) << paper.k_max;
  EXPECT_TRUE(paper.passivity_controller);
  p.passivity_energy_limit_j = 1e-6;
  const PassivityBoundary tank = find_passivity_boundary(p, 0.01);
  EXPECT_NEAR(tank.k_max / colgate_bound(p), 1.0, 0.02) << tank.k_max;
  EXPECT_EQ(tank.passivity_energy_limit_j, 1e-6);
  p.delay_periods = 0;
  const PassivityBoundary undelayed = find_passivity_boundary(p, 0.01);
  EXPECT_NEAR(undelayed.k_max / colgate_bound(p), 1.0, 0.02) << undelayed.k_max;
  p.passivity_energy_limit_j = 0.0;
  EXPECT_THROW(probe_passivity(p), std::invalid_argument);
}

// The velocity estimators on a damped wall (B = b/2, Δ = 0, 1 kHz): FOAW keeps the
// difference's (Colgate & Schenkel's) boundary, 2(b − B)/T; the 50 Hz filter, which removes the
// damper's Nyquist-rate response where that bound binds, renders a stiffer wall (docs/
// passivity.md "Velocity estimators": 1846 against 1010 N/m).
TEST(StudyPassivity, FoawKeepsColgatesBoundTheFilterRendersAStifferDampedWall) {
  PassivityPoint p = wall(1e-3, 1.0, 0.0, 0.0);
  p.damping = 0.5;
  const PassivityBoundary difference = find_passivity_boundary(p, 0.01);
  EXPECT_NEAR(difference.k_max / colgate_bound(p), 1.0, 0.05) << difference.k_max;
  EXPECT_EQ(difference.velocity_estimator, "difference");
  p.velocity_estimator = "foaw";
  const PassivityBoundary foaw = find_passivity_boundary(p, 0.01);
  EXPECT_NEAR(foaw.k_max / difference.k_max, 1.0, 0.01) << foaw.k_max;
  EXPECT_EQ(foaw.velocity_estimator, "foaw");
  p.velocity_estimator = "filter";
  const PassivityBoundary filter = find_passivity_boundary(p, 0.01);
  EXPECT_GT(filter.k_max, 1.5 * colgate_bound(p)) << filter.k_max;
  EXPECT_LT(filter.k_max, 2.0 * p.device_damping / p.period_s * 1.05) << filter.k_max;
  p.velocity_estimator = "kalman";
  try {
    probe_passivity(p);
    FAIL() << "accepted velocity_estimator \"kalman\"";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("velocity_estimator"), std::string::npos) << e.what();
  }
}

TEST(StudyPassivity, ProbeRefusesABadPointNamingTheSetting) {
  PassivityPoint p = wall(1e-3, 1.0, 0.0, 0.0);
  p.coupling = "spring";
  try {
    probe_passivity(p);
    FAIL() << "accepted coupling \"spring\"";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("coupling"), std::string::npos) << e.what();
  }
  p = wall(0.0, 1.0, 0.0, 0.0);
  EXPECT_THROW(probe_passivity(p), std::invalid_argument);
  p = wall(1e-3, -1.0, 0.0, 0.0);
  EXPECT_THROW(probe_passivity(p), std::invalid_argument);
}

/// A result of two cases (one row and one boundary each) built by hand: what the CSV writer and
/// the shard files see, without running the sweep.
PassivityResult two_cases() {
  PassivityResult r;
  r.cases = 2;
  for (int k = 0; k < 2; ++k) {
    PassivityPoint p = wall(k ? 1e-4 : 1e-3, 1.0, 0.0, 0.0);
    p.stiffness = 1500.0;
    PassivityBoundary b = find_passivity_boundary(p, 0.05);
    b.case_index = k;
    r.boundaries.push_back(b);
    PassivityRow row;
    row.period_s = p.period_s;
    row.device_damping = 1.0;
    row.coupling = "wall";
    row.stiffness = 1500.0;
    row.passive = k == 0;
    row.energy_min_j = k ? -1e-9 : 0.0;
    row.obstacle_stiffness = std::nan("");
    row.kind = "grid";
    row.case_index = k;
    r.rows.push_back(row);
  }
  return r;
}

TEST(StudyPassivity, CsvColumnsAreTheContract) {
  TempDir dir;
  write_passivity_csv(two_cases(), dir.path().string());
  std::istringstream csv(read_file((dir / "passivity.csv").string()));
  std::string header, line;
  std::getline(csv, header);
  const std::string contract =
      "period_s,device_damping,coulomb,resolution,delay_periods,coupling,stiffness,damping,"
      "passive,energy_min_j";
  EXPECT_EQ(header.rfind(contract, 0), 0u) << header;
  for (const char* extra :
       {"obstacle_stiffness", "limit_cycle", "limit_cycle_amplitude_m", "limit_cycle_hz",
        "colgate_bound", "abbott_okamura_bound", "delay_bound", "passivity_controller"})
    EXPECT_NE(header.find(std::string(",") + extra + ","), std::string::npos) << extra;
  std::string joined;
  for (const std::string& n : passivity_row_names()) joined += (joined.empty() ? "" : ",") + n;
  EXPECT_EQ(header, joined);
  std::getline(csv, line);
  EXPECT_EQ(line.rfind("0.001,1,0,0,0,wall,1500,0,1,0,", 0), 0u) << line;
  std::getline(csv, line);
  EXPECT_EQ(line.rfind("0.0001,1,0,0,0,wall,1500,0,0,-1e-09,", 0), 0u) << line;
  const std::string boundary = read_file((dir / "passivity_boundary.csv").string());
  EXPECT_EQ(boundary.rfind("period_s,device_damping,coulomb,resolution,delay_periods,coupling,"
                           "damping,obstacle_stiffness,k_max,",
                           0),
            0u)
      << boundary;
}

/// Two configurations with the records the plan of a --quick study gives each: a row per
/// point of the grid (made up: no probe), then the rows and the boundary of a real bisection.
PassivityResult planned_two_cases() {
  PassivityResult r;
  r.cases = 2;
  for (int k = 0; k < 2; ++k) {
    const PassivityPoint p = wall(k ? 1e-4 : 1e-3, 1.0, 0.0, 0.0);
    for (const double stiffness : passivity_grid(true)) {
      PassivityRow row;
      row.period_s = p.period_s;
      row.device_damping = 1.0;
      row.coupling = "wall";
      row.stiffness = stiffness;
      row.obstacle_stiffness = std::nan("");
      row.kind = "grid";
      row.case_index = k;
      r.rows.push_back(row);
    }
    std::vector<PassivityRow> bisection;
    PassivityBoundary b = find_passivity_boundary(p, 0.05, &bisection);
    for (PassivityRow& row : bisection) {
      row.case_index = k;
      r.rows.push_back(row);
    }
    b.case_index = k;
    r.boundaries.push_back(b);
  }
  return r;
}

/// Writes `one` into `dir` as shards 0 and 1 of 2 of a --quick study, each shard's part
/// passed through `edit` first.
void write_two_shards(const PassivityResult& one, const std::filesystem::path& dir,
                      const std::function<void(PassivityResult&)>& edit = {}) {
  PassivityOptions o;
  o.quick = true;
  for (int i = 0; i < 2; ++i) {
    PassivityResult part;
    part.cases = one.cases;
    part.shard = {i, 2};
    for (const PassivityRow& row : one.rows)
      if (row.case_index == i) part.rows.push_back(row);
    for (const PassivityBoundary& b : one.boundaries)
      if (b.case_index == i) part.boundaries.push_back(b);
    if (edit) edit(part);
    o.shard = part.shard;
    write_file_atomically(dir / shard_file_name("passivity", part.shard),
                          passivity_shard_document(part, o));
  }
}

/// The InputError merge_passivity_shards(`dir`) throws ("" for none).
std::string passivity_merge_error(const std::filesystem::path& dir) {
  try {
    (void)merge_passivity_shards(dir.string());
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(StudyPassivity, ShardFilesMergeIntoTheOneProcessCsv) {
  const PassivityResult one = planned_two_cases();
  TempDir whole, shards;
  write_passivity_csv(one, whole.path().string());
  write_two_shards(one, shards.path());
  EXPECT_EQ(study_of_shard_dir(shards.path()), "passivity");
  const PassivityResult merged = merge_passivity_shards(shards.path().string());
  write_passivity_csv(merged, shards.path().string());
  for (const char* name : {"passivity.csv", "passivity_boundary.csv"})
    EXPECT_EQ(read_file((whole / name).string()), read_file((shards / name).string())) << name;
}

// A case is merged only with the records its plan gives it: one boundary, and a row per grid
// point and per probe of its bisection. A shard file whose case 1 had "rows": [] was merged
// (the --quick study's passivity.csv had 1 198 lines instead of 1 217, exit status 0).
TEST(StudyPassivity, MergeRefusesACaseWithoutTheRecordsItsPlanGivesIt) {
  const PassivityResult one = planned_two_cases();
  const std::string grid = std::to_string(passivity_grid(true).size());
  const std::int64_t probes = one.boundaries[1].evaluations;
  const std::string rows = std::to_string(passivity_grid(true).size() + probes);
  const std::string why = " (" + grid + " grid points and " + std::to_string(probes) +
                          " bisection probes): the shard that ran it did not write it whole";
  TempDir dir;
  const std::string file = (dir / "passivity-shard-1-of-2.json").string();
  write_two_shards(one, dir.path(), [](PassivityResult& p) {
    if (p.shard.index == 1) p.rows.clear();
  });
  EXPECT_EQ(
      passivity_merge_error(dir.path()),
      file + ": case 1.rows: 0 in the file, but the study's plan gives the case " + rows + why);
  write_two_shards(one, dir.path(), [](PassivityResult& p) {
    if (p.shard.index == 1) p.rows.push_back(p.rows.back());
  });
  EXPECT_EQ(passivity_merge_error(dir.path()),
            file + ": case 1.rows: " + std::to_string(std::stoi(rows) + 1) +
                " in the file, but the study's plan gives the case " + rows + why);
  write_two_shards(one, dir.path(), [](PassivityResult& p) {
    if (p.shard.index == 1) p.boundaries.clear();
  });
  EXPECT_EQ(passivity_merge_error(dir.path()),
            file +
                ": case 1.boundaries: 0 in the file, but the study's plan gives the case 1 "
                "(one per configuration): the shard that ran it did not write it whole");
  write_two_shards(one, dir.path());
  EXPECT_EQ(passivity_merge_error(dir.path()), "");
}

// A NaN where passivity_failures() would find one is refused naming the file and the member:
// a merge reported "case 7: energy is NaN" after it had written both CSV files.
TEST(StudyPassivity, MergeRefusesANanNamingTheFileAndTheMember) {
  const PassivityResult one = planned_two_cases();
  TempDir dir;
  const std::vector<std::pair<std::function<void(PassivityResult&)>, std::string>> cases = {
      {[](PassivityResult& p) {
         if (p.shard.index == 1) p.rows[3].energy_min_j = std::nan("");
       },
       "passivity-shard-1-of-2.json: case 1.rows[3].energy_min_j: NaN (the energy at K = 10000 "
       "N/m)"},
      {[](PassivityResult& p) {
         if (p.shard.index == 0) p.boundaries[0].k_max = std::nan("");
       },
       "passivity-shard-0-of-2.json: case 0.boundaries[0].k_max: NaN (the boundary K_max)"},
  };
  for (const auto& [edit, want] : cases) {
    write_two_shards(one, dir.path(), edit);
    EXPECT_EQ(passivity_merge_error(dir.path()),
              dir.path().string() + "/" + want + ": the shard's probe failed; rerun that shard");
  }
}

// `numen study merge` of a set it refuses writes nothing: no CSV file, and no --out directory
// (a merge wrote both CSV files and then failed on a NaN); the set it accepts writes the
// one-process run's files.
TEST(StudyPassivity, MergeCommandWritesNothingFromARefusedSet) {
  const PassivityResult one = planned_two_cases();
  TempDir dir;
  const std::string cli = NUMEN_CLI, shards = (dir / "shards").string();
  const std::string out = (dir / "out").string();
  std::filesystem::create_directories(shards);
  const auto merge = [&] {
    return test::run_child({cli, "study", "merge", shards, "--out", out}, dir.path().string(), 60);
  };
  write_two_shards(one, shards, [](PassivityResult& p) {
    if (p.shard.index == 1) p.rows[0].contact_energy_min_j = std::nan("");
  });
  test::ChildResult r = merge();
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_EQ(r.err, "numen: " + shards +
                       "/passivity-shard-1-of-2.json: case 1.rows[0]."
                       "contact_energy_min_j: NaN (the energy at K = 10 N/m): the shard's probe "
                       "failed; rerun that shard\n");
  EXPECT_EQ(r.out, "");
  EXPECT_FALSE(std::filesystem::exists(out));
  write_two_shards(one, shards, [](PassivityResult& p) {
    if (p.shard.index == 1) p.rows.clear();
  });
  r = merge();
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_EQ(r.err.rfind("numen: " + shards +
                            "/passivity-shard-1-of-2.json: case 1.rows: 0 in the "
                            "file, but the study's plan gives the case ",
                        0),
            0u)
      << r.err;
  EXPECT_FALSE(std::filesystem::exists(out));
  write_two_shards(one, shards);
  r = merge();
  EXPECT_EQ(r.status, 0) << r.err;
  const std::string csv = read_file(out + "/passivity.csv");
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), static_cast<long>(one.rows.size()) + 1);
}

TEST(StudyPassivity, ListHasOneCasePerConfigurationAndShardsSplitIt) {
  PassivityOptions o;
  o.quick = true;
  const std::vector<StudyCase> all = passivity_cases(o);
  ASSERT_GE(all.size(), 8u);
  EXPECT_EQ(all[0].family, "passivity");
  EXPECT_EQ(all[0].name, "wall");
  o.shard = {1, 3};
  const std::vector<StudyCase> part = passivity_cases(o);
  for (const StudyCase& c : part) EXPECT_EQ(c.index % 3, 1);
  EXPECT_EQ(part.size(), (all.size() + 1) / 3);
  o.shard = {3, 3};
  EXPECT_THROW(passivity_cases(o), InputError);
}

TEST(StudyPassivity, CommandRefusesBadOptionsClearly) {
  TempDir dir;
  const std::string cli = NUMEN_CLI;
  const auto run = [&](const std::vector<std::string>& args) {
    std::vector<std::string> argv = {
        "/usr/bin/env", "-u",       "SLURM_ARRAY_TASK_ID", "-u", "SLURM_ARRAY_TASK_COUNT", cli,
        "study",        "passivity"};
    argv.insert(argv.end(), args.begin(), args.end());
    return test::run_child(argv, dir.path().string(), 60);
  };
  const test::ChildResult bad_shard = run({"--list", "--shard", "2/2"});
  EXPECT_EQ(bad_shard.status, 2) << bad_shard.out;
  EXPECT_NE(bad_shard.err.find("--shard: shard index 2 is not below the count 2"),
            std::string::npos)
      << bad_shard.err;
  const test::ChildResult not_shard = run({"--list", "--shard", "one/2"});
  EXPECT_EQ(not_shard.status, 2);
  EXPECT_NE(not_shard.err.find("--shard"), std::string::npos) << not_shard.err;
  const test::ChildResult unknown = run({"--stiffness", "3"});
  EXPECT_EQ(unknown.status, 2);
  EXPECT_NE(unknown.err.find("--stiffness"), std::string::npos) << unknown.err;
  const test::ChildResult list = run({"--quick", "--list"});
  EXPECT_EQ(list.status, 0) << list.err;
  EXPECT_EQ(list.out.rfind("0\tpassivity\twall\tT=0.001 b=1 fc=0 delta=0 d=0 B=0 kw=nan\n", 0), 0u)
      << list.out;
}

}  // namespace
}  // namespace numen::sim
