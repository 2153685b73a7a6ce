#!/usr/bin/env bash
# A throwaway single-node Slurm cluster on this machine, for trying scripts/slurm-bench.sh and
# for tests/slurm.rs: Debian's slurmctld, slurmd and munge, started directly (no systemd), with
# everything they write (configuration, munge key and socket, state, spool, logs, pid files)
# in one folder.
#
#   scripts/slurm-local.sh install      apt-get the packages when missing (needs root)
#   scripts/slurm-local.sh start DIR    write DIR/slurm.conf for this host, start munged,
#                                       slurmctld and slurmd, wait until the node is idle
#   scripts/slurm-local.sh stop DIR     cancel the cluster's jobs, stop its daemons (by the
#                                       pids in DIR/run), leave DIR for the caller to delete
#
# After `start`, point the Slurm commands at it: `export SLURM_CONF=DIR/slurm.conf`.
#
# Written for Debian bookworm's slurm-wlm 22.05 as root on a machine without systemd or
# cgroups: SlurmUser=root, proctrack/linuxproc, task/none, no accounting; the node is
# `hostname -s` at NodeAddr=127.0.0.1 (nothing needs the name to resolve); the CPUs and memory
# are what `slurmd -C` reports; the ports are the first free pair from 6817 up; munged listens
# on its own socket in DIR (AuthInfo=socket=...), so a system munged, if any, is left alone.
set -euo pipefail

PACKAGES=(munge slurmctld slurmd slurm-client)

die() {
  echo "slurm-local: $*" >&2
  exit 1
}

as_root() {
  if [ "$(id -u)" -eq 0 ]; then "$@"; elif command -v sudo >/dev/null; then sudo "$@"; else
    echo "slurm-local: need root for: $*" >&2; return 1; fi
}

install() {
  local missing=() pkg
  for pkg in "${PACKAGES[@]}"; do
    dpkg -s "$pkg" >/dev/null 2>&1 || missing+=("$pkg")
  done
  if [ "${#missing[@]}" -gt 0 ]; then
    command -v apt-get >/dev/null ||
      die "apt-get not found: install ${missing[*]} (Slurm and munge) by hand"
    local start=$SECONDS
    echo "slurm-local: installing ${missing[*]}" >&2
    # The lists may be stale or absent on a fresh machine: update only when the install fails.
    if ! as_root env DEBIAN_FRONTEND=noninteractive apt-get -o DPkg::Lock::Timeout=600 \
      install -y -qq --no-install-recommends "${missing[@]}" >/dev/null 2>&1; then
      as_root apt-get -o DPkg::Lock::Timeout=600 update -qq
      as_root env DEBIAN_FRONTEND=noninteractive apt-get -o DPkg::Lock::Timeout=600 \
        install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
    fi
    echo "slurm-local: installed in $((SECONDS - start)) s" >&2
  fi
  echo "slurm-local: ok ($(slurmd -V))" >&2
}

# True when nothing listens on TCP port $1 of this machine.
port_free() {
  ! (exec 3<>"/dev/tcp/127.0.0.1/$1") 2>/dev/null
}

# The pid in file $1 when that process is alive.
alive_pid() {
  local pid
  [ -s "$1" ] || return 1
  pid=$(cat "$1")
  [ -n "$pid" ] && kill -0 "$pid" 2>/dev/null && echo "$pid"
}

logs_tail() {
  local f
  for f in "$1"/log/*.log; do
    [ -f "$f" ] || continue
    echo "--- $f (last 15 lines)" >&2
    tail -n 15 "$f" >&2
  done
}

start() {
  local dir=$1
  for cmd in munged mungekey slurmctld slurmd sinfo sbatch; do
    command -v "$cmd" >/dev/null || die "$cmd not found: run \`$0 install\` first"
  done
  mkdir -p "$dir"
  dir=$(cd "$dir" && pwd)
  # munged refuses key, socket and log folders that others may write; it wants the socket's
  # folders searchable by all (jobs may run as other users).
  chmod 0711 "$dir"
  mkdir -p "$dir"/{munge,state,spool/slurmd,log,run}
  chmod 0700 "$dir"/{state,spool,log,run}
  chmod 0711 "$dir/munge"

  local node cpu_line port=6817
  node=$(hostname -s 2>/dev/null || true)
  [ -n "$node" ] || node=$(cut -d. -f1 /proc/sys/kernel/hostname)
  [ -n "$node" ] || die "this machine has no hostname"
  # `slurmd -C`: NodeName=... CPUs=2 Boards=1 SocketsPerBoard=1 ... RealMemory=24105
  cpu_line=$(slurmd -C | head -n 1 | sed -e 's/^NodeName=[^ ]* *//')
  [[ "$cpu_line" == *CPUs=* ]] || die "slurmd -C printed no CPUs: $cpu_line"
  while ! { port_free "$port" && port_free $((port + 1)); }; do
    port=$((port + 2))
    [ "$port" -lt 7017 ] || die "no free pair of TCP ports in 6817..7017"
  done

  cat >"$dir/slurm.conf" <<EOF
# Written by scripts/slurm-local.sh for a single-node test cluster on $node.
ClusterName=pointsight-local
SlurmctldHost=$node(127.0.0.1)
SlurmctldPort=$port
SlurmdPort=$((port + 1))
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$dir/munge/munge.socket
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool/slurmd
SlurmctldPidFile=$dir/run/slurmctld.pid
SlurmdPidFile=$dir/run/slurmd.pid
SlurmctldLogFile=$dir/log/slurmctld.log
SlurmdLogFile=$dir/log/slurmd.log
PlugStackConfig=$dir/plugstack.conf
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
MinJobAge=600
MailProg=/bin/true
NodeName=$node NodeAddr=127.0.0.1 $cpu_line State=UNKNOWN
PartitionName=local Nodes=$node Default=YES MaxTime=INFINITE State=UP
EOF
  : >"$dir/plugstack.conf"

  # munge: a fresh key, the daemon on its own socket (root, hence --force).
  mungekey --create --keyfile="$dir/munge/munge.key" --force >/dev/null 2>&1 ||
    dd if=/dev/urandom of="$dir/munge/munge.key" bs=1024 count=1 status=none
  chmod 0400 "$dir/munge/munge.key"
  # --origin: the address munge stamps on credentials, without resolving the hostname.
  munged --force --origin=127.0.0.1 --socket="$dir/munge/munge.socket" --key-file="$dir/munge/munge.key" \
    --pid-file="$dir/run/munged.pid" --log-file="$dir/log/munged.log" \
    --seed-file="$dir/munge/munged.seed" </dev/null >>"$dir/log/munged.log" 2>&1 ||
    { logs_tail "$dir"; die "munged did not start"; }

  export SLURM_CONF=$dir/slurm.conf
  slurmctld -f "$SLURM_CONF" </dev/null >>"$dir/log/slurmctld.log" 2>&1 ||
    { logs_tail "$dir"; die "slurmctld did not start"; }
  slurmd -f "$SLURM_CONF" -N "$node" </dev/null >>"$dir/log/slurmd.log" 2>&1 ||
    { logs_tail "$dir"; die "slurmd did not start"; }

  # Ready when the node is idle (slurmd registered with slurmctld).
  local state=""
  for _ in $(seq 1 60); do
    state=$(sinfo -h -N -n "$node" -o %T 2>/dev/null || true)
    [ "$state" = idle ] && break
    sleep 0.5
  done
  if [ "$state" != idle ]; then
    logs_tail "$dir"
    die "node $node is ${state:-unknown} after 30 s, not idle (logs in $dir/log)"
  fi
  echo "slurm-local: up: node $node ($cpu_line), ports $port/$((port + 1)); export SLURM_CONF=$SLURM_CONF" >&2
}

stop() {
  local dir=$1 pid name
  [ -d "$dir" ] || return 0
  # The cluster's own jobs first: slurmd leaves running steps behind when it stops.
  if [ -f "$dir/slurm.conf" ] && alive_pid "$dir/run/slurmctld.pid" >/dev/null; then
    SLURM_CONF=$dir/slurm.conf scancel --quiet --full --partition=local 2>/dev/null || true
    for _ in $(seq 1 20); do
      [ -z "$(SLURM_CONF=$dir/slurm.conf squeue -h -o %i 2>/dev/null)" ] && break
      sleep 0.5
    done
  fi
  for name in slurmd slurmctld munged; do
    pid=$(alive_pid "$dir/run/$name.pid") || continue
    kill -TERM "$pid" 2>/dev/null || true
    for _ in $(seq 1 20); do
      kill -0 "$pid" 2>/dev/null || break
      sleep 0.25
    done
    if kill -0 "$pid" 2>/dev/null; then
      echo "slurm-local: $name ($pid) still running after 5 s: killing it" >&2
      kill -KILL "$pid" 2>/dev/null || true
    fi
  done
}

case "${1:-}" in
install) install ;;
start)
  [ $# -eq 2 ] || die "usage: $0 start DIR"
  start "$2"
  ;;
stop)
  [ $# -eq 2 ] || die "usage: $0 stop DIR"
  stop "$2"
  ;;
*) die "usage: $0 install | start DIR | stop DIR" ;;
esac
