"""The force on the platform (``wrench.*``, ``cable.*``, ``platform_drag.*``; platform_force.hpp).

Checked against virtual work written here: the efforts the drive spends on a wrench (f, m) at the
platform satisfy F . dq = -(f . dP + m . dphi) for every small motion, with dq from finite
differences of the core's inverse kinematics, dP the platform point's displacement and dphi the
platform's small rotation from R = Rx(rx) Ry(ry) Rz(rz) (the 6-PUS pose convention, docs/6pus.md)
at poses a step apart.  The wrench itself (the cable's direction and tension, the drag) is
computed here from its definition."""
import numpy as np
import pytest

from cosim.core import Model


def _rot(a):
    cx, sx, cy, sy, cz, sz = np.cos(a[0]), np.sin(a[0]), np.cos(a[1]), np.sin(a[1]), np.cos(a[2]), np.sin(a[2])
    Rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    Ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    Rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return Rx @ Ry @ Rz


def _virtual_work_efforts(m, x, wrench_at, h=1e-6):
    """F with F . (dq/dx_j) = -(generalised force of the wrench on x_j) for each pose coordinate j,
    by central differences of the core's ik and of the platform's point and rotation."""
    n = m.ndof
    Jq, G = np.zeros((n, n)), np.zeros(n)
    for j in range(n):
        e = np.zeros(n)
        e[j] = h
        xp, xm = x + e, x - e
        Jq[:, j] = (m.ik(xp) - m.ik(xm)) / (2 * h)
        f, mom, P = wrench_at(x)
        dP = (wrench_at(xp)[2] - wrench_at(xm)[2]) / (2 * h)
        if n == 6:
            dR = (_rot(xp[3:]) - _rot(xm[3:])) / (2 * h)
            W = dR @ _rot(x[3:]).T  # skew(omega per unit x_j)
            dphi = np.array([W[2, 1], W[0, 2], W[1, 0]])
        else:
            dphi = np.zeros(3)
        G[j] = f @ dP + mom @ dphi
    return np.linalg.solve(Jq.T, -G)


X0 = np.array([0.003, -0.002, 0.004, 0.02, -0.015, 0.03])
CABLE = {"cable.anchor_x": 0.4, "cable.anchor_y": -0.3, "cable.anchor_z": 0.9, "cable.point_x": 0.05,
         "cable.point_y": 0.02, "cable.point_z": -0.01, "cable.tension": 3.0, "cable.stiffness": 20.0,
         "cable.rest_length": 0.5}


def _cable_wrench(m, params):
    A = np.array([params[f"cable.anchor_{a}"] for a in "xyz"])
    r = np.array([params[f"cable.point_{a}"] for a in "xyz"])

    def at(x):
        p = x
        P = p[:3] + _rot(p[3:]) @ r
        L = np.linalg.norm(A - P)
        f = (params["cable.tension"] + params["cable.stiffness"] * (L - params["cable.rest_length"])) * (A - P) / L
        return f, np.zeros(3), P  # a force at the point P: its virtual work is f . dP, rotation included
    return at


def test_a_constant_wrench_on_the_6pus_is_mapped_by_virtual_work():
    w = {"wrench.fx": 1.5, "wrench.fy": -2.0, "wrench.fz": 3.0, "wrench.mx": 0.1, "wrench.my": -0.2, "wrench.mz": 0.3}
    nominal, m = Model("6pus"), Model("6pus", params=w)
    x = m.home() + X0
    xd, xdd = np.array([0.05, -0.02, 0.03, 0.2, -0.1, 0.3]), np.zeros(6)
    dtau = m.inverse_dynamics(x, xd, xdd) - nominal.inverse_dynamics(x, xd, xdd)
    f, mom = np.array([1.5, -2.0, 3.0]), np.array([0.1, -0.2, 0.3])
    want = _virtual_work_efforts(m, x, lambda y: (f, mom, y[:3]))
    assert np.max(np.abs(want)) > 1.0
    np.testing.assert_allclose(dtau, want, rtol=1e-5, atol=1e-6)
    # the mechanism's part (a load like gravity), not the drive layer's
    np.testing.assert_allclose(m.mechanism_inverse_dynamics(x, xd, xdd)
                               - nominal.mechanism_inverse_dynamics(x, xd, xdd), want, rtol=1e-5, atol=1e-6)
    assert not {"wrench.fx", "cable.tension", "platform_drag.linear"} & set(m.drive_layer_params())
    # holding still needs it too
    np.testing.assert_allclose(m.gravity_load(x) - nominal.gravity_load(x), want, rtol=1e-5, atol=1e-6)


def test_a_cable_to_an_anchor_with_a_point_off_the_centre():
    nominal, m = Model("6pus"), Model("6pus", params=CABLE)
    x = m.home() + X0
    z = np.zeros(6)
    dtau = m.inverse_dynamics(x, z, z) - nominal.inverse_dynamics(x, z, z)
    want = _virtual_work_efforts(m, x, _cable_wrench(m, CABLE))
    assert np.max(np.abs(want)) > 1.0
    np.testing.assert_allclose(dtau, want, rtol=1e-5, atol=1e-6)


def test_drag_opposes_the_platform_velocity_and_vanishes_at_rest():
    nominal, m = Model("6pus"), Model("6pus", params={"platform_drag.linear": 40.0, "platform_drag.angular": 0.0})
    x = m.home() + X0
    xd, z = np.array([0.05, -0.02, 0.03, 0.0, 0.0, 0.0]), np.zeros(6)
    dtau = m.inverse_dynamics(x, xd, z) - nominal.inverse_dynamics(x, xd, z)
    f = -40.0 * xd[:3]
    want = _virtual_work_efforts(m, x, lambda y: (f, np.zeros(3), y[:3]))
    np.testing.assert_allclose(dtau, want, rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(m.inverse_dynamics(x, z, z), nominal.inverse_dynamics(x, z, z), atol=1e-12)


def test_forward_dynamics_are_driven_by_the_effort_less_the_force():
    nominal, m = Model("6pus"), Model("6pus", params=dict(CABLE, **{"platform_drag.linear": 10.0}))
    x = m.home() + X0
    xd = np.array([0.05, -0.02, 0.03, 0.2, -0.1, 0.3])
    tau = nominal.gravity_load(x) + np.array([0.1, -0.2, 0.3, 0.0, 0.1, -0.1])
    F = m.inverse_dynamics(x, xd, np.zeros(6)) - nominal.inverse_dynamics(x, xd, np.zeros(6))
    np.testing.assert_allclose(m.forward_dynamics(x, xd, tau), nominal.forward_dynamics(x, xd, tau - F),
                               rtol=1e-9, atol=1e-9)


def test_a_described_delta_with_three_coordinates():
    params = {"wrench.fx": 2.0, "wrench.fz": -5.0, "cable.anchor_x": 0.3, "cable.anchor_z": 0.5,
              "cable.tension": 4.0}
    nominal, m = Model("delta_clavel"), Model("delta_clavel", params=params)
    x = m.home() + np.array([0.01, -0.02, 0.0])
    z = np.zeros(3)
    dtau = m.inverse_dynamics(x, z, z) - nominal.inverse_dynamics(x, z, z)

    def at(y):
        A = np.array([0.3, 0.0, 0.5])
        u = (A - y) / np.linalg.norm(A - y)
        return np.array([2.0, 0.0, -5.0]) + 4.0 * u, np.zeros(3), y
    want = _virtual_work_efforts(m, x, at)
    assert np.max(np.abs(want)) > 0.1
    np.testing.assert_allclose(dtau, want, rtol=1e-5, atol=1e-7)


def test_parameters_only_where_there_is_a_platform_and_errors_name_the_cable():
    info = {p.name: p for p in Model("6pus").param_info()}
    assert info["cable.tension"].unit == "N" and info["platform_drag.linear"].unit == "N s/m"
    assert info["wrench.mz"].unit == "N m"
    assert "wrench.fx" in Model("quattro").param_names()
    assert not any(n.startswith(("wrench.", "cable.")) for n in Model("fourbar").param_names())
    x = Model("6pus").home()
    m = Model("6pus", params={"cable.tension": 1.0, "cable.anchor_x": x[0], "cable.anchor_y": x[1],
                              "cable.anchor_z": x[2]})
    with pytest.raises(Exception, match="cable"):
        m.inverse_dynamics(x, np.zeros(6), np.zeros(6))
