# Scenario: candump (can-utils, a real SocketCAN client) records the frames SocketCanBus
# writes: the pattern of `numen_hil_can send` (16 classic 11-bit, 16 classic 29-bit, 16 FD of
# every FD length, 16 remote requests) must appear in `candump -L` byte for byte, in order,
# with nothing else.
. /hil/lib.sh
candump -L vcan0 >/tmp/candump.log 2>/tmp/candump.err &
pid=$!
# candump prints nothing when ready: probe with cansend until the probe shows up.
ready=0
for i in $(seq 1 50); do
  cansend vcan0 7F0#
  if grep -q ' vcan0 7F0#$' /tmp/candump.log; then ready=1; break; fi
  usleep 200000
done
[ "$ready" -eq 1 ] || { kill "$pid"; fail "candump never recorded a probe frame: $(cat /tmp/candump.err)"; }
numen_hil_can send vcan0 >/tmp/sent.txt || { kill "$pid"; fail "numen_hil_can send failed"; }
cansend vcan0 7F1#
for i in $(seq 1 50); do
  grep -q ' vcan0 7F1#$' /tmp/candump.log && break
  usleep 200000
done
kill "$pid"
wait "$pid" 2>/dev/null
echo "--- candump -L (first lines)"
head -n 8 /tmp/candump.log
awk '$2 != "vcan0" {bad = 1} END {exit bad}' /tmp/candump.log || fail "candump lines from another interface"
# The kernel marks received FD frames with CANFD_FDF (flags bit 2), which candump prints in the
# flags nibble after "##"; the "##" already says FD, so compare without that bit.
awk '{print $3}' /tmp/candump.log | grep -v '^7F[01]#$' |
  sed 's/##4/##0/; s/##5/##1/; s/##6/##2/; s/##7/##3/' >/tmp/dumped.txt
fdf=$(awk '{print $3}' /tmp/candump.log | grep -c '##[4-7]' || true)
sent=$(wc -l </tmp/sent.txt)
dumped=$(wc -l </tmp/dumped.txt)
[ "$sent" -eq 64 ] || fail "numen_hil_can sent $sent frames, expected 64"
if ! diff /tmp/sent.txt /tmp/dumped.txt >/tmp/diff.txt; then
  head -n 20 /tmp/diff.txt
  fail "candump recorded $dumped frames, sent $sent; first difference above"
fi
fd=$(grep -c '##' /tmp/dumped.txt)
rtr=$(grep -c '#R' /tmp/dumped.txt)
ext=$(grep -c '^[0-9A-F]\{8\}#' /tmp/dumped.txt)
pass "$dumped frames byte-exact in candump -L ($fd FD ($fdf with CANFD_FDF), $ext 29-bit, $rtr remote)"
