#!/usr/bin/env bash
# Regenerates the figures of docs/results.md. Run from the project root after
# building (README). Needs python3-matplotlib (apt-get install python3-matplotlib).
set -euo pipefail
cmake --build build -j2 --target numen figures >/dev/null  # numen_bench is in the figures target
out=docs/figures
tmp=$(mktemp -d)
./build/numen run --trace "$tmp/default.csv" > /dev/null
./build/numen run sim/scenes/lattice.toml --trace "$tmp/lattice.csv" > /dev/null
./build/numen run sim/scenes/construction.toml --trace "$tmp/god.csv" > /dev/null
./build/numen run sim/scenes/construction.toml --coupling direct --trace "$tmp/direct.csv" > /dev/null
/usr/bin/python3 $out/plot_runs.py default "$tmp/default.csv" $out/default_run.png
/usr/bin/python3 $out/plot_runs.py lattice "$tmp/lattice.csv" $out/lattice_run.png
/usr/bin/python3 $out/plot_runs.py construction "$tmp/god.csv" "$tmp/direct.csv" $out/construction.png
rm -rf "$tmp"
echo "wrote $out/default_run.png $out/lattice_run.png $out/construction.png"
c=$(mktemp) && ./build/tests/numen_bench --benchmark_filter=Chain --benchmark_repetitions=3 --benchmark_report_aggregates_only=true --benchmark_out="$c" --benchmark_out_format=json > /dev/null && /usr/bin/python3 $out/plot_articulation_scaling.py "$c" $out/articulation_scaling.png && rm -f "$c"
d=$(mktemp) && ./build/tests/numen_bench --benchmark_filter=DeformableBall --benchmark_repetitions=5 --benchmark_report_aggregates_only=true --benchmark_out="$d" --benchmark_out_format=json > /dev/null && /usr/bin/python3 $out/plot_deformable_scaling.py "$d" $out/deformable_scaling.png && rm -f "$d"
# Net solve against Eigen's solvers on one frozen step (docs/deformable.md; ~3.5 minutes)
p=$(mktemp) && ./build/tests/numen_bench --benchmark_filter=NetPeer --benchmark_repetitions=5 --benchmark_enable_random_interleaving=true --benchmark_report_aggregates_only=true --benchmark_out="$p" --benchmark_out_format=json > /dev/null && /usr/bin/python3 $out/plot_net_solve_work_precision.py "$p" $out/net_solve_work_precision.png && rm -f "$p"
# Accuracy: error against run time (docs/accuracy.md; ~5 minutes; --quick for a look in seconds)
a=$(mktemp -d) && ./build/numen study accuracy --out "$a" && /usr/bin/python3 $out/plot_accuracy.py "$a" $out && rm -rf "$a"
# Stability: stiff and extreme cases (docs/stability.md; ~1 minute; --quick for a look in seconds)
s=$(mktemp -d) && ./build/numen study stability --out "$s" > /dev/null && /usr/bin/python3 $out/plot_stability.py "$s" $out && rm -rf "$s"
# Passivity: the Z-width of a 1-DOF device (docs/passivity.md; ~1 minute; --quick for a look in seconds)
z=$(mktemp -d) && ./build/numen study passivity --out "$z" > /dev/null && /usr/bin/python3 $out/plot_passivity.py "$z" $out/passivity_zwidth.png && rm -rf "$z"
# Multirate quality against the rate ratio, construction, lattice, deformable and endobag scenes (docs/multirate.md; 44 runs)
/usr/bin/python3 $out/plot_multirate.py ./build/numen $out
# The default scene's deformable organ: hand vs tool vs organ surface, excerpt and full trials (docs/results.md, docs/organs.md; ~6 minutes)
docs/figures/organ_runs.sh > /dev/null
