"""Writes the Pinocchio references for chain_from_urdf (tests/urdf_test.cpp): for each case, the
chain's link parameters as Pinocchio lumps them (<case>_theta.csv) and its RNEA torques at 20
random states (<case>_rnea.csv). Pinocchio builds the whole URDF, locks every joint off the
chain at the held values (buildReducedModel), and the chain's links then carry what sid's
chain_from_urdf must give them. Needs `pip install pin numpy` (Pinocchio 4.1.0)."""
import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pinocchio as pin

HERE = Path(__file__).resolve().parent
# name, URDF, base link, tip link, held joint values (the others off the chain are held at 0)
CASES = [
    ("arm_tool0", "arm_hand.urdf", "base_link", "tool0", {}),
    ("arm_tool0_held", "arm_hand.urdf", "base_link", "tool0",
     {"sensor_tilt": 0.7, "finger_left": 0.03, "finger_right": 0.01}),
    ("arm_link2_held", "arm_hand.urdf", "base_link", "link2",
     {"sensor_tilt": -0.4, "j3": 0.9, "j4": -0.8, "j5": 2.3, "finger_left": 0.02,
      "finger_right": 0.02}),
    ("mobile_gripper", "mobile_manipulator.urdf", "base_footprint", "gripper_link", {}),
    ("mobile_gripper_held", "mobile_manipulator.urdf", "base_footprint", "gripper_link",
     {"head_pan": 0.5, "head_tilt": -0.3, "l_gripper_finger": 0.04, "r_gripper_finger": 0.01}),
]
STATES = 20


def chain_joints(urdf, base, tip):
    """The moving joints from base to tip, base first, with their types."""
    into = {j.find("child").get("link"): j for j in ET.parse(urdf).getroot().iter("joint")}
    path, link = [], tip
    while link != base:
        joint = into[link]
        if joint.get("type") != "fixed":
            path.append((joint.get("name"), joint.get("type")))
        link = joint.find("parent").get("link")
    return path[::-1]


def configuration(model, values):
    """Pinocchio's q for joint values by name (continuous joints are (cos, sin))."""
    q = pin.neutral(model)
    for name, value in values.items():
        joint = model.joints[model.getJointId(name)]
        if joint.nq == 2:
            q[joint.idx_q:joint.idx_q + 2] = [math.cos(value), math.sin(value)]
        else:
            q[joint.idx_q] = value
    return q


def g(x):
    return repr(float(x))


def main():
    for seed, (case, urdf, base, tip, held) in enumerate(CASES, 1):
        model = pin.buildModelFromUrdf(str(HERE / urdf))
        chain = chain_joints(HERE / urdf, base, tip)
        names = [name for name, _ in chain]
        lock = [i for i in range(1, model.njoints) if model.names[i] not in names]
        reduced = pin.buildReducedModel(model, lock, configuration(model, held))
        assert list(reduced.names)[1:] == names, (list(reduced.names), names)
        data = reduced.createData()
        n = len(names)
        theta = np.concatenate([reduced.inertias[i].toDynamicParameters() for i in range(1, n + 1)])
        comment = (f"# {urdf} from {base} to {tip}, joints {' '.join(names)}; held "
                   + (" ".join(f"{k}={v}" for k, v in held.items()) or "none")
                   + f"; Pinocchio {pin.__version__}")
        (HERE / f"{case}_theta.csv").write_text(
            comment + "\ntheta\n" + "".join(g(v) + "\n" for v in theta))
        rng = np.random.default_rng(seed)
        prismatic = np.array([kind == "prismatic" for _, kind in chain])
        rows = []
        worst = 0.0
        for _ in range(STATES):
            q = np.where(prismatic, rng.uniform(-0.1, 0.4, n), rng.uniform(-math.pi, math.pi, n))
            qd = np.where(prismatic, rng.uniform(-0.5, 0.5, n), rng.uniform(-2, 2, n))
            qdd = np.where(prismatic, rng.uniform(-2, 2, n), rng.uniform(-5, 5, n))
            qp = configuration(reduced, dict(zip(names, q)))
            tau = pin.rnea(reduced, data, qp, qd, qdd)
            y = pin.computeJointTorqueRegressor(reduced, data, qp, qd, qdd)
            worst = max(worst, np.abs(y @ theta - tau).max())
            rows.append(np.concatenate([q, qd, qdd, tau]))
        assert worst < 1e-12, worst  # theta is in the regressor's order
        header = ",".join(f"{s}{j}" for s in ("q", "qd", "qdd", "tau") for j in range(1, n + 1))
        (HERE / f"{case}_rnea.csv").write_text(
            comment + "\n" + header + "\n" + "".join(",".join(g(v) for v in r) + "\n" for r in rows))
        print(f"{case}: {n} joints, max |Y theta - rnea| = {worst:.1e}")


if __name__ == "__main__":
    main()
