#!/usr/bin/env bash
# Builds the Cortex-M firmware for both QEMU machines, runs each under semihosting, runs the
# same program on the host, and checks that all three print the same lines.
#
#   targets/cortex-m/run.sh              # from anywhere; exit 0 iff every machine PASSes
#   CARGO_FLAGS=--locked targets/cortex-m/run.sh
#
# Outputs land in targets/cortex-m/target/run/ (host.txt, <machine>.txt, <machine>.err), or in
# $CARGO_TARGET_DIR/run/ when CARGO_TARGET_DIR is set (relative to this directory).
# Needs qemu-system-arm (apt-get install qemu-system-arm) and the Rust targets
# thumbv6m-none-eabi and thumbv7em-none-eabihf (rustup target add ...).
set -euo pipefail

cd "$(dirname "${BASH_SOURCE[0]}")"
read -r -a cargo_flags <<< "${CARGO_FLAGS:-}"
bin=qloop-cortex-m
target_dir=${CARGO_TARGET_DIR:-target}
out=$target_dir/run
mkdir -p "$out"

# machine:target:core
machines=(
    "microbit:thumbv6m-none-eabi:Cortex-M0"
    "mps2-an386:thumbv7em-none-eabihf:Cortex-M4F"
)

command -v qemu-system-arm >/dev/null || {
    echo "FAIL: qemu-system-arm not found (apt-get install qemu-system-arm)"
    exit 1
}

echo "== build"
cargo build --release "${cargo_flags[@]}"
for m in "${machines[@]}"; do
    IFS=: read -r _ target _ <<< "$m"
    cargo build --release "${cargo_flags[@]}" --target "$target"
done

size=$(command -v arm-none-eabi-size || command -v llvm-size || true)
if [[ -n $size ]]; then
    echo "== size"
    for m in "${machines[@]}"; do
        IFS=: read -r _ target _ <<< "$m"
        "$size" "$target_dir/$target/release/$bin"
    done
fi

echo "== host reference"
"$target_dir/release/$bin" > "$out/host.txt"
lines=$(wc -l < "$out/host.txt")
last=$(tail -n 1 "$out/host.txt")
if [[ $last != "qloop-cortex-m done "* ]]; then
    echo "FAIL host: the reference run did not finish (last line: $last)"
    exit 1
fi
echo "host: $lines lines, $last"

status=0
for m in "${machines[@]}"; do
    IFS=: read -r machine target core <<< "$m"
    echo "== $machine ($core, $target)"
    # -icount: the virtual clock counts instructions, so SysTick measures them (the firmware's
    # "cost" lines on stderr); it does not change what the program prints.
    rc=0
    timeout 60 qemu-system-arm -M "$machine" -nographic \
        -semihosting-config enable=on,target=native -icount shift=10 \
        -kernel "$target_dir/$target/release/$bin" \
        < /dev/null > "$out/$machine.txt" 2> "$out/$machine.err" || rc=$?
    sed 's/^/  /' "$out/$machine.err"
    if ((rc != 0)); then
        [[ $rc == 124 ]] && why="timed out after 60 s" || why="exit status $rc"
        echo "FAIL $machine: qemu-system-arm $why"
        status=1
    elif ! diff -u "$out/host.txt" "$out/$machine.txt" > "$out/$machine.diff"; then
        head -n 40 "$out/$machine.diff"
        echo "FAIL $machine: output differs from the host reference (see $out/$machine.diff)"
        status=1
    else
        echo "PASS $machine ($core, $target): $lines lines identical to the host, ${last#qloop-cortex-m done }"
    fi
done
exit "$status"
