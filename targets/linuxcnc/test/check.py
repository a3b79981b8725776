#!/usr/bin/env python3
"""Stream generator and checker for targets/linuxcnc/run.sh.

  check.py gen   --rows N --seed S --period-ns NS --meta meta.txt > stream.txt
  check.py check --stream stream.txt --samples samples.txt --meta meta.txt
                 --period-ns NS --ref 'REFERENCE_CMD'

meta.txt is `host_ref --meta`: the sample period, the inputs' conversion constants (scale,
raw bounds, rounding), the outputs' scales and the override multiplier.

`gen` writes the scripted inputs, one HAL period per line: `index value...` (halstreamer cfg
s, then one f per input). Input 0 gets cutting levels, air cuts and the conversion's edge
cases; further inputs slower levels and their own edge cases, each within its declared range.

`check` replays what the component saw and recomputes every sampled row independently:
  * input:  the streamer row the sampler saw (by index; held while the streamer is empty),
            converted as the component documents: floor(x * 2^frac) (nearest specs:
            floor(x * 2^frac + 1/2)) saturated to the raw bounds, NaN -> upper bound;
  * timing: one controller step in the first period, then every period_us of thread time;
  * step:   REFERENCE_CMD (raw inputs in, raw outputs out, one line per controller step);
  * output: held between steps; value = raw * 2^-frac; override = value * (1 / range max),
            clamped to [0, 1] (output 0; further outputs are not sampled).
Integer columns must match exactly. Float columns are compared as halsampler prints them
(printf "%f", which Python's "%f" reproduces exactly); the override and the physical output
are also sampled times 2^52 (HAL `scale`, exact), which makes their check bit-exact.
"""
import argparse
import math
import random
import subprocess
import sys

# sampler columns after halsampler's -t tag; keep in sync with run.sh (sampler cfg
# "sb" + "fs" per input + "sffffu")
def columns(n_in):
    cols = ["idx", "empty"]
    for i in range(n_in):
        cols += ["in%d" % i, "in%d_raw" % i]
    return cols + ["out_raw", "out", "ovr", "out_x", "ovr_x", "steps"]


SCALE_X = 2.0 ** 52


def read_meta(path):
    meta = {"in": {}, "out": {}}
    for ln in open(path):
        p = ln.split()
        if p[0] == "in":
            meta["in"][int(p[1])] = (float.fromhex(p[2]), int(p[3]), int(p[4]))
        elif p[0] == "out":
            meta["out"][int(p[1])] = float.fromhex(p[2])
        elif p[0] == "override":
            meta["override"] = float.fromhex(p[1])
        else:
            meta[p[0]] = int(p[1])
    if meta["n_in"] < 1 or meta["n_out"] < 1 or len(meta["in"]) != meta["n_in"]:
        sys.exit("FAIL: bad meta data in %s" % path)
    return meta


def fmt_stream(x):
    if math.isnan(x):
        return "nan"
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    return repr(x)


def step_rows(rows, period_ns, ctl_ns):
    """The periods in which the component runs a controller step (its countdown, replayed)."""
    countdown = 0
    steps = []
    for k in range(rows):
        if countdown > 0:
            countdown -= period_ns
            continue
        countdown = max(0, countdown + ctl_ns - period_ns)
        steps.append(k)
    return steps


def input_values(rnd, rows, per_step, steps, scale, raw_lo, raw_hi, first):
    """One input's stream. The values were written for the 1981 spec's force in [0, 5] kN (raw
    Q12 in [0, 20480], air-cut threshold 0.15 kN); other ranges get the same shape, mapped."""
    lo, hi = raw_lo / scale, raw_hi / scale
    f = (hi - lo) / 5.0

    def at(x):                      # a point of [0, 5] mapped onto [lo, hi]
        return lo + x * f

    vals = []
    if first:
        # Depth-of-cut steps and air cuts, with per-period noise, so that every period's value
        # differs and a controller step that sampled the wrong period would show.
        levels = [0.0, 1.0, 2.2, 0.05, 3.5, 0.8, 4.9, 0.0, 1.6, 6.0, 2.8, 0.1, 1.4, 4.2, 0.0]
        hold, noise = (8, 30), 0.08
    else:
        # A reference or second measurement: slower levels.
        levels = [1.5, 2.5, 1.0, 4.0, 0.0, 5.0, 3.0]
        hold, noise = (20, 60), 0.05
    li = 0
    while len(vals) < rows:
        n = rnd.randint(*hold) * per_step + rnd.randint(0, per_step - 1)
        lvl = levels[li % len(levels)]
        li += 1
        for _ in range(n):
            vals.append(at(lvl + rnd.uniform(-noise, noise)) if lvl > 0.0 else at(rnd.uniform(0.0, 0.12)))
    vals = vals[:rows]
    # Edge cases of the float -> raw conversion, placed on controller-step periods and beside.
    thr = math.floor(at(0.15) * scale)  # raw neighbours of the 1981 spec's F_AIR
    special = [float("nan"), float("inf"), float("-inf"), at(-1.0), -0.0, 0.0, hi,
               (raw_hi + 1) / scale, (raw_hi - 1) / scale, (raw_hi - 0.5) / scale, at(7.5), 1e300,
               -1e300, 5e-324, -5e-324, at(0.15), (thr + 1) / scale, thr / scale,
               (thr + 0.9999) / scale, at(1.5), at(0.1500000001), (raw_lo + 0.5) / scale, 1e9,
               lo - 2.0 ** -40, (raw_lo + scale - 1e-7) / scale]
    k = 10 if first else 10 + len(special) + 3
    for i, x in enumerate(special):
        for off in (0, 1):
            if k + i < len(steps):
                r = steps[k + i] + off * (per_step // 2)
                if r < rows:
                    vals[r] = x
    return vals


def gen(args):
    meta = read_meta(args.meta)
    rnd = random.Random(args.seed)
    ctl_ns = meta["period_us"] * 1000
    per_step = max(1, ctl_ns // args.period_ns)  # HAL periods per step, at least
    steps = step_rows(args.rows, args.period_ns, ctl_ns)
    cols = []
    for i in range(meta["n_in"]):
        scale, raw_lo, raw_hi = meta["in"][i]
        cols.append(input_values(rnd, args.rows, per_step, steps, scale, raw_lo, raw_hi, i == 0))
    for r in range(args.rows):
        print(r, " ".join(fmt_stream(c[r]) for c in cols))


def to_raw(x, scale, lo, hi, nearest):
    """The component's documented conversion, reimplemented."""
    if math.isnan(x):
        return hi
    y = x * scale
    if y <= lo:
        return lo
    if y >= hi:
        return hi
    t = math.floor(y)
    if nearest and y - t >= 0.5:
        t += 1
    return t


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


def check_ref_meta(meta, path):
    """The component's period and conversion scales against the reference's formats."""
    ref = {}
    errors = []
    for ln in open(path):
        p = ln.split()
        ref[tuple(p[:-1])] = int(p[-1])
    for key in ("period_us", "n_in", "n_out"):
        if ref.get((key,)) != meta[key]:
            errors.append("%s: component %d, reference %s" % (key, meta[key], ref.get((key,))))
    for i in range(meta["n_in"]):
        f = ref.get(("in_frac", str(i)))
        if f is None or meta["in"][i][0] != 2.0 ** f:
            errors.append("input %d scale %r, reference format 2^%s" % (i, meta["in"][i][0], f))
    for j in range(meta["n_out"]):
        f = ref.get(("out_frac", str(j)))
        if f is None or meta["out"][j] != 2.0 ** -f:
            errors.append("output %d scale %r, reference format 2^-%s" % (j, meta["out"][j], f))
    if errors:
        fail(errors, " between the component's glue and the reference's formats")
    print("glue constants: period and %d + %d scales as in the reference" % (meta["n_in"], meta["n_out"]))


def check(args):
    meta = read_meta(args.meta)
    n_in = meta["n_in"]
    stream = []
    for ln in open(args.stream):
        p = ln.split()
        if int(p[0]) != len(stream) or len(p) != 1 + n_in:
            sys.exit("FAIL: stream file line %r: index out of order or not %d values" % (ln, n_in))
        stream.append([float(v) for v in p[1:]])

    if args.ref_meta:
        check_ref_meta(meta, args.ref_meta)
    ins = [meta["in"][i] for i in range(n_in)]      # (scale, raw lo, raw hi)
    nearest = meta["round_nearest"] == 1
    out_scale = meta["out"][0]
    ovr_scale = meta["override"]
    period_ns = args.period_ns
    ctl_ns = meta["period_us"] * 1000
    cols = columns(n_in)

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
        if len(p) != 1 + len(cols):
            errors.append("samples line %d: %d fields, expected %d: %r" % (n, len(p), 1 + len(cols), ln))
            continue
        tag = int(p[0])
        if tag != expect_tag:
            errors.append("samples line %d: sample number %d, expected %d (rows lost)" % (n, tag, expect_tag))
        expect_tag = tag + 1
        rows.append(dict(zip(["tag"] + cols, p)))
    if errors:
        fail(errors, " in the sampled data")
    if not rows:
        sys.exit("FAIL: no sampled rows")

    # 1. What the component saw, period by period: streamer alignment.
    held = [0.0] * n_in   # the input pins' values before the streamer wrote anything
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
        for i in range(n_in):
            if not same_printed(r["in%d" % i], held[i]):
                errors.append("row %s: input %d pin %s, streamed %s" % (r["tag"], i, r["in%d" % i], f_fmt(held[i])))
    if last_idx != len(stream) - 1:
        errors.append("only %d of %d streamed rows were sampled (sequence not consumed)" % (last_idx + 1, len(stream)))
    if errors:
        fail(errors, " in the input alignment")

    # 2. Conversion and controller timing.
    raw_in = [[to_raw(x[i], *ins[i], nearest) for i in range(n_in)] for x in inputs]
    steps_at = step_rows(len(rows), period_ns, ctl_ns)

    # 3. The reference controller.
    ref_in = "".join(" ".join("%d" % v for v in raw_in[k]) + "\n" for k in steps_at)
    res = subprocess.run(args.ref, shell=True, input=ref_in, capture_output=True, text=True)
    if res.returncode != 0:
        sys.exit("FAIL: reference command %r exited %d: %s" % (args.ref, res.returncode, res.stderr.strip()))
    ref_out = [int(l.split()[0]) for l in res.stdout.splitlines() if l.strip()]
    if len(ref_out) != len(steps_at):
        sys.exit("FAIL: reference gave %d outputs for %d steps" % (len(ref_out), len(steps_at)))

    # 4. Row by row.
    out_raw = 0
    steps = 0
    si = 0
    mism = {"in_raw": 0, "out_raw": 0, "out": 0, "ovr": 0, "steps": 0}
    for k, r in enumerate(rows):
        if si < len(steps_at) and steps_at[si] == k:
            out_raw = ref_out[si]
            si += 1
            steps += 1
        out = out_raw * out_scale
        ovr = min(max(out * ovr_scale, 0.0), 1.0)
        t = r["tag"]
        checks = [
            ("in_raw", all(int(r["in%d_raw" % i]) == raw_in[k][i] for i in range(n_in)),
             "input raw %s, expected %s (input %r)" % ([r["in%d_raw" % i] for i in range(n_in)], raw_in[k], inputs[k])),
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

    sat = sum(1 for k in steps_at for i in range(n_in) if raw_in[k][i] in (ins[i][1], ins[i][2]))
    nan = sum(1 for k in steps_at for i in range(n_in) if math.isnan(inputs[k][i]))
    outs = [ref_out[i] for i in range(len(steps_at))]
    print("rows: %d sampled (%d with the streamer empty, %d of them before its first row), %d streamed"
          % (len(rows), n_empty, n_empty_start, len(stream)))
    print("controller steps: %d (one per %d us of thread time, periods of %d ns); %d input%s; at steps: "
          "%d inputs saturated, %d NaN; output raw %d..%d" % (len(steps_at), ctl_ns // 1000, period_ns,
                                                            n_in, "" if n_in == 1 else "s", sat, nan,
                                                            min(outs), max(outs)))
    print("PASS: %d periods compared (%d controller steps): input raw, output raw and steps exact, "
          "output and override bit-exact" % (len(rows), len(steps_at)))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    g = sub.add_parser("gen")
    g.add_argument("--rows", type=int, required=True)
    g.add_argument("--seed", type=int, default=1981)
    g.add_argument("--period-ns", type=int, required=True)
    g.add_argument("--meta", required=True)
    c = sub.add_parser("check")
    for a in ("--stream", "--samples", "--meta", "--ref"):
        c.add_argument(a, required=True)
    c.add_argument("--period-ns", type=int, required=True)
    c.add_argument("--ref-meta", help="the reference's period and formats (rust_ref --meta)")
    args = ap.parse_args()
    gen(args) if args.cmd == "gen" else check(args)


if __name__ == "__main__":
    main()
