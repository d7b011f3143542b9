# Scenario (e): the device process is killed (kill -9) during a run: the controller must command
# zero torque within 3 periods of the last device frame and report the heartbeat loss (its
# summary: the period of the last frame read vs the last torque-to-zero transition; the trace
# confirms it period by period).
. /hil/lib.sh
period_us=${HIL_PAIR_PERIOD_US:-1000}
pair_scene "$period_us"
start_device /tmp/dev.txt
numen run "$HIL_SCENE" --bus can:vcan0 --duration 4 --overrun-limit "${HIL_OVERRUN_LIMIT:-3}" --trace /tmp/kill.csv >/tmp/run.txt 2>&1 &
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
# From the trace (columns period,time_ns,flags,frames_read,sample_valid,torque_commanded,...):
# the last period with a frame read, the first period with zero torque after it, and whether
# torque was commanded in the 6 periods up to that last one (torque flowing until the kill; the
# very last period may hold only part of the device's frames, hence no valid sample).
trace_check=$(awk -F, 'NR > 1 { if ($4 > 0) last = $1; t[$1] = $6 }
  END { on = 0; for (k = last - 5; k <= last; k++) if (t[k] == 1) on = 1
        for (k = last + 1; (k in t); k++) if (t[k] == 0) { print last, k, on; exit } }' /tmp/kill.csv)
torque_before=$(echo "$trace_check" | awk '{ print $3 }')
detail="period $period_us us; last device frame at period $last_frame, zero torque from period $stop ($((stop - last_frame)) periods), trace: $trace_check; heartbeat losses $hb; $first_fault"
[ "$torque_before" = 1 ] || fail "no torque commanded in the periods before the kill: $detail"
[ -n "$stop" ] && [ -n "$last_frame" ] && [ "$stop" -gt "$last_frame" ] ||
  fail "torque did not go to zero after the last device frame: $detail"
[ $((stop - last_frame)) -le 3 ] || fail "zero torque too late: $detail"
[ "$hb" -ge 1 ] || fail "heartbeat loss not reported: $detail"
pass "$detail"
