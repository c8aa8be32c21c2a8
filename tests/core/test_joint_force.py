"""The drive layer's generic joint force (``<j>[i].force_*``, joint_force.hpp; its constant is
the drive's ``<j>[i].offset``): the term the discovery step of the discrepancy engine fits.
Checked against the formula written here from the joint positions and rates (inverse kinematics of the pose, and of a pose a small
step along the velocity), in the inverse dynamics, the forward dynamics and on a described
robot with rotary joints."""
import math

import numpy as np
import pytest

from cosim.core import Model

COEF = {"offset": 0.3, "force_qc": 0.25, "force_k1": -230.0, "force_k2": 40.0, "force_k3": -900.0,
        "force_v2": 2.5, "force_vpos": 0.7, "force_vneg": 0.2, "force_cpos": 0.05, "force_cneg": 0.11,
        "force_sin": 0.32, "force_cos": -0.1, "force_period": 0.01, "force_step": 0.04, "force_step_q": 0.26,
        "force_step_w": 0.002}


def _expected(q, qd, v_eps):
    c = COEF
    z = q - c["force_qc"]
    s = math.tanh(qd / v_eps)
    a = 2 * math.pi * q / c["force_period"]
    return (c["offset"] + c["force_k1"] * z + c["force_k2"] * z**2 + c["force_k3"] * z**3
            + c["force_v2"] * qd * abs(qd) + c["force_vpos"] * max(qd, 0) + c["force_vneg"] * min(qd, 0)
            + c["force_cpos"] * max(s, 0) + c["force_cneg"] * min(s, 0)
            + c["force_sin"] * math.sin(a) + c["force_cos"] * math.cos(a)
            + c["force_step"] * math.tanh((q - c["force_step_q"]) / c["force_step_w"]))


def _state(m):
    x = m.home() + np.array([0.002, -0.001, 0.004, 0.01, -0.02, 0.015])
    xd = np.array([0.05, -0.02, 0.03, 0.2, -0.1, 0.3])
    return x, xd


def _joint_rates(m, x, xd, h=1e-7):
    return (m.ik(x + h * xd) - m.ik(x - h * xd)) / (2 * h)


@pytest.mark.parametrize("joint", [1, 4])
def test_inverse_dynamics_adds_the_force_on_its_joint_only(joint):
    nominal = Model("6pus")
    m = Model("6pus", params={f"rail[{joint}].{k}": v for k, v in COEF.items()})
    x, xd = _state(m)
    xdd = np.array([0.3, -0.2, 0.1, 1.0, 0.5, -0.7])
    dtau = m.inverse_dynamics(x, xd, xdd) - nominal.inverse_dynamics(x, xd, xdd)
    q, qd = m.ik(x), _joint_rates(m, x, xd)
    want = _expected(q[joint - 1], qd[joint - 1], m.params()["drive.v_eps"])
    assert abs(want) > 0.05
    np.testing.assert_allclose(dtau[joint - 1], want, rtol=1e-6)
    np.testing.assert_allclose(np.delete(dtau, joint - 1), 0.0, atol=1e-12)


def test_forward_dynamics_is_driven_by_the_effort_less_the_force():
    nominal = Model("6pus")
    m = Model("6pus", params={f"rail[3].{k}": v for k, v in COEF.items()})
    x, xd = _state(m)
    tau = nominal.gravity_load(x) + np.array([0.1, -0.2, 0.3, 0.0, 0.1, -0.1])
    q, qd = m.ik(x), _joint_rates(m, x, xd)
    f = np.zeros(6)
    f[2] = _expected(q[2], qd[2], m.params()["drive.v_eps"])
    np.testing.assert_allclose(m.forward_dynamics(x, xd, tau), nominal.forward_dynamics(x, xd, tau - f),
                               rtol=1e-9, atol=1e-9)


def test_shape_parameters_alone_are_no_force():
    nominal = Model("6pus")
    m = Model("6pus", params={"rail[2].force_qc": 0.3, "rail[2].force_period": 0.01, "rail[2].force_step_w": 0.01})
    x, xd = _state(m)
    xdd = np.zeros(6)
    np.testing.assert_array_equal(m.inverse_dynamics(x, xd, xdd), nominal.inverse_dynamics(x, xd, xdd))


def test_parameters_are_in_the_table_with_units_and_bounds():
    info = {p.name: p for p in Model("quattro").param_info()}
    assert info["joint[2].force_k1"].unit == "N m/rad"
    assert info["joint[2].force_v2"].unit == "N m s2/rad2"
    with pytest.raises(Exception, match="force_period"):
        Model("quattro", params={"joint[1].force_period": -0.1})
