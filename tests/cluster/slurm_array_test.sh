#!/usr/bin/env bash
# Studies on a cluster (docs/studies.md), end to end on this machine: starts a one-node Slurm
# (Debian's slurm-wlm and munge; every path, socket and port of its own), submits the quick
# stability study as a 4-task array job (sbatch --array=0-3, polled), merges the shard files and
# compares the CSV files byte for byte with the one-process run; then runs the same 4 shards with
# GNU parallel and compares again. A daemon that cannot start fails the test with its own log.
#
#   slurm_array_test.sh NUMEN WORK_DIR
#
# WORK_DIR is emptied at the start (after the daemons a previous run left are stopped by their
# pid files). A lock (flock, /tmp/numen-slurm-array-test.lock) keeps two runs on one machine from
# sharing the ports. The daemons are stopped on exit (trap), by their pid files.
set -euo pipefail
numen=$(realpath "$1")
work=$2
ctld_port=16817   # not Slurm's 6817/6818: a Slurm of the machine keeps its own
slurmd_port=16818

for tool in munged slurmctld slurmd sbatch scontrol sinfo parallel flock; do
  command -v "$tool" >/dev/null || { echo "FAIL: $tool is not installed (bash .ci/deps)"; exit 1; }
done

exec 9>/tmp/numen-slurm-array-test.lock
flock -w 600 9 || { echo "FAIL: another run holds /tmp/numen-slurm-array-test.lock"; exit 1; }

state=$work/state
# Stops the daemon of pid file $1 if that pid is still the program $2.
stop_daemon() {
  local file=$1 name=$2 pid
  [ -s "$file" ] || return 0
  pid=$(cat "$file")
  if [ -r "/proc/$pid/comm" ] && [ "$(cat "/proc/$pid/comm")" = "$name" ]; then
    kill "$pid" 2>/dev/null || true
    for _ in $(seq 100); do [ -d "/proc/$pid" ] || break; sleep 0.1; done
    [ -d "/proc/$pid" ] && kill -9 "$pid" 2>/dev/null || true
  fi
  rm -f "$file"
}
stop_all() {
  stop_daemon "$state/slurmd.pid" slurmd
  stop_daemon "$state/slurmctld.pid" slurmctld
  stop_daemon "$state/munged.pid" munged
}
stop_all
trap stop_all EXIT
rm -rf "$work"
mkdir -p "$state/ctld" "$state/spool" "$work/whole" "$work/slurm" "$work/parallel"
chmod 700 "$state"

# --- munge: a key of our own (1024 random bytes, mode 400), its own socket, pid and log.
dd if=/dev/urandom of="$state/munge.key" bs=1024 count=1 status=none
chmod 400 "$state/munge.key"
if ! munged --force --key-file="$state/munge.key" --socket="$state/munge.socket" \
     --pid-file="$state/munged.pid" --log-file="$state/munged.log" \
     --seed-file="$state/munged.seed" 2>"$state/munged.err"; then
  echo "FAIL: munged did not start:"; cat "$state/munged.err" "$state/munged.log" 2>/dev/null
  exit 1
fi

# --- Slurm: one node, this machine.
host=$(hostname -s)
conf=$state/slurm.conf
cat >"$conf" <<CONF
ClusterName=numentest
SlurmctldHost=$host
SlurmUser=root
SlurmdUser=root
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$state/munge.socket
StateSaveLocation=$state/ctld
SlurmdSpoolDir=$state/spool
SlurmctldPidFile=$state/slurmctld.pid
SlurmdPidFile=$state/slurmd.pid
SlurmctldLogFile=$state/slurmctld.log
SlurmdLogFile=$state/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SwitchType=switch/none
MpiDefault=none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ReturnToService=2
SlurmctldTimeout=30
SlurmdTimeout=30
NodeName=$host CPUs=$(nproc) State=UNKNOWN
PartitionName=numen Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF
export SLURM_CONF=$conf
unset SLURM_ARRAY_TASK_ID SLURM_ARRAY_TASK_COUNT SLURM_JOB_ID

# Fails the test with the daemon's own messages.
daemon_failed() {
  echo "FAIL: $1"
  for f in "$state/$2.err" "$state/$2.log"; do
    [ -s "$f" ] && { echo "--- $f"; tail -n 40 "$f"; }
  done
  exit 1
}
slurmctld -f "$conf" 2>"$state/slurmctld.err" || daemon_failed "slurmctld did not start" slurmctld
for _ in $(seq 100); do scontrol ping 2>/dev/null | grep -q UP && break; sleep 0.2; done
scontrol ping 2>/dev/null | grep -q UP || daemon_failed "slurmctld does not answer (scontrol ping)" slurmctld
slurmd -f "$conf" -N "$host" 2>"$state/slurmd.err" || daemon_failed "slurmd did not start" slurmd
for _ in $(seq 150); do
  [ "$(sinfo -h -n "$host" -o %t 2>/dev/null)" = idle ] && break
  sleep 0.2
done
[ "$(sinfo -h -n "$host" -o %t 2>/dev/null)" = idle ] ||
  daemon_failed "node $host is not idle: $(sinfo -h -n "$host" -o '%t %E' 2>&1)" slurmd

echo "Slurm up after ${SECONDS} s (node $host, $(nproc) CPUs)"

# --- The one-process run.
t0=$SECONDS
"$numen" study stability --quick --out "$work/whole" >"$work/whole.out" 2>/dev/null
echo "one-process run: $((SECONDS - t0)) s"
t0=$SECONDS

compare() {  # $1: directory of the merged CSV files, $2: what ran the shards
  local n=0
  for f in "$work"/whole/*.csv; do
    cmp "$f" "$1/$(basename "$f")" || { echo "FAIL: $2: $(basename "$f") differs"; exit 1; }
    n=$((n + 1))
  done
  [ "$(ls "$1"/*.csv | wc -l)" -eq "$n" ] || { echo "FAIL: $2: other CSV files"; ls "$1"; exit 1; }
  echo "$2: $n CSV files byte-identical to the one-process run"
}

# --- 4 array tasks under Slurm: each finds its shard in SLURM_ARRAY_TASK_ID/COUNT.
cat >"$work/shard.sbatch" <<JOB
#!/bin/bash
#SBATCH --job-name=numen-stability
#SBATCH --array=0-3
#SBATCH --cpus-per-task=1
#SBATCH --output=$work/slurm/task-%a.log
exec "$numen" study stability --quick --out "$work/slurm"
JOB
# Polled (sbatch --wait polls every few seconds): done when no task is pending or running.
job=$(sbatch --parsable --chdir="$work" "$work/shard.sbatch" 2>"$work/sbatch.err") ||
  daemon_failed "sbatch refused the job: $(cat "$work/sbatch.err")" slurmctld
job=${job%%;*}
tasks() { scontrol -o show job "$job" 2>/dev/null | grep -o 'JobState=[A-Z_]*' || true; }
deadline=$((SECONDS + 240))
while :; do
  states=$(tasks)
  [ -n "$states" ] &&
    ! grep -qvE 'JobState=(COMPLETED|FAILED|CANCELLED|TIMEOUT|NODE_FAIL|OUT_OF_MEMORY)' <<<"$states" &&
    break
  if [ "$SECONDS" -ge "$deadline" ]; then
    echo "FAIL: array job $job not done after 240 s:"; scontrol -o show job "$job"
    daemon_failed "see the daemons' logs" slurmd
  fi
  sleep 0.2
done
if [ "$(scontrol -o show job "$job" | grep -c 'JobState=COMPLETED.*ExitCode=0:0')" -ne 4 ]; then
  echo "FAIL: array job $job:"; scontrol -o show job "$job"
  for f in "$work"/slurm/task-*.log; do [ -f "$f" ] && { echo "--- $f"; tail -n 5 "$f"; }; done
  exit 1
fi
grep -h "shard [0-3]/4" "$work"/slurm/task-*.log
"$numen" study merge "$work/slurm" >"$work/slurm-merge.out"
compare "$work/slurm" "Slurm array job (4 tasks, $((SECONDS - t0)) s)"
t0=$SECONDS

# --- The same shards with GNU parallel (2 at a time).
parallel --will-cite -j2 "$numen" study stability --quick --shard {}/4 --out "$work/parallel" \
  ::: 0 1 2 3 >"$work/parallel.out" 2>/dev/null
# A second round finds every shard file and skips it.
parallel --will-cite -j2 "$numen" study stability --quick --shard {}/4 --out "$work/parallel" \
  ::: 0 1 2 3 >"$work/parallel-again.out" 2>/dev/null
[ "$(grep -c "exists, skipped" "$work/parallel-again.out")" -eq 4 ] ||
  { echo "FAIL: existing shards were not skipped:"; cat "$work/parallel-again.out"; exit 1; }
"$numen" study merge "$work/parallel" >"$work/parallel-merge.out"
compare "$work/parallel" "GNU parallel (4 shards, $((SECONDS - t0)) s with the skipped round)"
