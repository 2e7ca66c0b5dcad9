"""Writes tx40.urdf: the TX40 of the n-joint reference set (params.md's modified DH table and
link inertias about the centre of mass) as URDF, with a fixed base plate, a fixed tool flange
and a camera off the path. Standard library only."""
import math
from pathlib import Path

HALF_PI = 1.5707963267948966
TABLE = [(0, 0, 0), (-HALF_PI, 0, 0), (0, 0.225, 0.035), (HALF_PI, 0, 0.225), (-HALF_PI, 0, 0),
         (HALF_PI, 0, 0)]  # Khalil's alpha_j, d_j, r_j
LINKS = [  # mass, centre of mass, (Ixx, Iyy, Izz, Ixy, Iyz, Ixz) about it, link axes
    (10.5, (0, 0.02, -0.043), (0.055, 0.047, 0.035, 0, 0.003, 0)),
    (3.6, (0.109, -0.002, 0.134), (0.038, 0.009, 0.04, 0, -0.002, 0)),
    (4.07, (0.008, 0.006, 0.041), (0.012, 0.012, 0.004, 0, -0.001, -0.001)),
    (3.62, (-0.004, 0.002, -0.107), (0.014, 0.013, 0.004, 0, 0, -0.001)),
    (1.02, (-0.004, -0.003, -0.001), (0.001, 0.001, 0.001, 0, 0, 0)),
    (0.2, (0, 0, 0.042), (8e-05, 8e-05, 0.00016, 0, 0, 0))]


def g(x):
    return repr(float(x)) if x != 0 else "0"


out = ['<?xml version="1.0"?>',
       '<!-- The TX40 of the n-joint reference set written as URDF: joint frames placed in their',
       "     parents' frames (Khalil's modified DH rows alpha, d, r as rpy = (alpha, 0, 0) and",
       '     xyz = (d, -sin(alpha) r, cos(alpha) r)), inertias about the centre of mass in link axes.',
       '     A base plate, a tool flange and a camera off the path are there to be ignored or folded. -->',
       '<robot name="tx40_test">', '  <link name="base_link">',
       '    <inertial><mass value="20"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>',
       '  </link>',
       '  <joint name="base_plate" type="fixed"><parent link="base_link"/><child link="link0"/><origin xyz="0 0 0.32"/></joint>',
       '  <link name="link0"/>']
parent = "link0"
for j, ((alpha, d, r), (m, c, inertia)) in enumerate(zip(TABLE, LINKS), 1):
    xyz = [d, -math.sin(alpha) * r, math.cos(alpha) * r]
    xyz = [0.0 if abs(v) < 1e-12 else v for v in xyz]
    kind = "continuous" if j == 6 else "revolute"
    limit = '' if kind == "continuous" else '<limit lower="-3" upper="3" effort="100" velocity="5"/>'
    ixx, iyy, izz, ixy, iyz, ixz = inertia
    out += [f'  <joint name="j{j}" type="{kind}">',
            f'    <parent link="{parent}"/><child link="link{j}"/>',
            f'    <origin xyz="{g(xyz[0])} {g(xyz[1])} {g(xyz[2])}" rpy="{g(alpha)} 0 0"/>',
            f'    <axis xyz="0 0 1"/>{limit}', '  </joint>', f'  <link name="link{j}">', '    <inertial>',
            f'      <origin xyz="{g(c[0])} {g(c[1])} {g(c[2])}" rpy="0 0 0"/>',
            f'      <mass value="{g(m)}"/>',
            f'      <inertia ixx="{g(ixx)}" ixy="{g(ixy)}" ixz="{g(ixz)}" iyy="{g(iyy)}" iyz="{g(iyz)}" izz="{g(izz)}"/>',
            '    </inertial>', '  </link>']
    parent = f"link{j}"
out += ['  <joint name="flange" type="fixed"><parent link="link6"/><child link="tool0"/><origin xyz="0 0 0.065"/></joint>',
        '  <link name="tool0"/>',
        '  <joint name="camera_mount" type="fixed"><parent link="link3"/><child link="camera"/><origin xyz="0.05 0 0.1"/></joint>',
        '  <link name="camera"><inertial><mass value="0.3"/><inertia ixx="1e-4" ixy="0" ixz="0" iyy="1e-4" iyz="0" izz="1e-4"/></inertial></link>',
        '</robot>']
(Path(__file__).resolve().parent / "tx40.urdf").write_text("\n".join(out) + "\n")
