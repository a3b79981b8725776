#!/usr/bin/env bash
# run.sh -- build the simavr cycle runner, the ATmega328P firmware and the host check; check
# the measurement method (selftest), run the controller firmware on a scripted ADC sequence,
# print cycles and raw values per step, and diff the firmware's values against the host
# computation. Exit 0 and a PASS line only if everything matches.
#
#   targets/avr/run.sh                 # stand-in controller (firmware/stub)
#   GEN=/path/to/gen targets/avr/run.sh   # generated koren_masory_1981.{h,c}
#   BUILD=dir (default targets/avr/build), VREF=mV (default 5000)
set -euo pipefail

here=$(cd "$(dirname "$0")" && pwd)
gen=${GEN:-$here/firmware/stub}
case $gen in /*) ;; *) gen=$(cd "$gen" && pwd) ;; esac
build=${BUILD:-$here/build}
case $build in /*) ;; *) build=$PWD/$build ;; esac
vref=${VREF:-5000}

die() { echo "run.sh: FAIL: $*" >&2; exit 1; }

echo "== build (GEN=$gen)"
make -s -C "$here" GEN="$gen" BUILD="$build" >&2 || die "build failed"

echo "== selftest: marker method against datasheet cycle counts"
"$build/cycles" "$build/selftest.elf" > "$build/selftest.txt" || die "cycles runner failed on selftest.elf"
awk '
  $1 == "step" { got[$2] = $4 }
  $1 == "out"  { want[$2] = $3 }
  END {
    n = 0; bad = 0
    for (i in want) { n++; if (!(i in got) || got[i] != want[i]) { bad++; printf "  case %s: measured %s, datasheet %s\n", i, got[i], want[i] } }
    if (n == 0) { print "  no cases"; exit 1 }
    if (bad) exit 1
    printf "  %d cases, all equal to the datasheet counts\n", n
  }' "$build/selftest.txt" || die "selftest: measured cycles differ from the datasheet"

echo "== ADC script (mV on ADC0; 1 V per kN, Vref $vref mV)"
seq_file=$build/sequence.mv
{
  echo "# air cut: below F_AIR = 0.15 kN (150 mV -> code 30 -> fc 600 raw <= 614)"
  for v in 0 0 60 60 100 120 140 150; do echo $v; done
  echo "# depth steps, rising force: first cut just above F_AIR, then 1.0, 1.5 (= F_r), 2.5, 4.0 kN"
  for v in 160 1000 1500 2500 4000; do for _ in 1 2 3 4 5 6 7 8; do echo $v; done; done
  echo "# depth steps, falling force"
  for v in 2500 1000 500; do for _ in 1 2 3 4 5 6; do echo $v; done; done
  echo "# tool leaves the work: air cut again"
  for _ in 1 2 3 4; do echo 100; done
  echo "# ramp up 0 .. 5500 mV (beyond the 5 V reference: the ADC clips at 1023)"
  for ((v = 0; v <= 5500; v += 250)); do echo $v; done
  echo "# ramp down"
  for ((v = 5500; v >= 0; v -= 500)); do echo $v; done
} > "$seq_file"
n_samples=$(grep -cv '^#' "$seq_file")
echo "  $n_samples samples in $seq_file"

echo "== simavr: $build/firmware.elf (ATmega328P, 16 MHz)"
"$build/cycles" --vref "$vref" --adc "$seq_file" "$build/firmware.elf" > "$build/avr.txt" 2> "$build/avr.err" \
  || { cat "$build/avr.err" >&2; die "cycles runner failed"; }
grep -v 'clipped' "$build/avr.err" >&2 || true

echo "== host check: same controller C and io_scale.h, host cc + UBSan"
"$build/host_check" --vref "$vref" "$seq_file" > "$build/host.txt" || die "host check failed"

grep '^out ' "$build/avr.txt" > "$build/avr_out.txt" || true
n_steps=$(grep -c '^step ' "$build/avr.txt" || true)

echo
grep -v '^#' "$seq_file" | paste -d' ' - <(grep '^out ' "$build/avr.txt") \
  | awk -v cyc="$build/avr.txt" '
    BEGIN {
      while ((getline l < cyc) > 0) { split(l, f, " "); if (f[1] == "step") c[f[2]] = f[4] }
      printf "%5s %6s %5s %6s %6s %6s %6s %6s %6s %7s\n", "step", "mV", "adc", "fc", "feed", "OCR1A", "km", "kc", "u", "cycles"
    }
    { printf "%5s %6s %5s %6s %6s %6s %6s %6s %6s %7s\n", $3, $1, $4, $5, $6, $7, $8, $9, $10, c[$3] }'
echo "(raw Q12 integers: fc kN, feed/u mm/s, km kN/(mm/s), kc (mm/s)/kN; OCR1A of TOP 1280)"
echo
grep -E '^(calib|end|summary) ' "$build/avr.txt"
echo

[ "$n_steps" -eq "$n_samples" ] || die "$n_steps steps for $n_samples ADC samples"
if ! diff -u "$build/host.txt" "$build/avr_out.txt" > "$build/diff.txt"; then
  cat "$build/diff.txt"
  die "firmware outputs differ from the host computation (see $build/diff.txt)"
fi
summary=$(grep '^summary ' "$build/avr.txt")
echo "PASS: $n_steps steps, simavr firmware outputs == host computation (diff empty); cycles/step: ${summary#summary steps $n_steps }"
