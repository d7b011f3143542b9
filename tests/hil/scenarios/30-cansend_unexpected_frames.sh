# Scenario: cansend injects frames the protocol does not expect (an unknown id, a position
# TPDO of the wrong length, an empty frame, a 29-bit remote request, FD frames). SocketCanBus
# must return each one as a frame, unchanged (rejecting them is the device layer's job), and
# the reader must not fail or crash. cansend rounds a 9-byte FD payload up to the next FD
# length (12) with zeros (can-utils lib.c, parse_canframe), so that frame is expected padded.
. /hil/lib.sh
numen_hil_can recv vcan0 --idle-ms 1500 --max-ms 30000 >/tmp/recv.txt 2>/tmp/recv.err &
pid=$!
wait_for_line /tmp/recv.txt READY 20 || { kill "$pid"; fail "reader not ready: $(cat /tmp/recv.err)"; }
cat >/tmp/sent.txt <<'FRAMES'
7AB#1122334455
181#010203
181#0102030405060708
080#
1FFFFFFF#R
123##1AABBCCDDEEFF0011
123##0000102030405060708090A0B
124##0000102030405060708
FRAMES
sed 's/^124##0000102030405060708$/124##0000102030405060708000000/' /tmp/sent.txt >/tmp/expected.txt
while read -r frame; do
  cansend vcan0 "$frame" || fail "cansend $frame failed"
done </tmp/sent.txt
wait "$pid"
rc=$?
cat /tmp/recv.err
grep -v '^READY$' /tmp/recv.txt >/tmp/got.txt
[ "$rc" -eq 0 ] || fail "reader exited with $rc"
if ! diff /tmp/expected.txt /tmp/got.txt; then
  fail "frames read differ from frames injected (diff above)"
fi
grep -q 'errors=0' /tmp/recv.err || fail "read errors: $(cat /tmp/recv.err)"
grep -q 'malformed=0' /tmp/recv.err || fail "frames rejected: $(cat /tmp/recv.err)"
pass "$(wc -l </tmp/got.txt) injected frames read as sent, no errors, none rejected"
