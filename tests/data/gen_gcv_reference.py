"""GCV reference for the smoother (tests/smoothing_spline_test.cpp).

Data: t, y of uniform_n101.csv, weights w = 1. For 241 values of lam, log-spaced over 1e-9..1e-1,
SciPy's make_smoothing_spline gives the fit; its hat matrix A comes from fitting the n unit
vectors (the smoother is linear in y), so tr A and GCV = n RSS / (n - tr A)^2 are independent of
sid's O(n) recurrence. Run: python3 gen_gcv_reference.py > gcv_reference.csv
"""
import numpy as np
from scipy.interpolate import make_smoothing_spline

data = np.genfromtxt("uniform_n101.csv", delimiter=",", names=True, skip_header=1)
t, y = data["t"], data["y"]
n = len(t)
print("# GCV of SciPy make_smoothing_spline fits of uniform_n101.csv (w = 1); scipy", __import__("scipy").__version__)
print("lam,gcv,trace,cv")
for lam in np.logspace(-9, -1, 241):
    g = make_smoothing_spline(t, y, lam=lam)(t)
    A = np.column_stack([make_smoothing_spline(t, e, lam=lam)(t) for e in np.eye(n)])
    tr = np.trace(A)
    r = y - g
    gcv = n * np.sum(r**2) / (n - tr) ** 2
    cv = np.mean((r / (1 - np.diag(A))) ** 2)
    print(f"{lam:.17g},{gcv:.17g},{tr:.17g},{cv:.17g}")
