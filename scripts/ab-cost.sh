#!/usr/bin/env bash
# Two ways of rendering side by side: for each scene and method, the report's render seconds at
# 320x240, three runs of each in turn (A B A B A B), medians and their ratio A/B. A and B are
# each a binary and, optionally, flags added to every render (one string, split on spaces).
# Usage: scripts/ab-cost.sh 'BIN_A [FLAGS]' 'BIN_B [FLAGS]' [METHODS...]
#   (default methods: traced analytic; a quiet machine)
set -euo pipefail
cd "$(dirname "$0")/.."
read -r -a a <<<"$1"
read -r -a b <<<"$2"
shift 2
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
for m in ${@:-traced analytic}; do
  for f in scenes/gltf/*.toml; do
    n=$(basename "$f" .toml)
    times=""
    for _ in 1 2 3; do
      for side in a b; do
        if [ "$side" = a ]; then cmd=("${a[@]}"); else cmd=("${b[@]}"); fi
        "${cmd[0]}" render "$f" --width 320 --height 240 --shadows "$m" --out "$out/$n-$side.png" \
          --quiet "${cmd[@]:1}" >/dev/null 2>&1
        times+="$side $(python3 -c "import json,sys;print(json.load(open(sys.argv[1]))['timings_s']['render'])" "$out/$n-$side.json") "
      done
    done
    python3 - "$m" "$n" $times <<'PY'
import statistics, sys
m, n, rest = sys.argv[1], sys.argv[2], sys.argv[3:]
t = {"a": [], "b": []}
for k in range(0, len(rest), 2):
    t[rest[k]].append(float(rest[k + 1]))
a, b = statistics.median(t["a"]), statistics.median(t["b"])
print(f"{m} {n} A {a:.3f} B {b:.3f} ratio {a / b:.2f}")
PY
  done
done
