#!/usr/bin/env bash
# Run the drivers' fuzz targets (fuzz/) for a bounded time each and print libFuzzer's
# summary. Not part of CI. Needs cargo-fuzz (`cargo install cargo-fuzz`) and a nightly
# toolchain (`rustup toolchain install nightly`); libFuzzer itself is built from the
# libfuzzer-sys crate (needs a C++ compiler).
#
#   scripts/fuzz.sh [SECONDS_PER_TARGET]      (default 60)
#
# Corpora grow under fuzz/corpus/<target>/ (not committed); crashes land in
# fuzz/artifacts/<target>/ and make this script fail.
set -euo pipefail
cd "$(dirname "$0")/../fuzz"
seconds="${1:-60}"
status=0
for target in tactile_decoder can_decoder; do
    mkdir -p "corpus/$target"
    # Start from valid messages (fuzz/seeds, made by make_seeds.py) so the fuzzer begins
    # past the CRC and the framing.
    cp -n "seeds/$target"/* "corpus/$target"/ 2>/dev/null || true
    echo "== $target: ${seconds} s"
    # -jobs/-workers 1: the machine is shared; rss limit generous for the ASan build.
    if ! cargo +nightly fuzz run "$target" "corpus/$target" -- \
        -max_total_time="$seconds" -rss_limit_mb=4096 -print_final_stats=1 2>&1 |
        tee "/tmp/pulsetrack-fuzz-$target.log" | grep -E '^(#[0-9]+.*(DONE|pulse)|Done|stat::number_of_executed_units|stat::peak_rss_mb|.*ERROR|SUMMARY)'; then
        :
    fi
    if ls "artifacts/$target"/crash-* >/dev/null 2>&1; then
        echo "!! $target: crash artifacts in fuzz/artifacts/$target"
        status=1
    fi
done
exit "$status"
