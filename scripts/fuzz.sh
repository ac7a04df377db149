#!/usr/bin/env bash
# Run the fuzz targets (fuzz/) for a bounded time each, one after the other, and print
# libFuzzer's summary. Not part of CI. Needs cargo-fuzz (`cargo install cargo-fuzz --locked`)
# and a nightly toolchain (`rustup toolchain install nightly`); libFuzzer itself is built
# from the libfuzzer-sys crate (needs a C++ compiler).
#
#   scripts/fuzz.sh [SECONDS_PER_TARGET] [TARGET...]    (default 60 s, every target)
#
# FUZZ_SANITIZER picks cargo fuzz's sanitizer (default `none`: the project's crates deny
# unsafe code, and AddressSanitizer doubles the build and slows every run; `address` for the
# drivers' earlier runs). Corpora grow under fuzz/corpus/<target>/ (not committed); crashes,
# timeouts (a unit slower than 30 s) and out-of-memory inputs land in
# fuzz/artifacts/<target>/ and make this script fail.
set -euo pipefail
cd "$(dirname "$0")/../fuzz"
seconds="${1:-60}"
shift || true
all=(tactile_decoder can_decoder console_request config_loader scene_loader fem_model_loader
    gmsh_reader recording_reader)
if [ "$#" -gt 0 ]; then targets=("$@"); else targets=("${all[@]}"); fi
sanitizer="${FUZZ_SANITIZER:-none}"
status=0
for target in "${targets[@]}"; do
    mkdir -p "corpus/$target"
    # Start from valid inputs (fuzz/seeds, made by make_seeds.py and
    # examples/make_recording_seeds.rs) so the fuzzer begins past the parser's surface.
    cp -n "seeds/$target"/* "corpus/$target"/ 2>/dev/null || true
    echo "== $target: ${seconds} s (sanitizer: $sanitizer)"
    # One job (the machine is shared); rss limit generous for the FEM meshes.
    if ! cargo +nightly fuzz run -s "$sanitizer" "$target" "corpus/$target" -- \
        -max_total_time="$seconds" -timeout=30 -rss_limit_mb=4096 -print_final_stats=1 2>&1 |
        tee "/tmp/pulsetrack-fuzz-$target.log" | grep -E '^(#[0-9]+.*(DONE|pulse)|Done|stat::number_of_executed_units|stat::peak_rss_mb|.*ERROR|SUMMARY)'; then
        :
    fi
    if ls "artifacts/$target"/{crash,timeout,oom,leak}-* >/dev/null 2>&1; then
        echo "!! $target: artifacts in fuzz/artifacts/$target"
        status=1
    fi
done
exit "$status"
