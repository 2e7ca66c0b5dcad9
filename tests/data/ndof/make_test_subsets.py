"""Writes the test subsets of the n-joint reference set (made by gen_ndof.py, Pinocchio 4.1.0).

base_<arm>.csv: per column of theta (0-based index), the true value, whether the reference's
pivoted QR kept it as a base column, and beta at the kept ones (0 elsewhere); the first comment
line carries n_base. ident_<arm>.csv: every 20th row of the excitation trajectory (500 rows of
10000), with its exact velocities and accelerations. Needs the standard library only.
"""
import csv
import json
import sys
from pathlib import Path

source = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(".")
here = Path(__file__).resolve().parent
for arm in ("puma560", "tx40"):
    base = json.loads((source / f"base_{arm}.json").read_text())
    beta = dict(zip(base["independent_columns"], base["beta"]))
    with open(here / f"base_{arm}.csv", "w", newline="") as out:
        out.write(f"# n_base={base['n_base']} (inertial {base['n_base_inertial']}, friction "
                  f"{base['n_base_friction']}); beta = theta[independent] + K theta[dependent]\n")
        out.write("column,theta,independent,beta\n")
        for j, value in enumerate(base["theta_full"]):
            kept = j in beta
            out.write(f"{j},{value:.17g},{int(kept)},{beta.get(j, 0.0):.17g}\n")
    with open(source / f"ident_{arm}.csv", newline="") as f, \
            open(here / f"ident_{arm}.csv", "w", newline="") as out:
        rows = list(csv.reader(f))
        writer = csv.writer(out, lineterminator="\n")
        writer.writerow(rows[0])
        for row in rows[1::20]:
            writer.writerow(row)
