# Scenario (c): while the controller and `numen device` run on vcan0, cansend injects an unknown
# id, an encoder TPDO of the wrong length and an encoder value out of the axis's range.
# Pass: the controller runs to its end (exit status 3, safety stop; no NaN); the unknown id never reaches the loop
# (kernel filter: unknown-id count 0) though candump saw it on the bus; the short frame is
# rejected and counted; the out-of-range value is counted and the safe state is latched (zero
# torque to the end of the run); the three frames were on the bus (candump).
. /hil/lib.sh
period_us=${HIL_PAIR_PERIOD_US:-1000}
pair_scene "$period_us"
candump -L vcan0 >/tmp/inj.log 2>/tmp/candump.err &
dump=$!
start_device /tmp/dev.txt
numen run "$HIL_SCENE" --bus can:vcan0 --duration 8 --overrun-limit "${HIL_OVERRUN_LIMIT:-3}" \
  --trace /tmp/inj.csv >/tmp/run.txt 2>&1 &
run=$!
sleep 3
cansend vcan0 123#DEADBEEF        # an id nobody on this bus uses
sleep 1
cansend vcan0 181#0102            # encoder TPDO of node 1 with 2 bytes instead of 4
sleep 1
cansend vcan0 183#FFFFFF00        # depth encoder: 16777215 counts = 167.8 m, range 0-0.35 m
wait "$run"
rc=$?
kill -TERM "$DEVICE_PID"
wait "$DEVICE_PID"
kill "$dump"
cat /tmp/run.txt
expect_status "$rc" /tmp/run.txt 3
grep -q 'nan detected: no' /tmp/run.txt || fail "NaN in the run"
unknown=$(field /tmp/run.txt 'unknown id ')
rejected=$(field /tmp/run.txt 'frames rejected ')
range=$(field /tmp/run.txt 'values out of range ')
faults=$(field /tmp/run.txt 'safety: ')
causes=$(grep -o 'fault record(s); first: [a-z ]*' /tmp/run.txt | sed 's/.*first: //')
on_bus=$(grep -c -E ' vcan0 (123#DEADBEEF|181#0102|183#FFFFFF00)$' /tmp/inj.log)
# From the trace: the last period with torque commanded and the last period of the run. The
# out-of-range value goes out ~3 s before the end, so the last 1.5 s must be torque-free.
last_torque=$(awk -F, 'NR > 1 && $6 == 1 { t = $1 } END { print t + 0 }' /tmp/inj.csv)
last_period=$(awk -F, 'NR > 1 { p = $1 } END { print p + 0 }' /tmp/inj.csv)
quiet=$((1500000 / period_us))
detail="period $period_us us; injected frames on the bus $on_bus/3; unknown ids in the loop $unknown, frames rejected $rejected, values out of range $range, safe stops $faults (first: $causes), last period with torque $last_torque of $last_period"
[ "$on_bus" = 3 ] || fail "candump did not see the 3 injected frames: $detail"
[ "$unknown" = 0 ] || fail "an unknown id reached the loop: $detail"
[ "$rejected" -ge 1 ] || fail "the short encoder frame was not rejected: $detail"
[ "$range" -ge 1 ] || fail "the out-of-range value was not counted: $detail"
[ "$faults" -ge 1 ] || fail "no safe stop: $detail"
[ "$last_torque" -gt 0 ] || fail_premise "first: $causes" "torque never flowed: $detail"
[ $((last_period - last_torque)) -ge "$quiet" ] || fail "torque still commanded after the bad values: $detail"
pass "$detail"
