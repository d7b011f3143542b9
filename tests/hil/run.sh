#!/usr/bin/env bash
# Hardware-in-the-loop run: builds numen's HIL programs, builds the guest image, boots it in
# qemu (TCG, no KVM needed) and checks the scenario results printed on the serial console.
#
# Usage: tests/hil/run.sh [BUILD_DIR]       (default BUILD_DIR: <repo>/build-hil/build)
# Environment: NUMEN_HIL_JOBS (build jobs, default 2), NUMEN_HIL_TIMEOUT (seconds for the whole
# qemu run, default 1500: room for inconclusive attempts), NUMEN_HIL_CACHE (downloaded
# packages, default <repo>/build-hil/deps),
# NUMEN_HIL_PAIR_PERIOD_US (control period of the controller + device scenarios, default 10000),
# NUMEN_HIL_OVERRUN_LIMIT (their numen run --overrun-limit, default 0: overruns counted only).
# Output: the guest console, then one line per scenario and "hil: N passed, M failed".
# Exit 0 only if every scenario in tests/hil/scenarios/ printed PASS. Any failure to build,
# boot or finish is a failure with a message: nothing is skipped.
set -euo pipefail
t_start=$(date +%s.%N)
here="$(cd "$(dirname "$0")" && pwd)"
repo="$(cd "$here/../.." && pwd)"
build="${1:-$repo/build-hil/build}"
jobs="${NUMEN_HIL_JOBS:-2}"
limit="${NUMEN_HIL_TIMEOUT:-1500}"
die() { echo "hil: FAIL: $*" >&2; exit 1; }
elapsed() { awk -v a="$1" -v b="$(date +%s.%N)" 'BEGIN {printf "%.1f", b - a}'; }

# 1. Host tools and guest packages.
bash "$here/deps" || die "tests/hil/deps could not install or download what the guest needs"

# 2. numen's HIL programs.
echo "hil: building numen_hil_tests, numen_hil_can and numen in $build"
# Only the targets below are built, so an existing build directory (CI passes the README's
# ./build) gains just the HIL programs: its libraries and numen are already up to date.
cmake -S "$repo" -B "$build" -DNUMEN_BUILD_HIL=ON >/dev/null ||
  die "cmake configure of $build failed"
cmake --build "$build" --target numen_hil_tests numen_hil_can numen -j"$jobs" >"$build/hil-build.log" 2>&1 ||
  { tail -n 40 "$build/hil-build.log" >&2; die "build failed (log: $build/hil-build.log)"; }

# 3. The guest image.
image="$build/hil-image"
bash "$here/build_image.sh" "$build" "$image" || die "building the guest image failed"
image_kib=$(( ($(stat -c %s "$image/initramfs.cpio.gz") + $(stat -c %s "$image/vmlinuz")) / 1024 ))

# 4. Boot. The guest's /init runs the scenarios and powers off; panic=-1 plus -no-reboot turn
# a kernel panic into a qemu exit. timeout bounds everything.
command -v qemu-system-x86_64 >/dev/null || die "qemu-system-x86_64 not found"
log="$build/hil-console.log"
# Control period of the controller + device scenarios (70+) in the guest: the scene's 1 kHz is
# beyond what qemu's TCG emulation holds on a 2-core machine (docs/hil.md, "Control period").
pair_period_us="${NUMEN_HIL_PAIR_PERIOD_US:-10000}"
# Their overrun policy (numen run --overrun-limit): 0 counts and reports overruns without
# latching the safe state, since a host preempting the emulator stalls the guest for periods.
overrun_limit="${NUMEN_HIL_OVERRUN_LIMIT:-0}"
echo "hil: booting $(cat "$image/kernel-version") under qemu (TCG), limit ${limit}s, console: $log"
t_boot=$(date +%s.%N)
# This machine's CPU time and the part the hypervisor stole (/proc/stat's cpu line: user..steal,
# steal 8th), jiffies: a host that starves this machine starves the emulator with it.
cpu_times() { awk '/^cpu / { t = 0; for (i = 2; i <= 9; i++) t += $i; print t, $9 }' /proc/stat; }
read -r cpu0 steal0 < <(cpu_times)
set +e
timeout --kill-after=10 "$limit" qemu-system-x86_64 -accel tcg -nographic -no-reboot -m 512M -smp 2 \
  -kernel "$image/vmlinuz" -initrd "$image/initramfs.cpio.gz" \
  -append "console=ttyS0 panic=-1 quiet loglevel=3 HIL_PAIR_PERIOD_US=$pair_period_us HIL_OVERRUN_LIMIT=$overrun_limit" </dev/null 2>&1 |
  while IFS= read -r line; do
    line="${line%$'\r'}"
    case "$line" in
      *HIL-START*) echo "HIL-START${line#*HIL-START} host_boot_s=$(elapsed "$t_boot")" ;;
      *) printf '%s\n' "$line" ;;
    esac
  done | tee "$log"
qemu_rc=${PIPESTATUS[0]}
set -e
t_run=$(elapsed "$t_boot")
read -r cpu1 steal1 < <(cpu_times)
steal_pct=$(awk -v c="$((cpu1 - cpu0))" -v s="$((steal1 - steal0))" 'BEGIN { printf "%.0f", (c > 0 ? 100 * s / c : 0) }')

# 5. Verdict.
[ "$qemu_rc" -ne 124 ] && [ "$qemu_rc" -ne 137 ] || echo "hil: qemu killed after ${limit}s" >&2
[ "$qemu_rc" -eq 0 ] || [ "$qemu_rc" -eq 124 ] || [ "$qemu_rc" -eq 137 ] ||
  echo "hil: qemu exited with status $qemu_rc" >&2
grep -q '^HIL-START' "$log" || die "the guest did not boot to its scenarios (qemu status $qemu_rc; see $log)"
if grep -q '^HIL setup FAIL' "$log"; then
  die "guest setup failed: $(grep '^HIL setup FAIL' "$log" | head -n 1)"
fi
passed=0
failed=0
summary=()
for script in "$here"/scenarios/*.sh; do
  name="${script##*/}"
  name="${name%.sh}"
  name="${name#[0-9][0-9]-}"
  result="$(grep -E "^HIL $name (PASS|FAIL)" "$log" | tail -n 1 || true)"
  if [ -z "$result" ]; then
    result="HIL $name FAIL no result on the console"
  fi
  inconclusive="$(grep -E "^HIL $name INCONCLUSIVE" "$log" | sed "s/^HIL $name INCONCLUSIVE //" | paste -sd ';' || true)"
  [ -z "$inconclusive" ] || result="$result [inconclusive attempts before: $inconclusive]"
  case "$result" in
    "HIL $name PASS"*) passed=$((passed + 1)) ;;
    *) failed=$((failed + 1)) ;;
  esac
  summary+=("$result")
done
grep -q '^HIL-END' "$log" || { failed=$((failed + 1)); summary+=("HIL guest FAIL did not finish (no HIL-END)"); }
boot_line="$(grep '^HIL-START' "$log" | head -n 1)"
echo
echo "hil: results"
printf '  %s\n' "${summary[@]}"
echo "hil: image $image_kib KiB (kernel + initramfs); ${boot_line#HIL-START }; qemu run ${t_run}s (host steal ${steal_pct} % of this machine's CPU time); total $(elapsed "$t_start")s"
echo "hil: $passed passed, $failed failed"
[ "$failed" -eq 0 ] && [ "$passed" -gt 0 ]
