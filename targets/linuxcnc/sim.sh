#!/usr/bin/env bash
# Closed-loop run of the ACC component in a real, headless LinuxCNC (milltask, motion, the
# trajectory planner): sim/acc_sim.ini simulates a lathe whose cutting force is K_p * feed,
# sim/acc_ui.py enables adaptive feed (M52 P1), feeds at F300 and steps K_p; the ACC must hold
# the force at F_r = 1.5 kN (feed = F_r / K_p) in every phase.
#
#   targets/linuxcnc/sim.sh [COMPFILE]    (default: example/qloop_koren_masory_1981.comp;
#                                          must be a qloop_koren_masory_1981.comp)
#
# Environment: RTAPI_UID (as root: 65534), QLOOP_HALRUN_CLEANUP=1, QLOOP_TEST_KEEP=1.
set -euo pipefail

HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
COMP=${1:-$HERE/example/qloop_koren_masory_1981.comp}
. "$HERE/lib.sh"

for tool in halcompile linuxcnc /usr/bin/python3; do
    command -v "$tool" >/dev/null || die "$tool not found (apt-get install linuxcnc-uspace-dev)"
done
/usr/bin/python3 -c 'import linuxcnc, hal' 2>/dev/null || die "/usr/bin/python3 cannot import linuxcnc, hal"
[ "$(basename "$COMP")" = qloop_koren_masory_1981.comp ] || die "sim/ is written for qloop_koren_masory_1981.comp"
[ -f "$COMP" ] || die "no such component: $COMP"
COMP=$(cd "$(dirname "$COMP")" && pwd)/$(basename "$COMP")

qloop_rtapi_env
WORK=
lpid=
cleanup() {
    rc=$?
    if [ -n "$lpid" ] && kill -0 "$lpid" 2>/dev/null; then
        kill "$lpid" 2>/dev/null || true   # our `timeout linuxcnc`
        wait "$lpid" 2>/dev/null || true
        "$REALTIME" status >/dev/null 2>&1 && halrun -U >/dev/null 2>&1 || true
    fi
    if [ -n "$WORK" ]; then
        if [ "${QLOOP_TEST_KEEP:-0}" = 1 ] || [ $rc != 0 ]; then
            echo "sim.sh: work directory kept: $WORK" >&2
        else
            rm -rf "$WORK"
        fi
    fi
    exit $rc
}
trap cleanup EXIT
trap 'exit 130' INT TERM

qloop_realtime_free
WORK=$(mktemp -d "${TMPDIR:-/tmp}/qloop-linuxcnc-sim.XXXXXX")
echo "== halcompile --install $(basename "$COMP")"
qloop_install "$COMP" "$WORK/halcompile.log"

# LinuxCNC writes its parameter file next to the INI: run a copy.
cp "$HERE"/sim/acc_sim.ini "$HERE"/sim/acc_sim.hal "$HERE"/sim/acc_ui.py "$HERE"/sim/tool.tbl "$WORK/"
chmod +x "$WORK/acc_ui.py"
echo "== linuxcnc acc_sim.ini (headless, ~30 s)"
export ACC_SIM_OUT=$WORK/acc_sim.csv
(cd "$WORK" && exec timeout 300 linuxcnc acc_sim.ini) > "$WORK/linuxcnc.log" 2>&1 &
lpid=$!
lrc=0
wait $lpid || lrc=$?
lpid=
{ grep -v -e '^Running with fallback_uid' -e '^Note: Using POSIX non-realtime' "$WORK/linuxcnc.log" || true; } | sed 's/^/   /'
[ -f "$ACC_SIM_OUT.result" ] || die "no result (linuxcnc exited $lrc); log: $WORK/linuxcnc.log"
read -r verdict rest < "$ACC_SIM_OUT.result"
echo "$rest" | tr ';' '\n' | sed 's/^ */   /'
if [ "${QLOOP_TEST_KEEP:-0}" = 1 ]; then trace="trace: $ACC_SIM_OUT"; else trace="QLOOP_TEST_KEEP=1 keeps the trace"; fi
echo "$verdict: ACC closed loop in LinuxCNC ($trace)"
[ "$verdict" = PASS ]
