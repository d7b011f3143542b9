#!/usr/bin/env bash
# CTest install_examples (tests/CMakeLists.txt, docs/architecture.md "Installed package"):
# installs the build tree into a temporary prefix, then, against that prefix only
# (CMAKE_PREFIX_PATH, never the build tree), configures, builds and runs the two examples
# (examples/scene_step, examples/minimal_core) and compiles every installed header on its own
# (tests/install/header_check).
#
#   install_examples.sh BUILD_DIR SOURCE_DIR WORK_DIR CXX SCENE_NAME DEFAULT_LOADS
#
# SCENE_NAME: the shipped scene scene_step runs (lattice.toml needs NUMEN_WITH_ARTICULATION).
# DEFAULT_LOADS: yes when the build loads the default scene (joints and a net): scene_step is
# then also run without a scene, for a few steps.
set -euo pipefail
build=$1 src=$2 work=$3 cxx=$4 scene=$5 default_loads=$6
rm -rf "$work"
mkdir -p "$work"
prefix=$work/prefix
t0=$(date +%s)

fail() { echo "install_examples: FAILED: $*" >&2; exit 1; }

cmake --install "$build" --prefix "$prefix" >"$work/install.log" || { cat "$work/install.log"; fail "cmake --install"; }
[ -f "$prefix/lib/cmake/numen/numenConfig.cmake" ] || [ -n "$(find "$prefix" -name numenConfig.cmake)" ] \
  || fail "no numenConfig.cmake under $prefix"
# The build tree must not be what the consumers find.
export CMAKE_PREFIX_PATH=$prefix
unset numen_DIR || true

configure_build() {  # NAME SOURCE
  cmake -S "$2" -B "$work/$1" -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_COMPILER="$cxx" \
        -DCMAKE_PREFIX_PATH="$prefix" -DCMAKE_FIND_PACKAGE_NO_PACKAGE_REGISTRY=ON \
        >"$work/$1.configure.log" 2>&1 || { cat "$work/$1.configure.log"; fail "configure $1"; }
  local dir
  dir=$(sed -n 's/^numen_DIR:PATH=//p' "$work/$1/CMakeCache.txt")
  case "$dir" in "$prefix"/*) ;; *) fail "$1 found numen in '$dir', not in $prefix" ;; esac
  cmake --build "$work/$1" -j2 >"$work/$1.build.log" 2>&1 || { cat "$work/$1.build.log"; fail "build $1"; }
}

finite_only() {  # FILE: no nan/inf anywhere
  if grep -qiE '(^|[^a-z])(nan|inf)([^a-z]|$)' "$1"; then cat "$1"; fail "non-finite number in $1"; fi
}

configure_build scene_step "$src/examples/scene_step"
"$work/scene_step/scene_step" "$prefix/share/numen/scenes/$scene" >"$work/scene_step.out" 2>&1 \
  || { cat "$work/scene_step.out"; fail "scene_step $scene"; }
finite_only "$work/scene_step.out"
[ "$(grep -c '^t ' "$work/scene_step.out")" -ge 10 ] || { cat "$work/scene_step.out"; fail "scene_step printed too few steps"; }
# With no argument it loads the installed default scene (numen_DEFAULT_SCENE).
if [ "$default_loads" = yes ]; then
  "$work/scene_step/scene_step" --steps 10 >"$work/scene_step_default.out" 2>&1 \
    || { cat "$work/scene_step_default.out"; fail "scene_step without a scene"; }
fi
tail -n 3 "$work/scene_step.out"

configure_build minimal_core "$src/examples/minimal_core"
"$work/minimal_core/minimal_core" >"$work/minimal_core.out" 2>&1 || { cat "$work/minimal_core.out"; fail "minimal_core"; }
finite_only "$work/minimal_core.out"
tail -n 2 "$work/minimal_core.out"
# The sphere rests on the floor: penetration about coupling force / contact stiffness
# (100 N/m · 15 mm / 1e4 N/m = 0.15 mm), well under 1 mm; the feedback pushes the hand up.
awk '/^final penetration/ { p = $3; f = $7; ok = (p > 0 && p < 1e-3 && f > 0) }
     END { exit ok ? 0 : 1 }' "$work/minimal_core.out" \
  || fail "minimal_core: final penetration not in (0, 1 mm) or feedback not upward"

# The Python module, when the build made it (NUMEN_PYTHON): imported from the prefix alone runs
# the installed scene through the simulated bus.
module=$(find "$prefix" -name 'numen*.so' -path '*dist-packages*' | head -n 1)
if [ -n "$module" ]; then
  PYTHONPATH=$(dirname "$module") /usr/bin/python3 -c "
import numen, sys
assert numen.__file__.startswith('$prefix'), numen.__file__
s = numen.load_scene('$prefix/share/numen/scenes/$scene')
r = numen.run_scene(s, duration=0.2)
print('python: numen from the prefix, run exit status', r['exit_status'])
sys.exit(r['exit_status'])" >"$work/python.out" 2>&1 || { cat "$work/python.out"; fail "import numen from $prefix"; }
  cat "$work/python.out"
fi

configure_build header_check "$src/tests/install/header_check"
grep 'header_check:' "$work/header_check.configure.log" || true
echo "install_examples: ok ($(( $(date +%s) - t0 )) s)"
