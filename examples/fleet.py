"""Identify a fleet: one fit per log, spread over a Dask cluster.

    python examples/fleet.py --robot arm.urdf [--tip tool0] [--transmission drives.yaml] \
        [--columns t=time,q1=...] [--scheduler tcp://host:8786 | --workers 2 | --serial] \
        [--json fleet.json] LOG.csv...

Each log is fitted on its own (sid.identify, as sid_identify --robot does); the summary lists
each log's relative torque residual and its largest parameter std. Without --scheduler a local
cluster of --workers processes runs the fits; the same code runs on any Dask cluster whose
workers have sid installed and see the files. The results equal the serial loop's (--serial)
bit for bit: each fit is deterministic and independent of where it runs.

Needs: pip install "dask[distributed]".
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from typing import Any, Optional, Sequence


def fit_log(robot: dict[str, Any], log: str, columns: dict[str, str]) -> dict[str, Any]:
    """One log's fit. Runs on a worker: sid objects stay there, plain data comes back."""
    import sid

    model = sid.Robot.from_urdf(**robot) if not robot["path"].endswith(".dh") else \
        sid.Robot.from_dh(robot["path"], transmission=robot.get("transmission"))
    fit = sid.identify(model, sid.Run.from_csv(log, columns=columns or None))
    return {
        "log": log,
        "parameter_names": fit.parameter_names,
        "theta": fit.theta.tolist(),
        "std_dev": fit.std_dev.tolist(),
        "relative_residual": fit.relative_residual,
    }


def fit_fleet(robot: dict[str, Any], logs: Sequence[str], columns: dict[str, str],
              client: Any = None) -> list[dict[str, Any]]:
    """Every log's fit, in the logs' order: on the Dask client's cluster, or here in turn."""
    if client is None:
        return [fit_log(robot, log, columns) for log in logs]
    futures = client.map(fit_log, [robot] * len(logs), logs, [columns] * len(logs), pure=False)
    return client.gather(futures)


def main(argv: Optional[Sequence[str]] = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("logs", nargs="+", help="CSV logs, one fit each")
    parser.add_argument("--robot", required=True, help="URDF or DH table")
    parser.add_argument("--base")
    parser.add_argument("--tip")
    parser.add_argument("--transmission", help="motor-side logs: YAML or URDF transmission")
    parser.add_argument("--columns", default="", help="renames, e.g. t=time,q1=pos_1")
    where = parser.add_mutually_exclusive_group()
    where.add_argument("--scheduler", help="a Dask scheduler's address (default: a local cluster)")
    where.add_argument("--serial", action="store_true", help="fit in turn here, no Dask")
    parser.add_argument("--workers", type=int, default=2, help="local cluster size (default 2)")
    parser.add_argument("--json", help="write every fit here")
    args = parser.parse_args(argv)
    if args.workers < 1:
        parser.error("--workers must be >= 1")
    for log in args.logs:
        if not os.path.exists(log):
            parser.error(f"{log}: no such file")
    if args.json and os.path.exists(args.json):
        parser.error(f"{args.json} exists; remove it first")
    columns = dict(kv.split("=", 1) for kv in args.columns.split(",") if kv)
    robot = {"path": os.path.abspath(args.robot), "base": args.base, "tip": args.tip,
             "transmission": args.transmission}
    logs = [os.path.abspath(log) for log in args.logs]

    def timed(client: Any = None) -> tuple[list[dict[str, Any]], float]:
        start = time.perf_counter()
        fits = fit_fleet(robot, logs, columns, client)
        return fits, time.perf_counter() - start

    if args.serial:
        fits, seconds = timed()
    else:
        from distributed import Client, LocalCluster

        if args.scheduler:
            with Client(args.scheduler) as client:
                fits, seconds = timed(client)
        else:
            # One thread per worker process: each fit uses the process's cores as it needs.
            with LocalCluster(n_workers=args.workers, threads_per_worker=1,
                              processes=True, dashboard_address=None) as cluster, \
                    Client(cluster) as client:
                client.run(lambda: __import__("sid"))  # each worker's import, not timed
                fits, seconds = timed(client)

    for f in fits:
        print(f"{os.path.basename(f['log'])}: relative residual {f['relative_residual']:.4f}, "
              f"largest std {max(f['std_dev']):.3g}")
    print(f"{len(fits)} fits in {seconds:.2f} s (the cluster's start not counted; "
          f"{'serial' if args.serial else args.scheduler or f'{args.workers} local workers'})")
    if args.json:
        with open(args.json, "w", encoding="utf-8") as out:
            json.dump({"seconds": seconds, "fits": fits}, out, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
