#!/usr/bin/env bash
# A real single-node Slurm cluster (munged, slurmctld, slurmd under a temporary folder,
# nothing written to /etc; see ../shared/design/farm.md) renders scenes/default.toml as 4
# tiles with scripts/slurm-render.sh --wait; the PNG, EXR and AOVs must equal a direct
# `penumbra render` byte for byte. Then a tile that fails must fail the script and the merge
# must never run. Installs slurm-wlm and munge with apt if missing (root only); prints one
# SKIPPED line where it cannot. The binary: $PENUMBRA, else target/release/penumbra (or
# $CARGO_TARGET_DIR/release/penumbra), built if absent.
set -euo pipefail
repo=$(cd "$(dirname -- "${BASH_SOURCE[0]}")/.." && pwd -P)
t_start=$EPOCHREALTIME

# Seconds since $1 (an $EPOCHREALTIME), one decimal.
since() {
    awk -v a="$1" -v b="$EPOCHREALTIME" 'BEGIN { printf "%.1f", b - a }'
}

tools=(munged mungekey slurmctld slurmd sbatch squeue sinfo scontrol scancel)
missing=()
for t in "${tools[@]}"; do
    command -v "$t" >/dev/null || missing+=("$t")
done
install_s=0
if ((${#missing[@]})); then
    if ((EUID != 0)); then
        echo "slurm: SKIPPED: ${missing[*]} missing and not root (cannot apt-get install slurm-wlm munge)"
        exit 0
    fi
    if ! command -v apt-get >/dev/null; then
        echo "slurm: SKIPPED: ${missing[*]} missing and no apt-get to install slurm-wlm munge"
        exit 0
    fi
    t=$EPOCHREALTIME
    echo "slurm: installing slurm-wlm munge (missing: ${missing[*]})"
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq slurm-wlm munge >/dev/null
    install_s=$(since "$t")
    echo "slurm: installed in $install_s s"
elif ((EUID != 0)); then
    # slurmd must start jobs as their user, and this cluster runs as root (SlurmUser=root).
    echo "slurm: SKIPPED: not root (the test cluster's daemons run as root)"
    exit 0
fi

fail() {
    echo "slurm: FAILED: $*" >&2
    exit 1
}

# Listening sockets on a port, from /proc (ss is not always installed).
port_busy() {
    local hex
    hex=$(printf '%04X' "$1")
    awk -v p=":$hex" '$2 ~ p"$" && $4 == "0A" { found = 1 } END { exit !found }' \
        /proc/net/tcp /proc/net/tcp6 2>/dev/null
}
for port in 6817 6818; do
    port_busy "$port" || continue
    # A run killed with SIGKILL leaves its daemons and folder: say how to stop them.
    for old in /tmp/penumbra-slurm.*/slurm.conf; do
        [[ -f $old ]] || continue
        old=${old%/slurm.conf}
        fail "port $port is in use, probably by the cluster of a killed test run: SLURM_CONF=$old/slurm.conf scontrol shutdown; kill \$(cat $old/munge/munged.pid); rm -r $old"
    done
    fail "port $port is in use (another Slurm? see pgrep -a 'slurm|munge')"
done

# Where cargo puts it: CARGO_TARGET_DIR (relative to the repository, where we run cargo) if set.
target=${CARGO_TARGET_DIR:-target}
[[ $target == /* ]] || target=$repo/$target
penumbra=${PENUMBRA:-$target/release/penumbra}
if [[ ! -x $penumbra ]]; then
    [[ -z ${PENUMBRA:-} ]] || fail "PENUMBRA=$PENUMBRA is not an executable"
    echo "slurm: $penumbra missing; cargo build --release"
    (cd "$repo" && cargo build --release --quiet)
fi
export PENUMBRA=$penumbra

D=$(mktemp -d /tmp/penumbra-slurm.XXXXXX)
chmod 0755 "$D" # munged insists the socket's folders are reachable by all
ctld_pid="" slurmd_pid="" munged_pid="" host=""
start_s=- render_s=- failpath_s=- teardown_s=-

log_tails() {
    local f
    for f in "$D"/log/*; do
        [[ -s $f ]] || continue
        echo "--- tail of $f" >&2
        tail -n 15 "$f" >&2
    done
}

# Waits up to $2 s for process $1 to end; reaps it (our child) so no zombie stays behind.
gone_within() {
    local pid=$1 tries=$(($2 * 10))
    while ((tries-- > 0)); do
        if [[ ! -e /proc/$pid/status ]] || grep -qs '^State:[[:space:]]*Z' "/proc/$pid/status"; then
            wait "$pid" 2>/dev/null || true
            return 0
        fi
        sleep 0.1
    done
    return 1
}
# Stops our child $1 (named $2): it may already be ending; then TERM, then KILL.
stop_pid() {
    local pid=$1 name=$2 cap=$3
    [[ -n $pid ]] || return 0
    gone_within "$pid" "$cap" && return 0
    echo "slurm: $name (pid $pid) still up after $cap s; SIGTERM" >&2
    kill -TERM "$pid" 2>/dev/null || true
    gone_within "$pid" 5 && return 0
    echo "slurm: $name (pid $pid) ignored SIGTERM; SIGKILL" >&2
    kill -KILL "$pid" 2>/dev/null || true
    gone_within "$pid" 5 || echo "slurm: $name (pid $pid) survived SIGKILL" >&2
}

# Runs a command in the background and waits for it, so a signal reaches our traps at once
# (bash runs them only after a foreground command ends) and teardown can stop the command.
child=""
run() {
    local rc=0
    "$@" &
    child=$!
    wait "$child" || rc=$?
    child=""
    return "$rc"
}

# Live slurmstepd processes of this cluster (they inherit slurmd's SLURM_CONF).
our_stepds() {
    local p
    for p in /proc/[0-9]*; do
        [[ $(cat "$p/comm" 2>/dev/null) == slurmstepd ]] || continue
        grep -qsaF "SLURM_CONF=$SLURM_CONF" "$p/environ" && echo "${p#/proc/}"
    done
    return 0
}

teardown() {
    local rc=$? t=$EPOCHREALTIME tries
    set +e
    trap - EXIT INT TERM HUP
    ((rc == 0)) || log_tails
    if [[ -n $child ]]; then
        kill -TERM "$child" 2>/dev/null
        wait "$child" 2>/dev/null
    fi
    if [[ -n $ctld_pid ]]; then
        scancel --user=root >/dev/null 2>&1
        # Job steps gone: slurmd removes their sockets from its spool folder.
        tries=100
        while ((tries-- > 0)) && [[ -n $(find "$D/spool" -type s -name "${host}_*" 2>/dev/null)$(our_stepds) ]]; do
            sleep 0.1
        done
        timeout 10 scontrol shutdown >/dev/null 2>&1
    fi
    stop_pid "$ctld_pid" slurmctld 10
    # slurmd stops on `scontrol shutdown`; not if slurmctld never reached it.
    [[ -z $slurmd_pid ]] || gone_within "$slurmd_pid" 3 || kill -TERM "$slurmd_pid" 2>/dev/null
    stop_pid "$slurmd_pid" slurmd 10
    [[ -z $munged_pid ]] || kill -TERM "$munged_pid" 2>/dev/null
    stop_pid "$munged_pid" munged 5
    rm -rf "$D"
    teardown_s=$(since "$t")
    if ((rc == 0)); then
        echo "slurm: PASSED in $(since "$t_start") s (install $install_s s, start $start_s s, tiles+merge $render_s s, failure path $failpath_s s, teardown $teardown_s s)"
    else
        echo "slurm: FAILED (exit $rc) after $(since "$t_start") s; teardown $teardown_s s" >&2
    fi
    exit "$rc"
}
trap teardown EXIT
trap 'exit 130' INT
trap 'exit 143' TERM
trap 'exit 129' HUP

# --- start-up --------------------------------------------------------------------------
t=$EPOCHREALTIME
mkdir -p "$D"/{munge,log,state,spool}
install -d -m 0700 "$D/key"
chmod 0755 "$D/munge"
mungekey -c -k "$D/key/munge.key" >/dev/null 2>&1 || fail "mungekey -c failed"
munged -F --socket="$D/munge/munge.socket" --key-file="$D/key/munge.key" \
    --pid-file="$D/munge/munged.pid" --log-file="$D/log/munged.log" \
    --seed-file="$D/munge/munged.seed" >"$D/log/munged.out" 2>&1 &
munged_pid=$!

host=$(uname -n)
host=${host%%.*}
cpus=$(nproc)
mem_mb=$(awk '/^MemTotal:/ { printf "%d", $2 / 1024 * 0.9 }' /proc/meminfo)
export SLURM_CONF=$D/slurm.conf
cat >"$SLURM_CONF" <<EOF
ClusterName=penumbra-test
SlurmctldHost=$host(127.0.0.1)
SlurmUser=root
SlurmctldPort=6817
SlurmdPort=6818
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$D/munge/munge.socket
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerParameters=batch_sched_delay=0
MailProg=/bin/true
ReturnToService=2
SlurmdParameters=config_overrides
MpiDefault=none
StateSaveLocation=$D/state
SlurmdSpoolDir=$D/spool
SlurmctldPidFile=$D/slurmctld.pid
SlurmdPidFile=$D/slurmd.pid
SlurmctldLogFile=$D/log/slurmctld.log
SlurmdLogFile=$D/log/slurmd.log
NodeName=$host NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$mem_mb State=UNKNOWN
PartitionName=test Nodes=ALL Default=YES MaxTime=INFINITE State=UP
EOF
for _ in $(seq 50); do
    [[ -S $D/munge/munge.socket ]] && break
    sleep 0.1
done
[[ -S $D/munge/munge.socket ]] || fail "munged did not create its socket in 5 s"
slurmctld -D -i >"$D/log/slurmctld.out" 2>&1 &
ctld_pid=$!
slurmd -D -N "$host" >"$D/log/slurmd.out" 2>&1 &
slurmd_pid=$!
state=""
for _ in $(seq 300); do
    state=$(sinfo -h -o %T 2>/dev/null || true)
    [[ $state == idle ]] && break
    sleep 0.1
done
[[ $state == idle ]] || fail "the node is not idle after 30 s (sinfo: '${state:-no answer}')"
start_s=$(since "$t")
echo "slurm: cluster up in $start_s s ($host, $cpus CPUs)"

# --- 4 tiles + merge against a direct render -------------------------------------------
t=$EPOCHREALTIME
flags=(--width 160 --height 120 --aov)
# Spaces and a quote in the paths: the jobs' /bin/sh must get them quoted.
scene="$D/a scene/default.toml"
farm="$D/farm out's"
mkdir -p "$D/a scene" "$D/direct"
cp "$repo/scenes/default.toml" "$scene"
# sbatch options pass through to both jobs.
PENUMBRA_SBATCH_ARGS="--time=10 --cpus-per-task=1" \
    run timeout 120 "$repo/scripts/slurm-render.sh" --wait "$scene" 4 "$farm/frame.png" "${flags[@]}" \
    >"$D/farm.out" || fail "slurm-render.sh --wait exited $?"
cat "$D/farm.out"
while read -r what _ id _; do
    [[ $what == tiles: || $what == merge: ]] || continue
    # Not `| grep -q`: grep quits at the first of the array's lines, and pipefail then
    # sees scontrol's SIGPIPE.
    job=$(scontrol -o show job "$id")
    [[ $job == *TimeLimit=00:10:00* ]] || fail "job $id did not get PENUMBRA_SBATCH_ARGS's --time=10"
done <"$D/farm.out"
run "$PENUMBRA" render "$scene" --out "$D/direct/frame.png" --quiet "${flags[@]}" ||
    fail "the direct render failed"
compared=0
for f in "$D"/direct/frame.png "$D"/direct/frame.exr "$D"/direct/frame.visibility.*; do
    [[ -e $f ]] || fail "the direct render wrote no $(basename "$f")"
    cmp "$f" "$farm/$(basename "$f")" || fail "$(basename "$f") differs between the farm and a direct render"
    compared=$((compared + 1))
done
((compared >= 4)) || fail "only $compared files compared (no --aov outputs?)"
render_s=$(since "$t")
echo "slurm: 4 tiles + merge equal a direct render ($compared files) in $render_s s"

# --- a failing tile: the script fails naming it, and the merge never runs ---------------
t=$EPOCHREALTIME
cat >"$D/flaky" <<EOF
#!/bin/sh
# Tile 2 of 4 fails; everything else is the real penumbra.
case " \$* " in *" --tile 2/4 "*) echo "flaky: tile 2 fails on purpose" >&2; exit 3 ;; esac
exec "$PENUMBRA" "\$@"
EOF
chmod +x "$D/flaky"
set +e
PENUMBRA=$D/flaky run timeout 120 "$repo/scripts/slurm-render.sh" --wait "$scene" 4 "$D/fail/frame.png" \
    "${flags[@]}" >"$D/fail.out" 2>&1
rc=$?
set -e
cat "$D/fail.out"
((rc != 124)) || fail "slurm-render.sh --wait still waiting after 120 s with a failed tile"
((rc != 0)) || fail "slurm-render.sh --wait exited 0 though tile 2 failed"
grep -q "tile 2: FAILED" "$D/fail.out" || fail "slurm-render.sh did not name tile 2 as failed"
grep -q "flaky: tile 2 fails on purpose" "$D/fail/.frame.tiles/frame.tile-2.log" ||
    fail "tile 2's log lacks its error"
[[ ! -e $D/fail/frame.png && ! -e $D/fail/.frame.tiles/frame.merge.log ]] ||
    fail "the merge ran although tile 2 failed"
failpath_s=$(since "$t")
echo "slurm: a failed tile fails slurm-render.sh (exit $rc) and skips the merge, in $failpath_s s"
