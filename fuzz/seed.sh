#!/usr/bin/env bash
# Fills fuzz/corpus/<target>/ with the seeds (existing corpus files are kept):
#   scene_file: the project's scenes (scenes/**/*.toml);
#   gltf:       the hand-made seeds (fuzz/seeds/gltf, see make_tiny.py), every .glb and every
#               .gltf (+ its .bin, as JSON + NUL + buffer, the target's input format) of
#               ../shared/gltf up to SEED_MAX_BYTES bytes (default 300000: larger ones load
#               too slowly for a fast run). A .gltf's buffer URI becomes "b.bin" and its image
#               URIs "t.png" (the harness writes both), so the seed loads as the original does.
# Usage: fuzz/seed.sh [scene_file|gltf]...   (default: both)
set -euo pipefail
fuzz="$(cd "$(dirname "$0")" && pwd)"
root="$(dirname "$fuzz")"
shared="${SHARED_GLTF:-$root/../shared/gltf}"
max="${SEED_MAX_BYTES:-300000}"
targets=("$@")
[ ${#targets[@]} -eq 0 ] && targets=(scene_file gltf)

for target in "${targets[@]}"; do
    out="$fuzz/corpus/$target"
    mkdir -p "$out"
    n=0
    case "$target" in
    scene_file)
        while IFS= read -r f; do
            rel="${f#"$root"/scenes/}"
            cat "$f" >"$out/seed-${rel//\//-}"
            n=$((n + 1))
        done < <(find "$root/scenes" -name '*.toml' | sort)
        ;;
    gltf)
        for f in "$fuzz"/seeds/gltf/*; do
            cat "$f" >"$out/seed-$(basename "$f")"
            n=$((n + 1))
        done
        if [ -d "$shared" ]; then
            for f in "$shared"/*/*.glb; do
                [ -f "$f" ] || continue
                if [ "$(stat -c %s "$f")" -le "$max" ]; then
                    cat "$f" >"$out/seed-$(basename "$f")"
                    n=$((n + 1))
                fi
            done
            for f in "$shared"/*/*.gltf; do
                [ -f "$f" ] || continue
                # The .bin its buffer names (each of these files has one buffer).
                bin="$(grep -o '"uri"[[:space:]]*:[[:space:]]*"[^"]*\.bin"' "$f" | head -n 1 | sed 's/.*"\([^"]*\)"$/\1/')"
                size=$(stat -c %s "$f")
                [ -n "$bin" ] && size=$((size + $(stat -c %s "$(dirname "$f")/$bin")))
                [ "$size" -le "$max" ] || continue
                seed="$out/seed-$(basename "$f")"
                sed -E -e 's/"uri"[[:space:]]*:[[:space:]]*"[^"]*\.bin"/"uri":"b.bin"/g' \
                    -e 's/"uri"[[:space:]]*:[[:space:]]*"[^"]*\.(png|jpg|jpeg)"/"uri":"t.png"/g' \
                    -e 's#"image/jpeg"#"image/png"#g' "$f" >"$seed"
                if [ -n "$bin" ]; then
                    printf '\0' >>"$seed"
                    cat "$(dirname "$f")/$bin" >>"$seed"
                fi
                n=$((n + 1))
            done
        else
            echo "seed.sh: no $shared; glTF seeds are the hand-made ones only"
        fi
        ;;
    *)
        echo "seed.sh: unknown target $target" >&2
        exit 2
        ;;
    esac
    echo "seed.sh: $n seeds in $out"
done
