#!/usr/bin/env bash
# What splitting a frame into tiles costs: the CPU time (user + sys, from GNU time) of the N
# tile renders plus the merge, against the single render with the same settings, pair by
# pair (single, then the tiles), REPEATS times; prints each pair's ratio and their median,
# and each phase's wall time summed over the tiles (from the merged report) beside the
# single render's, which says where the overhead goes.
#
#   scripts/tile-overhead.sh [-r REPEATS] SCENE.toml N [render flags...]
#   scripts/tile-overhead.sh -r 3 scenes/default.toml 16 --shadows edge_table
#
# The binary: $PENUMBRA, else target/release/penumbra of this checkout.
set -euo pipefail
repeats=3
if [[ ${1:-} == -r ]]; then repeats=$2; shift 2; fi
if [[ $# -lt 2 ]]; then
    echo "usage: $0 [-r REPEATS] SCENE.toml N [render flags...]" >&2
    exit 2
fi
scene=$1 n=$2
shift 2
root=$(cd "$(dirname "$0")/.." && pwd)
bin=${PENUMBRA:-$root/target/release/penumbra}
[[ -x $bin ]] || { echo "$0: no penumbra binary at $bin (cargo build --release)" >&2; exit 2; }
[[ -x /usr/bin/time ]] || { echo "$0: needs GNU time at /usr/bin/time (apt-get install time)" >&2; exit 2; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# CPU seconds (user + sys) of one command.
cpu() {
    /usr/bin/time -f '%U %S' -o "$work/t" "$@" >/dev/null
    awk '{ printf "%.3f", $1 + $2 }' "$work/t"
}
# A phase's wall seconds in a report.
phase() { grep -o "\"$2\": [0-9.e-]*" "$1" | head -1 | awk '{ printf "%.3f", $2 }'; }

ratios=()
for ((r = 1; r <= repeats; r++)); do
    single=$(cpu "$bin" render "$scene" --quiet --out "$work/single.png" "$@")
    tiles=0
    for ((k = 0; k < n; k++)); do
        t=$(cpu "$bin" render "$scene" --quiet --tile "$k/$n" --out "$work/tile-$k.png" "$@")
        tiles=$(awk -v a="$tiles" -v b="$t" 'BEGIN { print a + b }')
    done
    list=()
    for ((k = 0; k < n; k++)); do list+=("$work/tile-$k.json"); done
    merge=$(cpu "$bin" merge --quiet --out "$work/merged.png" "${list[@]}")
    cmp -s "$work/single.png" "$work/merged.png" || { echo "$0: the merged PNG differs from the single render's" >&2; exit 1; }
    ratio=$(awk -v s="$single" -v t="$tiles" -v m="$merge" 'BEGIN { printf "%.3f", (t + m) / s }')
    ratios+=("$ratio")
    echo "run $r: single ${single} s CPU; $n tiles ${tiles} s + merge ${merge} s; ratio $ratio"
done
median=$(printf '%s\n' "${ratios[@]}" | sort -g | awk '{ v[NR] = $1 } END { print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2 }')
echo "median ratio (tiles + merge) / single, CPU time: $median over $repeats run(s)"
echo "wall seconds per phase, the last run: single | the $n tiles summed"
for p in load bvh visible_points shadow_prepare render write total; do
    printf '  %-15s %8s | %8s\n' "$p" "$(phase "$work/single.json" "$p")" "$(phase "$work/merged.json" "$p")"
done
