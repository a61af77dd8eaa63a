#!/usr/bin/env bash
# Two builds of penumbra side by side: each scene's shadow cost (the report's shadow_prepare +
# render, less `none`'s, pooled over both builds) for `traced` and `silhouette`, the two binaries in turn (A, B,
# A, B ...) REPEATS times; prints the medians and silhouette's speedup over traced per binary,
# and B's speedup over A's. Both methods give traced's error at the same N, so the speedup is
# an equal-error speedup.
#
#   scripts/ab-shadow-cost.sh [-r REPEATS] BIN_A BIN_B SCENE.toml... [-- render flags...]
#   scripts/ab-shadow-cost.sh -r 3 /tmp/before/penumbra target/release/penumbra scenes/bench/*.toml \
#       -- --samples 1024 --width 320 --height 240
set -euo pipefail
repeats=3
if [[ ${1:-} == -r ]]; then repeats=$2; shift 2; fi
if [[ $# -lt 3 ]]; then
    echo "usage: $0 [-r REPEATS] BIN_A BIN_B SCENE.toml... [-- render flags...]" >&2
    exit 2
fi
bins=("$1" "$2")
shift 2
scenes=()
while [[ $# -gt 0 && $1 != -- ]]; do scenes+=("$1"); shift; done
[[ ${1:-} == -- ]] && shift
for b in "${bins[@]}"; do [[ -x $b ]] || { echo "$0: no binary at $b" >&2; exit 2; }; done
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# A phase's wall seconds in a report.
phase() { grep -o "\"$2\": [0-9.e-]*" "$1" | head -1 | awk '{ print $2 }'; }
# The median of the arguments.
median() { printf '%s\n' "$@" | sort -g | awk '{ v[NR] = $1 } END { print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2 }'; }

printf '%-22s %-3s %9s %9s %9s %8s\n' scene bin traced silhouette none speedup
for scene in "${scenes[@]}"; do
    name=$(basename "$scene" .toml)
    declare -A cost=()
    for ((r = 1; r <= repeats; r++)); do
        for m in none traced silhouette; do
            for i in 0 1; do
                "${bins[$i]}" render "$scene" --quiet --shadows "$m" --out "$work/o.png" "$@"
                c=$(awk -v p="$(phase "$work/o.json" shadow_prepare)" -v r="$(phase "$work/o.json" render)" \
                    'BEGIN { print p + r }')
                cost[$i.$m]+="$c "
            done
        done
    done
    declare -a speedup=()
    # `none` runs no shadow code, so both builds' runs of it are pooled into one baseline: on
    # a scene whose shadow cost is a few times the frame's (the default scene), its noise
    # alone moved the speedup's ratio by 10%.
    # shellcheck disable=SC2086
    n=$(median ${cost[0.none]} ${cost[1.none]})
    for i in 0 1; do
        # shellcheck disable=SC2086
        t=$(median ${cost[$i.traced]}) s=$(median ${cost[$i.silhouette]})
        speedup[i]=$(awk -v n="$n" -v t="$t" -v s="$s" 'BEGIN { printf "%.2f", (t - n) / (s - n) }')
        label=$([[ $i == 0 ]] && echo A || echo B)
        printf '%-22s %-3s %9.3f %9.3f %9.3f %7sx\n' "$name" "$label" "$t" "$s" "$n" "${speedup[i]}"
    done
    awk -v a="${speedup[0]}" -v b="${speedup[1]}" -v s="$name" \
        'BEGIN { printf "%-22s B/A silhouette speedup %.3f\n", s, b / a }'
    unset cost speedup
done
