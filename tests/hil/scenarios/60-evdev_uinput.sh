# Scenario: a virtual mouse made through uinput (libevdev_uinput_create_from_device) is read
# by EvdevPointer on its /dev/input/eventN and integrated by RelativePoseIntegrator: moves with
# and without the clutch (BTN_LEFT), wheel turns, a buffer overrun resynchronised by libevdev,
# an unplug, devices lacking the clutch key or an axis (tests/hil/evdev_pointer_hil_test.cpp,
# suite EvdevPointerHil). Needs the evdev and uinput modules, loaded by /init.
. /hil/lib.sh
[ -c /dev/uinput ] || fail "no /dev/uinput (uinput module not loaded?)"
numen_hil_tests --gtest_color=no --gtest_filter='EvdevPointerHil*' >/tmp/evdev.log 2>&1
rc=$?
cat /tmp/evdev.log
metrics="$(sed -n 's/^HIL-METRIC //p' /tmp/evdev.log | tr '\n' ' ')"
passed="$(sed -n 's/^\[  PASSED  \] \([0-9]*\) test.*/\1/p' /tmp/evdev.log)"
if [ "$rc" -eq 0 ] && [ -n "$passed" ]; then
  pass "$passed tests; $metrics"
fi
failed="$(sed -n 's/^\[  FAILED  \] \([A-Za-z0-9_.]*\)$/\1/p; s/^\[  FAILED  \] \([A-Za-z0-9_.]*\) (.*/\1/p' /tmp/evdev.log | sort -u | tr '\n' ' ')"
fail "exit $rc; failed: ${failed:-none listed}"
