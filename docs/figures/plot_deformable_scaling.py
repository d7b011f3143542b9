"""Step time of a deformable ball against its node count (docs/deformable.md,
"Measured"). Input: the JSON of
  numen_bench --benchmark_filter=DeformableBall --benchmark_repetitions=5
              --benchmark_report_aggregates_only=true
              --benchmark_out=FILE --benchmark_out_format=json
Left: median step time against nodes (log-log) — the median of the steps'
times (median_step_us) when the JSON has it, else Google Benchmark's mean
step time of a repetition — and the fastest step
(min_step_us, median over the repetitions) when the JSON has it, with the n
and n·log n references through the 642-node point and the 250 µs target; right: CG
iterations per step and the time per node per (iteration + 1), the linear part.
DeformableBallResidual runs in the JSON (the same ball stopped on the residual
ratio that the error estimate replaced, at 1e-3, which breaks the
solver-tolerance rule at 2562 nodes, and 3e-4, which keeps it) are drawn as
separate markers, one kind per tolerance: the old stopping test's cost. DeformableBallFrozen runs
(the same step repeated on the same input) are drawn as a vertical bar from
their fastest step to their median: the part of the spread that is the
machine's, not the trajectory's. An optional BEFORE.json
(same benchmark, an earlier build) is drawn dashed for comparison.
Usage: plot_deformable_scaling.py BENCH.json OUT.png [BEFORE.json]"""
import json
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

def load(path, prefix="DeformableBall/"):
    runs = [r for r in json.load(open(path))["benchmarks"]
            if r["name"].startswith(prefix) and r.get("aggregate_name") == "median"]
    runs.sort(key=lambda r: r["nodes"])
    return (np.array([r["nodes"] for r in runs]),
            np.array([r.get("median_step_us", r["real_time"] * 1e-3) for r in runs]),  # µs
            np.array([r["cg_iterations"] for r in runs]),
            np.array([r["ns_per_node_iteration"] for r in runs]),
            np.array([r.get("min_step_us", np.nan) for r in runs]))


n, t, it, per, tmin = load(sys.argv[1])
residual_runs = [r for r in json.load(open(sys.argv[1]))["benchmarks"]
                 if r["name"].startswith("DeformableBallResidual/")
                 and r.get("aggregate_name") == "median"]
residual = {}  # tolerance -> (nodes, median µs, CG iterations)
for r in sorted(residual_runs, key=lambda r: r["nodes"]):
    nodes, times, its = residual.setdefault(r["tolerance"], ([], [], []))
    nodes.append(r["nodes"])
    times.append(r.get("median_step_us", r["real_time"] * 1e-3))
    its.append(r["cg_iterations"])
frozen = [r for r in json.load(open(sys.argv[1]))["benchmarks"]
          if r["name"].startswith("DeformableBallFrozen/") and r.get("aggregate_name") == "median"]
before = load(sys.argv[3]) if len(sys.argv) > 3 else None

fig, (a, b) = plt.subplots(1, 2, figsize=(10, 4))
a.loglog(n, t, "o-", label="numen core::step (median)")
if np.all(np.isfinite(tmin)):
    a.loglog(n, tmin, "v-", color="C4", label="fastest step (min_step_us)")
for i, (tol, (rn, rt, _)) in enumerate(sorted(residual.items())):
    a.loglog(rn, rt, "Dx"[i % 2], color="C1", label=f"residual rule {tol:.0e} (median)")
for i, r in enumerate(frozen):
    a.plot([r["nodes"]] * 2, [r["frozen_min_us"], r["frozen_median_us"]], "_-", color="k", ms=10,
           label="same step, frozen input: fastest to median" if i == 0 else None)
if before is not None:
    slope_b = np.polyfit(np.log(before[0]), np.log(before[1]), 1)[0]
    a.loglog(before[0], before[1], "o--", color="C0", alpha=0.45,
             label=f"before, median (slope {slope_b:.2f})")
    if np.all(np.isfinite(before[4])):
        a.loglog(before[0], before[4], "v--", color="C4", alpha=0.45, label="before, fastest step")
k = int(np.argmin(abs(n - 642)))
a.loglog(n, t[k] * n / n[k], ":", color="grey", label="∝ n through 642")
a.loglog(n, t[k] * n * np.log(n) / (n[k] * np.log(n[k])), "--", color="grey",
         label="∝ n log n through 642")
a.axhline(250, color="C3", lw=1, label="target 250 µs @ 642 nodes")
slope = np.polyfit(np.log(n), np.log(t), 1)[0]
a.set_title(f"Step time vs nodes (log-log slope {slope:.2f})", fontsize=10)
a.set_xlabel("nodes (icosphere, subdivisions 1–4)")
a.set_ylabel("µs per step")
a.grid(alpha=0.3, which="both")
a.legend(fontsize=8)
b.plot(n, it, "s-", color="C1", label="CG iterations / step (mean)")
for i, (tol, (rn, _, ri)) in enumerate(sorted(residual.items())):
    b.plot(rn, ri, "Dx"[i % 2], color="C1", label=f"residual rule {tol:.0e}")
if before is not None:
    b.plot(before[0], before[2], "s--", color="C1", alpha=0.45, label="before")
b.set_xscale("log")
b.set_xlabel("nodes")
b.set_ylabel("iterations", color="C1")
b2 = b.twinx()
b2.plot(n, per, "o-", color="C2", label="ns per node per (iteration + 1)")
b2.set_ylabel("ns / node / iteration", color="C2")
b2.set_ylim(0, max(per) * 1.3)
b.set_title("Iterations (conditioning) and linear work per iteration", fontsize=10)
b.grid(alpha=0.3)
fig.tight_layout()
fig.savefig(sys.argv[2], dpi=120)
print("wrote", sys.argv[2])
