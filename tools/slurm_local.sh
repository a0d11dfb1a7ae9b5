#!/usr/bin/env bash
# A single-node SLURM cluster on this Debian machine, to run `mapush sweep launcher=slurm` for real (tests and
# trying out site settings). Needs root and apt (Debian bookworm's slurm-wlm 22.05 and munge); no systemd needed: the
# daemons are started directly, and the config uses no cgroups (they are often missing inside containers).
#   bash tools/slurm_local.sh         # install if missing, write the config, start munged, slurmctld, slurmd
#   bash tools/slurm_local.sh stop    # stop the three daemons (the packages and config stay)
#   bash tools/slurm_local.sh status  # exit 0 and print the status line if it is up, else exit 1
# Re-running it while the cluster is up does nothing but print the status line.
set -euo pipefail

PARTITION=local                        # the one partition; the default, so jobs need not name it
CONF=/etc/slurm/slurm.conf
MARK="# Written by mapush tools/slurm_local.sh"  # we only ever overwrite a config that we wrote
NODE=$(hostname -s)
PIDS=(/run/slurm/slurmd.pid /run/slurm/slurmctld.pid /run/munge/munged.pid)  # stopped in this order

die() { echo "slurm_local: $*" >&2; exit 1; }

[ "$(id -u)" = 0 ] || die "needs root (it installs packages and starts system daemons)"

stop() {
  for pidfile in "${PIDS[@]}"; do
    [ -s "$pidfile" ] || continue
    pid=$(cat "$pidfile")
    if kill "$pid" 2>/dev/null; then
      for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.2; done  # up to 10 s each
    fi
    rm -f "$pidfile"
  done
  echo "slurm_local: stopped"
}

running() { [ -s "$1" ] && kill -0 "$(cat "$1")" 2>/dev/null; }  # the daemon of this pid file is alive
# The node's state as sinfo prints it (idle, mix, alloc, down*, ...), empty when slurmctld does not answer.
node_state() { sinfo -h -n "$NODE" -o %t 2>/dev/null | head -1 || true; }
# Asked only of a running slurmctld: sinfo retries an absent controller for 10 s.
is_up() {
  running /run/slurm/slurmctld.pid || return 1
  case "$(node_state)" in idle | mix | alloc) return 0 ;; *) return 1 ;; esac
}
status_line() {
  echo "slurm_local: up, node $NODE ($(sinfo -h -n "$NODE" -o '%c CPUs, %m MB'), $(node_state))," \
    "partition $PARTITION; stop it with: bash tools/slurm_local.sh stop"
}

case "${1:-start}" in
  stop) stop; exit 0 ;;
  status) if is_up; then status_line; exit 0; else echo "slurm_local: not up"; exit 1; fi ;;
  start) ;;
  *) die "usage: $0 [start|stop|status]" ;;
esac

if is_up; then status_line; exit 0; fi

# 1. Packages. --no-install-recommends: the recommended plugins (HDF5, ROCm, InfluxDB ...) add 30-odd packages.
missing=$(for p in slurmctld slurmd slurm-client munge; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "ok installed" || echo "$p"; done)
if [ -n "$missing" ]; then
  command -v apt-get >/dev/null || die "needs apt-get to install" $missing
  echo "slurm_local: installing" $missing
  apt-get update -qq >/dev/null
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends $missing >/dev/null
fi

# 2. munge: slurm's authentication. A key readable only by the munge user, and munged running as that user.
mkdir -p /etc/munge /run/munge /var/lib/munge /var/log/munge
if [ ! -s /etc/munge/munge.key ]; then
  dd if=/dev/urandom bs=1 count=1024 of=/etc/munge/munge.key status=none
fi
chown -R munge:munge /etc/munge /run/munge /var/lib/munge /var/log/munge
chmod 0700 /etc/munge && chmod 0400 /etc/munge/munge.key
if ! munge -n 2>/dev/null | unmunge >/dev/null 2>&1; then
  runuser -u munge -- /usr/sbin/munged  # forks into the background; writes /run/munge/munged.pid
fi

# 3. slurm.conf: this host is the controller and the only node, with the CPUs and memory slurmd itself detects
# (`slurmd -C`; a node configured with more than it has is drained).
if [ -e "$CONF" ] && ! grep -qF "$MARK" "$CONF"; then
  die "$CONF exists and was not written by this script; not touching a site's SLURM config"
fi
hardware=$(slurmd -C | head -1 | sed 's/^NodeName=[^ ]* //; s/ UpTime=.*//')  # CPUs=.. ... RealMemory=..
mkdir -p /etc/slurm /run/slurm /var/lib/slurm/slurmctld /var/lib/slurm/slurmd /var/log/slurm
cat >"$CONF" <<EOF
$MARK: a single-node test cluster.
ClusterName=mapush-local
SlurmctldHost=$NODE
# Run as root, like the script: no slurm user or directory ownership to set up.
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
StateSaveLocation=/var/lib/slurm/slurmctld
SlurmdSpoolDir=/var/lib/slurm/slurmd
SlurmctldPidFile=/run/slurm/slurmctld.pid
SlurmdPidFile=/run/slurm/slurmd.pid
SlurmctldLogFile=/var/log/slurm/slurmctld.log
SlurmdLogFile=/var/log/slurm/slurmd.log
# No cgroups (containers seldom have a writable cgroup tree): track job processes by their parent ids, bind no
# cores, enforce no memory limit at run time (the scheduler still counts --mem against RealMemory).
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
# No slurmdbd: sacct has nothing to read (submitit warns about it on each poll, and goes on).
AccountingStorageType=accounting_storage/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core_Memory
MpiDefault=none
# A node that was down when slurmctld last stopped comes back as soon as its slurmd registers.
ReturnToService=2
NodeName=$NODE $hardware State=UNKNOWN
PartitionName=$PARTITION Nodes=$NODE Default=YES MaxTime=INFINITE State=UP
EOF

# 4. The daemons (each forks into the background and writes its pid file). Started only if not running, so
# that a half-up cluster (say slurmd died) is completed rather than doubled.
running /run/slurm/slurmctld.pid || slurmctld
running /run/slurm/slurmd.pid || slurmd

# 5. Wait until the node takes jobs.
for _ in $(seq 60); do
  is_up && { status_line; exit 0; }
  sleep 1
done
die "the node is not idle after 60 s (state '$(node_state)'); see sinfo -R, /var/log/slurm/slurmctld.log and slurmd.log"
