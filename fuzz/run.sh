#!/usr/bin/env bash
# Runs each loader fuzz target (scene_file, gltf) for SECONDS (default 45) on the seeds
# (fuzz/seed.sh) plus whatever fuzz/corpus/ already holds; one process each, one after the
# other. Extra arguments go to libFuzzer (e.g. -runs=1000000). Exits non-zero on the first
# crash, timeout or out-of-memory; the input is left in fuzz/artifacts/<target>/.
# Needs the nightly toolchain and cargo-fuzz (`cargo install cargo-fuzz --locked`).
# Usage: fuzz/run.sh [SECONDS [libFuzzer flags...]]
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-45}"
shift || true
# Seeds above 16 KiB (the real .gltf scenes) load ~100x slower than the small ones; a short
# run spends its time better on the small ones. SEED_MAX_BYTES=300000 adds them.
SEED_MAX_BYTES="${SEED_MAX_BYTES:-16384}" fuzz/seed.sh
# Debug assertions and overflow checks as in the dev-profile tests: see fuzz/Cargo.toml.
cargo +nightly fuzz build -O
mkdir -p fuzz/artifacts
for target in scene_file gltf; do
    echo "fuzz: $target for ${seconds}s"
    log="fuzz/artifacts/$target.log"
    status=0
    cargo +nightly fuzz run -O "$target" "fuzz/corpus/$target" -- \
        -max_total_time="$seconds" -rss_limit_mb=2048 -timeout=10 -max_len=16384 -print_final_stats=1 "$@" \
        >"$log" 2>&1 || status=$?
    grep -E '^(#[0-9]+[[:space:]]+(INITED|DONE)|Done [0-9]+ runs|stat::number_of_executed_units)' "$log" || true
    if [ "$status" -ne 0 ]; then
        tail -n 60 "$log"
        echo "fuzz: $target FAILED (exit $status); the input is in fuzz/artifacts/$target/, the log in $log" >&2
        exit "$status"
    fi
done
echo "fuzz: no crash, timeout or out-of-memory"
