"""The real Staubli TX40 log (tests/data/staubli_tx40, FIGAROH's data set, Apache-2.0), motor
side at 5 kHz, taken at every 5th sample: the samples the Python tests fit."""

from pathlib import Path

import numpy as np

import sid

DATA = Path(__file__).resolve().parents[2] / "tests" / "data" / "staubli_tx40"
URDF = DATA / "tx40_mdh_modified.urdf"
TRANSMISSION = DATA / "tx40_transmission.yaml"
PERIOD = 0.0002  # s, FIGAROH's ts
STEP = 5


def robot() -> sid.Robot:
    return sid.Robot.from_urdf(URDF, transmission=TRANSMISSION)


def samples():
    q = np.loadtxt(DATA / "pos_read_data.csv", delimiter=",", skiprows=1)[::STEP]
    current = np.loadtxt(DATA / "curr_data.csv", delimiter=",", skiprows=1)[::STEP]
    t = np.arange(len(q)) * PERIOD * STEP
    return t, q, current


def write_csv(path: Path) -> Path:
    t, q, tau = samples()
    header = "t," + ",".join(f"q{j}" for j in range(1, 7)) + "," + ",".join(
        f"tau{j}" for j in range(1, 7)
    )
    np.savetxt(path, np.column_stack([t, q, tau]), delimiter=",", header=header, comments="",
               fmt="%.17g")
    return path
