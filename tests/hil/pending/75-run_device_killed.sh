# Scenario (e): the device process is killed (kill -9) during a run: the controller must command
# zero torque within 3 periods of the last device frame and report the heartbeat loss (its
# summary: the period of the last frame read vs the last torque-to-zero transition; the trace
# confirms it period by period).
. /hil/lib.sh
start_device /tmp/dev.txt
numen run "$HIL_SCENE" --bus can:vcan0 --duration 4 --trace /tmp/kill.csv >/tmp/run.txt 2>&1 &
run=$!
sleep 2
kill -9 "$DEVICE_PID"
wait "$run"
rc=$?
cat /tmp/run.txt
[ "$rc" -eq 0 ] || fail "numen run exited with $rc"
last_frame=$(field /tmp/run.txt 'last at period ')
stop=$(field /tmp/run.txt 'last torque stop at period ')
hb=$(field /tmp/run.txt 'heartbeat losses ')
first_fault=$(grep -o 'first: [a-z ]*' /tmp/run.txt | head -n 1)
# From the trace: the last period with a frame read and the first period with zero torque after it.
trace_check=$(awk -F, 'NR > 1 { if ($4 > 0) last = $1; t[$1] = $6 }
  END { for (k = last + 1; (k in t); k++) if (t[k] == 0) { print last, k; exit } }' /tmp/kill.csv)
detail="last device frame at period $last_frame, zero torque from period $stop ($((stop - last_frame)) periods), trace: $trace_check; heartbeat losses $hb; $first_fault"
[ -n "$stop" ] && [ "$stop" -gt 0 ] || fail "torque never went to zero: $detail"
[ $((stop - last_frame)) -le 3 ] || fail "zero torque too late: $detail"
[ "$hb" -ge 1 ] || fail "heartbeat loss not reported: $detail"
pass "$detail"
