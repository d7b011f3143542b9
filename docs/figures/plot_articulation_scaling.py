"""Step time of articulated chains against their body count (docs/articulation.md,
"Chain scaling"). Input: the JSON of
  numen_bench --benchmark_filter=Chain --benchmark_repetitions=3
              --benchmark_out=FILE --benchmark_out_format=json
Usage: plot_articulation_scaling.py BENCH.json OUT.png"""
import json
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

runs = json.load(open(sys.argv[1]))["benchmarks"]
fig, ax = plt.subplots(figsize=(6, 4))
for name, label, color in [("ChainRevolute", "revolute (5 rows)", "C0"),
                           ("ChainSpherical", "spherical (3 rows)", "C1")]:
    pts = sorted((int(r["bodies"]), r["real_time"] * 1e-3)  # ns -> µs
                 for r in runs if r["name"].startswith(name + "/")
                 and r.get("aggregate_name") == "median")
    n, t = np.array(pts).T
    slope, icpt = np.polyfit(n, t, 1)
    ax.plot(n, t, "o", color=color, label=f"{label}")
    ax.plot(n, slope * n + icpt, "-", color=color, lw=1,
            label=f"fit {slope:.2f} µs/body {icpt:+.1f} µs")
ax.set_xlabel("bodies N (chain, one joint per body)")
ax.set_ylabel("core::step time, median (µs)")
ax.set_title("Articulated chain: step cost vs N (implicit, coupled tip)")
ax.grid(alpha=0.3)
ax.legend(fontsize=8)
fig.tight_layout()
fig.savefig(sys.argv[2], dpi=120)
print("wrote", sys.argv[2])
