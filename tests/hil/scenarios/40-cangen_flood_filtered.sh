# Scenario: cangen floods vcan0 with random 11-bit, 29-bit and FD frames while cansend sends
# 20 frames of each of two ids the reader asked for. A reader with kernel filters (0x181 data
# frames; 29-bit 0x18FFxxxx) must see only matching ids, and all 40 wanted frames; a reader
# without filters (the control) shows that the flood really reached the bus.
. /hil/lib.sh
numen_hil_can recv vcan0 --filter 181:C00007FF --filter 98FF0000:DFFF0000 \
  --idle-ms 3000 --max-ms 120000 >/tmp/filtered.txt 2>/tmp/filtered.err &
fpid=$!
numen_hil_can recv vcan0 --idle-ms 3000 --max-ms 120000 >/tmp/all.txt 2>/tmp/all.err &
apid=$!
wait_for_line /tmp/filtered.txt READY 20 || fail "filtered reader not ready: $(cat /tmp/filtered.err)"
wait_for_line /tmp/all.txt READY 20 || fail "control reader not ready: $(cat /tmp/all.err)"
cangen vcan0 -g 0 -n 3000 -I r -L r &
g1=$!
cangen vcan0 -g 0 -n 1000 -e -I r -L 8 &
g2=$!
cangen vcan0 -g 0 -n 1000 -f -I r -L r &
g3=$!
for i in $(seq 1 20); do
  cansend vcan0 181#DEADBEEF
  cansend vcan0 18FF1234#CAFE
done
wait "$g1" "$g2" "$g3"
wait "$fpid"
frc=$?
wait "$apid"
arc=$?
cat /tmp/filtered.err /tmp/all.err
[ "$frc" -eq 0 ] || fail "filtered reader exited with $frc"
[ "$arc" -eq 0 ] || fail "control reader exited with $arc"
grep -v '^READY$' /tmp/filtered.txt >/tmp/f.txt
# Allowed: 11-bit 0x181 data frames (classic or FD), 29-bit 0x18FFxxxx data frames.
bad=$(grep -v -e '^181#' -e '^181##' -e '^18FF[0-9A-F]\{4\}#' /tmp/f.txt | grep -c . || true)
rtr=$(grep -c '#R' /tmp/f.txt || true)
wanted_a=$(grep -cx '181#DEADBEEF' /tmp/f.txt || true)
wanted_b=$(grep -cx '18FF1234#CAFE' /tmp/f.txt || true)
total_f=$(grep -c . /tmp/f.txt || true)
all_frames=$(sed -n 's/.*frames=\([0-9]*\).*/\1/p' /tmp/all.err)
all_dropped=$(sed -n 's/.*dropped=\([0-9]*\).*/\1/p' /tmp/all.err)
f_dropped=$(sed -n 's/.*dropped=\([0-9]*\).*/\1/p' /tmp/filtered.err)
seen=$((all_frames + all_dropped))
detail="filtered reader: $total_f frames ($wanted_a+$wanted_b wanted), $bad not matching, dropped $f_dropped; control: $all_frames read + $all_dropped dropped of 5040"
[ "$bad" -eq 0 ] && [ "$rtr" -eq 0 ] || { grep -v -e '^181#' -e '^18FF' /tmp/f.txt | head; fail "$detail"; }
[ "$wanted_a" -eq 20 ] && [ "$wanted_b" -eq 20 ] || fail "$detail"
[ "$f_dropped" -eq 0 ] || fail "$detail"
[ "$seen" -ge 5000 ] || fail "flood did not reach the bus: $detail"
pass "$detail"
