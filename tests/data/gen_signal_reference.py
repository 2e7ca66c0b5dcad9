#!/usr/bin/env python3
"""Reference numbers for tests/butterworth_test.cpp (SciPy's butter, lfilter_zi, lfilter, filtfilt).

Writes, next to this script:
  butter_reference.csv   b, a of butter(3, 0.05), butter(3, 0.015), butter(4, 0.01); zi: the exact
                         (50-digit mpmath) solution of lfilter_zi's system for those b, a, rounded
                         to double; zi_scipy: scipy.signal.lfilter_zi(b, a)
  filtfilt_reference.csv a 200 x 2 test signal, and for each filter and column: lfilter (zero
                         state), filtfilt (scipy.signal.filtfilt, defaults) and filtfilt_exactzi
                         (SciPy's filtfilt algorithm, run with scipy.signal.lfilter, but started
                         from the exact zi)

Why two filtfilt references: lfilter_zi solves (I - A^T) zi = B, whose condition number is 3.8e3,
1.6e5 and 7.1e7 for the three filters, so scipy's LU answer carries relative errors up to 3.5e-10
(butter(4, 0.01)); sid computes zi to full precision, so it matches filtfilt_exactzi to rounding.

Run: python3 gen_signal_reference.py   (numpy 2.4.6, scipy 1.17.1 made the committed files)
"""
import os

import mpmath
import numpy as np
import scipy
from scipy import signal

HERE = os.path.dirname(os.path.abspath(__file__))
# The paper's three filters (as corrected in docs/paper-reproduction.md): q, qd, qdd.
FILTERS = [("q", 3, 0.05), ("qd", 3, 0.015), ("qdd", 4, 0.01)]


def lcg(n, seed):
    """A fixed pseudo-random sequence in [-0.5, 0.5) (Numerical Recipes LCG), independent of numpy."""
    out, state = [], seed
    for _ in range(n):
        state = (1664525 * state + 1013904223) % 2**32
        out.append(state / 2**32 - 0.5)
    return np.array(out)


def exact_zi(b, a):
    """lfilter_zi's linear system solved in 50-digit arithmetic for the double coefficients b, a."""
    mpmath.mp.dps = 50
    n = len(a) - 1
    m = mpmath.matrix(n, n)
    for i in range(n):
        m[i, i] = 1
        m[i, 0] += mpmath.mpf(a[i + 1])
        if i + 1 < n:
            m[i, i + 1] -= 1
    rhs = mpmath.matrix([mpmath.mpf(b[i + 1]) - mpmath.mpf(a[i + 1]) * mpmath.mpf(b[0]) for i in range(n)])
    return np.array([float(v) for v in mpmath.lu_solve(m, rhs)])


def filtfilt_with_zi(b, a, x, zi):
    """scipy.signal.filtfilt(b, a, x) step by step (padtype odd, default padlen), given zi."""
    edge = 3 * max(len(a), len(b))
    ext = np.concatenate((2 * x[0] - x[edge:0:-1], x, 2 * x[-1] - x[-2:-(edge + 2):-1]))
    y, _ = signal.lfilter(b, a, ext, zi=zi * ext[0])
    y, _ = signal.lfilter(b, a, y[::-1], zi=zi * y[-1])
    return y[::-1][edge:-edge]


def main():
    header = f"# made by gen_signal_reference.py with numpy {np.__version__}, scipy {scipy.__version__}"
    rows = []
    for name, order, wn in FILTERS:
        b, a = signal.butter(order, wn)
        zi = exact_zi(b, a)
        zi_scipy = signal.lfilter_zi(b, a)
        for i in range(order + 1):
            z = zi[i] if i < order else np.nan
            z_scipy = zi_scipy[i] if i < order else np.nan
            rows.append(f"{order},{wn!r},{i},{float(b[i])!r},{float(a[i])!r},{float(z)!r},{float(z_scipy)!r}")
    with open(os.path.join(HERE, "butter_reference.csv"), "w") as f:
        f.write(header + "\n")
        f.write("# b, a = scipy.signal.butter(order, wn); zi = exact solution of lfilter_zi's system, "
                "zi_scipy = scipy.signal.lfilter_zi(b, a); zi has order entries (nan pads)\n")
        f.write("order,wn,index,b,a,zi,zi_scipy\n")
        f.write("\n".join(rows) + "\n")

    n = 200
    t = np.arange(n) * 0.0025
    x1 = np.sin(2 * np.pi * 1.3 * t) + 0.5 * np.sin(2 * np.pi * 17.0 * t + 0.3) + 0.2 * lcg(n, 1)
    x2 = 0.3 + 2.0 * np.cos(2 * np.pi * 0.7 * t) + 0.1 * lcg(n, 2)
    cols = {"x1": x1, "x2": x2}
    for name, order, wn in FILTERS:
        b, a = signal.butter(order, wn)
        for j, x in (("1", x1), ("2", x2)):
            cols[f"lfilter_{name}{j}"] = signal.lfilter(b, a, x)
            cols[f"filtfilt_{name}{j}"] = signal.filtfilt(b, a, x)
            # The step-by-step algorithm is SciPy's: with SciPy's zi it gives filtfilt bit for bit.
            assert np.array_equal(filtfilt_with_zi(b, a, x, signal.lfilter_zi(b, a)), cols[f"filtfilt_{name}{j}"])
            cols[f"filtfilt_exactzi_{name}{j}"] = filtfilt_with_zi(b, a, x, exact_zi(b, a))
    with open(os.path.join(HERE, "filtfilt_reference.csv"), "w") as f:
        f.write(header + "\n")
        f.write("# x1, x2: 200 samples (Ts = 0.0025 s) of sines plus a fixed LCG sequence; "
                "lfilter_<f><j> = lfilter(b, a, xj) (zero state), filtfilt_<f><j> = filtfilt(b, a, xj) "
                "(SciPy defaults), filtfilt_exactzi_<f><j> = the same from the exact zi; "
                "f in q (3, 0.05), qd (3, 0.015), qdd (4, 0.01)\n")
        f.write(",".join(cols) + "\n")
        for i in range(n):
            f.write(",".join(repr(float(c[i])) for c in cols.values()) + "\n")


if __name__ == "__main__":
    main()
