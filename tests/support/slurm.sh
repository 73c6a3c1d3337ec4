#!/usr/bin/env bash
# A one-node Slurm cluster on this machine for tests (tests/slurm.rs):
# Debian's Slurm (slurmctld, slurmd and the client commands of slurm-wlm,
# 22.05 on Debian 12) authenticated by a munge daemon of its own. Everything
# the cluster writes (slurm.conf, the munge key and socket, state and spool
# directories, logs, pid files) lives in STATE_DIR; no system configuration
# is read or written (no /etc/slurm/slurm.conf, no systemd unit, not the
# system's munged) and the daemons listen on two free ports drawn at random
# in 20000-40000 (on 127.0.0.1 only where the host name resolves there). A
# STATE_DIR longer than 60 characters is reached through a symbolic link
# /tmp/ezy-slurm-HASH (unix socket paths are limited to 108 bytes), which
# `down` removes.
#
# Usage:
#   slurm.sh up STATE_DIR    Installs slurmctld, slurmd, slurm-client and munge
#                            with apt-get when missing (as root), stops a
#                            cluster left running in STATE_DIR, starts munged,
#                            slurmctld and slurmd, waits until the node is idle
#                            and prints KEY=VALUE lines on stdout, the last one
#                            SLURM_CONF=/abs/STATE_DIR/slurm.conf. Export that
#                            SLURM_CONF for sbatch, squeue, scontrol, scancel.
#   slurm.sh down STATE_DIR  Cancels the cluster's jobs, stops the daemons
#                            started in STATE_DIR (by their pid files, then any
#                            slurmctld, slurmd, munged or slurmstepd left that
#                            belongs to STATE_DIR) and leaves the files there.
#
# Exit codes:
#   0   done
#   77  the cluster cannot be brought up here (not root, no apt-get, the
#       install failed, a daemon did not come up within 60 s): stdout is one
#       line `skip: REASON`, and nothing is left running
#   2   usage
#   1   a bug in this script (a command failed unexpectedly; see stderr), or
#       `down` found processes of the cluster still running after SIGKILL
#
# Every wait has a time limit: each apt-get call 10 min, the daemons 60 s,
# down 40 s.
set -euo pipefail
export PATH="$PATH:/usr/sbin:/sbin"

usage() { echo "usage: $0 up|down STATE_DIR" >&2; exit 2; }
[ $# -eq 2 ] || usage
cmd=$1
case "$cmd" in up | down) ;; *) usage ;; esac
if [ "$cmd" = down ] && [ ! -d "$2" ]; then exit 0; fi
mkdir -p "$2"
state=$(cd "$2" && pwd -P)
conf=$state/slurm.conf
partition=ezy

skip() { echo "skip: $*"; exit 77; }

# ---------------------------------------------------------------- processes
# Unix socket paths (munge's, the job steps' in the spool) must stay short:
# a long STATE_DIR is reached through a symbolic link /tmp/ezy-slurm-HASH.
base=$state
if [ ${#state} -gt 60 ]; then
    base=/tmp/ezy-slurm-$(printf '%s' "$state" | md5sum | cut -c1-12)
fi

# Fields of /proc/PID/stat after the command name: state, ppid, ...
# A process that has exited but not been reaped is a zombie (state Z), which
# kill -0 would still find.
alive() {
    local s
    s=$(cat "/proc/$1/stat" 2>/dev/null) || return 1
    s=${s##*) }
    case "${s%% *}" in Z | X) return 1 ;; esac
}

comm() { cat "/proc/$1/comm" 2>/dev/null || true; }

# The processes of this cluster that are still running: the daemons named by
# the pid files (when the name matches), any slurmctld, slurmd or munged whose
# command line names STATE_DIR, any slurmstepd working in STATE_DIR or with a
# file open there (its log, its socket in the spool), and every process below
# a slurmstepd (the jobs' own processes).
cluster_pids() {
    local d f p c s steps=() found=() frontier next
    local -A children=()
    for d in slurmd slurmctld munged; do
        f=$state/$d.pid
        [ -f "$f" ] || continue
        p=$(cat "$f" 2>/dev/null || true)
        case "$p" in '' | *[!0-9]*) continue ;; esac
        if alive "$p" && [ "$(comm "$p")" = "$d" ]; then found+=("$p"); fi
    done
    for f in /proc/[0-9]*; do
        p=${f#/proc/}
        s=$(cat "$f/stat" 2>/dev/null) || continue
        s=${s##*) }
        case "${s%% *}" in Z | X) continue ;; esac
        s=${s#* }
        children[${s%% *}]+=" $p"
        c=$(comm "$p")
        case "$c" in
        slurmctld | slurmd | munged)
            if tr '\0' ' ' <"$f/cmdline" 2>/dev/null | grep -qF -e "$state/" -e "$base/"; then
                found+=("$p")
            fi
            ;;
        slurmstepd)
            if [ "$(readlink "$f/cwd" 2>/dev/null)" = "$state" ] ||
                find "$f/fd" -maxdepth 1 -lname "$state/*" 2>/dev/null | grep -q .; then
                steps+=("$p")
            fi
            ;;
        esac
    done
    # slurmctld's helper slurmscriptd, and the jobs below their slurmstepd
    frontier=("${steps[@]+"${steps[@]}"}")
    for p in "${found[@]+"${found[@]}"}"; do
        [ "$(comm "$p")" = slurmctld ] && frontier+=("$p")
    done
    found+=("${steps[@]+"${steps[@]}"}")
    while [ ${#frontier[@]} -gt 0 ]; do
        next=()
        for p in "${frontier[@]}"; do
            for c in ${children[$p]:-}; do next+=("$c"); done
        done
        found+=("${next[@]+"${next[@]}"}")
        frontier=("${next[@]+"${next[@]}"}")
    done
    if [ ${#found[@]} -gt 0 ]; then printf '%s\n' "${found[@]}" | sort -un; fi
}

# Waits up to $1 tenths of a second for the pids that follow to be gone.
wait_gone() {
    local n=$1 p left
    shift
    while :; do
        left=0
        for p in "$@"; do alive "$p" && left=1 && break; done
        [ $left = 0 ] && return 0
        [ "$n" -le 0 ] && return 1
        n=$((n - 1))
        sleep 0.1
    done
}

stop_all() {
    local pids p
    # cancel the jobs first, so that every slurmstepd ends its job and exits
    if [ -f "$conf" ] && [ -f "$state/slurmctld.pid" ] && alive "$(cat "$state/slurmctld.pid" 2>/dev/null || echo x)"; then
        SLURM_CONF=$conf timeout 10 scancel --partition="$partition" >/dev/null 2>&1 || true
        local steps=()
        mapfile -t steps < <(cluster_pids | while read -r p; do [ "$(comm "$p")" = slurmstepd ] && echo "$p"; done)
        if [ ${#steps[@]} -gt 0 ]; then wait_gone 150 "${steps[@]}" || true; fi
    fi
    mapfile -t pids < <(cluster_pids)
    if [ ${#pids[@]} -gt 0 ]; then
        for p in "${pids[@]}"; do
            # slurmstepd ignores SIGTERM; its job's processes get it
            if [ "$(comm "$p")" = slurmstepd ]; then kill -KILL "$p"; else kill -TERM "$p"; fi 2>/dev/null || true
        done
        if ! wait_gone 100 "${pids[@]}"; then
            mapfile -t pids < <(cluster_pids)
            if [ ${#pids[@]} -gt 0 ]; then
                kill -KILL "${pids[@]}" 2>/dev/null || true
                wait_gone 50 "${pids[@]}" || true
            fi
        fi
    fi
    rm -f "$state/slurmd.pid" "$state/slurmctld.pid" "$state/munged.pid"
    # a cluster_pids that still finds something is a failure to stop
    [ -z "$(cluster_pids)" ]
}

if [ "$cmd" = down ]; then
    stop_all || { echo "slurm.sh down: processes of $state still running: $(cluster_pids | tr '\n' ' ')" >&2; exit 1; }
    if [ "$base" != "$state" ] && [ "$(readlink "$base" 2>/dev/null)" = "$state" ]; then rm -f "$base"; fi
    exit 0
fi

# ---------------------------------------------------------------- up
up_ok=no
# whatever ends `up` before the cluster is ready stops what it started
trap 'if [ "$up_ok" != yes ]; then stop_all >/dev/null 2>&1 || true; fi' EXIT
now_ms() { echo $(($(date +%s%N) / 1000000)); }
secs_since() { local d=$(($(now_ms) - $1)); printf '%d.%d' $((d / 1000)) $((d % 1000 / 100)); }
started=$(now_ms)

case "$state" in *[[:space:]\#\"\'\\]*) skip "STATE_DIR $state has a character that slurm.conf cannot hold" ;; esac
[ "$(id -u)" = 0 ] || skip "the test cluster runs its daemons as root (SlurmUser=root) and this is uid $(id -u)"

need=(slurmctld slurmd sbatch squeue scontrol sinfo scancel munged)
missing=()
for c in "${need[@]}"; do command -v "$c" >/dev/null 2>&1 || missing+=("$c"); done
install_s=0
if [ ${#missing[@]} -gt 0 ]; then
    command -v apt-get >/dev/null 2>&1 || skip "Slurm is not installed (${missing[*]} missing) and there is no apt-get"
    pkgs=(slurmctld slurmd slurm-client munge)
    apt() {
        DEBIAN_FRONTEND=noninteractive timeout 600 apt-get "$@" -o DPkg::Lock::Timeout=120 >>"$state/apt.log" 2>&1
    }
    t0=$(now_ms)
    : >"$state/apt.log"
    if ! apt install -y --no-install-recommends "${pkgs[@]}"; then
        apt update || true
        apt install -y --no-install-recommends "${pkgs[@]}" ||
            skip "apt-get install ${pkgs[*]} failed (see $state/apt.log)"
    fi
    install_s=$(secs_since "$t0")
    for c in "${need[@]}"; do
        command -v "$c" >/dev/null 2>&1 || skip "$c is still missing after apt-get install ${pkgs[*]}"
    done
fi

stop_all || skip "processes of an earlier cluster in $state would not stop"
rm -rf "$state/ctld" "$state/spool" "$state/munge"
rm -f "$state"/slurmctld.log "$state"/slurmd.log "$state"/munged.log "$state"/*.out
mkdir -p "$state/ctld" "$state/spool" "$state/munge"
chmod 711 "$state/munge"
if [ "$base" != "$state" ]; then
    if [ -L "$base" ] || [ ! -e "$base" ]; then
        rm -f "$base"
        ln -s "$state" "$base"
    else
        skip "$base (the short path for the long STATE_DIR) exists and is not a link"
    fi
fi

# the last error in these logs (else their last line), for a skip reason
last_error() {
    local e
    e=$(cat "$@" 2>/dev/null | grep -iE 'fatal|error' | grep -viE 'pmix|MPI:|state file|backup state' | tail -n 1 || true)
    [ -n "$e" ] || e=$(cat "$@" 2>/dev/null | grep -v '^[[:space:]]*$' | tail -n 1 || true)
    printf '%s' "${e:-no log}" | tr -d '\r'
}

# ---------------------------------------------------------------- munge
key=$base/munge/munge.key
head -c 1024 /dev/urandom >"$key"
chmod 400 "$key"
socket=$base/munge/munge.socket
timeout 20 munged --force --key-file="$key" --socket="$socket" --pid-file="$base/munged.pid" \
    --log-file="$base/munged.log" --seed-file="$base/munge/seed" >>"$state/munged.log" 2>&1 ||
    skip "munged did not start: $(tail -n 1 "$state/munged.log")"
for _ in $(seq 100); do [ -S "$socket" ] && break; sleep 0.1; done
[ -S "$socket" ] || skip "munged did not open its socket within 10 s"
timeout 10 munge -n -S "$socket" 2>>"$state/munged.log" | timeout 10 unmunge -S "$socket" >/dev/null 2>>"$state/munged.log" ||
    skip "munged does not answer on $socket: $(tail -n 1 "$state/munged.log")"

# ---------------------------------------------------------------- config
host=$(hostname -s 2>/dev/null || hostname)
cpus=$(nproc)
free_port() {
    if command -v ss >/dev/null 2>&1; then
        [ -z "$(ss -Hltn "sport = :$1" 2>/dev/null)" ]
    else
        # a port that takes a connection is in use
        if (exec 3<>"/dev/tcp/127.0.0.1/$1") 2>/dev/null; then return 1; fi
    fi
}
ctld_port=
for _ in $(seq 50); do
    p=$((20000 + RANDOM % 19999))
    if free_port "$p" && free_port $((p + 1)); then ctld_port=$p; break; fi
done
[ -n "$ctld_port" ] || skip "no two free ports next to each other in 20000-40000"
slurmd_port=$((ctld_port + 1))
# Both daemons are reached at 127.0.0.1. Where the host name resolves to a
# loopback address they also listen there only (not on every interface).
comm_params=
case "$(getent ahostsv4 "$host" 2>/dev/null | awk 'NR == 1 {print $1}')" in
127.*) comm_params="CommunicationParameters=NoCtldInAddrAny,NoInAddrAny" ;;
esac
: >"$state/plugstack.conf"
via=
[ "$base" = "$state" ] || via=" (reached as $base: unix socket paths must be short)"
cat >"$conf" <<EOF
# written by tests/support/slurm.sh up $state$via
ClusterName=ezytest
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
$comm_params
AuthType=auth/munge
AuthInfo=socket=$socket
CredType=cred/munge
SlurmUser=root
SlurmdUser=root
StateSaveLocation=$base/ctld
SlurmdSpoolDir=$base/spool
SlurmctldPidFile=$base/slurmctld.pid
SlurmdPidFile=$base/slurmd.pid
SlurmctldLogFile=$base/slurmctld.log
SlurmdLogFile=$base/slurmd.log
PlugStackConfig=$base/plugstack.conf
MailProg=/bin/true
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SwitchType=switch/none
MpiDefault=none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
SchedulerType=sched/backfill
# start jobs on the controller's next one-second tick, not up to 3 s later
SchedulerParameters=batch_sched_delay=0
SlurmdParameters=config_overrides
ReturnToService=2
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
SlurmctldTimeout=30
SlurmdTimeout=30
MessageTimeout=10
InactiveLimit=0
KillWait=5
# sbatch --wait polls every 2 s only while MinJobAge <= 5 (then 8 s, 32 s);
# a finished job stays in squeue/scontrol for MinJobAge s or a little more
MinJobAge=5
NodeName=$host NodeAddr=127.0.0.1 NodeHostname=$host CPUs=$cpus RealMemory=1000 State=UNKNOWN
PartitionName=$partition Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
export SLURM_CONF=$conf
version=$(sbatch --version 2>/dev/null | awk '{print $2}' || true)

# ---------------------------------------------------------------- daemons
timeout 30 slurmctld -c -f "$conf" >>"$state/slurmctld.out" 2>&1 ||
    skip "slurmctld did not start: $(last_error "$state/slurmctld.out" "$state/slurmctld.log")"
timeout 30 slurmd -f "$conf" -N "$host" >>"$state/slurmd.out" 2>&1 ||
    skip "slurmd did not start: $(last_error "$state/slurmd.out" "$state/slurmd.log")"
pid_of() { cat "$state/$1.pid" 2>/dev/null || echo x; }
deadline=$((SECONDS + 60))
ready=no
while [ $SECONDS -lt $deadline ]; do
    if [ -f "$state/slurmctld.pid" ] && ! alive "$(pid_of slurmctld)"; then
        skip "slurmctld exited: $(last_error "$state/slurmctld.log")"
    fi
    if [ -f "$state/slurmd.pid" ] && ! alive "$(pid_of slurmd)"; then
        skip "slurmd exited: $(last_error "$state/slurmd.log")"
    fi
    if timeout 10 scontrol ping 2>/dev/null | grep -q 'is UP'; then
        st=$(timeout 10 sinfo -h -n "$host" -o %t 2>/dev/null || true)
        case "$st" in
        idle) ready=yes; break ;;
        down | drain | drng | fail | inval)
            timeout 10 scontrol update nodename="$host" state=resume >/dev/null 2>&1 || true ;;
        esac
    fi
    sleep 0.25
done
[ $ready = yes ] || skip "the node did not become idle within 60 s (state: $(timeout 10 sinfo -h -n "$host" -o '%t %E' 2>/dev/null | tr '\n' ' ' || true)): $(last_error "$state/slurmctld.log" "$state/slurmd.log")"
up_ok=yes

echo "SLURM_VERSION=$version"
echo "SLURM_CLUSTER=ezytest"
echo "SLURM_NODE=$host"
echo "SLURM_CPUS=$cpus"
echo "SLURM_PARTITION=$partition"
echo "SLURMCTLD_PORT=$ctld_port"
echo "SLURMD_PORT=$slurmd_port"
echo "SLURM_STATE_DIR=$state"
echo "SLURM_INSTALL_SECONDS=$install_s"
echo "SLURM_UP_SECONDS=$(secs_since "$started")"
echo "SLURM_CONF=$conf"
