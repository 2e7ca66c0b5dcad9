"""sid.read_bag on a real arm's log recorded as ROS bags: the TX40's joints among two finger
joints (listed first, in another order than the robot's), an empty velocity and a second
JointState topic; rosbag2 in MCAP and in sqlite3, and ROS 1."""

import json
import subprocess
import sys

import numpy as np
import pytest

import sid

import tx40

rosbags = pytest.importorskip("rosbags")
from rosbags.rosbag1 import Writer as Writer1  # noqa: E402
from rosbags.rosbag2 import StoragePlugin, Writer  # noqa: E402
from rosbags.typesys import Stores, get_typestore  # noqa: E402

EPOCH_NS = 1_764_000_000 * 1_000_000_000  # stamps of a real recording are since 1970
FINGERS = ["finger_right_joint", "finger_left_joint"]
ORDER = [3, 0, 5, 1, 4, 2]  # the arm's joints as the driver lists them


def joint_states(typestore, t, q, tau, stamp=True, effort=True, velocity=()):
    JointState = typestore.types["sensor_msgs/msg/JointState"]
    Header = typestore.types["std_msgs/msg/Header"]
    Time = typestore.types["builtin_interfaces/msg/Time"]
    names = tx40.robot().joint_names
    ns = EPOCH_NS + round(t * 1e9) if stamp else 0
    header = dict(stamp=Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000), frame_id="")
    if "seq" in Header.__dataclass_fields__:  # ROS 1
        header["seq"] = 0
    return JointState(
        header=Header(**header),
        name=FINGERS + [names[j] for j in ORDER],
        position=np.concatenate([[0.01, 0.02], q[ORDER]]),
        velocity=np.asarray(velocity, dtype=np.float64),
        effort=np.concatenate([[0.5, -0.5], tau[ORDER]]) if effort else np.zeros(0),
    )


def write_bag(path, storage, samples, **kw):
    """A recording of samples on /joint_states, with a gripper's own /gripper/joint_states."""
    typestore = get_typestore(Stores.ROS1_NOETIC if storage == "ros1" else Stores.ROS2_HUMBLE)
    msgtype = "sensor_msgs/msg/JointState"
    if storage == "ros1":
        writer = Writer1(path)
        serialize = typestore.serialize_ros1
    else:
        writer = Writer(path, version=9, storage_plugin=storage)
        serialize = typestore.serialize_cdr
    writer.open()
    arm = writer.add_connection("/joint_states", msgtype, typestore=typestore)
    gripper = writer.add_connection("/gripper/joint_states", msgtype, typestore=typestore)
    t, q, tau = samples
    for i in range(len(t)):
        received = EPOCH_NS + round(t[i] * 1e9) + 250_000
        writer.write(arm, received, serialize(joint_states(typestore, t[i], q[i], tau[i], **kw),
                                              msgtype))
        if i % 10 == 0:
            fingers = joint_states(typestore, t[i], q[i], tau[i])
            fingers.name, fingers.position, fingers.effort = FINGERS, fingers.position[:2], \
                fingers.effort[:2]
            writer.write(gripper, received + 1000, serialize(fingers, msgtype))
    writer.close()
    return path


@pytest.fixture(scope="module")
def samples():
    return tx40.samples()


@pytest.fixture(scope="module")
def csv_fit(tmp_path_factory):
    csv = tx40.write_csv(tmp_path_factory.mktemp("csv") / "tx40.csv")
    return sid.identify(tx40.robot(), sid.Run.from_csv(csv), validate_fraction=0.3)


@pytest.mark.parametrize("storage", [StoragePlugin.MCAP, StoragePlugin.SQLITE3, "ros1"],
                         ids=["mcap", "sqlite3", "ros1"])
def test_reads_the_robots_joints_and_fits_as_from_csv(storage, samples, csv_fit, tmp_path):
    suffix = ".bag" if storage == "ros1" else ""
    bag = write_bag(tmp_path / f"tx40{suffix}", storage, samples)
    run = sid.read_bag(bag, tx40.robot())
    t, q, tau = samples
    np.testing.assert_array_equal(run.q, q)
    np.testing.assert_array_equal(run.tau, tau)
    np.testing.assert_allclose(run.t, t, rtol=0, atol=1e-12)
    fit = sid.identify(tx40.robot(), run, validate_fraction=0.3)
    np.testing.assert_allclose(fit.theta, csv_fit.theta, rtol=1e-4)
    np.testing.assert_allclose(fit.validation[0].relative_residual,
                               csv_fit.validation[0].relative_residual, rtol=1e-4)


def test_bag2csv_gives_the_cli_the_numbers_read_bag_gives_python(samples, cli, tmp_path):
    bag = write_bag(tmp_path / "tx40", StoragePlugin.MCAP, samples)
    csv = tmp_path / "run.csv"
    args = [sys.executable, "-m", "sid.bag2csv", str(bag), "--robot", str(tx40.URDF), "-o",
            str(csv)]
    subprocess.run(args, check=True, capture_output=True)
    again = subprocess.run(args, capture_output=True, text=True)
    assert again.returncode != 0 and "--force" in again.stderr
    out = tmp_path / "fit.json"
    subprocess.run(
        [str(cli), "--robot", str(tx40.URDF), "--transmission", str(tx40.TRANSMISSION),
         "--validate-fraction", "0.3", "--json", str(out), str(csv)],
        check=True, capture_output=True,
    )
    expected = json.loads(out.read_text())
    fit = sid.identify(tx40.robot(), sid.read_bag(bag, tx40.robot()), validate_fraction=0.3)
    got = fit.to_dict()
    assert set(got) == set(expected)
    np.testing.assert_allclose(fit.theta, expected["theta"], rtol=1e-12)
    np.testing.assert_allclose(fit.validation[0].relative_residual,
                               expected["validation"][0]["relative_residual"], rtol=1e-12)


def short(samples, n=50):
    return tuple(x[:n] for x in samples)


def test_uses_the_receive_time_when_no_message_is_stamped(samples, tmp_path):
    bag = write_bag(tmp_path / "unstamped", StoragePlugin.MCAP, short(samples), stamp=False)
    run = sid.read_bag(bag, tx40.robot())
    np.testing.assert_allclose(run.t, samples[0][:50], atol=1e-12)


def test_says_what_the_bag_lacks(samples, tmp_path):
    robot = tx40.robot()
    bag = write_bag(tmp_path / "arm", StoragePlugin.SQLITE3, short(samples))
    with pytest.raises(ValueError, match="no topic '/joint_state'.*/gripper/joint_states"):
        sid.read_bag(bag, robot, topic="/joint_state")
    with pytest.raises(ValueError, match="lacks joint 'joint_1'"):
        sid.read_bag(bag, robot, topic="/gripper/joint_states")
    no_effort = write_bag(tmp_path / "no_effort", StoragePlugin.MCAP, short(samples),
                          effort=False)
    with pytest.raises(ValueError, match="empty effort"):
        sid.read_bag(no_effort, robot)
    with pytest.raises(ValueError, match="no such bag"):
        sid.read_bag(tmp_path / "missing", robot)
    with pytest.raises(ValueError, match="cannot read"):
        (tmp_path / "junk").mkdir()
        sid.read_bag(tmp_path / "junk", robot)
