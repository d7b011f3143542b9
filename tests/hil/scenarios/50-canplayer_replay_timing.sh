# Scenario: canplayer replays a recorded log (20 encoder TPDOs 50 ms apart, as `candump -L`
# writes them) onto vcan0. SocketCanBus must read all 20 in order, and the receive timestamps
# it reports (kernel SO_TIMESTAMPNS mapped to CLOCK_MONOTONIC) must follow canplayer's pacing:
# median gap 40-60 ms, whole span 0.9-5 s (an emulated CPU may be late, not much early).
. /hil/lib.sh
: >/tmp/replay.log
for i in $(seq 0 19); do
  printf '(%d.%06d) vcan0 181#%02X000000\n' $((1000 + i / 20)) $(( (i % 20) * 50000 )) "$i" >>/tmp/replay.log
done
numen_hil_can recv vcan0 --filter 181:C00007FF --timestamps 1 --idle-ms 2000 --max-ms 60000 \
  >/tmp/replayed.txt 2>/tmp/replayed.err &
pid=$!
wait_for_line /tmp/replayed.txt READY 20 || { kill "$pid"; fail "reader not ready: $(cat /tmp/replayed.err)"; }
canplayer -I /tmp/replay.log vcan0=vcan0 || { kill "$pid"; fail "canplayer failed"; }
wait "$pid" || fail "reader failed: $(cat /tmp/replayed.err)"
cat /tmp/replayed.err
grep -v '^READY$' /tmp/replayed.txt >/tmp/r.txt
awk '{print $3}' /tmp/replay.log >/tmp/want.txt
awk '{print $2}' /tmp/r.txt >/tmp/got.txt
diff /tmp/want.txt /tmp/got.txt || fail "frames replayed differ from the log (diff above)"
# Gaps in microseconds from "(s.us)"; canplayer paces against its own clock with sleep
# granularity (gaps of 46-54 ms seen for 50 ms), so check the median gap and the span.
awk '{ gsub(/[()]/, "", $1); split($1, t, "."); us = t[1] * 1000000 + t[2];
       if (NR > 1) print us - prev; prev = us }' /tmp/r.txt | sort -n >/tmp/gaps.txt
min=$(head -n 1 /tmp/gaps.txt)
max=$(tail -n 1 /tmp/gaps.txt)
median=$(sed -n '10p' /tmp/gaps.txt)
span=$(awk '{ s += $1 } END { print s }' /tmp/gaps.txt)
detail="20 frames in order; receive-time gaps median ${median} us (${min}-${max}), span ${span} us (log: 50000 us gaps, 950000 us span)"
[ "$median" -ge 40000 ] && [ "$median" -le 60000 ] || fail "$detail"
[ "$span" -ge 900000 ] && [ "$span" -le 5000000 ] || fail "$detail"
pass "$detail"
