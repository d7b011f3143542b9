# Scenario (f): vcan0 goes down for one second and comes back while the controller and
# `numen device` run. Pass: the controller reports the link loss (SocketCAN link-down count,
# failed writes or an I/O fault), latches the safe state (no torque from a controller that lost
# its device), runs to its end without crashing, and after the link is up again frames flow
# both ways (the trace shows device frames read in the periods after the outage and candump
# sees SYNCs again).
. /hil/lib.sh
period_us=${HIL_PAIR_PERIOD_US:-1000}
pair_scene "$period_us"
start_device /tmp/dev.txt
numen run "$HIL_SCENE" --bus can:vcan0 --duration 8 --overrun-limit "${HIL_OVERRUN_LIMIT:-3}" \
  --trace /tmp/link.csv >/tmp/run.txt 2>&1 &
run=$!
sleep 3
ip link set vcan0 down
sleep 1
ip link set vcan0 up
candump -L vcan0 >/tmp/link.log 2>/tmp/candump.err &
dump=$!
wait "$run"
rc=$?
kill -TERM "$DEVICE_PID"
wait "$DEVICE_PID"
kill "$dump"
cat /tmp/run.txt /tmp/dev.txt
expect_status "$rc" /tmp/run.txt 3
grep -q 'nan detected: no' /tmp/run.txt || fail "NaN in the run"
link_down=$(field /tmp/run.txt 'link down ')
sync_fail=$(field /tmp/run.txt 'SYNC write failures ')
faults=$(field /tmp/run.txt 'safety: ')
first=$(grep -o 'fault record(s); first: [a-z ]*' /tmp/run.txt | sed 's/.*first: //')
syncs_after=$(grep -c ' vcan0 080#' /tmp/link.log)
# Periods with device frames read, split at the longest run of periods without any (the outage).
split=$(awk -F, 'NR > 1 { if ($4 > 0) { if (gap > best) { best = gap; end = $1 } gap = 0; n++ } else gap++ }
  END { print best + 0, end + 0 }' /tmp/link.csv)
outage=${split% *}
resumed=${split#* }
read_after=$(awk -F, -v e="$resumed" 'NR > 1 && $1 >= e && $4 > 0 { n++ } END { print n + 0 }' /tmp/link.csv)
detail="period $period_us us; link down reported $link_down, SYNC write failures $sync_fail, safe stops $faults (first: $first); longest gap without device frames $outage periods, frames read again from period $resumed in $read_after periods; SYNCs on the bus after the link came up $syncs_after"
[ "$link_down" -ge 1 ] || [ "$sync_fail" -ge 1 ] || fail "the link loss was not reported: $detail"
[ "$faults" -ge 1 ] || fail "no safe stop for the lost link: $detail"
[ "$outage" -ge $((500000 / period_us)) ] || fail_timing /tmp/run.txt "no outage in the trace: $detail"
[ "$read_after" -ge $((1000000 / period_us)) ] || fail_timing /tmp/run.txt "frames did not flow again: $detail"
[ "$syncs_after" -ge $((1000000 / period_us)) ] ||
  fail_timing /tmp/run.txt "no SYNC on the bus after the link came up: $detail"
pass "$detail"
