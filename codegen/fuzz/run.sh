#!/usr/bin/env bash
# Runs each fuzz target for SECONDS (default 60), seeded with every spec in the repository,
# as many targets at a time as there are cores (each libFuzzer process uses one), each
# target's output printed when it ends.
# Needs nightly and cargo-fuzz:  rustup toolchain install nightly && cargo install cargo-fuzz
# Usage: bash codegen/fuzz/run.sh [SECONDS] [TARGET...]
#        FUZZ_BUILD_ONLY=1 bash codegen/fuzz/run.sh    # the build alone (CI starts it early)
set -euo pipefail
cd "$(dirname "$0")"
secs=${1:-60}
shift || true
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(parse check_lower pipeline)
# The flags of every build and run: see `fuzz_one`.
flags=(-s none --debug-assertions)
# One build of every target first, so that the runs below do not wait on each other's build.
cargo +nightly fuzz build "${flags[@]}"
[ -z "${FUZZ_BUILD_ONLY:-}" ] || exit 0

fuzz_one() { # TARGET: seeds its corpus and fuzzes it for $secs
    local t=$1 corpus="corpus/$1"
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
    cargo +nightly fuzz run "${flags[@]}" "$t" "$corpus" -- -max_total_time="$secs" -timeout=60 -rss_limit_mb=4096 -print_final_stats=1
}

jobs=$(nproc 2>/dev/null || echo 1)
logs=$(mktemp -d)
status=0
running=()
finish() { # PID TARGET: waits for one run and prints its output
    local rc=0
    wait "$1" || rc=$?
    cat "$logs/$2.log"
    if [ "$rc" -ne 0 ]; then
        echo "error: fuzz target $2 failed (exit $rc)"
        status=$rc
    fi
}
for t in "${targets[@]}"; do
    if [ $((${#running[@]} / 2)) -ge "$jobs" ]; then
        finish "${running[0]}" "${running[1]}"
        running=("${running[@]:2}")
    fi
    fuzz_one "$t" >"$logs/$t.log" 2>&1 &
    running+=("$!" "$t")
done
while [ ${#running[@]} -gt 0 ]; do
    finish "${running[0]}" "${running[1]}"
    running=("${running[@]:2}")
done
rm -rf "$logs"
exit "$status"
