#!/usr/bin/env bash
# Regenerates the paper-reproduction figures of the book (Koren & Masory (1981) Figs. 5a, 5b,
# 6, 7 and the milling, grinding and finishing runs) with `qloop sim`, from the seed specs in
# verified/specs, and the figures of `qloop aco`. Each figure comes with the run's summary
# table (*.txt), and `data.sha256` holds a SHA-256 of the data each figure plots (its trace or
# CSV files): CI regenerates them and fails if a committed summary or data hash no longer
# matches the code.
set -euo pipefail
cd "$(dirname "$0")/../../../.."
out=docs/book/src/figures
cargo build -q --release -p qloop
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
mkdir -p "$tmp/hash"
# data NAME FILE...: the hash of the data figure NAME plots, kept until the end.
data() {
  local name=$1
  shift
  [ $# -gt 0 ] || { echo "error: no data files for figure $name" >&2; return 1; }
  cat "$@" | sha256sum | awk -v n="$name" '{ print $1 "  " n }' >"$tmp/hash/$name"
}
fig() { # spec plant scenario name (spec: a seed's stem, or a path to a .qloop file)
  local spec="verified/specs/$1.qloop" stem=$1
  case $1 in */*) spec=$1; stem=$(basename "$1" .qloop) ;; esac
  ./target/release/qloop sim "$spec" --plant "$2" --scenario "$3" --out "$tmp/$4" >/dev/null
  cp "$tmp/$4/$stem-$2-$3.svg" "$out/$4.svg"
  cp "$tmp/$4/$stem-$2-$3.png" "$out/$4.png"
  cp "$tmp/$4/summary.txt" "$out/$4.txt"
  data "$4" "$tmp/$4/trace.csv"
  echo "$out/$4.{svg,png,txt}"
}
# The runs are independent, and each runs on one core: as many at a time as there are cores.
export tmp out
export -f fig data
{
  # The guide's first spec (docs/book/src/guide/simulating.md shows this run).
  echo docs/book/src/guide/first_loop.qloop turning depth-steps guide-first-loop-depth-steps
  echo acc_fixed_gain turning depth-steps fig5a-conventional-depth-steps
  echo koren_masory_1981 turning depth-steps fig5b-adaptive-depth-steps
  echo koren_masory_tuned turning depth-steps tuned-depth-steps
  echo koren_masory_1981 turning depth-ramp fig6-adaptive-depth-ramp
  echo koren_masory_1981 turning speed-drop fig7-adaptive-speed-drop
  echo acc_fixed_gain turning speed-drop fig7-conventional-speed-drop
  echo milling_acc milling depth-profile milling-adaptive-depth-profile
  echo grinding_pi grinding force-step grinding-pi-force-step
  echo grinding_pi grinding eta-varying grinding-pi-eta-varying
  echo grinding_adaptive_pzc grinding eta-varying grinding-apzc-eta-varying
  echo gac_surface_finish finishing tool-failure gac-tool-failure
  # The safe spec (the tuned law with qloop's `feed_safety` rules) through the
  # turning plant's fault scenarios: the summaries say when the fault came and when the hold
  # was set.
  for sc in adc-saturation stuck-sensor sensor-dropout tool-breakage noise-burst spindle-stall; do
    echo koren_masory_safe turning "$sc" "safe-$sc"
  done
} | xargs -P "$(nproc)" -L 1 bash -c 'set -euo pipefail; fig "$@"' fig
# The paper's tuning against `qloop tune`'s: the demo's comparison figure.
./target/release/qloop demo --out "$tmp/demo" >/dev/null
for ext in svg png txt; do cp "$tmp/demo/paper-vs-tuned.$ext" "$out/paper-vs-tuned-depth-steps.$ext"; done
data paper-vs-tuned-depth-steps $(find "$tmp/demo" -name '*.csv' | sort)
echo "$out/paper-vs-tuned-depth-steps.{svg,png,txt}"
# Rubio & De la Sen's multi-model controller: three designs on one figure, from the paper test
# that asserts the comparison.
# `--workspace`, as the default tier builds it: `-p qloop-tests` alone resolves other features
# and rebuilds qloop-core, qloop and the test binary (70-120 s).
QLOOP_FIGURES="$PWD/$out" cargo test -q --workspace --test integration -- --exact paper_multimodel::figure >/dev/null
data milling-multimodel-comparison "$out/milling-multimodel-comparison.txt"
echo "$out/milling-multimodel-comparison.{svg,png,txt}"
# RCB2 above the loops (Ivester & Danai): a seeded run beside their Table 2, and the study of
# confidence levels against the nominal optimiser over 100 seeded runs (their Figs. 5 and 6).
./target/release/qloop aco --out "$tmp/aco" >/dev/null
for f in rcb2-run.svg rcb2-run.png rcb2-study.svg rcb2-study.png rcb2.txt; do cp "$tmp/aco/$f" "$out/"; done
data rcb2 $(find "$tmp/aco" -name '*.csv' | sort)
echo "$out/rcb2-{run,study}.{svg,png}, $out/rcb2.txt"
# The Bendix index of Koren's survey maximised over feedrate and spindle speed.
./target/release/qloop aco bendix --out "$tmp/bendix" >/dev/null
for f in bendix.svg bendix.png bendix.txt; do cp "$tmp/bendix/$f" "$out/"; done
data bendix $(find "$tmp/bendix" -name '*.csv' -o -name '*.txt' | sort)
echo "$out/bendix.{svg,png,txt}"
# The cascade: RCB2 sets the force reference of the generated 1981 loop
# for ten parts, each cut in closed loop on the turning plant.
./target/release/qloop aco cascade --out "$tmp/cascade" >/dev/null
for f in cascade.svg cascade.png cascade.txt cascade-parts.svg cascade-parts.png; do cp "$tmp/cascade/$f" "$out/"; done
data cascade $(find "$tmp/cascade" -name '*.csv' -o -name '*.txt' | sort)
echo "$out/cascade{,-parts}.{svg,png}, $out/cascade.txt"
# The data hashes, one line per figure, sorted by name.
cat "$tmp"/hash/* | sort -k 2 >"$out/data.sha256.tmp"
mv "$out/data.sha256.tmp" "$out/data.sha256"
echo "$out/data.sha256"
