"""A continuous revolute axis (`continuous = true`, docs/robots.md): no limits, q the
unwrapped angle in the core's kinematics, the simulator and every check; and the platform
pose of the single-axis robots (Model.platform_pose).

Oracles, none from the code under test: the closed form q0 + qd0 t + tau t^2 / (2 M) of a
driven wheel without gravity; the pendulum's energy (m l^2 + I) qd^2 / 2 - m g l cos q written
here by hand; the pendulum's platform pose from its geometry (o = A - Ry(q) p); finite
differences of the pose for the motion map; scipy's rotations for a general axis."""
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from cosim._native import ArgumentError
from cosim.core import Model, Simulator

REPO = Path(__file__).resolve().parents[2]
M_BOB, L, I_BOB, G = 1.0, 0.5, 1e-4, 9.81

WHEEL = """
[robot]
name = "{name}"
coordinates = ["ry"]
home = [0.0]
[gravity]
vector = {g}
[platform]
mass = 1.0
inertia = [1e-4, 1e-4, 1e-4]
[[leg]]
type = "R"
platform_point = [0.0, 0.0, 0.5]
axis_point = [0.0, 0.0, 1.0]
axis = [0.0, 1.0, 0.0]
continuous = true
"""


def _robot(tmp_path, name, g=(0.0, 0.0, -9.81), text=WHEEL):
    p = tmp_path / f"{name}.toml"
    p.write_text(text.format(name=name, g=list(g)))
    return Model(str(p))


def test_a_continuous_axis_has_no_limits_anywhere(tmp_path):
    m = _robot(tmp_path, "wheel_nolim")
    assert not [n for n in m.param_names() if n.endswith(("qmin", "qmax"))]
    lo, hi = m.joint_limits()
    assert np.isnan(lo[0]) and np.isnan(hi[0])
    q = m.ik(np.array([[1234.5], [-987.0]]))  # far past any stroke a pendulum could have
    np.testing.assert_array_equal(q[:, 0], [1234.5, -987.0])


def test_a_driven_wheel_spins_past_100_rad_on_the_closed_form(tmp_path):
    """No gravity, a constant torque: q = q0 + qd0 t + tau t^2 / (2 M), M = m l^2 + I."""
    m = _robot(tmp_path, "wheel_free", g=(0.0, 0.0, 0.0))
    M = M_BOB * L**2 + I_BOB
    tau, qd0, T = 0.5, 5.0, 10.0
    sim = Simulator(m, rtol=1e-11, atol=1e-12)
    sim.reset(0.0, [0.0], [qd0])
    sim.set_input([tau])
    sim.advance(T)
    t, x, xd = sim.state
    q_true = qd0 * T + tau * T**2 / (2 * M)
    assert t == T and q_true > 100
    assert abs(x[0] - q_true) < 1e-8 * q_true, (x[0], q_true)
    assert abs(xd[0] - (qd0 + tau * T / M)) < 1e-8 * xd[0]


def test_a_spinning_pendulum_keeps_its_energy_over_dozens_of_turns(tmp_path):
    """With gravity, launched at 20 rad/s (it needs 8.9 rad/s to go over the top): it turns
    round and round, q passes 100 rad unwrapped, and (m l^2 + I) qd^2 / 2 - m g l cos q
    stays what it was at the start."""
    m = _robot(tmp_path, "wheel_grav")
    M = M_BOB * L**2 + I_BOB

    def energy(q, qd):
        return 0.5 * M * qd**2 - M_BOB * G * L * np.cos(q)

    sim = Simulator(m, rtol=1e-11, atol=1e-12)
    sim.reset(0.0, [0.0], [20.0])
    sim.set_input([0.0])
    E0 = energy(0.0, 20.0)
    qs = []
    for k in range(1, 81):
        sim.advance(0.1 * k)
        _, x, xd = sim.state
        qs.append(x[0])
        assert abs(energy(x[0], xd[0]) - E0) < 1e-7 * abs(E0), (k, x, xd)
    assert qs[-1] > 100 and np.all(np.diff(qs) > 0)  # unwrapped: it only grows


def test_the_same_pendulum_with_a_stroke_stops_at_it(tmp_path):
    text = WHEEL.replace("continuous = true", "stroke = [-3.1, 3.1]")
    m = _robot(tmp_path, "wheel_stroke", text=text)
    sim = Simulator(m)
    sim.reset(0.0, [0.0], [20.0])
    sim.set_input([0.0])
    with pytest.raises(Exception, match="axis\\[1\\].qmax"):
        sim.advance(1.0)


@pytest.mark.parametrize("edit, says", [
    (("continuous = true", "continuous = true\nstroke = [-1.0, 1.0]"), "a continuous joint has no stroke"),
    (("continuous = true", "continuous = 1"), "continuous must be true or false"),
    (("continuous = true", ""), "field 'stroke' is missing"),
])
def test_a_continuous_declaration_is_checked_where_it_is_written(tmp_path, edit, says):
    p = tmp_path / "bad_wheel.toml"
    p.write_text(WHEEL.format(name="bad_wheel", g=[0.0, 0.0, -9.81]).replace(*edit))
    with pytest.raises(ArgumentError, match=says) as e:
        Model(str(p))
    assert "bad_wheel.toml:" in str(e.value)


def test_only_a_revolute_axis_may_be_continuous(tmp_path):
    text = (REPO / "robots" / "emps.toml").read_text().replace('name = "emps"', 'name = "emps_spin"')
    text = text.replace("stroke = [-0.05, 0.30]", "continuous = true")
    p = tmp_path / "emps_spin.toml"
    p.write_text(text)
    with pytest.raises(ArgumentError, match="only a revolute axis \\(type R\\) turns without limit"):
        Model(str(p))


def test_platform_pose_of_the_single_axes_in_a_fresh_process():
    """Model.platform_pose once crashed the process on emps and pendulum: run in a fresh
    interpreter, its exit status is the test."""
    code = textwrap.dedent("""
        from cosim.core import Model
        for r in ("emps", "pendulum"):
            X, S = Model(r).platform_pose([0.3])
            print(r, *X, *S.ravel())
    """)
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=REPO)
    assert r.returncode == 0, r.stderr[-2000:]
    rows = {ln.split()[0]: np.array(ln.split()[1:], float) for ln in r.stdout.splitlines()}
    np.testing.assert_allclose(rows["emps"][:6], [0.3, 0, 0, 0, 0, 0], atol=1e-15)
    np.testing.assert_allclose(rows["emps"][6:], [1, 0, 0, 0, 0, 0], atol=1e-15)
    q = 0.3  # the pendulum: o = A - Ry(q) p, A = (0, 0, 1), p = (0, 0, 0.5); it turns about +y
    np.testing.assert_allclose(rows["pendulum"][:6], [-0.5 * np.sin(q), 0, 1 - 0.5 * np.cos(q), 0, q, 0], atol=1e-15)
    np.testing.assert_allclose(rows["pendulum"][6:], [-0.5 * np.cos(q), 0, 0.5 * np.sin(q), 0, 1, 0], atol=1e-15)


def test_platform_pose_of_a_general_axis_matches_its_rotation_and_finite_differences(tmp_path):
    text = WHEEL.replace("axis = [0.0, 1.0, 0.0]", "axis = [0.5773502691896258, 0.5773502691896258, "
                                                   "0.5773502691896258]").replace('"ry"', '"rz"')
    m = _robot(tmp_path, "slanted_wheel", text=text)
    k = np.ones(3) / np.sqrt(3)
    for q in (0.2, 1.0, 2.5, 7.0):
        X, S = m.platform_pose([q])
        R = Rotation.from_euler("XYZ", X[3:]).as_matrix()  # R = Rx Ry Rz
        np.testing.assert_allclose(R, Rotation.from_rotvec(q * k).as_matrix(), atol=1e-12)
        np.testing.assert_allclose(X[:3], [0, 0, 1] - R @ [0, 0, 0.5], atol=1e-12)
        h = 1e-6
        dX = (m.platform_pose([q + h])[0] - m.platform_pose([q - h])[0]) / (2 * h)
        np.testing.assert_allclose(S[:, 0], dX, atol=1e-7)


@pytest.mark.parametrize("method", ["erk", "bdf"])
def test_a_limit_reached_at_speed_is_the_limit_not_a_singularity(tmp_path, method):
    """An axis with the widest stroke its parameters take ([-100, 100] rad), spun at 200 rad/s:
    past the limit the axis refuses the angle, and the stop is its joint limit (it was once
    reported as a direct singularity)."""
    from cosim.errors import JointLimitError

    text = WHEEL.replace("continuous = true", "stroke = [-100.0, 100.0]")
    m = _robot(tmp_path, f"fast_wheel_{method}", g=(0.0, 0.0, 0.0), text=text)
    sim = Simulator(m, method=method)
    sim.reset(0.0, [99.0], [200.0])
    sim.set_input([0.0])
    with pytest.raises(JointLimitError, match=r"reached its joint limit axis\[1\]\.qmax = 100 rad at t = 0\.00"):
        sim.advance(0.1)
    t, x, _ = sim.state
    assert abs(t - 1.0 / 200.0) < 1e-6 and x[0] <= 100.0
