"""Writes robots/urdf/kr300_r2500_ultra.urdf from the KUKA KR300 R2500 ultra model of
J. Weigand's Robot_Identification (GitHub JonasWeigand/Robot_Identification, MIT licence,
robot_model/model_KUKA_Quantec_Ultra_KR300.m, 2021): standard Denavit-Hartenberg parameters
(Corke's Robotics Toolbox convention, frame i = frame i-1 Rz(q_i + offset_i) Tz(d_i) Tx(a_i)
Rx(alpha_i)), base Rx(180 deg), tool Ry(-90 deg), link masses, centres of mass and inertias
about them in frame i ([Ixx, Iyy, Izz, Ixy, Iyz, Ixz] there).  Link 6 is the axis-6 body
alone (17.78 kg at -50 mm; the model adds its payload to it): the model gives it no inertia,
so this file gives it a uniform cylinder's of radius 0.125 m and height 0.1 m (an assumption,
stated in the file).  Run: python scripts/kr300_urdf.py > robots/urdf/kr300_r2500_ultra.urdf
"""
import math

import numpy as np

DEG = math.pi / 180
# d, a, alpha, offset [m, rad]; I [kg m2] as [Ixx, Iyy, Izz, Ixy, Iyz, Ixz]; r [m]; m [kg]; qlim [deg]
LINKS = [
    (-0.675, 0.350, math.pi / 2, 0, [16733765, 29799119, 32814954, -1703664, 129384, 4404062], [-353, 174, -4], 395.40, (-147, 147)),
    (-0.189, 1.15, 0, 0, [7507819, 88886691, 88673761, 430046, 173157, -4396607], [-709, -1, 23], 339.12, (-140, -5)),
    (0.189, 0.041, -math.pi / 2, 90 * DEG, [10783798, 10186135, 1943179, 118474, -606384, -101950], [-18, -18, -76], 105.21, (-112, 153)),
    (-1, 0, math.pi / 2, 0, [425035, 217993, 428465, -4, -11353, -27], [0, 236, 1], 35.80, (-350, 350)),
    (0, 0, -math.pi / 2, 0, [283826, 229562, 258266, -4, -19521, -120], [0, -80, -9], 31.46, (-122.5, 122.5)),
    (-0.24, 0, math.pi, 0, None, [0, 0, -50], 17.78, (-350, 350)),
]


def rot(axis, t):
    c, s = math.cos(t), math.sin(t)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    R = np.eye(3)
    R[i, i], R[i, j], R[j, i], R[j, j] = c, -s, s, c
    return R


def rpy(R):
    return (math.atan2(R[2, 1], R[2, 2]), math.atan2(-R[2, 0], math.hypot(R[0, 0], R[1, 0])), math.atan2(R[1, 0], R[0, 0]))


def f(v):
    return " ".join(repr(float(x)) for x in v)


def main():
    out = ['<?xml version="1.0"?>',
           "<!-- KUKA KR300 R2500 ultra, written by scripts/kr300_urdf.py from the standard DH model of",
           "     JonasWeigand/Robot_Identification (MIT licence), robot_model/model_KUKA_Quantec_Ultra_KR300.m:",
           "     kinematics, masses, centres of mass and inertias as given there; link 6 is the axis-6 body",
           "     without payload, its inertia a uniform cylinder's (r 0.125 m, h 0.1 m: an assumption, the",
           "     model gives none).  Motor inertias, gears and friction are the drive layer's (not URDF). -->",
           '<robot name="kr300_r2500_ultra">', '  <link name="base"/>']
    parent, pre = "base", rot(0, math.pi)  # base Rx(180 deg), then joint 1
    pre_p = np.zeros(3)
    for i, (d, a, alpha, off, I, r, m, lim) in enumerate(LINKS, 1):
        R0 = pre @ rot(2, off)
        out += [f'  <joint name="a{i}" type="revolute">', f'    <parent link="{parent}"/>', f'    <child link="link{i}"/>',
                f'    <origin xyz="{f(pre_p)}" rpy="{f(rpy(R0))}"/>', '    <axis xyz="0 0 1"/>',
                f'    <limit lower="{lim[0] * DEG!r}" upper="{lim[1] * DEG!r}" effort="0" velocity="0"/>', "  </joint>"]
        # Frame i in the joint's moved frame: Tz(d) Tx(a) Rx(alpha).
        p_f, R_f = np.array([a, 0.0, d]), rot(0, alpha)
        c = p_f + R_f @ (np.array(r) * 1e-3)
        if I is None:
            rc, h = 0.125, 0.1
            Ixx = Iyy = m * (3 * rc * rc + h * h) / 12
            Iv = dict(ixx=Ixx, iyy=Iyy, izz=m * rc * rc / 2, ixy=0.0, iyz=0.0, ixz=0.0)
        else:
            Iv = dict(zip(("ixx", "iyy", "izz", "ixy", "iyz", "ixz"), (x * 1e-6 for x in I)))
        attrs = " ".join(f'{k}="{Iv[k]!r}"' for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz"))
        out += [f'  <link name="link{i}">', "    <inertial>", f'      <origin xyz="{f(c)}" rpy="{f(rpy(R_f))}"/>',
                f'      <mass value="{m!r}"/>', f"      <inertia {attrs}/>", "    </inertial>", "  </link>"]
        parent, pre, pre_p = f"link{i}", R_f, p_f
    out += ['  <joint name="flange" type="fixed">', '    <parent link="link6"/>', '    <child link="tool0"/>',
            f'    <origin xyz="{f(pre_p)}" rpy="{f(rpy(pre @ rot(1, -math.pi / 2)))}"/>', "  </joint>",
            '  <link name="tool0"/>', "</robot>"]
    print("\n".join(out))


if __name__ == "__main__":
    main()
