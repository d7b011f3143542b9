# Scenario (c'): the operator's re-arm on a real bus. During the pair, cansend injects a depth
# encoder value of 167 m (out of range): the safe state latches (zero torque, drives disabled).
# 2 s later `kill -USR1` asks numen run to re-arm (fault resets, drives enabled again once no
# cause is present). Pass: torque was commanded before the bad value, none between it and the
# re-arm request, the request was accepted, and torque is commanded again for >= 0.5 s after it.
. /hil/lib.sh
period_us=${HIL_PAIR_PERIOD_US:-1000}
pair_scene "$period_us"
start_device /tmp/dev.txt
numen run "$HIL_SCENE" --bus can:vcan0 --duration 9 --overrun-limit "${HIL_OVERRUN_LIMIT:-3}" \
  --trace /tmp/rearm.csv >/tmp/run.txt 2>&1 &
run=$!
sleep 3
cansend vcan0 183#FFFFFF00
sleep 2
kill -USR1 "$run"
wait "$run"
rc=$?
kill -TERM "$DEVICE_PID"
wait "$DEVICE_PID"
cat /tmp/run.txt
expect_status "$rc" /tmp/run.txt 3
grep -q 'nan detected: no' /tmp/run.txt || fail "NaN in the run"
range=$(field /tmp/run.txt 'values out of range ')
requests=$(field /tmp/run.txt 're-arm: ')
accepted=$(grep -o 're-arm: [0-9]* request(s), [0-9]*' /tmp/run.txt | sed 's/.* //')
at=$(field /tmp/run.txt 'accepted, first before period ')
# Trace columns: period,time_ns,flags,frames_read,sample_valid,torque_commanded,...
before=$(awk -F, -v a="$at" 'NR > 1 && $1 < a && $6 == 1 { n++ } END { print n + 0 }' /tmp/rearm.csv)
last_before=$(awk -F, -v a="$at" 'NR > 1 && $1 < a && $6 == 1 { t = $1 } END { print t + 0 }' /tmp/rearm.csv)
after=$(awk -F, -v a="$at" 'NR > 1 && $1 >= a && $6 == 1 { n++ } END { print n + 0 }' /tmp/rearm.csv)
first_after=$(awk -F, -v a="$at" 'NR > 1 && $1 >= a && $6 == 1 { print $1; exit }' /tmp/rearm.csv)
detail="period $period_us us; values out of range $range; torque in $before periods before the re-arm (last at period $last_before); re-arm requests $requests, accepted $accepted, taken before period $at; torque again from period $first_after, in $after periods"
[ "$range" -ge 1 ] || fail "the out-of-range value was not counted: $detail"
[ "$before" -gt 0 ] || fail_premise "$(first_fault /tmp/run.txt)" "no torque before the bad value: $detail"
[ -n "$at" ] && [ $((at - last_before)) -ge $((1000000 / period_us)) ] ||
  fail_timing /tmp/run.txt "torque did not stop for the bad value: $detail"
[ "$requests" = 1 ] && [ "$accepted" = 1 ] || fail_timing /tmp/run.txt "the re-arm was not accepted: $detail"
[ "$after" -ge $((500000 / period_us)) ] || fail_timing /tmp/run.txt "no torque after the re-arm: $detail"
pass "$detail"
