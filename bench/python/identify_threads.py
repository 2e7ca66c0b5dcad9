"""Two identifications in two Python threads against one: the GIL released, they overlap.

    python bench/python/identify_threads.py [--repeat 3]

The run: the real TX40 log (tests/data/staubli_tx40) at 1 kHz, 9 s, six joints."""

import argparse
import threading
import time
from pathlib import Path

import numpy as np

import sid

DATA = Path(__file__).resolve().parents[2] / "tests" / "data" / "staubli_tx40"


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    robot = sid.Robot.from_urdf(DATA / "tx40_mdh_modified.urdf",
                                transmission=DATA / "tx40_transmission.yaml")
    q = np.loadtxt(DATA / "pos_read_data.csv", delimiter=",", skiprows=1)[::5]
    current = np.loadtxt(DATA / "curr_data.csv", delimiter=",", skiprows=1)[::5]
    run = sid.Run(np.arange(len(q)) * 0.001, q, current)

    def one():
        sid.identify(robot, run)

    def two():
        threads = [threading.Thread(target=one) for _ in range(2)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()

    def best(f):
        times = []
        for _ in range(args.repeat):
            start = time.perf_counter()
            f()
            times.append(time.perf_counter() - start)
        return min(times)

    one()  # warm up
    single, double = best(one), best(two)
    print(f"one identification {single:.3f} s; two in two threads {double:.3f} s "
          f"({double / single:.2f}x one)")


if __name__ == "__main__":
    main()
