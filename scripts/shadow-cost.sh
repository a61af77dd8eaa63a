#!/usr/bin/env bash
# One build's shadow cost per scene: `traced` and `silhouette` (the report's shadow_prepare +
# render, less `--shadows none`'s), the methods in turn REPEATS times, medians, and
# silhouette's speedup over traced. Both give traced's visibility at the same N, so the
# speedup is an equal-error one. Also prints silhouette's prepare share of its shadow cost
# and its per-point counters (edges tested and active per silhouette point).
#
#   scripts/shadow-cost.sh [-r REPEATS] BIN SCENE.toml... [-- render flags...]
#   scripts/shadow-cost.sh -r 3 target/release/penumbra scenes/gltf/*.toml \
#       -- --samples 1024 --width 320 --height 240
set -euo pipefail
repeats=3
if [[ ${1:-} == -r ]]; then repeats=$2; shift 2; fi
if [[ $# -lt 2 ]]; then
    echo "usage: $0 [-r REPEATS] BIN SCENE.toml... [-- render flags...]" >&2
    exit 2
fi
bin=$1
shift
scenes=()
while [[ $# -gt 0 && $1 != -- ]]; do scenes+=("$1"); shift; done
[[ ${1:-} == -- ]] && shift
[[ -x $bin ]] || { echo "$0: no binary at $bin" >&2; exit 2; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

phase() { grep -o "\"$2\": [0-9.e-]*" "$1" | head -1 | awk '{ print $2 }'; }
median() { printf '%s\n' "$@" | sort -g | awk '{ v[NR] = $1 } END { print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2 }'; }

printf '%-22s %8s %8s %8s %8s %7s %9s %9s\n' scene traced silh none speedup prep% tested/pt active/pt
logsum=0
count=0
for scene in "${scenes[@]}"; do
    name=$(basename "$scene" .toml)
    declare -A cost=()
    declare -A prep=()
    for ((r = 1; r <= repeats; r++)); do
        for m in none traced silhouette; do
            "$bin" render "$scene" --quiet --shadows "$m" --out "$work/$m.png" "$@" 2>/dev/null
            p=$(phase "$work/$m.json" shadow_prepare)
            c=$(awk -v p="$p" -v r="$(phase "$work/$m.json" render)" 'BEGIN { print p + r }')
            cost[$m]+="$c "
            prep[$m]+="$p "
        done
    done
    # shellcheck disable=SC2086
    n=$(median ${cost[none]}) t=$(median ${cost[traced]}) s=$(median ${cost[silhouette]}) \
        sp=$(median ${prep[silhouette]})
    j=$work/silhouette.json
    pts=$(phase "$j" silhouette_points) tested=$(phase "$j" edges_tested) active=$(phase "$j" edges_active)
    same=$(cmp -s "$work/traced.exr" "$work/silhouette.exr" && echo "" || echo " (images differ)")
    awk -v name="$name" -v n="$n" -v t="$t" -v s="$s" -v sp="$sp" -v pts="${pts:-0}" \
        -v te="${tested:-0}" -v ac="${active:-0}" -v same="$same" 'BEGIN {
        su = (t - n) / (s - n); pp = 100 * sp / (s - n); d = pts > 0 ? pts : 1
        printf "%-22s %8.3f %8.3f %8.3f %7.2fx %6.1f%% %9.0f %9.1f%s\n", name, t, s, n, su, pp, te / d, ac / d, same }'
    su=$(awk -v n="$n" -v t="$t" -v s="$s" 'BEGIN { print log((t - n) / (s - n)) }')
    logsum=$(awk -v a="$logsum" -v b="$su" 'BEGIN { print a + b }')
    count=$((count + 1))
    unset cost prep
done
awk -v l="$logsum" -v c="$count" 'BEGIN { printf "geometric mean speedup %.2fx over %d scenes\n", exp(l / c), c }'
