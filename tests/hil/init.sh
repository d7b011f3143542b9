#!/bin/busybox sh
# /init of the hardware-in-the-loop guest (tests/hil/build_image.sh puts it in the initramfs).
# Mounts the kernel file systems, loads the modules of /etc/hil-modules (CAN, evdev, uinput),
# creates the virtual CAN buses, runs every /hil/scenarios/*.sh in name order and powers off. Console protocol (parsed by run.sh):
#   HIL-START uptime=S            scenarios are about to start (S: seconds since boot)
#   HIL <name> PASS|FAIL detail   one line per scenario, after its run
#   HIL <name> INCONCLUSIVE why   an attempt whose premise did not hold (lib.sh): run again
#                                 after a 20 s pause, at most 5 attempts, then FAIL
#   HIL-END scenarios=N uptime=S  all scenarios ran
# Buses: vcan0 CAN FD (mtu 72), vcan1 classic (mtu 16); both up.
export PATH=/bin:/hil/bin
set -o pipefail
mount -t proc proc /proc
mount -t sysfs sysfs /sys
mount -t devtmpfs devtmpfs /dev 2>/dev/null || true
mount -t tmpfs tmpfs /tmp

finish() {
  echo "HIL-END scenarios=$1 uptime=$(cut -d' ' -f1 /proc/uptime)"
  sync
  poweroff -f
  sleep 5
}

setup_failed() {
  echo "HIL setup FAIL $*"
  dmesg | tail -n 20
  finish 0
}

for m in $(cat /etc/hil-modules); do
  insmod "/lib/modules/$m.ko" || setup_failed "insmod $m"
done
ip link set lo up
make_vcan() {  # make_vcan NAME MTU
  ip link add dev "$1" type vcan 2>/dev/null || ip.iproute2 link add dev "$1" type vcan ||
    setup_failed "ip link add dev $1 type vcan"
  ip link set dev "$1" mtu "$2" || setup_failed "ip link set $1 mtu $2"
  ip link set dev "$1" up || setup_failed "ip link set $1 up"
}
make_vcan vcan0 72
make_vcan vcan1 16
# The HIL tests re-create vcan1 with `ip`: use whichever ip can (busybox first).
if ! ip link add dev hilprobe0 type vcan 2>/dev/null; then
  ln -sf /bin/ip.iproute2 /hil/bin/ip
  ip_impl=iproute2
else
  ip link del dev hilprobe0
  ip_impl=busybox
fi
echo "HIL-INFO kernel=$(uname -r) ip=$ip_impl modules=$(cat /etc/hil-modules | tr '\n' ',')"

echo  # the firmware leaves escape sequences on the console line
echo "HIL-START uptime=$(cut -d' ' -f1 /proc/uptime)"
count=0
for script in /hil/scenarios/*.sh; do
  file="${script##*/}"
  name="${file%.sh}"
  name="${name#[0-9][0-9]-}"
  count=$((count + 1))
  echo "HIL-RUN $name"
  out="/tmp/$name.out"
  cd /tmp
  attempt=1
  while :; do
    HIL_NAME="$name" timeout "${HIL_SCENARIO_TIMEOUT:-240}" sh "$script" 2>&1 | tee "$out"
    rc=$?
    grep -q "^HIL $name INCONCLUSIVE" "$out" || break
    if [ "$attempt" -ge 5 ]; then
      echo "HIL $name FAIL inconclusive in $attempt attempts"
      break
    fi
    # A starved host tends to stay starved for a while (CI-like run here: minutes at
    # 0.15-0.8x real time): let it pass before the next attempt.
    sleep 20
    attempt=$((attempt + 1))
    echo "HIL-RUN $name (attempt $attempt)"
  done
  if ! grep -q "^HIL $name \(PASS\|FAIL\|INCONCLUSIVE\)" "$out"; then
    echo "HIL $name FAIL no result line (exit $rc)"
  fi
done
finish "$count"
