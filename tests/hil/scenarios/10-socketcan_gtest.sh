# Scenario: the SocketCanBus GoogleTest suite (tests/hil/socketcan_bus_hil_test.cpp) on vcan0
# and vcan1.
. /hil/lib.sh
numen_hil_tests --gtest_color=no --gtest_filter='SocketCanHil*' >/tmp/gtest.log 2>&1
rc=$?
cat /tmp/gtest.log
metrics="$(sed -n 's/^HIL-METRIC //p' /tmp/gtest.log | tr '\n' ' ')"
passed="$(sed -n 's/^\[  PASSED  \] \([0-9]*\) test.*/\1/p' /tmp/gtest.log)"
if [ "$rc" -eq 0 ] && [ -n "$passed" ]; then
  pass "$passed tests; $metrics"
fi
failed="$(sed -n 's/^\[  FAILED  \] \([A-Za-z0-9_.]*\)$/\1/p; s/^\[  FAILED  \] \([A-Za-z0-9_.]*\) (.*/\1/p' /tmp/gtest.log | sort -u | tr '\n' ' ')"
fail "exit $rc; failed: ${failed:-none listed}"
