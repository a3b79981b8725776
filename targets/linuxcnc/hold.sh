#!/usr/bin/env bash
# Checks a component's feed hold in halrun (issue 18, item 4): `hold.sh COMP.comp`.
#
# COMP must have the `spindle_load` input, a `feed` output, the bit pin `feed_hold` (a
# `#[flag]` output) and a `fault` output, as qloop's `koren_masory_safe` spec gives. The
# spindle load is held at a constant 1.5 kN, which a force sensor never reads for long: the
# `unknown_load` rule of `feed_safety` counts it as stuck and, on the 10th unchanged reading
# (the 11th controller step, about 1.0 s at 100 ms), latches the hold with fault 3. The script
# reads the pins at 0.5 s (no hold yet) and at 1.8 s (held: `feed-hold` TRUE, `feed` 0,
# `fault` 3) and prints `PASS: ...` or exits non-zero.
set -euo pipefail

HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
COMP=${1:?usage: hold.sh COMP.comp}
. "$HERE/lib.sh"

for tool in halcompile halrun; do
    command -v "$tool" >/dev/null || die "$tool not found (apt-get install linuxcnc-uspace-dev)"
done
[ -f "$COMP" ] || die "no such component: $COMP"
COMP=$(cd "$(dirname "$COMP")" && pwd)/$(basename "$COMP")
comp_name=$(basename "$COMP" .comp)
for p in spindle_load feed feed_hold fault; do
    grep -q "^pin [a-z]* [a-z0-9]* $p " "$COMP" || die "$COMP: no pin '$p'"
done
grep -q '^pin out bit feed_hold ' "$COMP" || die "$COMP: 'feed_hold' is not a bit pin (declare the output #[flag])"
inst=$(echo "$comp_name" | tr _ -).0

qloop_rtapi_env
WORK=
started=0
cleanup() {
    rc=$?
    if [ "$started" = 1 ] && "$REALTIME" status >/dev/null 2>&1; then
        halrun -U >/dev/null 2>&1 || true
    fi
    if [ -n "$WORK" ]; then
        if [ $rc != 0 ]; then echo "hold.sh: work directory kept: $WORK" >&2; else rm -rf "$WORK"; fi
    fi
    exit $rc
}
trap cleanup EXIT
trap 'exit 130' INT TERM

qloop_realtime_free
WORK=$(mktemp -d "${TMPDIR:-/tmp}/qloop-hold.XXXXXX")
echo "== halcompile --install $(basename "$COMP")"
qloop_install "$COMP" "$WORK/halcompile.log"

cat > "$WORK/hold.hal" <<HAL
loadrt threads name1=servo period1=1000000
loadrt $comp_name
addf $inst servo
setp $inst.spindle-load 1.5
start
loadusr -w sleep 0.5
getp $inst.feed-hold
getp $inst.fault
getp $inst.feed
getp $inst.steps
loadusr -w sleep 1.3
getp $inst.feed-hold
getp $inst.fault
getp $inst.feed
getp $inst.steps
stop
HAL
started=1
timeout 60 halrun -f "$WORK/hold.hal" > "$WORK/halrun.log" 2>&1 || { cat "$WORK/halrun.log" >&2; die "halrun failed"; }
started=0
sed 's/^/   /' "$WORK/halrun.log"

# `getp` prints one value per line: feed-hold, fault, feed, steps at 0.5 s, then at 1.8 s.
mapfile -t v < <(grep -E '^(TRUE|FALSE|-?[0-9][0-9.e+-]*|0x[0-9a-fA-F]+)$' "$WORK/halrun.log")
[ "${#v[@]}" = 8 ] || die "expected 8 pin values from halrun, got ${#v[@]}"
h1=${v[0]}; h2=${v[4]}; f2=${v[5]}; feed2=${v[6]}; steps2=$((${v[7]}))
[ "$h1" = FALSE ] || die "feed-hold is '$h1' at 0.5 s; expected FALSE (no hold before 10 unchanged readings)"
[ "$h2" = TRUE ] || die "feed-hold is '$h2' at 1.8 s; expected TRUE"
awk -v f="$f2" -v x="$feed2" 'BEGIN { exit !(f == 3 && x == 0) }' \
    || die "at 1.8 s: fault '$f2' (expected 3), feed '$feed2' (expected 0)"
echo "PASS: feed-hold FALSE at 0.5 s, TRUE at 1.8 s with fault $f2 and feed $feed2 after $steps2 steps"
