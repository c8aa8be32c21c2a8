"""The joint force's products and couplings (``<j>[i].force_qv, force_cq1, force_cq2, force_czone*,
force_xj/xqc/xk1/xv, force_cload, force_ceff, force_eq``, joint_force.hpp): the terms the discovery
step's families fit (cosim/discrepancy/families/products.py).  Checked against the formula
written here from the joint positions and rates; the effort terms in the forward dynamics
(subtracted from the given effort) and in the inverse dynamics (the effort solved for by hand,
tau = b / (1 - g - mu sign(b)))."""
import math

import numpy as np
import pytest

from cosim.core import Model

COEF = {"force_qc": 0.25, "force_qv": 30.0, "force_cq1": 4.0, "force_cq2": -60.0, "force_czone": 0.9,
        "force_czone_q": 0.252, "force_czone_w": -0.004, "force_cv": 0.04}
EFF = {"force_cload": 0.12, "force_ceff": 0.05, "force_eq": 0.8, "force_eg": -0.03}


def _state(m):
    x = m.home() + np.array([0.002, -0.001, 0.004, 0.01, -0.02, 0.015])
    xd = np.array([0.05, -0.02, 0.03, 0.2, -0.1, 0.3])
    return x, xd, np.array([0.3, -0.2, 0.1, 1.0, 0.5, -0.7])


def _pos_rate_terms(q, qd, c):
    z = q - c["force_qc"]
    s = math.tanh(qd / c["force_cv"])
    zone = 0.5 * (1 + math.tanh((q - c["force_czone_q"]) / c["force_czone_w"]))
    return c["force_qv"] * z * qd + (c["force_cq1"] * z + c["force_cq2"] * z * z) * s + c["force_czone"] * s * zone


def test_position_and_rate_products_in_the_inverse_dynamics():
    nominal = Model("6pus")
    m = Model("6pus", params={f"rail[2].{k}": v for k, v in COEF.items()})
    x, xd, xdd = _state(m)
    dtau = m.inverse_dynamics(x, xd, xdd) - nominal.inverse_dynamics(x, xd, xdd)
    q, qd = m.ik(x), m.joint_velocity(x, xd)
    want = _pos_rate_terms(q[1], qd[1], COEF)
    assert abs(want) > 0.05
    np.testing.assert_allclose(dtau[1], want, rtol=1e-9)
    np.testing.assert_allclose(np.delete(dtau, 1), 0.0, atol=1e-12)


def test_a_force_in_another_joints_motion():
    nominal = Model("6pus")
    m = Model("6pus", params={"rail[5].force_xj": 2, "rail[5].force_xqc": 0.24, "rail[5].force_xk1": -150.0,
                              "rail[5].force_xv": 7.0})
    x, xd, xdd = _state(m)
    dtau = m.inverse_dynamics(x, xd, xdd) - nominal.inverse_dynamics(x, xd, xdd)
    q, qd = m.ik(x), m.joint_velocity(x, xd)
    want = -150.0 * (q[1] - 0.24) + 7.0 * qd[1]
    assert abs(want) > 0.05
    np.testing.assert_allclose(dtau, np.eye(6)[4] * want, rtol=1e-9, atol=1e-12)


def test_the_effort_terms_solve_the_inverse_dynamics_by_hand_and_invert_the_forward():
    p = {f"rail[3].{k}": v for k, v in dict(COEF, **EFF).items()}
    p["rail[1].force_cload"] = 0.2  # sharp: drive.v_eps
    nominal, m = Model("6pus"), Model("6pus", params=p)
    x, xd, xdd = _state(m)
    b = nominal.inverse_dynamics(x, xd, xdd)
    q, qd = m.ik(x), m.joint_velocity(x, xd)
    b[2] += _pos_rate_terms(q[2], qd[2], COEF)
    s3 = math.tanh(qd[2] / COEF["force_cv"])
    g = np.zeros(6)
    mu = np.zeros(6)
    g[2] = EFF["force_ceff"] * s3 + EFF["force_eq"] * (q[2] - COEF["force_qc"]) + EFF["force_eg"]
    mu[2] = EFF["force_cload"] * s3
    mu[0] = 0.2 * math.tanh(qd[0] / m.params()["drive.v_eps"])
    want = b / (1 - g - mu * np.sign(b))
    tau = m.inverse_dynamics(x, xd, xdd)
    # the solution holds tau = b + g tau + mu |tau|, and differs from b by well over the tolerance
    np.testing.assert_allclose(tau, want, rtol=1e-10)
    np.testing.assert_allclose(tau, b + g * tau + mu * np.abs(tau), rtol=1e-10)
    assert np.min(np.abs(tau - b)[[0, 2]]) > 1e-3 * np.max(np.abs(b))
    # forward: the given effort less the terms drives the mechanism (the acceleration back)
    np.testing.assert_allclose(m.forward_dynamics(x, xd, tau), xdd, rtol=1e-8, atol=1e-8)


def test_a_self_locking_load_friction_and_a_bad_joint_index_are_refused():
    m = Model("pendulum", params={"axis[1].force_cload": 1.5})
    with pytest.raises(Exception, match="self-locks"):
        m.inverse_dynamics(np.array([0.3]), np.array([0.5]), np.array([1.0]))
    with pytest.raises(Exception, match=r"rail\[2\]\.force_xj"):
        Model("6pus", params={"rail[2].force_xj": 2})
    with pytest.raises(Exception, match=r"rail\[2\]\.force_xj"):
        Model("6pus", params={"rail[2].force_xj": 1.5})


def test_shape_parameters_alone_are_no_force():
    m = Model("6pus", params={"rail[2].force_czone_q": 0.3, "rail[2].force_czone_w": 0.01, "rail[2].force_xj": 4,
                              "rail[2].force_xqc": 0.2})
    x, xd, xdd = _state(m)
    np.testing.assert_array_equal(m.inverse_dynamics(x, xd, xdd), Model("6pus").inverse_dynamics(x, xd, xdd))
