"""Writes the Pinocchio references for chain_from_urdf on real robot descriptions
(tests/urdf_test.cpp, RealRobots): the URDFs in real/ are copied unchanged from the PyPI package
example-robot-data 6.0.0 (tests/data/README.md names each file's origin and licence). For each
case, the chain's link parameters as Pinocchio lumps them (real/<case>_theta.csv) and its RNEA
torques at 20 random states (real/<case>_rnea.csv), made exactly as gen_urdf_reference.py makes
those of the hand-written fixtures. Every base is the URDF's root, so Pinocchio's gravity (-9.81
along the root's z) is sid's default in base_link's frame. Deterministic: rerunning gives the
same files. Needs `pip install pin numpy` (Pinocchio 4.1.0)."""
import math
import xml.etree.ElementTree as ET

import numpy as np
import pinocchio as pin

from gen_urdf_reference import HERE, STATES, configuration, g

REAL = HERE / "real"
# name, URDF, base link, tip link, held joint values (the others off the chain are held at 0)
CASES = [
    # 7 axes, the hand and its two prismatic fingers past the tip
    ("panda_link8_held", "panda.urdf", "panda_link0", "panda_link8",
     {"panda_finger_joint1": 0.035, "panda_finger_joint2": 0.01}),
    # a fixed world joint before the first axis, tool frames past the tip
    ("ur5_tool0", "ur5_robot.urdf", "world", "tool0", {}),
    # prismatic torso lift, continuous forearm and wrist rolls; the torso carries the head, the
    # tilting laser and the whole left arm and gripper, all held
    ("pr2_right_held", "pr2.urdf", "base_footprint", "r_gripper_tool_frame",
     {"head_pan_joint": 0.4, "head_tilt_joint": -0.3, "laser_tilt_mount_joint": 0.2,
      "l_shoulder_pan_joint": 0.6, "l_shoulder_lift_joint": 0.3, "l_upper_arm_roll_joint": -0.5,
      "l_elbow_flex_joint": -1.2, "l_forearm_roll_joint": 0.8, "l_wrist_flex_joint": -0.4,
      "l_wrist_roll_joint": 1.5, "r_gripper_l_finger_joint": 0.3,
      "r_gripper_r_finger_joint": 0.3}),
    # a middle link as the tip: the forearm, wrist and gripper past it held
    ("pr2_elbow_held", "pr2.urdf", "base_footprint", "r_elbow_flex_link",
     {"r_forearm_roll_joint": 1.1, "r_wrist_flex_joint": -0.6, "r_wrist_roll_joint": 2.0,
      "l_elbow_flex_joint": -0.7}),
    # dual-arm: the left arm, its prismatic gripper fingers held (the other arm is the base's)
    ("baxter_left_held", "baxter.urdf", "base", "left_gripper",
     {"l_gripper_l_finger_joint": 0.01, "l_gripper_r_finger_joint": -0.01}),
    # humanoid: waist and left arm from the pelvis; the torso carries the head and the right arm
    ("g1_left_hand_held", "g1_29dof_rev_1_0.urdf", "pelvis", "left_rubber_hand",
     {"right_shoulder_pitch_joint": 0.4, "right_shoulder_roll_joint": -0.3,
      "right_elbow_joint": 1.0, "right_wrist_yaw_joint": 0.5}),
    # three continuous joints, fingers fixed past the tip
    ("kinova_end_effector", "kinova.urdf", "base", "j2s6s200_end_effector", {}),
]


def chain_joints(urdf, base, tip):
    """The moving joints from base to tip, base first, with their types (only the <robot>'s own
    <joint>s: a <transmission> names joints in elements of the same name)."""
    into = {j.find("child").get("link"): j for j in ET.parse(urdf).getroot().findall("joint")}
    path, link = [], tip
    while link != base:
        joint = into[link]
        if joint.get("type") != "fixed":
            path.append((joint.get("name"), joint.get("type")))
        link = joint.find("parent").get("link")
    return path[::-1]


def main():
    for seed, (case, urdf, base, tip, held) in enumerate(CASES, 101):
        model = pin.buildModelFromUrdf(str(REAL / urdf))
        chain = chain_joints(REAL / urdf, base, tip)
        names = [name for name, _ in chain]
        lock = [i for i in range(1, model.njoints) if model.names[i] not in names]
        reduced = pin.buildReducedModel(model, lock, configuration(model, held))
        assert list(reduced.names)[1:] == names, (list(reduced.names), names)
        data = reduced.createData()
        pin.framesForwardKinematics(reduced, data, pin.neutral(reduced))
        assert data.oMf[reduced.getFrameId(base, pin.BODY)].isIdentity(), base  # sid's gravity
        n = len(names)
        theta = np.concatenate([reduced.inertias[i].toDynamicParameters() for i in range(1, n + 1)])
        comment = (f"# real/{urdf} from {base} to {tip}, joints {' '.join(names)}; held "
                   + (" ".join(f"{k}={v}" for k, v in held.items()) or "none")
                   + f"; Pinocchio {pin.__version__}")
        (REAL / f"{case}_theta.csv").write_text(
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
        (REAL / f"{case}_rnea.csv").write_text(
            comment + "\n" + header + "\n" + "".join(",".join(g(v) for v in r) + "\n" for r in rows))
        kinds = " ".join(kind for _, kind in chain)
        print(f"{case}: {n} joints ({kinds}), max |theta| {np.abs(theta).max():.3g}, "
              f"max |tau| {max(np.abs(r[3 * n:]).max() for r in rows):.3g}, "
              f"max |Y theta - rnea| = {worst:.1e}")


if __name__ == "__main__":
    main()
