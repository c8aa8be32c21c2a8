"""Serial arms read from URDF against Pinocchio on the same file.

Oracle: Pinocchio (``pin``), its model built by its own URDF reader
(``pinocchio.buildModelFromUrdf``): ``rnea`` (inverse dynamics), ``crba`` (mass matrix), ``aba``
(forward dynamics), the tool frame's placement and its Jacobian; ``model.armature`` for the
drive layer's rotor inertia.  Arms: the KUKA KR300 R2500 ultra (robots/urdf/kr300_r2500_ultra.urdf,
from the standard DH model of JonasWeigand/Robot_Identification) and the UR5
(robots/urdf/ur5.urdf, from Gepetto/example-robot-data).  Random states within the joint
limits; every quantity within 1e-12 of Pinocchio's, relative to its largest entry."""
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from cosim.core import Model
from cosim.robots.urdf import register_urdf

REPO = Path(__file__).resolve().parents[2]
ARMS = [("kr300_r2500_ultra.urdf", "tool0"), ("ur5.urdf", "tool0")]
TOL = 1e-12


def _rel(a, b):
    return float(np.max(np.abs(np.asarray(a) - b)) / max(np.max(np.abs(b)), 1e-300))


def _arm(file, tip):
    path = str(REPO / "robots" / "urdf" / file)
    m = Model(register_urdf(path, tip=tip, name=Path(file).stem + "_pin"))
    pm = pin.buildModelFromUrdf(path)
    assert pm.nq == m.ndof == 6
    assert [pm.names[i] for i in range(1, pm.njoints)] == list(m.facts.pose_names)
    return m, pm, pm.createData()


def _states(m, n, seed):
    rng = np.random.default_rng(seed)
    lo, hi = m.joint_limits()
    q = lo + (hi - lo) * rng.random((n, m.ndof))
    return q, rng.normal(0, 1.5, (n, m.ndof)), rng.normal(0, 3, (n, m.ndof)), rng.normal(0, 300, (n, m.ndof))


@pytest.mark.parametrize("file,tip", ARMS)
def test_dynamics_match_pinocchio(file, tip):
    m, pm, pd = _arm(file, tip)
    q, v, a, tau = _states(m, 25, 7)
    worst = {"rnea": 0.0, "crba": 0.0, "aba": 0.0}
    for k in range(len(q)):
        worst["rnea"] = max(worst["rnea"], _rel(m.inverse_dynamics(q[k], v[k], a[k]), pin.rnea(pm, pd, q[k], v[k], a[k])))
        M = pin.crba(pm, pd, q[k])
        worst["crba"] = max(worst["crba"], _rel(m.mass_matrix(q[k]), np.triu(M) + np.triu(M, 1).T))
        worst["aba"] = max(worst["aba"], _rel(m.forward_dynamics(q[k], v[k], tau[k]), pin.aba(pm, pd, q[k], v[k], tau[k])))
    assert max(worst.values()) < TOL, worst


def _angles_matrix(r):
    cx, sx, cy, sy, cz, sz = np.cos(r[0]), np.sin(r[0]), np.cos(r[1]), np.sin(r[1]), np.cos(r[2]), np.sin(r[2])
    Rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    Ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    Rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return Rx @ Ry @ Rz


@pytest.mark.parametrize("file,tip", ARMS)
def test_tool_pose_and_jacobian_match_pinocchio(file, tip):
    """platform_pose: the tool frame (position, R = Rx Ry Rz of the angles) and S = dX/dq, whose
    rows are Pinocchio's frame Jacobian (world-aligned): linear rows as they are, angular rows
    through the angle rates' map E (w = E(angles) d(angles)/dt)."""
    m, pm, pd = _arm(file, tip)
    fid = pm.getFrameId(tip)
    q = _states(m, 10, 3)[0]
    for qk in q:
        X, S = m.platform_pose(qk)
        pin.framesForwardKinematics(pm, pd, qk)
        ref = pd.oMf[fid]
        assert _rel(X[:3], ref.translation) < TOL
        assert np.max(np.abs(_angles_matrix(X[3:]) - ref.rotation)) < 1e-13
        J = pin.computeFrameJacobian(pm, pd, qk, fid, pin.LOCAL_WORLD_ALIGNED)
        Rx = _angles_matrix([X[3], 0, 0])
        E = np.column_stack([[1, 0, 0], Rx[:, 1], Rx @ _angles_matrix([0, X[4], 0])[:, 2]])
        assert _rel(S[:3], J[:3]) < TOL
        assert _rel(E @ S[3:], J[3:]) < 1e-11  # through E's solve (cos ry away from 0 here)


def test_rotor_inertia_is_pinocchio_armature():
    """The drive layer's joint[i].rotor_inertia (the KR300's motor inertias Jm G^2 of the same
    model) enters the mass matrix and the forward dynamics as Pinocchio's armature does."""
    m, pm, pd = _arm("kr300_r2500_ultra.urdf", "tool0")
    jm_g2 = np.array([0.00923 * (1798 / 7) ** 2, 0.0118 * (1872 / 7) ** 2, 0.0118 * (757 / 3) ** 2,
                      0.00173 * 221 ** 2, 0.00173 * (5032 / 21) ** 2, 0.00173 * (206793 / 1340) ** 2])
    m.set_params({f"joint[{i + 1}].rotor_inertia": float(j) for i, j in enumerate(jm_g2)})
    pm.armature = jm_g2
    q, v, _, tau = _states(m, 10, 11)
    for k in range(len(q)):
        M = pin.crba(pm, pd, q[k])
        assert _rel(m.mass_matrix(q[k]), np.triu(M) + np.triu(M, 1).T) < TOL
        assert _rel(m.forward_dynamics(q[k], v[k], tau[k]), pin.aba(pm, pd, q[k], v[k], tau[k])) < TOL


MERGED = """<?xml version="1.0"?>
<robot name="merged_arm">
  <link name="base"/>
  <joint name="mount" type="fixed"><parent link="base"/><child link="plate"/>
    <origin xyz="0.1 -0.2 0.3" rpy="0.3 -0.2 0.5"/></joint>
  <link name="plate"><inertial><mass value="7"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
  <joint name="j1" type="continuous"><parent link="plate"/><child link="l1"/>
    <origin xyz="0 0 0.2" rpy="0 0.1 0"/><axis xyz="0 0.6 0.8"/></joint>
  <link name="l1"><inertial><origin xyz="0.1 0.02 0.3" rpy="0.4 0.1 -0.3"/><mass value="3"/>
    <inertia ixx="0.05" ixy="0.004" ixz="-0.003" iyy="0.06" iyz="0.002" izz="0.04"/></inertial></link>
  <joint name="bracket" type="fixed"><parent link="l1"/><child link="motor"/>
    <origin xyz="0.05 0.1 0.4" rpy="-0.7 0.2 1.1"/></joint>
  <link name="motor"><inertial><origin xyz="0.02 -0.01 0.05" rpy="0.2 0.3 0.1"/><mass value="2.2"/>
    <inertia ixx="0.01" ixy="0.001" ixz="0" iyy="0.012" iyz="-0.001" izz="0.008"/></inertial></link>
  <joint name="j2" type="revolute"><parent link="motor"/><child link="l2"/>
    <origin xyz="0.3 0 0.1" rpy="1.2 0 -0.4"/><axis xyz="1 0 0"/><limit lower="-2" upper="2.5" effort="100" velocity="3"/></joint>
  <link name="l2"><inertial><origin xyz="0.2 0.01 0" rpy="0 0 0.2"/><mass value="1.5"/>
    <inertia ixx="0.004" ixy="0" ixz="0" iyy="0.03" iyz="0" izz="0.03"/></inertial></link>
  <joint name="j3" type="revolute"><parent link="l2"/><child link="l3"/>
    <origin xyz="0.4 0 0" rpy="0 0 0"/><axis xyz="0 0 1"/><limit lower="-2" upper="2" effort="100" velocity="3"/></joint>
  <link name="l3"><inertial><origin xyz="0.1 0 0"/><mass value="0.8"/>
    <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.004" iyz="0" izz="0.004"/></inertial></link>
  <joint name="flange" type="fixed"><parent link="l3"/><child link="tip"/><origin xyz="0.2 0 0.05" rpy="0 1.5 0"/></joint>
  <link name="tip"><inertial><mass value="0.3"/><inertia ixx="0.0002" ixy="0" ixz="0" iyy="0.0002" iyz="0" izz="0.0002"/></inertial></link>
</robot>
"""


def test_fixed_joints_merge_as_pinocchio_merges_them(tmp_path):
    """Massive links on fixed joints (with turned inertials) merged into the moving links, a
    continuous joint on a skew axis, a massive tool link: the same dynamics as Pinocchio's."""
    path = tmp_path / "merged_arm.urdf"
    path.write_text(MERGED)
    m = Model(register_urdf(str(path)))
    pm = pin.buildModelFromUrdf(str(path))
    pd = pm.createData()
    assert list(m.facts.pose_names) == ["j1", "j2", "j3"]
    assert np.isnan(m.joint_limits()[0][0])  # continuous: no limit
    assert pm.nq == 4  # Pinocchio's continuous joint is (cos q, sin q)
    rng = np.random.default_rng(5)
    for _ in range(20):
        q = np.array([rng.uniform(-6, 6), rng.uniform(-2, 2.5), rng.uniform(-2, 2)])
        qp = np.array([np.cos(q[0]), np.sin(q[0]), q[1], q[2]])
        v, a, tau = rng.normal(0, 2, 3), rng.normal(0, 4, 3), rng.normal(0, 20, 3)
        assert _rel(m.inverse_dynamics(q, v, a), pin.rnea(pm, pd, qp, v, a)) < TOL
        M = pin.crba(pm, pd, qp)
        assert _rel(m.mass_matrix(q), np.triu(M) + np.triu(M, 1).T) < TOL
        assert _rel(m.forward_dynamics(q, v, tau), pin.aba(pm, pd, qp, v, tau)) < TOL
        pin.framesForwardKinematics(pm, pd, qp)
        assert _rel(m.platform_pose(q)[0][:3], pd.oMf[pm.getFrameId("tip")].translation) < TOL
