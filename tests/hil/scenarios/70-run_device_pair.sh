# Scenario (a): `numen run --bus can:vcan0` (the controller, paced at the scene's 1 kHz) and
# `numen device --bus can:vcan0` (the simulated instrument: CANopen nodes, heartbeats, CiA 402
# drives, encoders playing the trajectory) as two processes on one vcan, recorded by candump.
# Pass: the start-up reaches active, torque flows (the device applied non-zero torque), no
# frame lost (SocketCAN drops 0 on both ports, every SYNC answered by the device, the
# controller read every period's sample), candump's SYNC period median 1 ms +- 0.1 ms, the
# log holds only the device's and the controller's ids; the default scene's [device.plant] closes
# the haptic loop in the device process (the trainer moves under the torques it receives and the
# simulated hand) and it stays free of limit cycles with its plant bounded. Prints the latency
# figures and the end-to-end histogram as HIL-CSV lines.
. /hil/lib.sh
period_us=${HIL_PAIR_PERIOD_US:-1000}
pair_scene "$period_us"
duration=10
candump -L vcan0 >/tmp/pair.log 2>/tmp/candump.err &
dump=$!
start_device /tmp/dev.txt
numen run "$HIL_SCENE" --bus can:vcan0 --duration "$duration" --overrun-limit "${HIL_OVERRUN_LIMIT:-3}" --trace /tmp/pair.csv >/tmp/run.txt 2>&1
rc=$?
usleep 200000
kill -TERM "$DEVICE_PID"
wait "$DEVICE_PID"
kill "$dump"
cat /tmp/run.txt /tmp/dev.txt
expect_status "$rc" /tmp/run.txt 0 3 5 6  # 5: trace records lost by a starved guest, judged below (fail_timing)
rx_drop=$(field /tmp/run.txt 'frames rx [0-9]+, tx [0-9]+, dropped ')
active=$(field /tmp/run.txt 'active at period ')
invalid=$(field /tmp/run.txt 'invalid periods ')
faults=$(field /tmp/run.txt 'safety: ')
trace_drop=$(field /tmp/run.txt 'trace records [0-9]+, dropped ')
first_fault=$(first_fault /tmp/run.txt)
torque_periods=$(awk -F, 'NR > 1 && $6 == 1 { n++ } END { print n + 0 }' /tmp/pair.csv)
syncs=$(field /tmp/dev.txt 'SYNCs ')
answered=$(field /tmp/dev.txt 'answered ')
nonzero=$(field /tmp/dev.txt 'non-zero torque ')
dev_drop=$(field /tmp/dev.txt 'port: rx [0-9]+, tx [0-9]+, dropped ')
overruns=$(field /tmp/run.txt 'loop overruns: ')
e2e=$(grep 'end-to-end (SYNC' /tmp/run.txt | sed 's/.*us: //')
device_loop=$(grep -o 'device loop [a-z]*' /tmp/dev.txt | awk '{ print $3 }')
limit_cycle=$(grep -o 'limit cycle [a-z]*' /tmp/dev.txt | awk '{ print $3 }')
plant=$(grep -o 'plant [a-z]*$' /tmp/dev.txt | awk '{ print $2 }')
closed_loop=$(grep 'device loop' /tmp/dev.txt | sed 's/^ *//')
ctl_syncs=$(grep -c '^([0-9.]*) vcan0 080#' /tmp/pair.log)
# SYNC period median from candump's timestamps (us).
sync_median=$(grep ' vcan0 080#' /tmp/pair.log | sed 's/^(\([0-9]*\)\.\([0-9]*\)).*/\1\2/' |
  awk 'NR > 1 { print $1 - p } { p = $1 }' | sort -n | awk '{ a[NR] = $1 } END { print a[int((NR + 1) / 2)] }')
ids=$(sed 's/^([0-9.]*) vcan0 \([0-9A-F]*\)#.*/\1/' /tmp/pair.log | sort -u | tr '\n' ' ')
unexpected=$(echo "$ids" | tr ' ' '\n' | grep -v -E '^(000|080|08[1-5]|18[1-5]|20[1-3]|28[1-3]|70[1-5]|77F)$' | grep -c . )
detail="period $period_us us; syncs sent $ctl_syncs (candump), device SYNCs $syncs answered $answered, drops ctl $rx_drop dev $dev_drop, invalid periods $invalid, active at period $active, periods with torque commanded $torque_periods, device non-zero torque RPDO periods $nonzero, overruns $overruns, safe stops $faults ${first_fault:+($first_fault)}, trace dropped $trace_drop, SYNC period median ${sync_median} us, ids $ids; $closed_loop; end-to-end us: $e2e"
[ "$rx_drop" = 0 ] && [ "$dev_drop" = 0 ] || fail_timing /tmp/run.txt "SocketCAN dropped frames: $detail"
[ -n "$active" ] && [ "$active" -ge 0 ] || fail_timing /tmp/run.txt "lifecycle never active: $detail"
# Every SYNC reaches the device; every SYNC after the start-up (nodes operational by the period
# the lifecycle went active) is answered with the encoder TPDOs.
[ "$syncs" -ge $((duration * 1000000 / period_us - 1)) ] && [ "$syncs" = "$ctl_syncs" ] &&
  [ "$answered" -ge $((syncs - active)) ] || fail_timing /tmp/run.txt "SYNCs lost or unanswered: $detail"
# A safe stop may only come from the guest's timing (lib.sh: timing_cause), never from the
# protocol. One before any torque flowed leaves nothing to check: inconclusive, run again.
if [ "$faults" != 0 ]; then
  timing_cause "$first_fault" || fail "safe stop not caused by timing: $first_fault; $detail"
fi
[ "$nonzero" -gt 0 ] || fail_premise "$first_fault" "no torque reached the device: $detail"
[ "$unexpected" = 0 ] || fail "unexpected ids on the bus: $detail"
[ "$device_loop" = closed ] || fail "the device did not close the haptic loop: $detail"
[ "$plant" = bounded ] || fail "the device's plant ran away: $detail"
[ "$limit_cycle" = no ] || fail "the closed haptic loop went into a limit cycle: $detail"
[ "$trace_drop" = 0 ] || fail_timing /tmp/run.txt "trace records dropped: $detail"
[ "$sync_median" -ge $((period_us * 9 / 10)) ] && [ "$sync_median" -le $((period_us * 11 / 10)) ] || fail_timing /tmp/run.txt "SYNC period off: $detail"
e2e_histogram /tmp/pair.csv $((period_us / 40))
pass "$detail"
