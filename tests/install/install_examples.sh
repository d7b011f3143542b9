#!/usr/bin/env bash
# CTest install_examples (tests/CMakeLists.txt, docs/package.md):
# installs the build tree into a temporary prefix, then, against that prefix only
# (CMAKE_PREFIX_PATH, never the build tree), configures, builds and runs the two C++ examples
# (examples/scene_step on the installed probe.toml and SCENE_NAME, examples/minimal_core) and
# compiles every installed header on its own (tests/install/header_check); where the build made
# the Python module, imports it from the prefix alone (PYTHONPATH the prefix's, run from outside
# the source tree), checks that it finds the prefix's share/numen, and runs the README's Python
# loop as written there and examples/python_push.py. The figures the examples print are checked.
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
# The docs: the top-level README and docs/README.md (the docs' index) under their own names (both
# went to share/doc/numen/README.md, the one installed last winning).
cmp -s "$src/README.md" "$prefix/share/doc/numen/README.md" || fail "share/doc/numen/README.md is not README.md"
cmp -s "$src/docs/README.md" "$prefix/share/doc/numen/docs/README.md" \
  || fail "share/doc/numen/docs/README.md is not docs/README.md"
[ -f "$prefix/share/doc/numen/docs/python.md" ] || fail "docs/ is not in share/doc/numen/docs"
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
# With no argument it loads the installed default scene (sim::default_scene_path()).
if [ "$default_loads" = yes ]; then
  "$work/scene_step/scene_step" --steps 10 >"$work/scene_step_default.out" 2>&1 \
    || { cat "$work/scene_step_default.out"; fail "scene_step without a scene"; }
fi
tail -n 3 "$work/scene_step.out"
# The lattice scene's trajectory is the instrument's tip: the held tube's centre of mass is 40 mm
# behind it, and the recorded wrist 16.5° off the shaft (docs/scenes.md "Drive it from your own
# program").
if [ "$scene" = lattice.toml ]; then
  grep -qx "trajectory sample at 0 s (tool frame) to the held body's target: 40.0 mm, 16.5 deg" \
    "$work/scene_step.out" || { cat "$work/scene_step.out"; fail "scene_step: tool frame offset"; }
fi
# The library scene (no [trajectory]): the probe's target 20 mm down from 5 mm above the box; the
# probe stays on the box's top face, under 1 mm in, and the feedback pushes the hand up.
"$work/scene_step/scene_step" "$prefix/share/numen/scenes/probe.toml" >"$work/scene_step_probe.out" 2>&1 \
  || { cat "$work/scene_step_probe.out"; fail "scene_step probe.toml"; }
finite_only "$work/scene_step_probe.out"
# sim::default_scene_path() of a program built on the installed package is the prefix's (it was
# numen's source tree's: only numen_DATA_DIR in CMake gave the prefix's).
grep -qx "default scene $prefix/share/numen/scenes/default.toml" "$work/scene_step_probe.out" \
  || { cat "$work/scene_step_probe.out"; fail "scene_step: default_scene_path() is not the prefix's"; }
grep -q "^deepest contact .* body 'probe' on obstacle 'box'$" "$work/scene_step_probe.out" \
  && grep -qx "invalid target steps 0" "$work/scene_step_probe.out" \
  && awk '/^max penetration/ { p = $3 } /^t 1.000/ { f = $15 }
          END { exit (p > 0 && p < 1e-3 && f > 0) ? 0 : 1 }' "$work/scene_step_probe.out" \
  || { cat "$work/scene_step_probe.out"; fail "scene_step probe.toml: contact on 'box' under 1 mm, feedback up"; }
tail -n 3 "$work/scene_step_probe.out"

configure_build minimal_core "$src/examples/minimal_core"
"$work/minimal_core/minimal_core" >"$work/minimal_core.out" 2>&1 || { cat "$work/minimal_core.out"; fail "minimal_core"; }
finite_only "$work/minimal_core.out"
tail -n 2 "$work/minimal_core.out"
# The sphere rests on the floor: penetration about coupling force / contact stiffness
# (100 N/m · 15 mm / 1e4 N/m = 0.15 mm), well under 1 mm; the feedback pushes the hand up.
awk '/^final penetration/ { p = $3; f = $7; ok = (p > 0 && p < 1e-3 && f > 0) }
     END { exit ok ? 0 : 1 }' "$work/minimal_core.out" \
  || fail "minimal_core: final penetration not in (0, 1 mm) or feedback not upward"

# The Python module, when the build made it (NUMEN_PYTHON): imported from the prefix alone (run
# from the work folder, PYTHONPATH the prefix's only), it finds the prefix's share/numen as the
# installed `numen` does (not the source tree it was built from), and runs the installed scene
# through the simulated bus.
module=$(find "$prefix" -name 'numen*.so' -path '*dist-packages*' | head -n 1)
if [ -n "$module" ]; then
  pythonpath=$(dirname "$module")
  [ "$pythonpath" = "$prefix/lib/python3/dist-packages" ] || fail "module in $pythonpath, not where the README says"
  (cd "$work" && PYTHONPATH=$pythonpath /usr/bin/python3 -c "
import numen, os, sys
assert numen.__file__.startswith('$prefix'), numen.__file__
default = numen.default_scene_path()
assert default == os.path.join('$prefix', 'share/numen/scenes/default.toml'), default
s = numen.load_scene(os.path.join(os.path.dirname(default), '$scene'))
assert s.file.startswith('$prefix'), s.file
if '$default_loads' == 'yes':
    d = numen.load_scene(default)
    print('python: default scene', d.name, 'from', os.path.dirname(d.file))
r = numen.run_scene(s, duration=0.2)
print('python: numen from the prefix, run exit status', r['exit_status'])
sys.exit(r['exit_status'])") >"$work/python.out" 2>&1 || { cat "$work/python.out"; fail "import numen from $prefix"; }
  cat "$work/python.out"
  # The README's Python loop, as written there, with the installed PYTHONPATH.
  if [ "$default_loads" = yes ]; then
    sed -n '/^PYTHONPATH=build\/sim\/python \/usr\/bin\/python3 -c "$/,/"$/p' "$src/README.md" \
      | sed "s|^PYTHONPATH=build/sim/python |PYTHONPATH=$pythonpath |" >"$work/readme_loop.sh"
    [ "$(wc -l <"$work/readme_loop.sh")" -ge 5 ] || fail "no Python loop found in README.md"
    (cd "$work" && bash "$work/readme_loop.sh") >"$work/readme_loop.out" 2>&1 \
      || { cat "$work/readme_loop.out"; fail "the README's Python loop"; }
    [ "$(tail -n 1 "$work/readme_loop.out")" = 0 ] || { cat "$work/readme_loop.out"; fail "README loop: run exit status"; }
    tail -n 2 "$work/readme_loop.out"
  fi
  # examples/python_push.py on the installed probe.toml: the probe rests on the box under 1 mm
  # in, the feedback is the Eq. 8 spring 200 N/m × (probe − target) (< 1 % off: its damping
  # term is the probe's rest), pushing up.
  (cd "$work" && PYTHONPATH=$pythonpath /usr/bin/python3 "$src/examples/python_push.py") \
    >"$work/python_push.out" 2>&1 || { cat "$work/python_push.out"; fail "examples/python_push.py"; }
  finite_only "$work/python_push.out"
  awk '/ into the box$/ { target = $7; centre = $11; depth = $13 }
       /^contacts 1 on box;/ { box = 1 }
       /^feedback force/ { f = $3; invalid = $NF }
       END { spring = 200 * (centre - target) / 1000
             exit (box && depth > 0 && depth < 1 && f > 0 && invalid == 0 &&
                   (f - spring) < 0.01 * spring && (spring - f) < 0.01 * spring) ? 0 : 1 }' \
    "$work/python_push.out" || { cat "$work/python_push.out"; fail "python_push.py figures"; }
  cat "$work/python_push.out"
fi

configure_build header_check "$src/tests/install/header_check"
grep 'header_check:' "$work/header_check.configure.log" || true
echo "install_examples: ok ($(( $(date +%s) - t0 )) s)"
