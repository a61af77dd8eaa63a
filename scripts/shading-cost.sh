#!/usr/bin/env bash
# glTF shading's cost against diffuse shading, side by side: for each method and scene, the
# report's render seconds at 320x240, three runs of each in turn, medians and their ratio.
# Usage: scripts/shading-cost.sh [METHODS...]   (default: traced analytic; quiet machine)
set -euo pipefail
cd "$(dirname "$0")/.."
bin=target/release/penumbra
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
for m in "${@:-traced analytic}"; do
  for m1 in $m; do
    for f in scenes/gltf/*.toml; do
      n=$(basename "$f" .toml)
      times=""
      for _ in 1 2 3; do
        for mode in gltf diffuse; do
          "$bin" render "$f" --width 320 --height 240 --shadows "$m1" --shading "$mode" \
            --out "$out/$n-$mode.png" --quiet >/dev/null
          times+="$mode $(python3 -c "import json,sys;print(json.load(open(sys.argv[1]))['timings_s']['render'])" "$out/$n-$mode.json") "
        done
      done
      python3 - "$m1" "$n" $times <<'PY'
import statistics, sys
m, n, rest = sys.argv[1], sys.argv[2], sys.argv[3:]
t = {"gltf": [], "diffuse": []}
for k in range(0, len(rest), 2):
    t[rest[k]].append(float(rest[k + 1]))
g, d = statistics.median(t["gltf"]), statistics.median(t["diffuse"])
print(f"{m} {n} gltf {g:.3f} diffuse {d:.3f} ratio {g / d:.2f}")
PY
    done
  done
done
