#!/usr/bin/env bash
# A one-node Slurm cluster on this machine, for tests/slurm.rs: Debian's
# slurm-wlm (slurmctld, slurmd, the client commands) with a munge daemon of
# its own. Everything it writes (slurm.conf, the munge key and socket, spool
# directories, logs, pid files) lives in STATE_DIR; no system configuration
# is touched and no systemd unit is used.
#
#   slurm.sh up STATE_DIR     installs the packages if missing (apt-get, as
#                             root), starts munged, slurmctld and slurmd, waits
#                             until the node is idle, prints KEY=VALUE lines,
#                             the last one SLURM_CONF=STATE_DIR/slurm.conf
#   slurm.sh down STATE_DIR   stops the daemons it started there
#
# Exit codes: 0 done; 77 the cluster cannot be brought up here (one line
# `skip: REASON` on stdout: not root, no apt-get, install failed, a daemon
# did not start); 2 usage. Every wait has a time limit.
set -euo pipefail

usage() { echo "usage: $0 up|down STATE_DIR" >&2; exit 2; }
[ $# -eq 2 ] || usage
cmd=$1
mkdir -p "$2"
state=$(cd "$2" && pwd)

skip() { echo "skip: $*"; exit 77; }

stop_all() {
    for d in slurmd slurmctld munged; do
        f="$state/$d.pid"
        if [ -f "$f" ]; then
            pid=$(cat "$f" 2>/dev/null || true)
            if [ -n "$pid" ] && kill -0 "$pid" 2>/dev/null; then
                kill "$pid" 2>/dev/null || true
                for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
                kill -9 "$pid" 2>/dev/null || true
            fi
            rm -f "$f"
        fi
    done
}

case "$cmd" in
down) stop_all; exit 0 ;;
up) ;;
*) usage ;;
esac

# ---------------------------------------------------------------- install
need=(slurmctld slurmd sbatch squeue scontrol sinfo munged)
missing=()
for c in "${need[@]}"; do command -v "$c" >/dev/null 2>&1 || [ -x "/usr/sbin/$c" ] || missing+=("$c"); done
if [ ${#missing[@]} -gt 0 ]; then
    [ "$(id -u)" = 0 ] || skip "Slurm is not installed (${missing[*]} missing) and installing it needs root"
    command -v apt-get >/dev/null 2>&1 || skip "Slurm is not installed and there is no apt-get to install it"
    pkgs=(slurmctld slurmd slurm-client munge)
    export DEBIAN_FRONTEND=noninteractive
    if ! timeout 600 apt-get install -y -o DPkg::Lock::Timeout=120 --no-install-recommends "${pkgs[@]}" \
        >"$state/apt.log" 2>&1; then
        timeout 300 apt-get update >>"$state/apt.log" 2>&1 || true
        timeout 600 apt-get install -y -o DPkg::Lock::Timeout=120 --no-install-recommends "${pkgs[@]}" \
            >>"$state/apt.log" 2>&1 || skip "apt-get install ${pkgs[*]} failed (see $state/apt.log)"
    fi
fi
export PATH="$PATH:/usr/sbin:/sbin"
[ "$(id -u)" = 0 ] || skip "the test cluster runs its daemons as root (SlurmUser=root); run as root"

stop_all
rm -rf "$state/ctld" "$state/d" "$state/munge"
mkdir -p "$state/ctld" "$state/d" "$state/munge"
chmod 700 "$state/munge"

# ---------------------------------------------------------------- munge
key="$state/munge/munge.key"
head -c 1024 /dev/urandom >"$key"
chmod 400 "$key"
socket="$state/munge/munge.socket"
munged --force --key-file="$key" --socket="$socket" --pid-file="$state/munged.pid" \
    --log-file="$state/munged.log" --seed-file="$state/munge/seed" >/dev/null 2>&1 ||
    skip "munged did not start (see $state/munged.log)"
for _ in $(seq 100); do [ -S "$socket" ] && break; sleep 0.1; done
[ -S "$socket" ] || skip "munged did not open its socket within 10 s"

# ---------------------------------------------------------------- config
host=$(hostname -s 2>/dev/null || hostname)
cpus=$(nproc)
port() { echo $((20000 + RANDOM % 20000)); }
ctld_port=$(port)
slurmd_port=$((ctld_port + 1))
conf="$state/slurm.conf"
cat >"$conf" <<EOF
ClusterName=ezytest
SlurmctldHost=$host
AuthType=auth/munge
AuthInfo=socket=$socket
CredType=cred/munge
SlurmUser=root
SlurmdUser=root
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
StateSaveLocation=$state/ctld
SlurmdSpoolDir=$state/d
SlurmctldPidFile=$state/slurmctld.pid
SlurmdPidFile=$state/slurmd.pid
SlurmctldLogFile=$state/slurmctld.log
SlurmdLogFile=$state/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SwitchType=switch/none
MpiDefault=none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
SchedulerType=sched/backfill
ReturnToService=2
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
SlurmctldTimeout=30
SlurmdTimeout=30
InactiveLimit=0
MinJobAge=30
KillWait=5
NodeName=$host CPUs=$cpus RealMemory=1000 State=UNKNOWN
PartitionName=ezy Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
export SLURM_CONF="$conf"

# ---------------------------------------------------------------- daemons
slurmctld -c -f "$conf" >"$state/slurmctld.out" 2>&1 || skip "slurmctld did not start (see $state/slurmctld.log)"
slurmd -f "$conf" >"$state/slurmd.out" 2>&1 || { stop_all; skip "slurmd did not start (see $state/slurmd.log)"; }
up=no
for _ in $(seq 120); do
    if scontrol ping 2>/dev/null | grep -q UP; then
        st=$(sinfo -h -n "$host" -o %t 2>/dev/null || true)
        case "$st" in
        idle*) up=yes; break ;;
        down* | drain* | inval*) scontrol update nodename="$host" state=resume >/dev/null 2>&1 || true ;;
        esac
    fi
    sleep 0.5
done
if [ $up != yes ]; then
    stop_all
    skip "the Slurm node did not become idle within 60 s (see $state/slurmctld.log, $state/slurmd.log)"
fi
echo "SLURM_VERSION=$(sinfo -V 2>/dev/null | awk '{print $2}')"
echo "SLURM_NODE=$host"
echo "SLURM_CPUS=$cpus"
echo "SLURM_CONF=$conf"
