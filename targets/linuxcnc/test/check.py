#!/usr/bin/env python3
"""Stream generator and checker for targets/linuxcnc/run.sh.

  check.py gen   --rows N --seed S --period-ns NS --period-us US > stream.txt
  check.py check --stream stream.txt --samples samples.txt --meta meta.txt
                 --period-ns NS --ref 'REFERENCE_CMD'

`gen` writes the scripted input, one HAL period per line: `index value` (halstreamer cfg=sf).

`check` replays what the component saw and recomputes every sampled row independently:
  * input:  the streamer row the sampler saw (by index; held while the streamer is empty),
            converted as the component documents: floor(x * 2^frac) saturated to the raw
            bounds, NaN -> upper bound;
  * timing: one controller step in the first period, then every period_us of thread time;
  * step:   REFERENCE_CMD (raw inputs in, raw outputs out, one line per controller step);
  * output: held between steps; value = raw * 2^-frac; override = value / full scale in [0, 1].
Integer columns must match exactly. Float columns are compared as halsampler prints them
(printf "%f", which Python's "%f" reproduces exactly); the override and the physical output
are also sampled times 2^52 (HAL `scale`, exact), which makes their check bit-exact.
"""
import argparse
import math
import random
import subprocess
import sys

# sampler cfg, column by column (after halsampler's -t tag); keep in sync with run.sh
COLUMNS = ["idx", "empty", "in", "in_raw", "out_raw", "out", "ovr", "out_x", "ovr_x", "steps"]
SCALE_X = 2.0 ** 52


def fmt_stream(x):
    if math.isnan(x):
        return "nan"
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    return repr(x)


def gen(args):
    rnd = random.Random(args.seed)
    rows = args.rows
    per_step = max(1, (args.period_us * 1000) // args.period_ns)  # HAL periods per controller step
    vals = []
    # Depth-of-cut steps and air cuts (kN), with per-period noise, so that every period's value
    # differs and a controller step that sampled the wrong period would show.
    levels = [0.0, 1.0, 2.2, 0.05, 3.5, 0.8, 4.9, 0.0, 1.6, 6.0, 2.8, 0.1, 1.4, 4.2, 0.0]
    li = 0
    while len(vals) < rows:
        n = rnd.randint(8, 30) * per_step + rnd.randint(0, per_step - 1)
        lvl = levels[li % len(levels)]
        li += 1
        for _ in range(n):
            vals.append(lvl + rnd.uniform(-0.08, 0.08) if lvl > 0.0 else rnd.uniform(0.0, 0.12))
    vals = vals[:rows]
    # Edge cases of the float -> raw conversion, placed on controller-step periods and beside.
    special = [float("nan"), float("inf"), float("-inf"), -1.0, -0.0, 0.0, 5.0, 20481 / 4096,
               20479 / 4096, 20479.5 / 4096, 7.5, 1e300, -1e300, 5e-324, -5e-324, 0.15,
               615 / 4096, 614 / 4096, 614.9999 / 4096, 1.5, 0.1500000001, 2.0 ** -13, 1e9,
               -2.0 ** -40, 4095.9999999 / 4096]
    k = 10
    for i, x in enumerate(special):
        for off in (0, 1):
            r = (k + i) * per_step + off * (per_step // 2)
            if r < rows:
                vals[r] = x
    for i, x in enumerate(vals):
        print(i, fmt_stream(x))


def to_raw(x, scale, lo, hi):
    """The component's documented conversion, reimplemented."""
    if math.isnan(x):
        return hi
    y = x * scale
    if y <= lo:
        return lo
    if y >= hi:
        return hi
    return math.floor(y)


def f_fmt(x):
    return "%f" % x


def same_printed(text, x):
    if math.isnan(x):
        return text in ("nan", "-nan")
    return text == f_fmt(x)


def fail(msgs, extra=""):
    print("FAIL: %d mismatch(es)%s" % (len(msgs), extra), file=sys.stderr)
    for m in msgs[:20]:
        print("  " + m, file=sys.stderr)
    if len(msgs) > 20:
        print("  ... %d more" % (len(msgs) - 20), file=sys.stderr)
    sys.exit(1)


def check(args):
    stream = []
    for ln in open(args.stream):
        i, v = ln.split()
        if int(i) != len(stream):
            sys.exit("FAIL: stream file index %s out of order" % i)
        stream.append(float(v))

    meta = {"in": {}, "out": {}}
    for ln in open(args.meta):
        p = ln.split()
        if p[0] == "in":
            meta["in"][int(p[1])] = (float.fromhex(p[2]), int(p[3]), int(p[4]))
        elif p[0] == "out":
            meta["out"][int(p[1])] = (float.fromhex(p[2]), float.fromhex(p[3]))
        else:
            meta[p[0]] = int(p[1])
    if meta["n_in"] != 1 or meta["n_out"] < 1:
        sys.exit("FAIL: the harness drives components with one input (got %d)" % meta["n_in"])
    in_scale, in_lo, in_hi = meta["in"][0]
    out_scale, full_scale = meta["out"][0]
    period_ns = args.period_ns
    ctl_ns = meta["period_us"] * 1000

    rows = []
    errors = []
    expect_tag = 0
    for n, ln in enumerate(open(args.samples), 1):
        p = ln.split()
        if not p:
            continue
        if p[0] == "overrun":
            errors.append("samples line %d: halsampler reports an overrun (rows lost)" % n)
            continue
        if len(p) != 1 + len(COLUMNS):
            errors.append("samples line %d: %d fields, expected %d: %r" % (n, len(p), 1 + len(COLUMNS), ln))
            continue
        tag = int(p[0])
        if tag != expect_tag:
            errors.append("samples line %d: sample number %d, expected %d (rows lost)" % (n, tag, expect_tag))
        expect_tag = tag + 1
        rows.append(dict(zip(["tag"] + COLUMNS, p)))
    if errors:
        fail(errors, " in the sampled data")
    if not rows:
        sys.exit("FAIL: no sampled rows")

    # 1. What the component saw, period by period: streamer alignment.
    held = 0.0        # the input pin's value before the streamer wrote anything
    last_idx = -1
    inputs = []
    n_empty = n_empty_start = 0
    for r in rows:
        idx, empty = int(r["idx"]), r["empty"] == "1"
        if empty:
            n_empty += 1
            if last_idx < 0:
                n_empty_start += 1
            if idx != max(last_idx, 0):
                errors.append("row %s: streamer empty but index %d (last %d)" % (r["tag"], idx, last_idx))
        else:
            if idx != last_idx + 1:
                errors.append("row %s: streamer index %d, expected %d (streamer rows skipped or "
                              "repeated: check addf order streamer -> component -> sampler)" % (r["tag"], idx, last_idx + 1))
            if 0 <= idx < len(stream):
                held = stream[idx]
            else:
                errors.append("row %s: streamer index %d outside the stream" % (r["tag"], idx))
            last_idx = idx
        inputs.append(held)
        if not same_printed(r["in"], held):
            errors.append("row %s: input pin %s, streamed %s" % (r["tag"], r["in"], f_fmt(held)))
    if last_idx != len(stream) - 1:
        errors.append("only %d of %d streamed rows were sampled (sequence not consumed)" % (last_idx + 1, len(stream)))
    if errors:
        fail(errors, " in the input alignment")

    # 2. Conversion and controller timing.
    raw_in = [to_raw(x, in_scale, in_lo, in_hi) for x in inputs]
    countdown = 0
    step_rows = []
    for k in range(len(rows)):
        if countdown > 0:
            countdown -= period_ns
            continue
        countdown = max(0, countdown + ctl_ns - period_ns)
        step_rows.append(k)

    # 3. The reference controller.
    ref_in = "".join("%d\n" % raw_in[k] for k in step_rows)
    res = subprocess.run(args.ref, shell=True, input=ref_in, capture_output=True, text=True)
    if res.returncode != 0:
        sys.exit("FAIL: reference command %r exited %d: %s" % (args.ref, res.returncode, res.stderr.strip()))
    ref_out = [int(l.split()[0]) for l in res.stdout.splitlines() if l.strip()]
    if len(ref_out) != len(step_rows):
        sys.exit("FAIL: reference gave %d outputs for %d steps" % (len(ref_out), len(step_rows)))

    # 4. Row by row.
    out_raw = 0
    steps = 0
    si = 0
    mism = {"in_raw": 0, "out_raw": 0, "out": 0, "ovr": 0, "steps": 0}
    for k, r in enumerate(rows):
        if si < len(step_rows) and step_rows[si] == k:
            out_raw = ref_out[si]
            si += 1
            steps += 1
        out = out_raw * out_scale
        ovr = min(max(out / full_scale, 0.0), 1.0)
        t = r["tag"]
        checks = [
            ("in_raw", int(r["in_raw"]) == raw_in[k], "input raw %s, expected %d (input %r)" % (r["in_raw"], raw_in[k], inputs[k])),
            ("out_raw", int(r["out_raw"]) == out_raw, "output raw %s, expected %d" % (r["out_raw"], out_raw)),
            ("out", same_printed(r["out"], out) and same_printed(r["out_x"], out * SCALE_X),
             "output %s (x2^52: %s), expected %s (%s)" % (r["out"], r["out_x"], f_fmt(out), f_fmt(out * SCALE_X))),
            ("ovr", same_printed(r["ovr"], ovr) and same_printed(r["ovr_x"], ovr * SCALE_X),
             "override %s (x2^52: %s), expected %s (%s)" % (r["ovr"], r["ovr_x"], f_fmt(ovr), f_fmt(ovr * SCALE_X))),
            ("steps", int(r["steps"]) == steps, "steps %s, expected %d" % (r["steps"], steps)),
        ]
        for name, ok, msg in checks:
            if not ok:
                mism[name] += 1
                errors.append("row %s (streamer index %s%s): %s" % (t, r["idx"], ", empty" if r["empty"] == "1" else "", msg))
    if errors:
        fail(errors, " against the reference (%s)" % ", ".join("%s: %d" % kv for kv in mism.items() if kv[1]))

    sat = sum(1 for k in step_rows if raw_in[k] in (in_lo, in_hi))
    nan = sum(1 for k in step_rows if math.isnan(inputs[k]))
    outs = [ref_out[i] for i in range(len(step_rows))]
    print("rows: %d sampled (%d with the streamer empty, %d of them before its first row), %d streamed"
          % (len(rows), n_empty, n_empty_start, len(stream)))
    print("controller steps: %d (one per %d us of thread time, periods of %d ns); at steps: %d inputs "
          "saturated, %d NaN; output raw %d..%d" % (len(step_rows), ctl_ns // 1000, period_ns, sat, nan,
                                                  min(outs), max(outs)))
    print("PASS: %d periods compared (%d controller steps): input raw, output raw and steps exact, "
          "output and override bit-exact" % (len(rows), len(step_rows)))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    g = sub.add_parser("gen")
    g.add_argument("--rows", type=int, required=True)
    g.add_argument("--seed", type=int, default=1981)
    g.add_argument("--period-ns", type=int, required=True)
    g.add_argument("--period-us", type=int, required=True)
    c = sub.add_parser("check")
    for a in ("--stream", "--samples", "--meta", "--ref"):
        c.add_argument(a, required=True)
    c.add_argument("--period-ns", type=int, required=True)
    args = ap.parse_args()
    gen(args) if args.cmd == "gen" else check(args)


if __name__ == "__main__":
    main()
