#!/usr/bin/env bash
# Runs each fuzz target for SECONDS (default 60), seeded with every spec in the repository.
# Needs nightly and cargo-fuzz:  rustup toolchain install nightly && cargo install cargo-fuzz
# Usage: bash codegen/fuzz/run.sh [SECONDS] [TARGET...]
set -euo pipefail
cd "$(dirname "$0")"
secs=${1:-60}
shift || true
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(parse check_lower pipeline)
for t in "${targets[@]}"; do
    corpus="corpus/$t"
    mkdir -p "$corpus"
    # Seeds: the seed specs, the refutation corpus, the claim corpus, the compiler's fixtures,
    # each at most 16 KiB. The multi-model controller (36 KB) is left out: in the pipeline
    # target its 27 MB of generated harness text ran out of libFuzzer's memory limit
    # (2 GB, under ASan) in one run.
    for f in ../../verified/specs/*.qloop ../../tests/fixtures/*/*.qloop ../tests/fixtures/*.qloop; do
        [ "$(wc -c < "$f")" -le 16384 ] || continue
        cp -n "$f" "$corpus/seed-$(basename "$f")" 2>/dev/null || true
    done
    # -timeout: a unit slower than this is reported as a hang. The GAC seed and its mutations
    # take 10-12 s in the pipeline target (ASan, coverage and debug assertions; measured
    # 2026-11-27 with -runs=0 -report_slow_units over a 785-unit corpus), so 60 s leaves a
    # slower CI machine room while a real hang is still caught.
    # -s none: no AddressSanitizer. What is fuzzed (qloop without its `cli` feature, and
    # qloop-core) has no `unsafe` code, so ASan can only slow it down: without it the build
    # takes 132 s instead of 226 s and the pipeline target runs about 80 inputs a second
    # instead of 5 (BENCHMARKS.md, "Tests and CI"). A panic, an overflow (debug assertions
    # are on) or a hang is still a crash.
    echo "== fuzz target $t for ${secs}s ($(ls "$corpus" | wc -l) inputs in the corpus)"
    cargo +nightly fuzz run -s none --debug-assertions "$t" "$corpus" -- -max_total_time="$secs" -timeout=60 -rss_limit_mb=4096 -print_final_stats=1
done
