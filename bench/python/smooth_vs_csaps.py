"""sid.smooth against csaps at a fixed lam, side by side in one run: n = 1e6 samples of a noisy
sine on a uniform grid (and sorted uniform-random abscissae), csaps' smooth p = 1 / (1 + lam).

    pip install csaps && python bench/python/smooth_vs_csaps.py [--n 1000000] [--repeat 3]

Prints the best of --repeat timings of each and the largest difference of their curves."""

import argparse
import time

import numpy as np

import sid


def best(repeat, f):
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        value = f()
        times.append(time.perf_counter() - start)
    return min(times), value


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--n", type=int, default=1_000_000)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--lam", type=float, default=1e-7)
    args = parser.parse_args()
    import csaps

    rng = np.random.default_rng(1)
    for layout in ("uniform grid", "sorted uniform-random"):
        x = np.linspace(0.0, 1.0, args.n) if layout == "uniform grid" else \
            np.sort(rng.uniform(0.0, 1.0, args.n))
        y = np.sin(6.0 * x) + 0.1 * rng.standard_normal(args.n)
        t_sid, s = best(args.repeat, lambda: sid.smooth(x, y, lam=args.lam))
        t_csaps, c = best(args.repeat, lambda: csaps.CubicSmoothingSpline(
            x, y, smooth=1.0 / (1.0 + args.lam)))
        g_sid, g_csaps = s(x), c(x)
        difference = np.abs(g_sid - g_csaps).max() / np.abs(g_csaps).max()
        print(f"{layout}, n = {args.n}, lam = {args.lam:g}: sid {1e3 * t_sid:.1f} ms, csaps "
              f"{1e3 * t_csaps:.1f} ms ({t_csaps / t_sid:.1f}x); largest difference "
              f"{difference:.2e} of the curve (sid merged samples closer than "
              f"{s.merge_tolerance:g})")


if __name__ == "__main__":
    main()
