"""sid.external_torque finds sid_external's contacts with sid_external's numbers, from a sid.Fit
or from sid_identify's JSON file."""

import json
import subprocess

import numpy as np
import pytest

import sid

from conftest import DATA

UR5 = DATA / "urdf" / "real" / "ur5_robot.urdf"
SIM = ["--robot", str(UR5), "--tip", "tool0", "--T", "6", "--Ts", "0.001",
       "--sigma-q2", "1e-12", "--sigma-tau2", "0.01"]


@pytest.fixture
def logs(cli, tmp_path):
    """A log without contact and one pushed twice at the tool, made by sid_simulate."""
    simulate = str(cli.parent / "sid_simulate")
    subprocess.run([simulate, *SIM, "--seed", "1", "-o", str(tmp_path / "fit.csv")],
                   check=True, capture_output=True)
    subprocess.run([simulate, *SIM, "--seed", "2", "--push", "2,2.3,0,30,-20",
                    "--push", "4,4.4,25,0,10", "-o", str(tmp_path / "push.csv")],
                   check=True, capture_output=True)
    return tmp_path


def test_gives_the_clis_contacts_and_torques(cli, logs):
    robot = sid.Robot.from_urdf(UR5, tip="tool0")
    fit = sid.identify(robot, sid.Run.from_csv(logs / "fit.csv"))
    pushed = sid.Run.from_csv(logs / "push.csv")
    ext = sid.external_torque(robot, fit, pushed)
    assert [(c.start, c.end) for c in ext.contacts] == [
        (pytest.approx(2.0, abs=0.03), pytest.approx(2.3, abs=0.05)),
        (pytest.approx(4.0, abs=0.03), pytest.approx(4.4, abs=0.05)),
    ]
    assert ext.tau_ext.shape == (len(pushed), 6) and ext.contact.sum() > 0
    assert ext.beyond_effort_limit == []  # the UR5's drives give 150 N m; the pushes 11

    fit_json = logs / "arm.json"
    subprocess.run([str(cli), "--robot", str(UR5), "--tip", "tool0", "--json", str(fit_json),
                    str(logs / "fit.csv")], check=True, capture_output=True)
    subprocess.run([str(cli.parent / "sid_external"), "--robot", str(UR5), "--tip", "tool0",
                    "--model", str(fit_json), "-o", str(logs / "ext.csv"), "--json",
                    str(logs / "ext.json"), str(logs / "push.csv")],
                   check=True, capture_output=True)
    expected = np.loadtxt(logs / "ext.csv", delimiter=",", comments="#", skiprows=3)
    np.testing.assert_allclose(ext.tau_ext, expected[:, 1:7], rtol=1e-9, atol=1e-9)
    np.testing.assert_array_equal(ext.contact, expected[:, 7] == 1)
    tool = json.loads((logs / "ext.json").read_text())
    assert set(ext.to_dict()) == set(tool)
    assert [(c["start"], c["end"]) for c in ext.to_dict()["contacts"]] == [
        (c["start"], c["end"]) for c in tool["contacts"]]

    from_file = sid.external_torque(robot, fit_json, pushed)
    np.testing.assert_allclose(from_file.tau_ext, ext.tau_ext, rtol=1e-12, atol=1e-12)


def test_bad_input_raises_value_error(cli, logs):
    robot = sid.Robot.from_urdf(UR5, tip="tool0")
    pushed = sid.Run.from_csv(logs / "push.csv")
    fit = sid.identify(robot, sid.Run.from_csv(logs / "fit.csv"))
    with pytest.raises(ValueError, match="--method"):
        sid.external_torque(robot, fit, pushed, method="kalman")
    with pytest.raises(ValueError, match="cannot read"):
        sid.external_torque(robot, logs / "missing.json", pushed)
    (logs / "bad.json").write_text("{")
    with pytest.raises(ValueError, match="not JSON"):
        sid.external_torque(robot, logs / "bad.json", pushed)


def test_payload_is_the_clis(cli, tmp_path):
    """fit.identify_payload gives sid_identify --payload-of's load on a log that carries one."""
    robot = sid.Robot.from_urdf(UR5, tip="tool0")
    simulate = str(cli.parent / "sid_simulate")
    free, loaded = tmp_path / "free.csv", tmp_path / "loaded.csv"
    subprocess.run([simulate, *SIM, "--seed", "1", "-o", str(free)], check=True,
                   capture_output=True)
    # The load: the UR5 with 2 kg more on its last link, off its axes.
    urdf = UR5.read_text().replace("<robot ", "<robot ", 1)
    loaded_urdf = tmp_path / "loaded.urdf"
    payload = ('<link name="load"><inertial><origin xyz="0.03 -0.02 0.08" rpy="0.3 0.2 0.1"/>'
               '<mass value="2.0"/><inertia ixx="0.004" ixy="0" ixz="0" iyy="0.006" iyz="0" '
               'izz="0.008"/></inertial></link><joint name="load_joint" type="fixed">'
               '<parent link="wrist_3_link"/><child link="load"/></joint></robot>')
    loaded_urdf.write_text(urdf.replace("</robot>", payload))
    subprocess.run([simulate, "--robot", str(loaded_urdf), "--tip", "tool0", *SIM[4:], "--seed",
                    "2", "-o", str(loaded)], check=True, capture_output=True)
    fit = sid.identify(robot, sid.Run.from_csv(free))
    load = fit.identify_payload(sid.Run.from_csv(loaded), payload_frame="wrist_3_link")
    assert load.frame == "wrist_3_link"
    assert load.mass == pytest.approx(2.0, rel=0.03)
    np.testing.assert_allclose(load.com, [0.03, -0.02, 0.08], atol=0.005)
    # By default in the tip link's frame: tool0 is 0.0823 m out along wrist_3_link's y, turned
    # by -90 degrees about x, so (x, y, z) there is (x, -z, y - 0.0823) in tool0.
    at_tool = fit.identify_payload(sid.Run.from_csv(loaded))
    assert at_tool.frame == "tool0"
    assert at_tool.mass == pytest.approx(load.mass, rel=1e-6)
    np.testing.assert_allclose(at_tool.com, [load.com[0], -load.com[2], load.com[1] - 0.0823],
                               atol=1e-6)
    with pytest.raises(ValueError, match="is not below wrist_3_link"):
        fit.identify_payload(sid.Run.from_csv(loaded), payload_frame="base_link")

    arm = tmp_path / "arm.json"
    subprocess.run([str(cli), "--robot", str(UR5), "--tip", "tool0", "--json", str(arm),
                    str(free)], check=True, capture_output=True)
    subprocess.run([str(cli), "--robot", str(UR5), "--tip", "tool0", "--payload-of", str(arm),
                    "--payload-frame", "wrist_3_link", "--json", str(tmp_path / "load.json"),
                    str(loaded)], check=True, capture_output=True)
    tool = json.loads((tmp_path / "load.json").read_text())["payload"]
    assert load.mass == pytest.approx(tool["mass"], rel=1e-9)
    np.testing.assert_allclose(load.com, tool["com"], rtol=1e-9, atol=1e-12)
    assert set(load.to_dict()) == set(json.loads((tmp_path / "load.json").read_text()))

    load.write_urdf(tmp_path / "with_load.urdf")
    with pytest.raises(ValueError, match="force"):
        load.write_urdf(tmp_path / "with_load.urdf")
    assert 'name="payload"' in (tmp_path / "with_load.urdf").read_text()
