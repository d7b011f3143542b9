# Shared helpers of the HIL scenario scripts (sourced; busybox sh). A scenario prints exactly
# one result line through pass or fail; /init reports a missing line as a failure.
# HIL_NAME is the scenario name (file name without the NN- prefix and .sh), set by /init.

pass() { echo "HIL $HIL_NAME PASS $*"; exit 0; }
fail() { echo "HIL $HIL_NAME FAIL $*"; exit 1; }

# Waits until FILE contains LINE (a whole line), at most SECONDS (integer) seconds.
wait_for_line() {
  local file="$1" line="$2" left=$(( $3 * 10 ))
  while [ "$left" -gt 0 ]; do
    grep -qx "$line" "$file" 2>/dev/null && return 0
    usleep 100000
    left=$((left - 1))
  done
  return 1
}
