#!/usr/bin/python3
"""Headless "display" for acc_sim.ini: turns the machine on, enables adaptive feed (M52 P1),
starts a long axial feed move at F300 (5 mm/s, the controller's output range maximum, so the
actual feed equals the controller's feed command U) and steps the simulated process gain K_p.
The ACC must bring the cutting force to the reference F_r = 1.5 kN, i.e. the feed to
U = F_r / K_p, in each phase; the air-cut phase (force below F_AIR) must run at full feed.

Writes ACC_SIM_OUT (default acc_sim.csv) and ACC_SIM_OUT.result ("PASS ..." or "FAIL ...").
Must run under /usr/bin/python3 (the linuxcnc and hal modules are Debian packages).
"""
import os
import sys
import time

import hal
import linuxcnc

FR = 1.5            # kN, the spec's reference force
U_MIN, U_MAX = 0.05, 5.0
PHASES = [          # (K_p in kN/(mm/s), seconds)
    (1.5, 6.0),
    (3.0, 6.0),
    (0.6, 6.0),
    (0.02, 4.0),    # air cut: F = 0.02 * 5 = 0.1 kN < F_AIR
    (2.0, 6.0),
]
TOL = 0.05          # relative, on the mean of each phase's last second

out = os.environ.get("ACC_SIM_OUT", "acc_sim.csv")
log = open(out, "w")
log.write("t,kp,vel_mm_s,force_kN,adaptive_feed,steps\n")
results = []


def finish(ok, msg):
    with open(out + ".result", "w") as f:
        f.write(("PASS " if ok else "FAIL ") + msg + "\n")
    print(("PASS " if ok else "FAIL ") + msg, file=sys.stderr)


h = hal.component("acc-ui")   # the hal module needs a component before get_value/set_p
h.ready()
c = linuxcnc.command()
s = linuxcnc.stat()
e = linuxcnc.error_channel()
try:
    for _ in range(100):
        try:
            s.poll()
            break
        except linuxcnc.error:
            time.sleep(0.1)
    c.state(linuxcnc.STATE_ESTOP_RESET)
    c.state(linuxcnc.STATE_ON)
    c.wait_complete()
    c.mode(linuxcnc.MODE_MDI)
    c.wait_complete()
    c.mdi("G21 G90 G94 G18 M52 P1")
    c.wait_complete()
    c.mdi("G1 Z-900 F300")
    t0 = time.time()
    for kp, secs in PHASES:
        hal.set_p("process.in1", repr(kp))
        start = time.time()
        tail = []
        while time.time() - start < secs:
            time.sleep(0.05)
            v = hal.get_value("motion.current-vel")
            f = hal.get_value("process.out")
            a = hal.get_value("qloop-koren-masory-1981.0.adaptive-feed")
            n = hal.get_value("qloop-koren-masory-1981.0.steps")
            log.write("%.3f,%g,%.6f,%.6f,%.6f,%d\n" % (time.time() - t0, kp, v, f, a, n))
            if time.time() - start > secs - 1.0:
                tail.append(v)
        err = e.poll()
        if err:
            raise RuntimeError("LinuxCNC error: %s" % (err[1],))
        v_mean = sum(tail) / len(tail)
        u_exp = min(max(FR / kp, U_MIN), U_MAX)
        if kp * U_MAX < 0.15:
            u_exp = U_MAX                     # air cut: estimator frozen, feed to the limit
        ok = abs(v_mean - u_exp) <= TOL * u_exp
        results.append((ok, "K_p=%g: feed %.4f mm/s (expected %.4f), force %.4f kN"
                        % (kp, v_mean, u_exp, kp * v_mean)))
    c.abort()
    c.wait_complete()
    c.mode(linuxcnc.MODE_MDI)
    c.wait_complete()
    c.mdi("M52 P0")
    c.wait_complete()
    c.state(linuxcnc.STATE_OFF)
    c.state(linuxcnc.STATE_ESTOP)
    for ok, msg in results:
        print(("ok   " if ok else "BAD  ") + msg, file=sys.stderr)
    bad = [m for ok, m in results if not ok]
    finish(not bad, "; ".join(m for _, m in results))
except Exception as ex:   # report, then let linuxcnc shut down
    finish(False, "exception: %r" % (ex,))
finally:
    log.close()
