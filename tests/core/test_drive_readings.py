"""The sensor model of the drive layer (``pkm_measure_joints``): the encoder is on the drive
side of the transmission, so a gap and an elasticity read the effort the transmission carries:
the applied effort less the drive's own friction and rotor-inertia force (issue 12: MuJoCo's
two-body rails showed the difference), and the gap's side follows that effort, not the velocity."""
import numpy as np

from cosim.core import Model
from cosim.discrepancy import _corecalls as cc


def _state(m):
    x = m.home() + np.array([0.002, -0.001, 0.004, 0.01, -0.02, 0.015])
    xd = np.array([0.05, -0.02, 0.03, 0.2, -0.1, 0.3])
    return x, xd


def test_elasticity_deflects_by_the_carried_effort():
    c, jr, visc = 8e-5, 0.05, 0.6
    m = Model("6pus", params={"rail[2].compliance": c, "rail[2].rotor_inertia": jr, "rail[2].viscous": visc})
    x, xd = _state(m)
    tau = m.gravity_load(x) + np.array([0.1, 0.3, -0.2, 0.05, 0.0, -0.1])
    q_meas = cc.measure_joints(m, x[None], xd[None], tau[None])[0]
    xdd = m.forward_dynamics(x, xd, tau)
    qd = m.joint_velocity(x, xd)
    qdd = m.joint_acceleration(x, xd, xdd)
    carried = tau[1] - visc * qd[1] - jr * qdd[1]
    assert abs(jr * qdd[1]) > 0.01 and abs(visc * qd[1]) > 0.005      # both shares matter here
    dq = q_meas - m.ik(x)
    np.testing.assert_allclose(dq[1], c * carried, rtol=1e-9, atol=1e-15)
    np.testing.assert_array_equal(dq[[0, 2, 3, 4, 5]], 0.0)


def test_the_gap_side_follows_the_effort_not_the_velocity():
    b = 6e-5
    m = Model("6pus", params={"rail[1].backlash": b})
    x, _ = _state(m)
    qd = np.zeros(6)
    for effort_sign in (1.0, -1.0):
        for velocity_sign in (1.0, -1.0):
            qd[0] = velocity_sign * 0.05
            xd = np.linalg.solve(m.jacobians(x)[2], qd)
            tau = np.full(6, effort_sign * 0.5)
            dq = cc.measure_joints(m, x[None], xd[None], tau[None])[0] - m.ik(x)
            assert abs(dq[0] - effort_sign * b / 2) < 1e-12, dq
