#!/usr/bin/env bash
# CTest entry of the node-canopen interoperability tests (tests/interop, docs/protocol.md
# "Interoperability with node-canopen"):
#
#   run.sh NPM_DIR PTYS SKIP_REASON -- node ARGS...
#
# Skips (77) with the reason when SKIP_REASON is not empty (a build without the serial backend
# or without what the scenario's scene needs) or when node or npm is missing (CI installs them:
# .ci/run). Otherwise installs the npm packages pinned in package-lock.json into NPM_DIR with
# `npm ci` (once per lock file; serialised with flock so that parallel tests do not install
# twice), then runs `node ARGS` with NODE_PATH there, through pty_pairs.py with PTYS
# pseudo-terminal pairs. Nothing is downloaded after `npm ci`. PTYS = 0: `node ARGS` alone
# (the framing test needs neither the packages nor a line).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
npm_dir=$1 ptys=$2 skip=$3
shift 3
[ "$1" = -- ] && shift
if [ -n "$skip" ]; then echo "SKIP: $skip"; exit 77; fi
for tool in node npm; do
  command -v "$tool" >/dev/null || { echo "SKIP: $tool is not installed (CI: bash .ci/deps nodejs npm)"; exit 77; }
done
[ "$ptys" = 0 ] && exec "$@"
mkdir -p "$npm_dir"
(
  flock 9
  if ! cmp -s "$here/package-lock.json" "$npm_dir/package-lock.json" || [ ! -d "$npm_dir/node_modules/canopen" ]; then
    cp "$here/package.json" "$here/package-lock.json" "$npm_dir/"
    t0=$(date +%s.%N)
    # node-crc (a dependency of canopen) builds a native module with node-gyp: against the
    # installed node's headers when they are there, not downloaded ones.
    nodedir=()
    [ -f /usr/include/node/node.h ] && nodedir=(--nodedir=/usr)
    (cd "$npm_dir" && npm ci --no-audit --no-fund "${nodedir[@]}" >npm-ci.log 2>&1) ||
      { cat "$npm_dir/npm-ci.log"; rm -f "$npm_dir/package-lock.json"; exit 1; }
    echo "npm ci: $(awk -v a="$t0" -v b="$(date +%s.%N)" 'BEGIN { printf "%.1f", b - a }') s"
  fi
) 9>"$npm_dir/.lock"
export NODE_PATH="$npm_dir/node_modules"
exec /usr/bin/python3 "$here/pty_pairs.py" "$ptys" -- "$@"
