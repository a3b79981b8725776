#!/usr/bin/env python3
"""Independent oracle for qloop-plant's beta-FROH discretisation (plant/src/froh.rs).

Writes froh_scipy.toml beside this script: for the paper's initial plant model and reference
model (Rubio & De la Sen, Sec. V) at T = 0.0839 s, and for each beta of the paper's set,
the first samples of the beta-FROH model's impulse response, computed by scipy in two ways that
share nothing with the Rust code (which uses one Van Loan matrix exponential in state space):

  1. from scipy's ZOH and triangle-hold ("foh") discretisations, by the impulse-response
     identity  H_beta(z) = (1 - beta z^-1) H_zoh(z) + beta z^-1 H_tri(z);
  2. from Rubio & De la Sen, eq. 5 as derived in froh.rs: H_beta = ((z - beta)/z) Z[h0 G]
     + beta (z - 1)/(T z) Z[h0 G/s], with scipy's ZOH of G and of G/s.

The script asserts that the two agree, and also stores scipy's ZOH coefficients, which beta = 0
must reproduce exactly. `--check` recomputes and compares with the stored file instead of
writing it (CI runs that, so the stored numbers are what scipy gives).

Usage: python3 froh_scipy.py [--check]      (needs scipy; pip install scipy)
"""
import os
import sys

import numpy as np
from scipy.signal import cont2discrete, tf2ss

T = 0.0839
BETAS = [-0.5, -0.3, 0.0, 0.3, 0.5, 0.8, 1.0]
MODELS = {
    "plant": ([-3.0, 150.0], [1.0, 20.0, 550.0]),
    "reference": ([98.62], [1.0, 15.89, 98.62]),
}
SAMPLES = 12


def markov(sysd, n):
    a, b, c, d, _ = sysd
    h = [float(d[0, 0])]
    v = b
    for _ in range(n - 1):
        h.append(float((c @ v)[0, 0]))
        v = a @ v
    return np.array(h)


def delayed(h):
    return np.concatenate(([0.0], h[:-1]))


def oracle():
    out = {}
    for name, (num, den) in MODELS.items():
        ss = tf2ss(num, den)
        hz = markov(cont2discrete(ss, T, method="zoh"), SAMPLES)
        ht = markov(cont2discrete(ss, T, method="foh"), SAMPLES)
        hs = markov(cont2discrete(tf2ss(num, list(den) + [0.0]), T, method="zoh"), SAMPLES)
        numz, denz, _ = cont2discrete((num, den), T, method="zoh")
        rows = []
        for beta in BETAS:
            via_tri = hz - beta * delayed(hz) + beta * delayed(ht)
            via_eq5 = hz - beta * delayed(hz) + beta / T * (hs - delayed(hs))
            scale = np.max(np.abs(via_tri))
            assert np.max(np.abs(via_tri - via_eq5)) < 1e-12 * scale, (name, beta)
            rows.append((beta, via_tri))
        out[name] = (num, den, np.ravel(numz), np.ravel(denz), rows)
    return out


def toml_text(out):
    lines = [
        "# Written by froh_scipy.py (scipy %s); do not edit by hand." % __import__("scipy").__version__,
        "period = %r" % T,
        "",
    ]
    for name, (num, den, numz, denz, rows) in out.items():
        lines.append("[%s]" % name)
        lines.append("num = %r" % [float(x) for x in num])
        lines.append("den = %r" % [float(x) for x in den])
        lines.append("zoh_num = %r" % [float(x) for x in numz])
        lines.append("zoh_den = %r" % [float(x) for x in denz])
        lines.append("")
        for beta, h in rows:
            lines.append("[[%s.froh]]" % name)
            lines.append("beta = %r" % beta)
            lines.append("impulse = %r" % [float(x) for x in h])
            lines.append("")
    return "\n".join(lines)


def main():
    path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "froh_scipy.toml")
    out = oracle()
    if "--check" in sys.argv:
        import tomllib

        with open(path, "rb") as f:
            stored = tomllib.load(f)
        for name, (_, _, numz, denz, rows) in out.items():
            s = stored[name]
            assert np.allclose(s["zoh_num"], numz, rtol=1e-12, atol=1e-15), name
            assert np.allclose(s["zoh_den"], denz, rtol=1e-12, atol=1e-15), name
            for (beta, h), r in zip(rows, s["froh"]):
                assert r["beta"] == beta
                assert np.allclose(r["impulse"], h, rtol=1e-10, atol=1e-14), (name, beta)
        print("froh_scipy.toml agrees with scipy", __import__("scipy").__version__)
        return
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        f.write(toml_text(out))
    os.replace(tmp, path)
    print("wrote", path)


if __name__ == "__main__":
    main()
