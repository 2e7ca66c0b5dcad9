"""ROS bags: a robot's sensor_msgs/JointState recording as a sid.Run.

Reads rosbag2 recordings (MCAP or sqlite3) and ROS 1 bags through the ``rosbags`` package (pure
Python, no ROS install): ``pip install "sid[bags]"``.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Optional, Union

import numpy as np

from ._core import Robot, Run, _as_robot

PathLike = Union[str, "os.PathLike[str]"]

_JOINT_STATE = {"sensor_msgs/msg/JointState", "sensor_msgs/JointState"}


def _rosbags() -> Any:
    try:
        from rosbags.highlevel import AnyReader
        from rosbags.typesys import Stores, get_typestore
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError(
            "reading bags needs the rosbags package: pip install rosbags (or sid[bags])"
        ) from e
    return AnyReader, Stores, get_typestore


def read_bag(
    path: PathLike,
    robot: Robot,
    topic: str = "/joint_states",
    name: Optional[str] = None,
) -> Run:
    """The robot's joints from a bag's sensor_msgs/JointState topic, as a sid.Run.

    path: a rosbag2 directory (or its .mcap / .db3 file) or a ROS 1 .bag file. Times are the
    messages' header stamps, or the times the recorder received them when no message is stamped;
    the robot's joints are picked by name from messages that may carry other joints too (in any
    order); position gives q and effort gives tau. t counts from the first message [s] (taken in
    integer nanoseconds, so nothing is lost to the epoch's size). Raises ValueError naming the
    topic, joint or message at fault.
    """
    AnyReader, Stores, get_typestore = _rosbags()
    _as_robot(robot)
    bag = Path(os.fspath(path))
    if not bag.exists():
        raise ValueError(f"{bag}: no such bag")
    if bag.is_file() and bag.suffix in {".mcap", ".db3"}:
        bag = bag.parent
    label = name or str(path)
    joints = robot.joint_names
    stamps: list[int] = []  # [ns], integers until the first is subtracted: no rounding
    receipts: list[int] = []
    q: list[list[float]] = []
    tau: list[list[float]] = []
    try:
        reader_context = AnyReader([bag], default_typestore=get_typestore(Stores.LATEST))
        reader_context.open()
    except Exception as e:  # rosbags raises its own errors for unreadable bags
        raise ValueError(f"{bag}: cannot read the bag ({e})") from e
    try:
        reader = reader_context
        topics = sorted({c.topic for c in reader.connections})
        connections = [c for c in reader.connections if c.topic == topic]
        if not connections:
            raise ValueError(
                f"{label}: no topic '{topic}'; the bag's topics are: {', '.join(topics) or 'none'}"
            )
        for c in connections:
            if c.msgtype not in _JOINT_STATE:
                raise ValueError(
                    f"{label}: topic '{topic}' carries {c.msgtype}, not sensor_msgs/JointState"
                )
        for index, (connection, received, raw) in enumerate(
            reader.messages(connections=connections)
        ):
            msg = reader.deserialize(raw, connection.msgtype)
            where = f"{label}: message {index + 1} on '{topic}'"
            names = list(msg.name)
            position = np.asarray(msg.position, dtype=np.float64)
            effort = np.asarray(msg.effort, dtype=np.float64)
            if len(effort) == 0:
                raise ValueError(f"{where} has an empty effort: the bag has no torques")
            if len(position) != len(names) or len(effort) != len(names):
                raise ValueError(
                    f"{where} has {len(names)} names, {len(position)} positions and "
                    f"{len(effort)} efforts"
                )
            slot = {n: i for i, n in enumerate(names)}
            missing = [j for j in joints if j not in slot]
            if missing:
                raise ValueError(
                    f"{where} lacks joint '{missing[0]}' the robot needs; it has: "
                    f"{', '.join(names)}"
                )
            picked = [slot[j] for j in joints]
            stamp = msg.header.stamp
            stamps.append(int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec))
            receipts.append(int(received))
            q.append(position[picked].tolist())
            tau.append(effort[picked].tolist())
    finally:
        reader_context.close()
    if not stamps:
        raise ValueError(f"{label}: topic '{topic}' has no messages")
    unstamped = [i for i, ns in enumerate(stamps) if ns == 0]
    if len(unstamped) == len(stamps):
        stamps = receipts  # a publisher that leaves the header empty: the recorder's clock
    elif unstamped:
        raise ValueError(
            f"{label}: message {unstamped[0] + 1} on '{topic}' has a zero header stamp and others "
            "do not: its time is unknown on their clock"
        )
    first = min(stamps)
    t = np.asarray([1e-9 * (ns - first) for ns in stamps])
    order = np.argsort(t, kind="stable")
    t, qa, taua = t[order], np.asarray(q)[order], np.asarray(tau)[order]
    # A message recorded twice (two recorders, a replayed bag) is kept once; two different
    # samples at one time are an error the identification reports.
    keep = np.ones(len(t), dtype=bool)
    keep[1:] = ~(
        (t[1:] == t[:-1])
        & np.all(qa[1:] == qa[:-1], axis=1)
        & np.all(taua[1:] == taua[:-1], axis=1)
    )
    return Run(t[keep], qa[keep], taua[keep], name=label)
