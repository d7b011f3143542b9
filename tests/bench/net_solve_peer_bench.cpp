// Work–precision of the coupled net solve against Eigen's sparse solvers on
// the identical linear system (issue 5; docs/deformable.md, "Work–precision
// against Eigen's solvers"). Scene: the deformable ball of the step benchmark
// (tests/support/deformable_ball.hpp; 162, 642, 2562 nodes = subdivisions
// 2, 3, 4) after the same 300 warm-up steps as deformable_bench.cpp (a patch
// of nodes on the floor). Step 300's system is staged as step() stages it
// (net_system_sparse.hpp: stage_net_system) and frozen: numen's scratch as
// build_net_system() leaves it, the warm start (NetScratch::delta, the last
// step's Δv) and the same A Δ = b assembled as an Eigen::SparseMatrix from the
// header's formulas (net_system_sparse.hpp: assemble_net_system; bodies
// first, 6 each, then the nodes, 3 each). Every solver solves that system, in
// the same process, from the same warm start (bodies 0, nodes at the last Δv):
//   NetPeerNumen      core::solve_net_system(): SSOR–Eisenstat CG, stopping on
//                     ‖r‖_{M⁻¹}/‖b‖_{D̃⁻¹} ≤ tolerance (net_solve.hpp); NetScratch::delta
//                     restored before each solve (untimed), nothing else is
//                     needed (the solve overwrites the rest of its scratch);
//   NetPeerEigenCgDiagonal   Eigen::ConjugateGradient<SparseMatrix, Lower|Upper,
//                     DiagonalPreconditioner>, stopping on ‖r‖₂/‖b‖₂ ≤ tolerance;
//   NetPeerEigenCgIncompleteCholesky  the same with IncompleteCholesky<double,
//                     Lower, AMDOrdering> (Lin & Moré 1999; ordering computed once);
//   NetPeerEigenLdlt  Eigen::SimplicialLDLT (AMD ordering and symbolic analysis
//                     once, outside the timing: the pattern is fixed).
// Timed per solve: numen's solve_net_system() only (its matrix-free system and
// block inverses come from build_net_system(), a stage of every step, not
// timed); for Eigen the preconditioner's or factor's numeric factorization
// (factorize(), which a step would redo since A changes every step) plus the
// solve. Eigen gets its matrix assembled for free (untimed).
// Tolerances 1e-1 … 1e-10 (the argument tol_exp: tolerance 10^−tol_exp); the two
// stopping norms differ, so the comparison is at equal *true error*:
//   error_nodes = ‖Δv − Δv_ref‖/‖Δv_ref‖ over the nodes (m/s), error_all over
//   all unknowns, Δ_ref = the LDLᵀ solution refined twice
//   (‖A Δ_ref − b‖/‖b‖ in the counter reference_residual).
// Counters: nodes, tolerance, iterations (of this solve; 0 for LDLᵀ),
// converged (1/0), error_nodes, error_all, median_us (median solve time of the
// repetition, µs), min_us (its fastest solve: what the load inflates least),
// median_factorize_us (Eigen's factorize() part; LDLᵀ: factor_nonzeros, the
// nonzeros of L, against matrix_nonzeros, those of A),
// contacts (active node contacts in the frozen step).
//
//   ./build/tests/numen_bench --benchmark_filter=NetPeer --benchmark_repetitions=5
//       --benchmark_enable_random_interleaving=true --benchmark_report_aggregates_only=true
//       --benchmark_out=net_solve_work_precision.json --benchmark_out_format=json
//   (one command line)

#include <benchmark/benchmark.h>

#include <Eigen/IterativeLinearSolvers>
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <map>
#include <memory>
#include <vector>

#include "deformable_ball.hpp"
#include "net_system_sparse.hpp"
#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/step.hpp"

#include "scratch/data_scratch.hpp"
#include "net/net_solve.hpp"
#include "sample_median.hpp"

namespace {

namespace core = numen::core;
using Clock = std::chrono::steady_clock;
using SpMat = Eigen::SparseMatrix<double>;
using Eigen::VectorXd;

/// One step's system of the ball, frozen for every solver.
struct FrozenSystem {
  core::Model model;                // the ball; solver.tolerance set per benchmark
  core::Data data;                  // staged up to the solve (build_net_system() done)
  std::vector<core::Vec3> warm;     // NetScratch::delta before the solve
  numen::test::NetSystem system;    // the same A Δ = b, assembled
  VectorXd guess;                   // the warm start in the system's order
  VectorXd reference;               // Δ_ref (LDLᵀ, refined)
  double reference_residual = 0.0;  // ‖A Δ_ref − b‖/‖b‖
  int contacts = 0;
};

/// The frozen system of the ball with `subdivisions`, built once per process.
FrozenSystem& frozen(int subdivisions) {
  static std::map<int, std::unique_ptr<FrozenSystem>> cache;
  std::unique_ptr<FrozenSystem>& slot = cache[subdivisions];
  if (slot) return *slot;
  slot = std::make_unique<FrozenSystem>();
  FrozenSystem& f = *slot;
  // The step benchmark's model and warm-up (deformable_bench.cpp); room for
  // the tight tolerances' iterations.
  f.model = numen::test::make_deformable_ball(subdivisions, 1e-3, 1e-3, 100);
  f.data = core::make_data(f.model);
  const std::int64_t k =
      numen::test::run_deformable_ball(f.model, f.data, 0, numen::test::kBallWarmUpSteps);
  f.model.solver.max_iterations = 100000;
  numen::test::set_deformable_ball_target(f.model, f.data, k);
  const numen::test::NetSystemInputs in = numen::test::stage_net_system(f.model, f.data);
  f.warm = f.data.scratch->net.delta;
  f.system = numen::test::assemble_net_system(f.model, in);
  for (int c = 0; c < f.data.num_node_contacts; ++c)
    f.contacts += f.data.node_contacts[static_cast<std::size_t>(c)].active ? 1 : 0;
  f.guess = VectorXd::Zero(f.system.b.size());
  for (int i = 0; i < f.model.num_nodes(); ++i)
    f.guess.segment<3>(numen::test::net_system_node_index(f.model, i)) =
        f.warm[static_cast<std::size_t>(i)];
  Eigen::SimplicialLDLT<SpMat> ldlt(f.system.a);
  f.reference = ldlt.solve(f.system.b);
  for (int r = 0; r < 2; ++r) f.reference += ldlt.solve(f.system.b - f.system.a * f.reference);
  f.reference_residual = (f.system.a * f.reference - f.system.b).norm() / f.system.b.norm();
  return f;
}

/// Relative errors of `x` against the reference: nodes only, all unknowns.
void report_error(benchmark::State& state, const FrozenSystem& f, const VectorXd& x) {
  const Eigen::Index n0 = numen::test::net_system_node_index(f.model, 0);
  const Eigen::Index nn = x.size() - n0;
  state.counters["error_nodes"] =
      (x.tail(nn) - f.reference.tail(nn)).norm() / f.reference.tail(nn).norm();
  state.counters["error_all"] = (x - f.reference).norm() / f.reference.norm();
  state.counters["reference_residual"] = f.reference_residual;
  state.counters["nodes"] = f.model.num_nodes();
  state.counters["contacts"] = f.contacts;
}

double tolerance_of(const benchmark::State& state) {
  return std::pow(10.0, -static_cast<double>(state.range(1)));
}

/// Per benchmark iteration: `prepare()` (untimed), then `factorize()` and
/// `solve()` timed (the iteration's manual time: both); each returns whether
/// it succeeded. Sets the counters median_us, min_us and median_factorize_us
/// and returns whether every call succeeded.
template <class Prepare, class Factorize, class Solve>
bool time_solves(benchmark::State& state, Prepare prepare, Factorize factorize, Solve solve) {
  std::vector<double> times, factor_times;
  times.reserve(1 << 16);
  factor_times.reserve(1 << 16);
  bool ok = true;
  for (auto _ : state) {
    prepare();
    const auto t0 = Clock::now();
    ok = factorize() && ok;
    const auto t1 = Clock::now();
    ok = solve() && ok;
    const auto t2 = Clock::now();
    const double s = std::chrono::duration<double>(t2 - t0).count();
    times.push_back(s);
    factor_times.push_back(std::chrono::duration<double>(t1 - t0).count());
    state.SetIterationTime(s);
  }
  state.counters["median_us"] = numen::test::sample_median(times) * 1e6;
  state.counters["min_us"] =
      times.empty() ? 0.0 : *std::min_element(times.begin(), times.end()) * 1e6;
  state.counters["median_factorize_us"] = numen::test::sample_median(factor_times) * 1e6;
  return ok;
}

void NetPeerNumen(benchmark::State& state) {
  FrozenSystem& f = frozen(static_cast<int>(state.range(0)));
  const double tol = tolerance_of(state);
  f.model.solver.tolerance = tol;
  const bool converged = time_solves(
      state, [&] { std::copy(f.warm.begin(), f.warm.end(), f.data.scratch->net.delta.begin()); },
      [] { return true; }, [&] { return core::solve_net_system(f.model, f.data); });
  const VectorXd x = numen::test::net_system_unknowns(f.model, f.data);
  report_error(state, f, x);
  state.counters["tolerance"] = tol;
  state.counters["iterations"] = f.data.solver_iterations;
  state.counters["converged"] = converged ? 1.0 : 0.0;
  state.counters["median_factorize_us"] = 0.0;  // nothing to factorize
}

template <class Preconditioner>
void NetPeerEigenCg(benchmark::State& state) {
  const FrozenSystem& f = frozen(static_cast<int>(state.range(0)));
  const double tol = tolerance_of(state);
  Eigen::ConjugateGradient<SpMat, Eigen::Lower | Eigen::Upper, Preconditioner> cg;
  cg.setTolerance(tol);
  cg.setMaxIterations(100000);
  cg.analyzePattern(f.system.a);  // the ordering (IncompleteCholesky): once
  VectorXd x(f.system.b.size());
  const bool converged = time_solves(
      state, [] {},
      [&] {
        cg.factorize(f.system.a);
        return true;
      },
      [&] {
        x = cg.solveWithGuess(f.system.b, f.guess);
        return cg.info() == Eigen::Success;
      });
  report_error(state, f, x);
  state.counters["tolerance"] = tol;
  state.counters["iterations"] = static_cast<double>(cg.iterations());
  state.counters["converged"] = converged ? 1.0 : 0.0;
}

void NetPeerEigenCgDiagonal(benchmark::State& state) {
  NetPeerEigenCg<Eigen::DiagonalPreconditioner<double>>(state);
}

void NetPeerEigenCgIncompleteCholesky(benchmark::State& state) {
  NetPeerEigenCg<Eigen::IncompleteCholesky<double, Eigen::Lower, Eigen::AMDOrdering<int>>>(state);
}

void NetPeerEigenLdlt(benchmark::State& state) {
  const FrozenSystem& f = frozen(static_cast<int>(state.range(0)));
  Eigen::SimplicialLDLT<SpMat> ldlt;
  ldlt.analyzePattern(f.system.a);  // AMD ordering and elimination tree: once
  VectorXd x(f.system.b.size());
  const bool ok = time_solves(
      state, [] {},
      [&] {
        ldlt.factorize(f.system.a);
        return true;
      },
      [&] {
        x = ldlt.solve(f.system.b);
        return ldlt.info() == Eigen::Success;
      });
  report_error(state, f, x);
  state.counters["factor_nonzeros"] =
      static_cast<double>(ldlt.matrixL().nestedExpression().nonZeros());
  state.counters["matrix_nonzeros"] = static_cast<double>(f.system.a.nonZeros());
  state.counters["tolerance"] = 0.0;
  state.counters["iterations"] = 0.0;
  state.counters["converged"] = ok ? 1.0 : 0.0;
}

void IterativeArgs(benchmark::internal::Benchmark* b) {
  b->ArgNames({"subdivisions", "tol_exp"});
  for (int sub = 2; sub <= 4; ++sub)
    for (int e : {1, 2, 3, 4, 6, 8, 10}) b->Args({sub, e});
}

}  // namespace

BENCHMARK(NetPeerNumen)->Apply(IterativeArgs)->UseManualTime()->MinTime(0.4);
BENCHMARK(NetPeerEigenCgDiagonal)->Apply(IterativeArgs)->UseManualTime()->MinTime(0.4);
BENCHMARK(NetPeerEigenCgIncompleteCholesky)->Apply(IterativeArgs)->UseManualTime()->MinTime(0.4);
BENCHMARK(NetPeerEigenLdlt)
    ->ArgNames({"subdivisions", "tol_exp"})
    ->Args({2, 0})
    ->Args({3, 0})
    ->Args({4, 0})
    ->UseManualTime()
    ->MinTime(0.4);
