"""The sensor model of the drive layer (``pkm_measure_joints``): the encoder is on the drive
side of the transmission, so a gap and an elasticity read the effort the transmission carries:
the applied effort less the drive's own friction and rotor-inertia force (MuJoCo's
two-body rails showed the difference), and the gap's side follows that effort, not the velocity."""
import numpy as np
import pytest

from cosim.core import Model, PkmError
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


def test_coulomb_velocity_scale_makes_friction_fade_at_low_speed():
    # rail[3].coulomb_v = 5 mm/s: F tanh(v / 5 mm/s), so 10 % of F at 0.5 mm/s and 76 % at
    # 5 mm/s; the other rails keep the numerical scale drive.v_eps (full F at 1 mm/s).
    F, vc = 0.04, 5e-3
    m = Model("6pus", params={f"rail[{i}].coulomb": F for i in range(1, 7)} | {"rail[3].coulomb_v": vc})
    eps = m.param("drive.v_eps")
    for v in (5e-4, 5e-3, 3e-2, -2e-3):
        f = cc.per_sample(m, "pkm_joint_friction", np.full((1, 6), v))[0]
        np.testing.assert_allclose(f[2], F * np.tanh(v / vc), rtol=1e-12)
        np.testing.assert_allclose(f[[0, 1, 3, 4, 5]], F * np.tanh(v / eps), rtol=1e-12)
    # the inverse dynamics carry it: the effort changes by exactly the friction's change
    x, xd = _state(m)
    base = Model("6pus", params={f"rail[{i}].coulomb": F for i in range(1, 7)})
    qd = m.joint_velocity(x, xd)
    d_tau = m.inverse_dynamics(x, xd, np.zeros(6)) - base.inverse_dynamics(x, xd, np.zeros(6))
    expect = np.zeros(6)
    expect[2] = F * (np.tanh(qd[2] / vc) - np.tanh(qd[2] / eps))
    np.testing.assert_allclose(d_tau, expect, atol=1e-12)


def test_the_batched_readings_and_actuator_efforts_equal_the_per_sample_calls_and_name_a_bad_row():
    m = Model("6pus")
    m.set_params({"rail[2].dead_zone": 0.03, "rail[3].effort_max": 1.0, "rail[1].backlash": 2e-5,
                  "rail[4].compliance": 1e-5, "rail[5].encoder_offset": 1e-5})
    rng = np.random.default_rng(0)
    tau = rng.normal(0, 1, (500, 6))
    x = m.home() + rng.normal(0, 1e-3, (500, 6))
    xd = rng.normal(0, 1e-2, (500, 6))
    per_u = np.array([m.actuator_effort(t) for t in tau])       # one C call per row
    per_q = np.array([m.measure_joints(a, b, t) for a, b, t in zip(x, xd, tau)])
    assert np.array_equal(m.actuator_effort(tau), per_u)          # one batched C call
    assert np.array_equal(m.measure_joints(x, xd, tau), per_q)
    tau[77, 3] = np.nan
    with pytest.raises(PkmError, match=r"sample 77 \(t = 0\.077 s\): commanded effort tau_cmd\[3\] is not finite"):
        m.actuator_effort(tau, times=np.arange(500) * 1e-3, what="sample")
