"""python -m sid.bag2csv BAG --robot URDF -o run.csv: a bag's joint states as the CSV the sid
tools read (t, q1..qn, tau1..taun in the robot's joint order, full precision)."""

from __future__ import annotations

import argparse
import os
import sys
from typing import Optional, Sequence

import numpy as np

from ._core import Robot
from .bag import read_bag


def main(argv: Optional[Sequence[str]] = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m sid.bag2csv",
        description="Writes a ROS bag's sensor_msgs/JointState topic as a sid run CSV "
        "(t, q1..qn, tau1..taun), the robot's joints picked by name.",
    )
    parser.add_argument("bag", help="rosbag2 directory (MCAP or sqlite3) or ROS 1 .bag file")
    parser.add_argument("--robot", required=True, help="the robot's URDF (or DH table)")
    parser.add_argument("--base", help="URDF link the chain starts from (default: the root)")
    parser.add_argument("--tip", help="URDF link the chain ends at (default: the one leaf)")
    parser.add_argument("--topic", default="/joint_states", help="default: %(default)s")
    parser.add_argument("-o", "--output", required=True, help="the CSV to write")
    parser.add_argument("--force", action="store_true", help="overwrite an existing output")
    args = parser.parse_args(argv)
    try:
        if os.path.exists(args.output) and not args.force:
            raise ValueError(f"{args.output} exists; pass --force to overwrite it")
        robot = Robot.from_urdf(args.robot, base=args.base, tip=args.tip)
        run = read_bag(args.bag, robot, topic=args.topic)
        n = robot.joints
        header = ["t"] + [f"q{j + 1}" for j in range(n)] + [f"tau{j + 1}" for j in range(n)]
        table = np.column_stack([run.t, run.q, run.tau])
        with open(args.output, "w", encoding="utf-8") as f:
            f.write(",".join(header) + "\n")
            np.savetxt(f, table, delimiter=",", fmt="%.17g")
    except ValueError as e:
        print(f"sid.bag2csv: error: {e}", file=sys.stderr)
        return 2
    print(f"{args.output}: {len(run)} samples of {n} joints ({', '.join(robot.joint_names)})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
