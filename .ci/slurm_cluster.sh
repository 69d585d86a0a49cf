#!/usr/bin/env bash
# A one-node Slurm cluster on this machine, for trying the farm scripts `ragdoll plan`
# writes (JOB/slurm/) and for the Slurm farm test (crates/ragdoll-cli/tests/farm_slurm.rs).
#
#   .ci/slurm_cluster.sh start DIR   # munged, slurmctld and slurmd, everything under DIR
#   export SLURM_CONF=DIR/slurm.conf # for sbatch, squeue, sinfo, scancel
#   .ci/slurm_cluster.sh stop DIR    # stops exactly the daemons `start DIR` started
#
# Needs Debian's slurm-wlm and munge (apt-get install slurm-wlm munge) and root: the
# daemons run as root with their own munge key, socket, configuration, state, spool, logs
# and pid files under DIR, so the system's /etc/munge, /etc/slurm and /run are untouched.
# RAGDOLL_SLURM_PORT (default 6817) is slurmctld's port; slurmd takes the next one.
# `start` waits at most 60 s for the node to be idle; when it is not, it prints the
# daemons' log tails and one line saying why, and exits non-zero.
set -euo pipefail

usage() {
  echo "usage: $0 start|stop DIR" >&2
  exit 2
}
[ $# -eq 2 ] || usage
cmd=$1
dir=$2

# Each daemon's pid file, in the order `stop` stops them.
pidfiles() {
  echo "$dir/run/slurmd.pid" "$dir/run/slurmctld.pid" "$dir/run/munged.pid"
}

# Whether the pid in file $1 is a live process.
alive() {
  [ -s "$1" ] && kill -0 "$(cat "$1")" 2>/dev/null
}

stop() {
  local f pid waited
  for f in $(pidfiles); do
    alive "$f" || continue
    pid=$(cat "$f")
    kill -TERM "$pid" 2>/dev/null || true
    waited=0
    while kill -0 "$pid" 2>/dev/null; do
      if [ "$waited" -ge 100 ]; then # 10 s
        echo "$(basename "$f" .pid) (pid $pid) ignored SIGTERM for 10 s: killing it" >&2
        kill -KILL "$pid" 2>/dev/null || true
        sleep 0.2
        break
      fi
      sleep 0.1
      waited=$((waited + 1))
    done
  done
}

# Prints the last lines of every daemon's log and the reason, stops what started, exits 1.
fail() {
  local log
  for log in "$dir"/log/*.log; do
    [ -f "$log" ] || continue
    echo "---- $log (last 25 lines)" >&2
    tail -n 25 "$log" >&2
  done
  sleep 1 # a daemon that just forked writes its pid file a moment later
  stop
  echo "slurm_cluster.sh: the one-node Slurm cluster did not start: $1" >&2
  exit 1
}

start() {
  local bin host cpus port
  if [ "$(id -u)" -ne 0 ]; then
    echo "slurm_cluster.sh: the one-node Slurm cluster did not start: it must run as root (its daemons run as root)" >&2
    exit 1
  fi
  for bin in munged slurmctld slurmd sinfo sbatch; do
    if ! command -v "$bin" >/dev/null && [ ! -x "/usr/sbin/$bin" ]; then
      echo "slurm_cluster.sh: the one-node Slurm cluster did not start: $bin is not installed (apt-get install slurm-wlm munge)" >&2
      exit 1
    fi
  done
  export PATH="$PATH:/usr/sbin:/sbin"
  for f in $(pidfiles); do
    if alive "$f"; then
      echo "slurm_cluster.sh: the one-node Slurm cluster did not start: $dir already runs one ($(basename "$f" .pid), pid $(cat "$f")); stop it first" >&2
      exit 1
    fi
  done
  host=$(hostname -s)
  cpus=$(nproc)
  port=${RAGDOLL_SLURM_PORT:-6817}
  local p
  for p in "$port" $((port + 1)); do
    if command -v ss >/dev/null && [ -n "$(ss -Hltn "sport = :$p")" ]; then
      echo "slurm_cluster.sh: the one-node Slurm cluster did not start: port $p is in use (another Slurm? set RAGDOLL_SLURM_PORT)" >&2
      exit 1
    fi
  done
  mkdir -p "$dir"
  dir=$(cd "$dir" && pwd)
  rm -rf "$dir/key" "$dir/munge" "$dir/run" "$dir/log" "$dir/state" "$dir/spool"
  mkdir -p "$dir/key" "$dir/munge" "$dir/run" "$dir/log" "$dir/state" "$dir/spool"
  # munged refuses directories others can write to; its socket's must be searchable.
  chmod 0755 "$dir" "$dir/munge"
  chmod 0700 "$dir/key"

  dd if=/dev/urandom of="$dir/key/munge.key" bs=1 count=1024 status=none
  chmod 0400 "$dir/key/munge.key"
  munged --force \
    --socket="$dir/munge/munge.socket" \
    --key-file="$dir/key/munge.key" \
    --pid-file="$dir/run/munged.pid" \
    --log-file="$dir/log/munged.log" \
    --seed-file="$dir/key/munged.seed" ||
    fail "munged exited with status $? (its log is above)"

  cat >"$dir/slurm.conf" <<EOF
# Written by .ci/slurm_cluster.sh: one node, everything under $dir.
ClusterName=ragdoll
SlurmctldHost=$host
SlurmctldPort=$port
SlurmdPort=$((port + 1))
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$dir/munge/munge.socket
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
MpiDefault=none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
SchedulerType=sched/backfill
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/run/slurmctld.pid
SlurmdPidFile=$dir/run/slurmd.pid
SlurmctldLogFile=$dir/log/slurmctld.log
SlurmdLogFile=$dir/log/slurmd.log
MailProg=/bin/true
NodeName=$host CPUs=$cpus RealMemory=500 State=UNKNOWN
PartitionName=main Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
  export SLURM_CONF="$dir/slurm.conf"
  slurmctld -f "$SLURM_CONF" || fail "slurmctld exited with status $? (its log is above)"
  slurmd -f "$SLURM_CONF" || fail "slurmd exited with status $? (its log is above)"

  local state="" waited=0 d
  while [ "$waited" -lt 60 ]; do
    # The daemons write their pid files a moment after they fork.
    for d in slurmctld slurmd; do
      if [ -s "$dir/run/$d.pid" ] && ! alive "$dir/run/$d.pid"; then
        fail "$d stopped (its log is above)"
      fi
    done
    state=$(sinfo -h -N -n "$host" -o '%T' 2>/dev/null || true)
    if [ "$state" = idle ]; then
      echo "one-node Slurm cluster up on $host ($cpus CPUs); export SLURM_CONF=$SLURM_CONF"
      return 0
    fi
    sleep 1
    waited=$((waited + 1))
  done
  fail "node $host was not idle after 60 s (sinfo says: ${state:-nothing})"
}

case "$cmd" in
start) start ;;
stop)
  stop
  echo "stopped the Slurm cluster of $dir"
  ;;
*) usage ;;
esac
