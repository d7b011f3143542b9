# Scenario (b): canplayer replays a recorded log into the controller. First a field recording:
# the controller and `numen device` for 4 s, recorded by candump -L. Then the device's side of
# that log (its frames from the controller's first NMT command on) is replayed by canplayer, at
# the recorded timing, into a new controller alone on vcan0 — no device process.
# Pass: the controller runs the start-up against the replayed boot-ups and heartbeats and goes
# active, it reads the replayed encoder frames (>= 90 % of them), and its last target pose (the
# instrument pose from the last encoder frames) equals the recording run's within 1 mm
# in each coordinate (inconclusive when a run's safe stop has a timing cause: lib.sh timing_cause).
. /hil/lib.sh
period_us=${HIL_PAIR_PERIOD_US:-1000}
pair_scene "$period_us"
# 1. The recording.
candump -L vcan0 >/tmp/rec.log 2>/tmp/candump.err &
dump=$!
start_device /tmp/dev.txt
numen run "$HIL_SCENE" --bus can:vcan0 --duration 4 --overrun-limit "${HIL_OVERRUN_LIMIT:-3}" \
  --trace /tmp/rec.csv >/tmp/rec.txt 2>&1
rc=$?
expect_status "$rc" /tmp/rec.txt 0 3 5 6  # 5: its --trace lost records (a starved guest); not what this checks
usleep 200000
kill -TERM "$DEVICE_PID"
wait "$DEVICE_PID"
kill "$dump"
# 2. The device's frames (EMCY, encoder TPDOs, drive TPDOs, heartbeats) from the first NMT
# command of the recording controller on.
awk '/ vcan0 000#/ { on = 1 } on' /tmp/rec.log |
  grep -E ' vcan0 (08[1-5]|18[1-5]|28[1-3]|70[1-5])#' >/tmp/replay.log
replayed=$(grep -c . /tmp/replay.log)
encoders=$(grep -c -E ' vcan0 18[1-5]#' /tmp/replay.log)
# 3. The controller alone; canplayer starts once its first NMT command is on the bus.
numen run "$HIL_SCENE" --bus can:vcan0 --duration 5 --overrun-limit "${HIL_OVERRUN_LIMIT:-3}" \
  --trace /tmp/play.csv >/tmp/play.txt 2>&1 &
run=$!
candump -n 1 vcan0,000:7FF >/dev/null 2>&1
canplayer -I /tmp/replay.log
wait "$run"
rc=$?
cat /tmp/play.txt
expect_status "$rc" /tmp/play.txt 0 3 5 6  # 5: as above
grep -q 'nan detected: no' /tmp/play.txt || fail "NaN in the run"
rx=$(field /tmp/play.txt 'frames rx ')
active=$(field /tmp/play.txt 'active at period ')
# Trace columns: period,time_ns,flags,frames_read,sample_valid,torque_commanded,lifecycle,
# target_x,target_y,target_z,...: the last valid sample's target of each run (m).
last_rec=$(awk -F, 'NR > 1 && $5 == 1 { x = $8; y = $9; z = $10 } END { print x, y, z }' /tmp/rec.csv)
last_play=$(awk -F, 'NR > 1 && $5 == 1 { x = $8; y = $9; z = $10 } END { print x, y, z }' /tmp/play.csv)
# Largest coordinate difference, mm (busybox awk has no sqrt).
gap_mm=$(echo "$last_rec $last_play" | awk '{ m = 0; for (i = 1; i <= 3; i++) { d = $i - $(i + 3);
  if (d < 0) d = -d; if (d > m) m = d } printf "%.4f", m * 1000 }')
detail="period $period_us us; replayed $replayed frames ($encoders encoder TPDOs), controller read $rx, active at period $active; last target recorded ($last_rec) replayed ($last_play) m: $gap_mm mm apart (largest coordinate)"
[ "$replayed" -gt 0 ] || fail "nothing to replay: $detail"
[ -n "$active" ] && [ "$active" -ge 0 ] ||
  fail_timing /tmp/play.txt "the controller never went active on the replay: $detail"
[ "$rx" -ge $((replayed * 9 / 10)) ] || fail_timing /tmp/play.txt "replayed frames not read: $detail"
# A stall of the guest (an encoder timeout latched, samples went stale) ends a run's valid
# samples early, at a pose the other run went past (CI 2026-12-01: the replay's input stalled
# 0.85 s, 1.45 mm apart): inconclusive, as the timing of the guest explains it.
if ! awk -v g="$gap_mm" 'BEGIN { exit !(g != "" && g <= 1.0) }'; then
  for txt in /tmp/play.txt /tmp/rec.txt; do
    first=$(first_fault "$txt")
    [ -n "$first" ] && fail_premise "$first" "the replayed pose differs: $detail"
  done
  fail "the replayed pose differs: $detail"
fi
pass "$detail"
