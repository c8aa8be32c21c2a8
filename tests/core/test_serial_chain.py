"""Serial arms from a description file (docs/robots.md, Serial arms).

Oracles: the two-link planar arm's closed-form equations of motion (Spong, Hutchinson and
Vidyasagar 2006, sec. 7.4.1) and its tool position l1 (cos q1, sin q1) + l2 (cos q12, sin q12);
a joint declared by modified Denavit-Hartenberg parameters against the same joint written
as origin and rpy by hand from Craig's definition; a mistake of the file refused with its
line.  (Against Pinocchio on URDF arms: tests/robots/test_urdf_pinocchio.py.)"""
import numpy as np
import pytest

from cosim.core import Model, Simulator
from cosim.errors import InputError

L1, L2, LC1, LC2, M1, M2, I1, I2, G = 0.7, 0.5, 0.3, 0.2, 4.0, 2.5, 0.11, 0.05, 9.81

TWO_LINK = f"""[robot]
name = "{{name}}"
kind = "serial"
home = [0.2, 0.4]
[gravity]
vector = [0, -{G}, 0]
[[joint]]
name = "shoulder"
type = "revolute"
origin = [0, 0, 0]
axis = [0, 0, 1]
limits = [-3, 3]
mass = {M1}
com = [{LC1}, 0, 0]
inertia = [0.06, 0, 0, 0.07, 0, {I1}]
[[joint]]
name = "elbow"
type = "revolute"
{{second}}
limits = [-3, 3]
mass = {M2}
com = [{LC2}, 0, 0]
inertia = [0.03, 0, 0, 0.04, 0, {I2}]
[tool]
origin = [{L2}, 0, 0]
"""


def _model(tmp_path, name, second='origin = [0.7, 0, 0]\naxis = [0, 0, 1]'):
    p = tmp_path / f"{name}.toml"
    p.write_text(TWO_LINK.format(name=name, second=second))
    return Model(str(p))


def _closed_form(q, qd, qdd):
    c2, s2 = np.cos(q[1]), np.sin(q[1])
    M = np.array([[M1 * LC1**2 + M2 * (L1**2 + LC2**2 + 2 * L1 * LC2 * c2) + I1 + I2, M2 * (LC2**2 + L1 * LC2 * c2) + I2],
                  [M2 * (LC2**2 + L1 * LC2 * c2) + I2, M2 * LC2**2 + I2]])
    h = M2 * L1 * LC2 * s2
    c = np.array([-h * (2 * qd[0] * qd[1] + qd[1] ** 2), h * qd[0] ** 2])
    g = np.array([(M1 * LC1 + M2 * L1) * G * np.cos(q[0]) + M2 * LC2 * G * np.cos(q[0] + q[1]),
                  M2 * LC2 * G * np.cos(q[0] + q[1])])
    return M, M @ qdd + c + g


def test_two_link_arm_is_the_closed_form(tmp_path):
    m = _model(tmp_path, "two_link_cf")
    assert m.facts.pose_names == ("shoulder", "elbow") and m.facts.joint_unit == "rad"
    rng = np.random.default_rng(2)
    for _ in range(10):
        q, qd, qdd = rng.uniform(-2.5, 2.5, 2), rng.normal(0, 2, 2), rng.normal(0, 5, 2)
        M, tau = _closed_form(q, qd, qdd)
        np.testing.assert_allclose(m.mass_matrix(q), M, rtol=1e-13, atol=1e-13)
        np.testing.assert_allclose(m.inverse_dynamics(q, qd, qdd), tau, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(m.forward_dynamics(q, qd, tau), qdd, rtol=1e-10, atol=1e-10)
        X, S = m.platform_pose(q)
        tip = [L1 * np.cos(q[0]) + L2 * np.cos(q.sum()), L1 * np.sin(q[0]) + L2 * np.sin(q.sum()), 0]
        np.testing.assert_allclose(X[:3], tip, atol=1e-14)
        np.testing.assert_allclose(X[3:], [0, 0, np.arctan2(np.sin(q.sum()), np.cos(q.sum()))], atol=1e-14)
        np.testing.assert_allclose(S[5], [1, 1], atol=1e-14)  # rz = q1 + q2
        # the joints are the coordinates
        np.testing.assert_array_equal(m.jacobian(q), np.eye(2))
        np.testing.assert_array_equal(m.ik(q), q)


def test_modified_dh_is_the_same_joint(tmp_path):
    """dh = [a, alpha, d, theta] (Craig 1989: Rx(alpha) Tx(a) Rz(theta) Tz(d)) places the joint
    as origin = [a, -sin(alpha) d, cos(alpha) d] with the rotation Rx(alpha) Rz(theta)."""
    a, alpha, d, theta = 0.7, np.pi / 2, 0.15, 0.0
    dh = _model(tmp_path, "two_link_dh", f"dh = [{a}, {alpha!r}, {d}, {theta}]")
    by_hand = _model(tmp_path, "two_link_frame", f"origin = [{a}, -{d}, 0]\nrpy = [{alpha!r}, 0, 0]\naxis = [0, 0, 1]")
    rng = np.random.default_rng(4)
    for _ in range(5):
        q, qd, qdd = rng.uniform(-2.5, 2.5, 2), rng.normal(0, 2, 2), rng.normal(0, 5, 2)
        np.testing.assert_allclose(dh.inverse_dynamics(q, qd, qdd), by_hand.inverse_dynamics(q, qd, qdd), rtol=1e-14,
                                   atol=1e-13)
        np.testing.assert_allclose(dh.platform_pose(q)[0], by_hand.platform_pose(q)[0], atol=1e-15)


def test_energy_is_conserved_in_free_motion(tmp_path):
    """No effort, no friction: the core's simulator keeps kinetic + potential energy (5e-9 J
    over 0.5 s at rtol 1e-11)."""
    m = _model(tmp_path, "two_link_energy")
    sim = Simulator(m, rtol=1e-11, atol=1e-12)
    x0 = np.array([0.2, 0.4])
    sim.reset(0.0, x0, np.zeros(2))
    e0 = sum(m.energy(x0, np.zeros(2)))
    sim.advance(0.5)
    x, xd = sim.state[1:3]
    assert abs(sum(m.energy(x, xd)) - e0) < 5e-9
    assert np.max(np.abs(x - x0)) > 0.1  # it moved


@pytest.mark.parametrize("change,line,words", [
    ('name = "elbow"\ntype = "revolute"', 18, ["joint 2.type 'hinge' is not known"]),
    ("inertia = [0.03, 0, 0, 0.04, 0, 0.05]", 24, ["joint 2.inertia", "not a rigid body's"]),
    ("mass = 2.5", 22, ["joint 2.mass = -1 kg must be >= 0"]),
])
def test_description_mistakes_name_the_line(tmp_path, change, line, words):
    bad = {"name = \"elbow\"\ntype = \"revolute\"": 'name = "elbow"\ntype = "hinge"',
           "inertia = [0.03, 0, 0, 0.04, 0, 0.05]": "inertia = [0.03, 0, 0, 0.04, 0, 0.5]",
           "mass = 2.5": "mass = -1"}[change]
    p = tmp_path / "bad_arm.toml"
    p.write_text(TWO_LINK.format(name="bad_arm", second='origin = [0.7, 0, 0]\naxis = [0, 0, 1]').replace(change, bad))
    with pytest.raises(InputError) as e:
        Model(str(p))
    assert f"bad_arm.toml:{line}:" in str(e.value), str(e.value)
    for w in words:
        assert w in str(e.value), str(e.value)


def test_a_joint_that_moves_nothing_is_refused(tmp_path):
    p = tmp_path / "limp_arm.toml"
    text = TWO_LINK.format(name="limp_arm", second='origin = [0.7, 0, 0]\naxis = [0, 0, 1]')
    p.write_text(text.replace(f"mass = {M2}\ncom = [{LC2}, 0, 0]\ninertia = [0.03, 0, 0, 0.04, 0, {I2}]",
                              "mass = 0\ncom = [0, 0, 0]\ninertia = [0, 0, 0, 0, 0, 0]"))
    with pytest.raises(InputError, match="mass matrix at the home pose is singular: joint 2 moves 0 kg m2"):
        Model(str(p))
