#!/usr/bin/env bash
# Renders a scene on a Slurm cluster: one array task per tile (bands of rows), then a merge
# job that assembles OUT.png, OUT.exr, OUT.json (and the AOVs), the same bytes as a
# single `penumbra render SCENE --out OUT.png [render flags]`.
#
#   scripts/slurm-render.sh [--wait] SCENE.toml TILES OUT.png [render flags...]
#
# Tiles, their reports and Slurm's job logs go to OUT_DIR/.STEM.tiles/ (STEM = OUT's name
# without .png). --wait blocks until the merge ends and exits with its status; if a tile
# fails it names the tile and its log, cancels the remaining tasks and exits 1.
#
# Environment:
#   PENUMBRA             the penumbra binary (default: penumbra on PATH, else
#                        target/release/penumbra of this repository)
#   PENUMBRA_SBATCH_ARGS extra sbatch options for both jobs, split on spaces, e.g.
#                        "--partition=render --time=01:00:00 --mem=4G --cpus-per-task=8"
#                        (penumbra uses every core it can see, so --cpus-per-task sets
#                        the threads per tile)
set -euo pipefail

usage() {
    echo "usage: $0 [--wait] SCENE.toml TILES OUT.png [render flags...]" >&2
    exit 2
}
die() {
    echo "slurm-render: $*" >&2
    exit 2
}

wait_for_merge=0
if [[ ${1:-} == --wait ]]; then
    wait_for_merge=1
    shift
fi
(($# >= 3)) || usage
scene=$1 tiles=$2 out=$3
shift 3
[[ $tiles =~ ^[1-9][0-9]*$ ]] || die "TILES must be a positive integer, not '$tiles'"
[[ -f $scene ]] || die "$scene: no such scene file"
[[ $out == *.png ]] || die "$out: OUT must end in .png"
render_flags=()
for a in "$@"; do
    case $a in
    --out | --out=* | --tile | --tile=*) die "$a: the script sets --out and --tile itself" ;;
    --quiet) ;; # tiles get --quiet anyway; clap rejects a repeated flag
    *) render_flags+=("$a") ;;
    esac
done

for tool in sbatch scontrol scancel; do
    command -v "$tool" >/dev/null || die "$tool not found (is this a Slurm submit host?)"
done

# Jobs run on other nodes: every path they see must be absolute, on the shared file system.
if [[ -n ${PENUMBRA:-} ]]; then
    bin=$(command -v -- "$PENUMBRA") || die "PENUMBRA=$PENUMBRA: not found"
elif ! bin=$(command -v penumbra); then
    bin=$(dirname -- "${BASH_SOURCE[0]}")/../target/release/penumbra
fi
[[ -x $bin && -f $bin ]] || die "no penumbra binary: set PENUMBRA, put penumbra on PATH or cargo build --release"
bin=$(realpath -- "$bin")
scene=$(realpath -- "$scene")
out=$(realpath -m -- "$out")
stem=$(basename -- "$out" .png)
# Beside OUT rather than in /tmp: /tmp is per node, while the merge job must read what every
# tile task wrote; OUT's folder is already where the user can write and the nodes can see.
tiledir=$(dirname -- "$out")/.$stem.tiles
mkdir -p -- "$tiledir"
# Leftovers of an earlier run of the same OUT would mix into this one's folder.
rm -f -- "$tiledir/$stem".tile-* "$tiledir/$stem".merge.log

# Quotes one word for /bin/sh (dash runs --wrap scripts; printf %q is bash-only).
shq() {
    printf "'%s'" "${1//\'/\'\\\'\'}"
}
shq_all() {
    local w sep=""
    for w in "$@"; do
        printf '%s%s' "$sep" "$(shq "$w")"
        sep=" "
    done
}
# sbatch expands %-patterns in log paths.
logpat() {
    printf '%s' "${1//%/%%}"
}

sbatch_args=()
if [[ -n ${PENUMBRA_SBATCH_ARGS:-} ]]; then
    read -r -a sbatch_args <<<"$PENUMBRA_SBATCH_ARGS"
fi

tile_base=$tiledir/$stem.tile-
tile_cmd="exec $(shq "$bin") render $(shq "$scene") --tile \"\$SLURM_ARRAY_TASK_ID\"/$tiles"
tile_cmd+=" --out $(shq "$tile_base")\"\$SLURM_ARRAY_TASK_ID\".png --quiet"
((${#render_flags[@]} == 0)) || tile_cmd+=" $(shq_all "${render_flags[@]}")"

tile_jsons=()
for ((k = 0; k < tiles; k++)); do
    tile_jsons+=("$tile_base$k.json")
done
merge_cmd="exec $(shq "$bin") merge --out $(shq "$out") $(shq_all "${tile_jsons[@]}")"

submitted=$(sbatch --parsable "${sbatch_args[@]}" --job-name="penumbra-tiles-$stem" \
    --array="0-$((tiles - 1))" --output="$(logpat "$tile_base")%a.log" --wrap="$tile_cmd") ||
    die "sbatch of the tiles failed"
array_id=${submitted%%;*}
if ! submitted=$(sbatch --parsable "${sbatch_args[@]}" --job-name="penumbra-merge-$stem" \
    --dependency="afterok:$array_id" --kill-on-invalid-dep=yes \
    --output="$(logpat "$tiledir/$stem").merge.log" --wrap="$merge_cmd"); then
    scancel "$array_id" || true
    die "sbatch of the merge failed; cancelled the tiles (job $array_id)"
fi
merge_id=${submitted%%;*}
echo "tiles: job $array_id ($tiles tasks, logs $tile_base<K>.log)"
echo "merge: job $merge_id (log $tiledir/$stem.merge.log)"
echo "output: $out"
((wait_for_merge)) || exit 0

trap 'echo "slurm-render: stopped waiting; the jobs go on (scancel $array_id $merge_id stops them)" >&2; exit 130' INT TERM

# A job's KEY=VALUE from `scontrol -o show job` (one line per job or array task).
field() {
    local w words
    read -r -a words <<<"$2" # split, but no globbing of the job's fields
    for w in "${words[@]}"; do
        [[ $w == "$1"=* ]] && printf '%s\n' "${w#*=}" && return
    done
    return 0
}

# Polls rather than `sbatch --wait` so the ids above print at once and a forgotten job
# (past MinJobAge) still ends the wait. Every 0.5 s for 10 s, then every 5 s: a long queue
# should not hammer the controller.
state="" exit_code="" polls=0 errors=0
while :; do
    if ! line=$(scontrol -o show job "$merge_id" 2>&1); then
        if [[ $line == *"Invalid job id"* ]]; then
            state=PURGED
            break
        fi
        # A busy or restarting controller: try again, for a while.
        errors=$((errors + 1))
        ((errors < 60)) || die "scontrol keeps failing ($line); the jobs go on: $array_id, $merge_id"
        sleep 5
        continue
    fi
    errors=0
    state=$(field JobState "$line")
    exit_code=$(field ExitCode "$line")
    case $state in
    PENDING | RUNNING | CONFIGURING | COMPLETING | SUSPENDED | REQUEUED* | RESIZING | RESV_DEL_HOLD | STAGE_OUT | SIGNALING)
        polls=$((polls + 1))
        if ((polls < 20)); then sleep 0.5; else sleep 5; fi
        ;;
    *) break ;;
    esac
done
trap - INT TERM

if [[ $state == COMPLETED ]]; then
    echo "merged: $out"
    exit 0
fi
if [[ $state == PURGED && ${out%.png}.json -nt ${tile_base}0.json ]]; then
    # The controller forgot the job; a report newer than this run's tiles says it ran.
    echo "merged: $out"
    exit 0
fi

status=${exit_code%%:*}
[[ $status =~ ^[0-9]+$ && $status != 0 ]] || status=1
# Which tiles failed: the array's tasks, else (tasks forgotten) the missing tile reports.
failed=0 why=()
tasks=$(scontrol -o show job "$array_id" 2>/dev/null || true)
while IFS= read -r line; do
    task=$(field ArrayTaskId "$line")
    [[ $task =~ ^[0-9]+$ ]] || continue
    tstate=$(field JobState "$line")
    case $tstate in
    COMPLETED | PENDING | RUNNING | CONFIGURING | COMPLETING) ;;
    *)
        why[task]="slurm-render: tile $task: $tstate (exit $(field ExitCode "$line")), log $tile_base$task.log"
        failed=1
        ;;
    esac
done <<<"$tasks"
# scontrol lists the tasks last first; an indexed array prints them in tile order.
((!failed)) || printf '%s\n' "${why[@]}" >&2
if ((!failed)); then
    for ((k = 0; k < tiles; k++)); do
        if [[ ! -f $tile_base$k.json ]]; then
            echo "slurm-render: tile $k: no report, log $tile_base$k.log" >&2
            failed=1
        fi
    done
fi
scancel "$array_id" 2>/dev/null || true
if ((failed)); then
    echo "slurm-render: the merge (job $merge_id) did not run: $state; cancelled any tiles still queued or running" >&2
else
    echo "slurm-render: the merge (job $merge_id) ended $state (exit $exit_code), log $tiledir/$stem.merge.log" >&2
fi
exit "$status"
