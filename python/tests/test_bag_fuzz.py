"""sid.read_bag on damaged bags: a few hundred seeded mutations of small rosbag2 recordings in
MCAP and in sqlite3 (flipped bytes, truncations, inserted and deleted runs, zeroed ranges, a
damaged file header or sqlite page header). Each one reads as a sid.Run or fails with a
ValueError that names the file and says why; nothing else escapes."""

import random
import shutil

import numpy as np
import pytest

import sid
import sid.bag

import tx40

rosbags = pytest.importorskip("rosbags")
from rosbags.highlevel import AnyReader  # noqa: E402
from rosbags.rosbag2 import ReaderError, StoragePlugin, Writer  # noqa: E402
from rosbags.typesys import Stores, get_typestore  # noqa: E402

SEED = 20240611
MUTATIONS = 160  # per format
MESSAGES = 12
EPOCH_NS = 1_764_000_000 * 1_000_000_000
SQLITE_PAGE = 4096  # sqlite's default page size, which rosbags' writer keeps


def write_bag(path, storage, joints):
    """A short recording: the arm on /joint_states, a gripper on another JointState topic."""
    typestore = get_typestore(Stores.ROS2_HUMBLE)
    msgtype = "sensor_msgs/msg/JointState"
    JointState = typestore.types[msgtype]
    Header = typestore.types["std_msgs/msg/Header"]
    Time = typestore.types["builtin_interfaces/msg/Time"]
    writer = Writer(path, version=9, storage_plugin=storage)
    writer.open()
    arm = writer.add_connection("/joint_states", msgtype, typestore=typestore)
    gripper = writer.add_connection("/gripper/joint_states", msgtype, typestore=typestore)
    for i in range(MESSAGES):
        ns = EPOCH_NS + i * 1_000_000
        header = Header(stamp=Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000),
                        frame_id="")
        q = 0.1 * np.arange(len(joints)) + 0.01 * i
        msg = JointState(header=header, name=list(joints), position=q,
                         velocity=np.zeros(0), effort=-q)
        writer.write(arm, ns + 250_000, typestore.serialize_cdr(msg, msgtype))
        if i % 4 == 0:
            fingers = JointState(header=header, name=["finger"], position=np.zeros(1),
                                 velocity=np.zeros(0), effort=np.zeros(1))
            writer.write(gripper, ns + 260_000, typestore.serialize_cdr(fingers, msgtype))
    writer.close()
    return path


def mutate(data, rng, page=None):
    """data damaged one way, and that way in words; page: the file is sqlite's, in pages."""
    size = len(data)
    out = bytearray(data)
    kind = rng.choice(["flip", "flip", "truncate", "insert", "delete", "zero", "header",
                       "page" if page else "flip"])
    if kind == "flip":
        spots = [rng.randrange(size) for _ in range(rng.randint(1, 4))]
        for at in spots:
            out[at] ^= rng.randint(1, 255)
        return bytes(out), f"flip at {spots}"
    if kind == "truncate":
        at = rng.randrange(size)
        return bytes(out[:at]), f"truncate to {at}"
    if kind == "insert":
        at, n = rng.randrange(size + 1), rng.randint(1, 64)
        return bytes(out[:at] + rng.randbytes(n) + out[at:]), f"insert {n} at {at}"
    if kind == "delete":
        at, n = rng.randrange(size), rng.randint(1, 64)
        return bytes(out[:at] + out[at + n:]), f"delete {n} at {at}"
    if kind == "zero":
        at, n = rng.randrange(size), rng.randint(1, 256)
        out[at:at + n] = bytes(len(out[at:at + n]))
        return bytes(out), f"zero {n} at {at}"
    # The first 100 bytes hold MCAP's magic and header record, or sqlite's database header;
    # a page's first 12 bytes say what the page is.
    start = 0 if kind == "header" else page * rng.randrange(max(1, size // page))
    first = 100 if kind == "header" or start == 0 else 12
    spots = [start + rng.randrange(first) for _ in range(rng.randint(1, 3))]
    for at in spots:
        out[at] = rng.choice([0, 0xFF, out[at] ^ 0xFF, rng.getrandbits(8)])
    return bytes(out), f"{kind} damage at {spots}"


@pytest.mark.parametrize("storage", [StoragePlugin.MCAP, StoragePlugin.SQLITE3],
                         ids=["mcap", "sqlite3"])
def test_a_damaged_bag_reads_as_a_run_or_says_why_it_cannot(storage, tmp_path):
    robot = tx40.robot()
    joints = robot.joint_names
    bag = write_bag(tmp_path / "good", storage, joints)
    (data_file,) = [p for p in bag.iterdir() if p.suffix in {".mcap", ".db3"}]
    assert len(sid.read_bag(data_file, robot)) == MESSAGES
    data = data_file.read_bytes()
    rng = random.Random(f"{SEED}-{storage.name}")
    page = SQLITE_PAGE if storage == StoragePlugin.SQLITE3 else None
    runs, errors = 0, 0
    for i in range(MUTATIONS):
        damaged, how = mutate(data, rng, page)
        copy = tmp_path / f"m{i:03d}"
        copy.mkdir()
        shutil.copy(bag / "metadata.yaml", copy)
        path = copy / data_file.name
        path.write_bytes(damaged)
        try:
            run = sid.read_bag(path, robot)
        except ValueError as e:
            errors += 1
            message = str(e)
            assert str(path) in message, f"{how}: {message}"
            said = message.split(str(path), 1)[1].strip(" :")
            assert said and "()" not in message, f"{how}: {message!r}"
            continue
        runs += 1
        assert isinstance(run, sid.Run), how
        assert 0 < len(run) and run.q.shape == run.tau.shape == (len(run), len(joints)), how
        assert np.all(np.diff(run.t) >= 0), how
    print(f"{storage.name}: {MUTATIONS} damaged files, {runs} read as runs, {errors} ValueErrors")
    assert errors > 0  # the mutations do reach what rosbags parses


@pytest.mark.parametrize("failure", [KeyboardInterrupt, MemoryError])
def test_an_interrupt_or_a_machine_short_of_memory_is_not_called_a_bad_bag(failure, tmp_path,
                                                                           monkeypatch):
    robot = tx40.robot()
    bag = write_bag(tmp_path / "good", StoragePlugin.MCAP, robot.joint_names)

    def fail(*args, **kwargs):
        raise failure()
        yield  # a generator, as the method it stands in for

    monkeypatch.setattr(AnyReader, "messages", fail)
    monkeypatch.setattr(sid.bag, "_room_for", lambda bag: False)
    with pytest.raises(failure):
        sid.read_bag(bag, robot)


def test_an_error_without_words_is_given_some(tmp_path, monkeypatch):
    robot = tx40.robot()
    bag = write_bag(tmp_path / "good", StoragePlugin.MCAP, robot.joint_names)

    def fail(*args, **kwargs):
        raise ReaderError()
        yield  # a generator, as the method it stands in for

    monkeypatch.setattr(AnyReader, "messages", fail)
    with pytest.raises(ValueError, match=r"good: cannot read the messages on '/joint_states': "
                       r"the file is truncated or corrupt \(ReaderError\)$") as raised:
        sid.read_bag(bag, robot)
    assert isinstance(raised.value.__cause__, ReaderError)
