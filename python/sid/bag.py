"""ROS bags: a robot's sensor_msgs/JointState recording as a sid.Run.

Reads rosbag2 recordings (MCAP or sqlite3) and ROS 1 bags through the ``rosbags`` package (pure
Python, no ROS install): ``pip install "sid[bags]"``.
"""

from __future__ import annotations

import os
import sqlite3
from contextlib import contextmanager, suppress
from pathlib import Path
from typing import Any, Iterable, Iterator, Optional, Union

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


def _cause(e: Exception) -> str:
    """Why a bag could not be read, in words and never empty: rosbags, sqlite and the OS say it
    themselves; anything else (struct, int, dict, bytes decoding) is Python tripping over bytes
    that are not what the format says, i.e. a damaged file."""
    kind = type(e).__name__
    if kind == "error":  # struct.error, zlib.error: the module is the useful part
        kind = f"{type(e).__module__}.error"
    text = str(e).strip()
    told = type(e).__module__.startswith("rosbags") or isinstance(e, (sqlite3.Error, OSError))
    if told and text:
        return text
    if text:
        return f"the file is truncated or corrupt ({kind}: {text})"
    return f"the file is truncated or corrupt ({kind})"


def _room_for(bag: Path) -> bool:
    """Whether memory for all of the bag's bytes can still be had. After a MemoryError it can
    only when the failed request was for more than any record of the bag could hold: a size read
    from damaged bytes, not a machine short of memory."""
    try:
        files = [bag] if bag.is_file() else [p for p in bag.iterdir() if p.is_file()]
        size = sum(p.stat().st_size for p in files)
        bytes(size)  # calloc'ed: the pages are reserved, never touched
    except (OSError, MemoryError):
        return False
    return True


@contextmanager
def _unreadable(source: str, bag: Path, what: str) -> Iterator[None]:
    """Turns a failure of rosbags or of the bytes it decodes into a ValueError naming the file.

    A corrupt file fails in many ways below rosbags' own errors (struct, overflow, index, key,
    unicode, attribute errors); the caller should see one kind. A MemoryError is passed on when
    the machine is really short of memory.
    """
    try:
        yield
    except MemoryError as e:
        if not _room_for(bag):
            raise
        raise ValueError(
            f"{source}: cannot read {what}: the file is truncated or corrupt (a record claims "
            "more memory than the machine has: MemoryError)"
        ) from e
    except Exception as e:
        raise ValueError(f"{source}: cannot read {what}: {_cause(e)}") from e


def _guarded(items: Iterable[Any], source: str, bag: Path, what: str) -> Iterator[Any]:
    """items, with a failure while producing the next one (a damaged chunk, a truncated record)
    raised as _unreadable says, but not failures of the loop that consumes them."""
    end = object()
    with _unreadable(source, bag, what):
        it = iter(items)
    while True:
        with _unreadable(source, bag, what):
            item = next(it, end)
        if item is end:
            return
        yield item


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
    topic, joint or message at fault, or naming path and the cause when the file cannot be read
    (damaged, truncated, not a bag).
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
    source = os.fspath(path)
    with _unreadable(source, bag, "the bag"):
        reader = AnyReader([bag], default_typestore=get_typestore(Stores.LATEST))
        reader.open()
    try:
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
        messages = _guarded(
            reader.messages(connections=connections), source, bag, f"the messages on '{topic}'"
        )
        for index, (connection, received, raw) in enumerate(messages):
            where = f"{label}: message {index + 1} on '{topic}'"
            # A damaged message, or a damaged definition of its type, decodes into fields of the
            # wrong kind or none at all: that too is the file's fault.
            with _unreadable(source, bag, f"message {index + 1} on '{topic}'"):
                msg = reader.deserialize(raw, connection.msgtype)
                names = [str(n) for n in msg.name]
                position = np.asarray(msg.position, dtype=np.float64).reshape(-1)
                effort = np.asarray(msg.effort, dtype=np.float64).reshape(-1)
                stamp = int(msg.header.stamp.sec) * 1_000_000_000 + int(msg.header.stamp.nanosec)
                receipt = int(received)
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
            stamps.append(stamp)
            receipts.append(receipt)
            q.append(position[picked].tolist())
            tau.append(effort[picked].tolist())
    except BaseException:
        with suppress(Exception):  # the first failure is the one to report
            reader.close()
        raise
    with _unreadable(source, bag, "the bag"):
        reader.close()
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
