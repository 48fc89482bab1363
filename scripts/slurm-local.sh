#!/usr/bin/env bash
# A one-node Slurm cluster on this machine, for the farm test and demos: `lensfx farm` submits to it as to
# any cluster. Usage (as root): bash scripts/slurm-local.sh start|stop|status
#   start: a munge key, munged, slurm.conf for localhost with this machine's CPUs and memory (slurmd -C),
#          slurmctld and slurmd started directly (no systemd needed, works in a container); waits until
#          the node is idle. Idempotent: daemons already running are left alone.
#   stop:  ends the daemons this script started (by their pid files).
# Needs Debian's slurm-wlm and munge (scripts/install-deps.sh installs them). The config is written to
# /etc/slurm/slurm.conf (where sinfo/sbatch look) unless one not written by this script is there already.
set -euo pipefail

conf=/etc/slurm/slurm.conf
marker="# Written by lensfx scripts/slurm-local.sh"
state=/var/lib/lensfx-slurm
logs=/var/log/lensfx-slurm
munge_pid=/run/munge/munged.pid
ctld_pid=$state/slurmctld.pid
slurmd_pid=$state/slurmd.pid

die() { echo "slurm-local: $*" >&2; exit 1; }

# True when the pid file names a live process.
running() { [ -f "$1" ] && kill -0 "$(cat "$1")" 2>/dev/null; }

write_conf() {
  if [ -f "$conf" ] && ! grep -qF "$marker" "$conf"; then
    die "$conf exists and was not written by this script: leaving it (and its cluster) alone"
  fi
  # This machine as slurmd sees it (CPUs, sockets, cores, threads, memory); the node is called localhost.
  local hw
  hw=$(slurmd -C | head -1 | sed -e 's/^NodeName=[^ ]* //')
  mkdir -p /etc/slurm "$state/ctld" "$state/d" "$logs"
  cat >"$conf" <<EOF
$marker: a one-node cluster on localhost.
ClusterName=lensfx-local
SlurmctldHost=localhost
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
StateSaveLocation=$state/ctld
SlurmdSpoolDir=$state/d
SlurmctldPidFile=$ctld_pid
SlurmdPidFile=$slurmd_pid
SlurmctldLogFile=$logs/slurmctld.log
SlurmdLogFile=$logs/slurmd.log
# No cgroups in a container: processes tracked by their parent, no task binding, no accounting daemon.
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
# Array tasks share the node, one core each unless asked for more; memory is not booked (nor limited).
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
MinJobAge=3600
SchedulerType=sched/backfill
NodeName=localhost NodeAddr=127.0.0.1 $hw State=UNKNOWN
PartitionName=local Nodes=localhost Default=YES MaxTime=INFINITE State=UP
EOF
}

start_munge() {
  running "$munge_pid" && return
  [ -s /etc/munge/munge.key ] || { mungekey --create 2>/dev/null || dd if=/dev/urandom bs=1 count=1024 of=/etc/munge/munge.key 2>/dev/null; }
  chown munge:munge /etc/munge/munge.key && chmod 400 /etc/munge/munge.key
  mkdir -p /run/munge /var/log/munge /var/lib/munge && chown munge:munge /run/munge /var/log/munge /var/lib/munge
  runuser -u munge -- /usr/sbin/munged
  for _ in $(seq 50); do running "$munge_pid" && return; sleep 0.1; done
  die "munged did not start (see /var/log/munge/munged.log)"
}

start_slurm() {
  running "$ctld_pid" || slurmctld -f "$conf"
  running "$slurmd_pid" || slurmd -f "$conf" -N localhost
  local s=""
  for _ in $(seq 60); do
    s=$(sinfo -h -n localhost -o %t 2>/dev/null || true)
    case "$s" in idle*|mix*|alloc*) echo "slurm-local: node localhost $s ($(sinfo -h -o '%c CPUs, %m MB'))"; return ;; esac
    # A node left down or drained by an earlier run comes back.
    case "$s" in down*|drain*) scontrol update nodename=localhost state=resume 2>/dev/null || true ;; esac
    sleep 1
  done
  die "the node did not come up (state '${s}'; see $logs/slurmctld.log and $logs/slurmd.log)"
}

stop_daemon() {
  local pidfile=$1 name=$2
  running "$pidfile" || return 0
  local pid
  pid=$(cat "$pidfile")
  kill "$pid"
  for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || { echo "slurm-local: stopped $name"; return; }; sleep 0.1; done
  kill -9 "$pid" 2>/dev/null || true
}

[ "$(id -u)" -eq 0 ] || die "run as root"
case "${1:-}" in
  start)
    command -v slurmctld >/dev/null && command -v munged >/dev/null || die "slurm-wlm and munge are not installed (scripts/install-deps.sh)"
    write_conf
    start_munge
    start_slurm
    ;;
  stop)
    stop_daemon "$slurmd_pid" slurmd
    stop_daemon "$ctld_pid" slurmctld
    stop_daemon "$munge_pid" munged
    ;;
  status)
    for p in "$munge_pid:munged" "$ctld_pid:slurmctld" "$slurmd_pid:slurmd"; do
      running "${p%%:*}" && echo "${p#*:}: running (pid $(cat "${p%%:*}"))" || echo "${p#*:}: stopped"
    done
    ;;
  *) die "usage: $0 start|stop|status" ;;
esac
