#!/usr/bin/env bash
# CTest debian_package (tests/CMakeLists.txt, cmake/package.cmake, docs/deploy.md): builds
# numen_<version>_amd64.deb from the configured and built tree (cpack -G DEB, prefix /usr),
# lists it and checks the expected files, runs lintian (no E: line allowed; warnings printed),
# extracts it into a temporary root (dpkg -x) and runs the extracted /usr/bin/numen on the
# extracted default scene: the executable finds its data relative to itself.
#
#   debian_package.sh BUILD_DIR WORK_DIR SCENE_NAME DEFAULT_LOADS
#
# SCENE_NAME: the shipped scene the extracted numen runs; DEFAULT_LOADS: yes when the build
# loads the default scene (joints and a net), which is then found with no scene given.
#
# Exit 77 (skipped) only when dpkg-deb or lintian is missing (.ci/deps installs lintian).
set -euo pipefail
build=$1 work=$2 scene=$3 default_loads=$4
for tool in dpkg-deb dpkg-shlibdeps lintian; do
  command -v "$tool" >/dev/null || { echo "debian_package: $tool not found: skipped"; exit 77; }
done
fail() { echo "debian_package: FAILED: $*" >&2; exit 1; }
rm -rf "$work"
mkdir -p "$work"
t0=$(date +%s)

cpack --config "$build/CPackConfig.cmake" -G DEB -B "$work" >"$work/cpack.log" 2>&1 \
  || { cat "$work/cpack.log"; fail "cpack"; }
debs=("$work"/numen_*_amd64.deb)
[ -f "${debs[0]}" ] || { ls "$work"; fail "no numen_*_amd64.deb"; }
deb=${debs[0]}
echo "package: $(basename "$deb") ($(du -k "$deb" | cut -f1) KiB)"
dpkg-deb -f "$deb" Package Version Architecture Section Maintainer Depends

dpkg-deb -c "$deb" | awk '{ print $6 }' | sed 's|^\./|/|' >"$work/contents.txt"
for f in /usr/bin/numen \
         /usr/share/numen/scenes/default.toml \
         /usr/share/numen/data/jigsaws_suturing_b002_excerpt.txt \
         /usr/share/numen/viewer/index.html \
         /usr/include/numen/version.hpp /usr/include/numen/core/model.hpp \
         /usr/include/numen/core/features.hpp /usr/include/numen/sim/scene/scene.hpp \
         /usr/lib/cmake/numen/numenConfig.cmake /usr/lib/cmake/numen/numenConfigVersion.cmake \
         /usr/lib/cmake/numen/numenTargets.cmake \
         /usr/share/doc/numen/copyright /usr/share/doc/numen/docs/deploy.md \
         /lib/systemd/system/numen.service /etc/numen/scene.toml \
         /etc/security/limits.d/numen.conf; do
  grep -qx "$f" "$work/contents.txt" || fail "$f is not in the package"
done
grep -q '^/usr/lib/libnumen_core\.\(a\|so\)' "$work/contents.txt" || fail "no libnumen_core in the package"
# Internals stay out.
if grep -qE 'detail/|/cli_values\.hpp$|/progress_bar\.hpp$' "$work/contents.txt"; then
  fail "an internal header is in the package"
fi
dpkg-deb --ctrl-tarfile "$deb" | tar -xO ./conffiles >"$work/conffiles"
grep -qx /etc/numen/scene.toml "$work/conffiles" || fail "/etc/numen/scene.toml is not a conffile"

lintian --tag-display-limit 0 "$deb" >"$work/lintian.txt" 2>&1 || true
echo "lintian: $(grep -c '^E:' "$work/lintian.txt" || true) errors, $(grep -c '^W:' "$work/lintian.txt" || true) warnings"
grep -E '^(E|W):' "$work/lintian.txt" | sed 's/^/  /' || true
if grep -q '^E:' "$work/lintian.txt"; then fail "lintian reports errors"; fi

root=$work/root
dpkg -x "$deb" "$root"
grep -q '^ExecStart=/usr/bin/numen run /etc/numen/scene.toml' "$root/lib/systemd/system/numen.service" \
  || fail "numen.service does not start /usr/bin/numen on /etc/numen/scene.toml"
grep -q 'file = "/usr/share/numen/data/' "$root/etc/numen/scene.toml" \
  || fail "/etc/numen/scene.toml does not read its recording from /usr/share/numen/data"
"$root/usr/bin/numen" --version
(cd "$work" && "$root/usr/bin/numen" run "$root/usr/share/numen/scenes/$scene" --duration 0.2) \
  >"$work/run.log" 2>&1 || { cat "$work/run.log"; fail "numen run from the extracted root"; }
tail -n 3 "$work/run.log"
# With no scene, the extracted numen finds the default scene relative to itself.
if [ "$default_loads" = yes ]; then
  (cd "$work" && "$root/usr/bin/numen" info --json) >"$work/info.json" 2>&1 \
    || { cat "$work/info.json"; fail "numen info (default scene) from the extracted root"; }
  grep -qF "\"file\":\"$root/usr/share/numen/scenes/default.toml\"" "$work/info.json" \
    || { head -c 300 "$work/info.json"; fail "numen info did not load the extracted default scene"; }
fi
# The Python module, when the package holds it: where Debian's python3 looks under /usr.
if [ -n "$(dpkg-deb -c "$deb" | grep 'usr/lib/python3/dist-packages/numen')" ]; then
  PYTHONPATH="$root/usr/lib/python3/dist-packages" /usr/bin/python3 -c "
import numen, sys
s = numen.load_scene('$root/usr/share/numen/scenes/$scene')
sys.exit(numen.run_scene(s, duration=0.2)['exit_status'])" >"$work/python.log" 2>&1 \
    || { cat "$work/python.log"; fail "import numen from the extracted /usr/lib/python3/dist-packages"; }
  echo "python: the packaged module runs the packaged scene"
fi
echo "debian_package: ok ($(( $(date +%s) - t0 )) s)"
