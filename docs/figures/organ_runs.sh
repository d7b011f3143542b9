#!/usr/bin/env bash
# The default scene (sim/scenes/default.toml: the deformable organ) in --replay on the shipped excerpt and on every full
# JIGSAWS trial (*.txt of $NUMEN_JIGSAWS_DIR, docs/inputs.md; none when it is unset), then
# docs/figures/organ_runs.png (plot_organ.py: hand vs tool vs organ surface) and its figures as JSON on stdout. Run from the project root
# after building. Needs python3-numpy and python3-matplotlib.
set -euo pipefail
root=$(pwd)
trials=${NUMEN_JIGSAWS_DIR:-}
tmp=$(mktemp -d)
runs=()
./build/numen run sim/scenes/default.toml --replay --trace "$tmp/excerpt.csv" > /dev/null
runs+=("excerpt (30 s)=$tmp/excerpt.csv")
for f in "$trials"/*.txt; do
  [ -e "$f" ] || continue
  n=$(basename "$f" .txt)
  # The scene reading the trial: its DCFs, its mesh and the recording by absolute paths.
  sed -e "s#dcf = \"devices/#dcf = \"$root/sim/scenes/devices/#" \
      -e "s#file = \"../data/organ_lobe.obj\"#file = \"$root/sim/data/organ_lobe.obj\"#" \
      -e "s#file = \"../data/jigsaws_suturing_b002_excerpt.txt\"#file = \"$(realpath "$f")\"#" \
      sim/scenes/default.toml > "$tmp/$n.toml"
  ./build/numen run "$tmp/$n.toml" --replay --trace "$tmp/$n.csv" > /dev/null
  runs+=("$n=$tmp/$n.csv")
done
/usr/bin/python3 docs/figures/plot_organ.py docs/figures/organ_runs.png "${runs[@]}"
rm -rf "$tmp"
