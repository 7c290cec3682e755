#!/usr/bin/env bash
# Runs every cargo-fuzz target for a bounded time, failing on a crash.
#   bash .ci/fuzz.sh [SECONDS_PER_TARGET]      (default 60, or $FUZZ_SECONDS)
# Needs the nightly toolchain and cargo-fuzz (installed here if missing);
# when either cannot be had, says so and exits 0: the crashes found so far
# replay on stable in tests/fuzz_regressions.rs, which CI always runs.
# New corpus entries go to a temporary directory: the committed seed
# corpora (fuzz/corpus/TARGET) stay small. A crash is left in
# fuzz/artifacts/TARGET/; copy it to fuzz/regressions/TARGET/NAME and add a
# named test to tests/fuzz_regressions.rs.
set -euo pipefail
cd "$(dirname "$0")/.."
secs="${1:-${FUZZ_SECONDS:-60}}"

if ! cargo +nightly --version >/dev/null 2>&1; then
    echo "fuzz: no nightly toolchain (rustup toolchain install nightly); skipping"
    exit 0
fi
if ! cargo fuzz --version >/dev/null 2>&1; then
    echo "fuzz: installing cargo-fuzz"
    if ! cargo install --locked cargo-fuzz; then
        echo "fuzz: cargo-fuzz could not be installed; skipping"
        exit 0
    fi
fi

work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
for target in blob packet_vs_single tree_vs_brute scene_blob point_blob deforming distance; do
    echo "fuzz: $target for ${secs}s"
    mkdir -p "$work/$target"
    # -rss_limit_mb: libFuzzer's default 2 GB is fine; -timeout catches
    # walks that do not terminate; -detect_leaks=0: rayon's worker threads
    # may still be exiting when a run ends, which LeakSanitizer reports
    # (a leak is not what these targets look for).
    cargo +nightly fuzz run "$target" "$work/$target" "fuzz/corpus/$target" -- \
        -max_total_time="$secs" -timeout=10 -detect_leaks=0 -print_final_stats=1
done
echo "fuzz: no crash"
