#!/usr/bin/env bash
# glTF shading's cost against diffuse shading, side by side (scripts/ab-cost.sh with the same
# binary: A = --shading gltf, B = --shading diffuse).
# Usage: scripts/shading-cost.sh [METHODS...]   (default: traced analytic; quiet machine)
set -euo pipefail
cd "$(dirname "$0")/.."
bin=target/release/penumbra
exec scripts/ab-cost.sh "$bin --shading gltf" "$bin --shading diffuse" "$@"
