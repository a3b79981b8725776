#!/usr/bin/env bash
# Hardware-free LinuxCNC test of a qloop HAL component.
#
#   targets/linuxcnc/run.sh [COMPFILE [REFERENCE_CMD]]
#
# 1. halcompile --install COMPFILE (default: example/qloop_koren_masory_1981.comp);
# 2. halrun: a 1 ms `servo` thread running streamer -> component -> scale x2 -> sampler;
#    halstreamer preloads a scripted input sequence (one row per period, one value per
#    `pin in float`), halsampler records every period until the sequence is consumed plus a
#    tail;
# 3. test/check.py recomputes every sampled row: the conversion, the controller timing and,
#    through REFERENCE_CMD, the controller itself, and fails on the first difference.
#
# REFERENCE_CMD reads one controller step per line (the raw inputs, in declaration order) and
# writes one line per step (the raw outputs). Default: the component's own controller and glue
# code (between `qloop:controller:begin` and `qloop:glue:end`), compiled for the host with
# test/host_ref.c. `rust`: qloop's Rust output of the same spec (qloop_verified::NAME::
# Controller::step_bits, test/rust_ref), built with cargo; its period and formats are also
# compared with the component's glue constants.
#
# Environment: QLOOP_TEST_ROWS (20000 periods), QLOOP_TEST_TAIL (250 periods sampled after the
# stream ends), QLOOP_TEST_PERIOD_NS (1000000), QLOOP_TEST_SEED (1981), QLOOP_TEST_PRELOAD (1:
# fill the streamer before `start`; 0: stream while running, so the first periods see an empty
# streamer), QLOOP_TEST_KEEP (1: keep the work directory), RTAPI_UID (as root: 65534),
# QLOOP_HALRUN_CLEANUP (1: stop a LinuxCNC realtime session that is already running).
set -euo pipefail

HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
COMP=${1:-$HERE/example/qloop_koren_masory_1981.comp}
REF_CMD=${2:-}
ROWS=${QLOOP_TEST_ROWS:-20000}
TAIL=${QLOOP_TEST_TAIL:-250}
PERIOD_NS=${QLOOP_TEST_PERIOD_NS:-1000000}
SEED=${QLOOP_TEST_SEED:-1981}
PRELOAD=${QLOOP_TEST_PRELOAD:-1}
. "$HERE/lib.sh"

for tool in halcompile halrun halcmd halstreamer halsampler python3 cc; do
    command -v "$tool" >/dev/null || die "$tool not found (apt-get install linuxcnc-uspace-dev python3 gcc)"
done
[ -f "$COMP" ] || die "no such component: $COMP"
COMP=$(cd "$(dirname "$COMP")" && pwd)/$(basename "$COMP")

# --- names from the .comp ----------------------------------------------------------------
comp_name=$(sed -n 's/^component[[:space:]]\{1,\}\([A-Za-z_][A-Za-z0-9_]*\).*/\1/p' "$COMP" | head -1)
[ "$comp_name" = "$(basename "$COMP" .comp)" ] || die "component name '$comp_name' must match the file name"
pins() { sed -n "s/^pin[[:space:]]\{1,\}$1[[:space:]]\{1,\}$2[[:space:]]\{1,\}\([A-Za-z_][A-Za-z0-9_]*\).*/\1/p" "$COMP"; }
in_pins=$(pins in float)                # every input, in declaration order
[ -n "$in_pins" ] || die "$COMP: no 'pin in float' (the inputs)"
n_in=$(echo "$in_pins" | wc -l)
[ "$n_in" -le 6 ] || die "$COMP: $n_in inputs; the sampler (21 pins) records at most 6"
out_raw_pin=$(pins out s32 | grep '_raw$' | grep -vxF "$(echo "$in_pins" | sed 's/$/_raw/')" | head -1 || true)
out_pin=${out_raw_pin%_raw}
for p in $in_pins $(echo "$in_pins" | sed 's/$/_raw/') "$out_pin" "$out_raw_pin" adaptive_feed steps; do
    [ -n "$p" ] && { pins '[a-z]*' '[a-z0-9]*' | grep -qx "$p"; } \
        || die "$COMP: expected pins IN (in float) and IN_raw (out s32) per input, OUT (out float), OUT_raw (out s32), adaptive_feed, steps; missing '${p:-?}'"
done
hal() { echo "$1" | tr _ -; }           # halcompile: HAL names use '-' for '_'
inst=$(hal "$comp_name").0
grep -q '^function[[:space:]]\{1,\}_[[:space:]]' "$COMP" || die "$COMP: expected 'function _' (HAL function named $inst)"

# --- the RTAPI environment --------------------------------------------------------------------
qloop_rtapi_env
WORK=

started=0
hpid=
cleanup() {
    rc=$?
    if [ -n "$hpid" ] && kill -0 "$hpid" 2>/dev/null; then
        kill "$hpid" 2>/dev/null || true  # our `timeout halrun`
        wait "$hpid" 2>/dev/null || true
    fi
    if [ "$started" = 1 ] && "$REALTIME" status >/dev/null 2>&1; then
        echo "run.sh: stopping the realtime session left by this run (halrun -U)" >&2
        halrun -U >/dev/null 2>&1 || true
    fi
    if [ -z "$WORK" ]; then
        :
    elif [ "${QLOOP_TEST_KEEP:-0}" = 1 ] || [ $rc != 0 ]; then
        echo "run.sh: work directory kept: $WORK" >&2
    else
        rm -rf "$WORK"
    fi
    exit $rc
}
trap cleanup EXIT
trap 'exit 130' INT TERM

qloop_realtime_free
WORK=$(mktemp -d "${TMPDIR:-/tmp}/qloop-linuxcnc.XXXXXX")

# --- 1. install ----------------------------------------------------------------------------
echo "== halcompile --install $(basename "$COMP")"
qloop_install "$COMP" "$WORK/halcompile.log"

# --- 2. host reference -------------------------------------------------------------------
sed -n '/qloop:controller:begin/,/qloop:glue:end/p' "$COMP" > "$WORK/controller.inc"
[ -s "$WORK/controller.inc" ] || die "$COMP: no 'qloop:controller:begin' ... 'qloop:glue:end' section"
cc -std=c99 -O2 -Wall -Wextra -Wno-unused-function -o "$WORK/host_ref" \
    -DQLOOP_CONTROLLER_INC="\"$WORK/controller.inc\"" "$HERE/test/host_ref.c" \
    || die "host reference does not compile"
"$WORK/host_ref" --meta > "$WORK/meta.txt"
period_us=$(awk '$1 == "period_us" {print $2}' "$WORK/meta.txt")
[ -n "$REF_CMD" ] || REF_CMD=$WORK/host_ref
REF_META=()
if [ "$REF_CMD" = rust ]; then
    # qloop's Rust output of the same spec (crate qloop-verified, module = component name
    # without the `qloop_` prefix), built out of tree; cached in the workspace's target/.
    repo=$(cd "$HERE/../.." && pwd)
    command -v cargo >/dev/null || die "REFERENCE_CMD=rust needs cargo"
    mkdir -p "$WORK/rust_ref/src"
    sed "s|@VERIFIED@|$repo/verified|" "$HERE/test/rust_ref/Cargo.toml.in" > "$WORK/rust_ref/Cargo.toml"
    sed "s|@MODULE@|${comp_name#qloop_}|" "$HERE/test/rust_ref/main.rs.in" > "$WORK/rust_ref/src/main.rs"
    [ ! -f "$repo/Cargo.lock" ] || cp "$repo/Cargo.lock" "$WORK/rust_ref/"
    export CARGO_TARGET_DIR=${CARGO_TARGET_DIR:-$repo/target/linuxcnc-ref}
    echo "== cargo build (Rust reference: qloop_verified::${comp_name#qloop_})"
    (cd "$WORK/rust_ref" && { cargo build -q --release --offline 2>/dev/null || cargo build -q --release; }) \
        || die "Rust reference does not build"
    REF_CMD=$CARGO_TARGET_DIR/release/qloop-linuxcnc-ref
    # Its period and formats, which check.py compares with the component's glue constants.
    "$REF_CMD" --meta > "$WORK/ref_meta.txt" || die "Rust reference --meta failed"
    REF_META=(--ref-meta "$WORK/ref_meta.txt")
fi

# --- 3. halrun -----------------------------------------------------------------------------
python3 "$HERE/test/check.py" gen --rows "$ROWS" --seed "$SEED" --period-ns "$PERIOD_NS" \
    --meta "$WORK/meta.txt" > "$WORK/stream.txt"
total=$((ROWS + TAIL))
# Streamer pin 0 is the row index, pin 1+i input i. Sampler pins: index, empty, then input i
# and its raw at 2+2i, 3+2i, then the first output's columns (check.py's columns()).
in_nets=
i=0
for p in $in_pins; do
    in_nets="$in_nets
net in$i     streamer.0.pin.$((i + 1))                  => $inst.$(hal "$p") sampler.0.pin.$((2 + 2 * i))
net in-raw$i $inst.$(hal "${p}_raw")      => sampler.0.pin.$((3 + 2 * i))"
    i=$((i + 1))
done
o=$((2 + 2 * n_in))                     # the first output column
# The streamer FIFO holds depth-1 rows: with depth=ROWS, `loadusr -w halstreamer` before
# `start` would wait forever. The sampler FIFO holds every row, so halsampler cannot overrun.
# scale.N multiply by 2^52 (exact), so the sampled floats pin the doubles down to the bit.
cat > "$WORK/test.hal" <<EOF
loadrt threads name1=servo period1=$PERIOD_NS
loadrt streamer depth=$((ROWS + 1)) cfg=s$(printf 'f%.0s' $in_pins)
loadrt $comp_name
loadrt scale count=2
loadrt sampler depth=$((total + 1000)) cfg=sb$(printf 'fs%.0s' $in_pins)sffffu
setp scale.0.gain 4503599627370496.0
setp scale.1.gain 4503599627370496.0
net idx      streamer.0.pin.0                  => sampler.0.pin.0
net empty    streamer.0.empty                  => sampler.0.pin.1$in_nets
net out-raw  $inst.$(hal "$out_raw_pin")       => sampler.0.pin.$o
net out      $inst.$(hal "$out_pin")           => sampler.0.pin.$((o + 1)) scale.0.in
net ovr      $inst.adaptive-feed               => sampler.0.pin.$((o + 2)) scale.1.in
net out-x    scale.0.out                       => sampler.0.pin.$((o + 3))
net ovr-x    scale.1.out                       => sampler.0.pin.$((o + 4))
net steps    $inst.steps                       => sampler.0.pin.$((o + 5))
addf streamer.0 servo
addf $inst servo
addf scale.0 servo
addf scale.1 servo
addf sampler.0 servo
$([ "$PRELOAD" = 1 ] && echo "loadusr -w halstreamer -c 0 $WORK/stream.txt")
start
$([ "$PRELOAD" = 1 ] || echo "loadusr halstreamer -c 0 $WORK/stream.txt")
loadusr -w halsampler -c 0 -t -n $total $WORK/samples.txt
stop
show param $inst
EOF
secs=$(( (total * PERIOD_NS / 1000000000) * 3 + 60 ))
echo "== halrun: $total periods of $((PERIOD_NS / 1000)) us (~$((total * PERIOD_NS / 1000000000)) s), controller period $period_us us"
started=1
timeout "$secs" halrun -f "$WORK/test.hal" > "$WORK/halrun.log" 2>&1 &
hpid=$!                                 # in the background, so that INT/TERM run the trap now
hrc=0
wait $hpid || hrc=$?
hpid=
{ grep -v -e '^Running with fallback_uid' -e '^Note: Using POSIX non-realtime' "$WORK/halrun.log" || true; } | sed 's/^/   /'
[ $hrc = 0 ] || die "halrun exited $hrc (124: timed out after ${secs}s); log: $WORK/halrun.log"
"$REALTIME" status >/dev/null 2>&1 || started=0

# --- 4. check ------------------------------------------------------------------------------
echo "== check against: $REF_CMD"
python3 "$HERE/test/check.py" check --stream "$WORK/stream.txt" --samples "$WORK/samples.txt" \
    --meta "$WORK/meta.txt" --period-ns "$PERIOD_NS" --ref "$REF_CMD" ${REF_META[@]+"${REF_META[@]}"}
