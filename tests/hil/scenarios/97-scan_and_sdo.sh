# Scenario: bring-up over SDO on vcan0 (docs/sdo.md). `numen device` plays the default
# scene's five CANopen nodes (three drives, two encoders), left in pre-operational: no
# controller starts them. `numen scan` must hear every node and read its identity by SDO
# (device type profile 402 for the drives, 406 for the encoders, serial = node id, name), and
# start none; `numen sdo` must read a segmented object (0x1008 device name) and report a
# refused write (0x1000 is read-only) by its CiA 301 name with exit status 1.
. /hil/lib.sh
start_device /tmp/scan_dev.txt
numen scan --bus can:vcan0 --json >/tmp/scan.json 2>/tmp/scan.err
scan_rc=$?
numen sdo --bus can:vcan0 2 read 1008:00 >/tmp/sdo_read.txt 2>&1
read_rc=$?
numen sdo --bus can:vcan0 2 write 1000:00 1 --type u32 >/tmp/sdo_write.txt 2>&1
write_rc=$?
kill -TERM "$DEVICE_PID"
wait "$DEVICE_PID"
cat /tmp/scan.json /tmp/scan.err /tmp/sdo_read.txt /tmp/sdo_write.txt
nodes=$(grep -c '"node_id"' /tmp/scan.json)
drives=$(grep -c '"profile": 402' /tmp/scan.json)
encoders=$(grep -c '"profile": 406' /tmp/scan.json)
preop=$(grep -c '"state": "pre-operational"' /tmp/scan.json)
errors=$(grep -c '"errors": \[\]' /tmp/scan.json)
detail="scan exit $scan_rc: $nodes nodes ($drives drives, $encoders encoders, $preop pre-operational, $errors without errors); sdo read exit $read_rc, write exit $write_rc"
[ "$scan_rc" -eq 0 ] || fail "numen scan failed: $detail"
[ "$nodes" -eq 5 ] && [ "$drives" -eq 3 ] && [ "$encoders" -eq 2 ] || fail "nodes or profiles: $detail"
[ "$preop" -eq 5 ] || fail "a node left pre-operational during the scan: $detail"
[ "$errors" -eq 5 ] || fail "identity objects not all read: $detail"
for n in 1 2 3 4 5; do
  grep -q "\"serial\": $n," /tmp/scan.json || fail "no node with serial $n: $detail"
done
[ "$read_rc" -eq 0 ] && grep -q 'text: "numen emulated drive' /tmp/sdo_read.txt ||
  fail "0x1008 of node 2 not read: $detail"
[ "$write_rc" -eq 1 ] && grep -q 'attempt to write a read only object' /tmp/sdo_write.txt ||
  fail "the refused write was not reported by name: $detail"
pass "$detail"
