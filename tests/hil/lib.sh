# Shared helpers of the HIL scenario scripts (sourced; busybox sh). A scenario prints exactly
# one result line through pass or fail; /init reports a missing line as a failure.
# HIL_NAME is the scenario name (file name without the NN- prefix and .sh), set by /init.

pass() { echo "HIL $HIL_NAME PASS $*"; exit 0; }
fail() { echo "HIL $HIL_NAME FAIL $*"; exit 1; }
# inconclusive REASON: the scenario's premise did not hold for a cause outside what it tests
# (the emulator stalled the guest long enough for a timing safe stop before the torque the
# scenario acts on flowed). /init runs the scenario again, at most 5 attempts, and reports a
# FAIL if none was conclusive; a PASS or FAIL is never run again.
inconclusive() { echo "HIL $HIL_NAME INCONCLUSIVE $*"; exit 3; }

# fail_timing RUN_TXT MESSAGE: fails a check that holds only while the guest runs in real time
# (socket drops, SYNC pacing, frames read in time): inconclusive instead if the numen run whose
# summary is RUN_TXT got less than 0.8 of real time ("(0.371x real time)": the host starved the
# emulator; a local HIL run on 2026-11-22: a 5 s replay run took 13.6 s and its socket dropped 467
# frames).
fail_timing() {
  local f
  f=$(grep -o -m1 '([0-9.]*x real time)' "$1" | tr -d '(x' | cut -d' ' -f1)
  awk -v f="$f" 'BEGIN { exit !(f != "" && f < 0.8) }' &&
    inconclusive "$2 (the guest ran at ${f}x real time)"
  fail "$2"
}

# first_fault RUN_TXT: the summary's first safe-stop cause, "first: <cause>" (empty if none).
first_fault() { grep -o 'first: [a-z ]*' "$1" | head -n 1 | sed 's/ *$//'; }

# timing_cause FIRST: true if FIRST (a summary's "first: <cause>") is a safe-stop cause the
# guest's timing explains (a stalled emulator: encoder timeout, overruns, heartbeat loss, or the
# encoder jump of the samples a stall skipped), not the protocol (bad input, EMCY, drive fault,
# range, non-finite values).
timing_cause() {
  echo "$1" | grep -q -E '^first: (encoder timeout|overruns|heartbeat lost|encoder jump)'
}

# fail_premise FIRST MESSAGE: the scenario's premise (torque flowing before the act it checks)
# did not hold. Inconclusive if FIRST, the safe stop that came first ("first: <cause>"), has a
# timing cause (timing_cause); FAIL otherwise.
fail_premise() {
  timing_cause "$1" && inconclusive "$2 (a timing safe stop came first: $1)"
  fail "$2"
}

# expect_status RC RUN_TXT STATUS...: the numen run's exit status RC is the one its summary
# RUN_TXT states ("exit status N (...)") and one of STATUS..., the statuses this scenario may
# end with (docs/inputs.md: 0 clean, 3 safety stop, 6 samples rejected, ...).
expect_status() {
  local rc="$1" txt="$2" stated s
  shift 2
  stated=$(field "$txt" 'exit status ')
  [ "$rc" = "$stated" ] || fail "numen run exited with $rc but its summary says exit status ${stated:-(none)}"
  for s in "$@"; do [ "$rc" = "$s" ] && return 0; done
  fail "numen run exited with $rc ($(grep -o -m1 'exit status .*' "$txt")); expected one of: $*"
}

# Waits until FILE contains LINE (a whole line), at most SECONDS (integer) seconds.
wait_for_line() {
  local file="$1" line="$2" left=$(( $3 * 10 ))
  while [ "$left" -gt 0 ]; do
    grep -qx "$line" "$file" 2>/dev/null && return 0
    usleep 100000
    left=$((left - 1))
  done
  return 1
}

# numen run / numen device helpers (scenarios 70+). The scene and its data are in /hil/sim.
HIL_SCENE=/hil/sim/scenes/lattice.toml

# pair_scene PERIOD_US: writes /hil/sim/scenes/pair.toml, the lattice scene with its control
# period (dt: the SYNC period and step of both processes) set to PERIOD_US microseconds, the
# encoder sample age left to its default of 3 periods, and the CANopen heartbeats every 10
# periods (at least 10 ms; consumer timeout 3 heartbeats); points HIL_SCENE at it.
pair_scene() {
  local us="$1" out=/hil/sim/scenes/pair.toml
  local dt hb
  dt=$(awk -v u="$us" 'BEGIN { printf "%.6f", u * 1e-6 }')
  hb=$((us / 100))
  [ "$hb" -ge 10 ] || hb=10
  sed -e "s/^dt = 0\.001\$/dt = $dt/" -e '/^max_sample_age = /d' \
    /hil/sim/scenes/lattice.toml >"$out"
  grep -q "^dt = $dt\$" "$out" || fail "pair_scene: no 'dt = 0.001' line to replace in lattice.toml"
  # The heartbeat keys go into lattice.toml's [device.canopen]. The nodes come configured (the
  # node DCF lines are dropped): these scenarios time the loop, torque and faults from the first
  # periods on, and `numen device`'s nodes hold what the DCFs would write (the configuration
  # over SDO is covered by scan_and_sdo's transfers and the DcfConfiguration/CanopenMaster tests).
  grep -q '^\[device\.canopen\]$' "$out" || fail "pair_scene: lattice.toml has no [device.canopen]"
  sed -i "s/^\[device\.canopen\]\$/[device.canopen]\ncontroller_heartbeat_period = $hb\nnode_heartbeat_period = $hb/" "$out"
  sed -i '/^dcf = "devices\//d' "$out"
  ! grep -q '^dcf = ' "$out" || fail "pair_scene: a dcf line is left in pair.toml"
  HIL_SCENE="$out"
}

# field FILE REGEX: the first number after REGEX (an extended regex) on the first line that
# matches it, e.g. field run.txt 'frames rx ' -> 10342.
field() {
  grep -E -o -m1 "$2[-0-9.]+" "$1" | head -n 1 | sed -E 's/.*[^-0-9.]([-0-9.]+)$/\1/' 
}

# start_device LOG [EXTRA...]: starts `numen device` on vcan0 in the background (pid in
# DEVICE_PID) and waits for READY. LOG is removed first: the background shell truncates it
# only when it gets to run, and a READY left by an earlier scenario (or attempt) would
# otherwise let the caller start the controller while the device is still loading its scene,
# with its socket not yet open (the flood scenario's missing SYNCs, docs/hil.md).
start_device() {
  local log="$1"
  shift
  rm -f "$log"
  numen device "$HIL_SCENE" --bus can:vcan0 --ready "$@" >"$log" 2>&1 &
  DEVICE_PID=$!
  wait_for_line "$log" READY 30 || fail "device not ready: $(cat "$log")"
}

# e2e_histogram TRACE.csv BIN_US: bins the end_to_end_us column of a real-bus trace into BIN_US
# bins and prints "HIL-CSV <scenario>,<bin lower edge us>,<count>" lines
# (docs/figures/plot_hil_latency.py reads them from the console log).
e2e_histogram() {
  awk -F, -v name="$HIL_NAME" -v w="${2:-20}" '
    NR == 1 { for (i = 1; i <= NF; i++) if ($i == "end_to_end_us") c = i; next }
    c { b = int($c / w) * w; n[b]++; if (b > m) m = b }
    END { for (b = 0; b <= m; b += w) if (n[b]) printf "HIL-CSV %s,%d,%d\n", name, b, n[b] }' "$1"
}
