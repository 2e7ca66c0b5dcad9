"""examples/fleet.py: one fit per log on a local Dask cluster of two worker processes equals
the serial loop; here on six 1.5 s windows of the real TX40 log at 5 kHz."""

import importlib.util
import os
from pathlib import Path

import numpy as np
import pytest

import tx40

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def load_fleet():
    spec = importlib.util.spec_from_file_location("fleet", EXAMPLES / "fleet.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def windows(tmp_path_factory):
    """The log cut into six windows of 7500 samples, each from t = 0."""
    q = np.loadtxt(tx40.DATA / "pos_read_data.csv", delimiter=",", skiprows=1)
    current = np.loadtxt(tx40.DATA / "curr_data.csv", delimiter=",", skiprows=1)
    folder = tmp_path_factory.mktemp("fleet")
    header = "t," + ",".join(f"q{j}" for j in range(1, 7)) + "," + ",".join(
        f"tau{j}" for j in range(1, 7))
    size = len(q) // 6
    paths = []
    for k in range(6):
        part = slice(k * size, (k + 1) * size)
        t = np.arange(size) * tx40.PERIOD
        path = folder / f"tx40_{k}.csv"
        np.savetxt(path, np.column_stack([t, q[part], current[part]]), delimiter=",",
                   header=header, comments="", fmt="%.17g")
        paths.append(str(path))
    return paths


def test_a_local_cluster_gives_the_serial_loops_fits(windows, monkeypatch):
    distributed = pytest.importorskip("distributed")
    fleet = load_fleet()
    robot = {"path": str(tx40.URDF), "base": None, "tip": None,
             "transmission": str(tx40.TRANSMISSION)}
    serial = fleet.fit_fleet(robot, windows, {})
    assert [f["log"] for f in serial] == windows
    for f in serial:
        # Each 1.5 s window of the real arm alone: a fit near the whole run's 5 %.
        assert 0.0 < f["relative_residual"] < 0.08
    # The workers import the example by name, as a cluster's would from an installed module.
    monkeypatch.setenv("PYTHONPATH", str(EXAMPLES) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    import sys

    monkeypatch.syspath_prepend(str(EXAMPLES))
    sys.modules["fleet"] = fleet
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        spread = fleet.fit_fleet(robot, windows, {}, client)
    assert spread == serial
