"""End-to-end latency of the controller + device pair on vcan0 inside the HIL guest
(docs/hil.md, "Measured"). Input: the console log of
`bash tests/hil/run.sh` (build-hil/build/hil-console.log), whose scenario
run_device_pair prints its histogram as "HIL-CSV <scenario>,<bin lower edge us>,<count>"
lines (tests/hil/lib.sh, e2e_histogram). End-to-end latency: from the SYNC written to the
torque RPDOs written in the same period (platform::LoopStatistics), so it holds the compute
phase, the device's answer and the step.
Plots the histogram (log count) with the median, p99 and max marked, and the control period.
Usage: plot_hil_latency.py CONSOLE.log OUT.png [PERIOD_US]"""
import re
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

log, out = sys.argv[1], sys.argv[2]
period_us = float(sys.argv[3]) if len(sys.argv) > 3 else None
pattern = re.compile(r"HIL-CSV run_device_pair,(\d+),(\d+)")
edges, counts = [], []
for line in open(log, errors="replace"):
    m = pattern.search(line)
    if m:
        edges.append(int(m.group(1)))
        counts.append(int(m.group(2)))
if not edges:
    sys.exit(f"{log}: no 'HIL-CSV run_device_pair,...' lines (did scenario run_device_pair run?)")
edges = np.array(edges, dtype=float)
counts = np.array(counts, dtype=float)
width = np.min(np.diff(np.unique(edges))) if len(edges) > 1 else 20.0
cum = np.cumsum(counts) / counts.sum()
median = edges[np.searchsorted(cum, 0.5)]
p99 = edges[np.searchsorted(cum, 0.99)]
fig, ax = plt.subplots(figsize=(7.5, 4.0))
ax.bar(edges / 1000.0, counts, width=width / 1000.0, align="edge", color="#4477aa")
ax.set_yscale("log")
for x, label, style in ((median, "median", "-"), (p99, "p99", "--"), (edges.max() + width, "max", ":")):
    ax.axvline(x / 1000.0, color="k", linestyle=style, linewidth=1)
    ax.text(x / 1000.0, counts.max(), f" {label} {x / 1000.0:.2f} ms", rotation=90, va="top", fontsize=8)
if period_us:
    ax.axvline(period_us / 1000.0, color="#cc3311", linewidth=1.5)
    ax.text(period_us / 1000.0, counts.max() / 3, f" period {period_us / 1000.0:g} ms", color="#cc3311",
            rotation=90, va="top", fontsize=8)
ax.set_xlabel("end-to-end latency, SYNC written to torque written (ms)")
ax.set_ylabel("periods")
ax.set_title(f"controller + numen device on vcan0, qemu TCG guest ({int(counts.sum())} periods)")
fig.tight_layout()
fig.savefig(out, dpi=110)
print(f"wrote {out}: median {median / 1000:.2f} ms, p99 {p99 / 1000:.2f} ms, max {(edges.max() + width) / 1000:.2f} ms")
