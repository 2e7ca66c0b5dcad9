"""csaps_reference.csv: csaps' smoothing spline of nonuniform_n64.csv (weights 1/dy^2) at
smooth p = 1 / (1 + lam), its value, slope and curvature at the knots, for three lam.

    pip install csaps==1.3.3 && python tests/data/gen_csaps_reference.py
"""

from pathlib import Path

import csaps
import numpy as np

here = Path(__file__).resolve().parent
table = np.genfromtxt(here / "nonuniform_n64.csv", delimiter=",", names=True, skip_header=1)
t, y, w = table["t"], table["y"], 1.0 / table["dy"] ** 2
rows = []
for lam in (1e-4, 1e-2, 1.0):
    s = csaps.CubicSmoothingSpline(t, y, weights=w, smooth=1.0 / (1.0 + lam))
    for i in range(t.size):
        rows.append((lam, t[i], s(t[i]), s(t[i], nu=1), s(t[i], nu=2)))
with open(here / "csaps_reference.csv", "w", encoding="utf-8") as out:
    out.write(f"# csaps {csaps.__version__} CubicSmoothingSpline of nonuniform_n64.csv, "
              "weights 1/dy^2, smooth = 1/(1 + lam)\n")
    out.write("lam,t,g,dg,d2g\n")
    for row in rows:
        out.write(",".join(repr(float(v)) for v in row) + "\n")
