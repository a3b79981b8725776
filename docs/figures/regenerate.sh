#!/usr/bin/env bash
# Regenerates the paper-reproduction figures (000_b8cbacf29caa8fe2.txt Figs. 5a, 5b, 6, 7 and
# the milling, grinding and finishing runs) with `qloop sim`, from the seed specs in verified/specs.
# Each figure comes with the run's summary table (*.txt); CI regenerates them and fails if a
# committed summary no longer matches the code.
set -euo pipefail
cd "$(dirname "$0")/../.."
cargo build -q --release -p qloop
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fig() { # spec plant scenario name
  ./target/release/qloop sim "verified/specs/$1.qloop" --plant "$2" --scenario "$3" --out "$tmp/$4" >/dev/null
  cp "$tmp/$4/$1-$2-$3.svg" "docs/figures/$4.svg"
  cp "$tmp/$4/$1-$2-$3.png" "docs/figures/$4.png"
  cp "$tmp/$4/summary.txt" "docs/figures/$4.txt"
  echo "docs/figures/$4.{svg,png,txt}"
}
# The runs are independent, and each runs on one core: as many at a time as there are cores.
export tmp
export -f fig
{
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
  # The safe spec (issue 18: the tuned law with qloop's `feed_safety` rules) through the
  # turning plant's fault scenarios: the summaries say when the fault came and when the hold
  # was set.
  for sc in adc-saturation stuck-sensor sensor-dropout tool-breakage noise-burst spindle-stall; do
    echo koren_masory_safe turning "$sc" "safe-$sc"
  done
} | xargs -P "$(nproc)" -L 1 bash -c 'set -euo pipefail; fig "$@"' fig
# The paper's tuning against `qloop tune`'s (issue 18): the demo's comparison figure.
./target/release/qloop demo --out "$tmp/demo" >/dev/null
for ext in svg png txt; do cp "$tmp/demo/paper-vs-tuned.$ext" "docs/figures/paper-vs-tuned-depth-steps.$ext"; done
echo "docs/figures/paper-vs-tuned-depth-steps.{svg,png,txt}"
# 003's multi-model controller (issue 17): three designs on one figure, from the paper test
# that asserts the comparison (the specs are in tests/ until the full design's proof lands).
# `--workspace`, as the default tier builds it: `-p qloop-tests` alone resolves other features
# and rebuilds qloop-core, qloop and the test binary (70-120 s).
QLOOP_FIGURES="$PWD/docs/figures" cargo test -q --workspace --test integration -- --exact paper_multimodel::figure >/dev/null
echo "docs/figures/milling-multimodel-comparison.{svg,png,txt}"
# RCB2 above the loops (issue 19, 001): a seeded run beside 001's Table 2, and the study of
# confidence levels against the nominal optimiser over 100 seeded runs (001 Figs. 5 and 6).
./target/release/qloop aco --out "$tmp/aco" >/dev/null
for f in rcb2-run.svg rcb2-run.png rcb2-study.svg rcb2-study.png rcb2.txt; do cp "$tmp/aco/$f" docs/figures/; done
echo "docs/figures/rcb2-{run,study}.{svg,png}, docs/figures/rcb2.txt"
# 002's Bendix index maximised over feedrate and spindle speed (issue 19, item 5).
./target/release/qloop aco bendix --out "$tmp/bendix" >/dev/null
for f in bendix.svg bendix.png bendix.txt; do cp "$tmp/bendix/$f" docs/figures/; done
echo "docs/figures/bendix.{svg,png,txt}"
# The cascade (issue 19, item 6): RCB2 sets the force reference of the generated 1981 loop
# for ten parts, each cut in closed loop on the turning plant.
./target/release/qloop aco cascade --out "$tmp/cascade" >/dev/null
for f in cascade.svg cascade.png cascade.txt cascade-parts.svg cascade-parts.png; do cp "$tmp/cascade/$f" docs/figures/; done
echo "docs/figures/cascade{,-parts}.{svg,png}, docs/figures/cascade.txt"
