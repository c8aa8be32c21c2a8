"""Error models declared as data (robots/calibration/*.toml): what they declare reaches the one
problem class, checked against an independent four-bar solved here, and bad files are refused
with the file and the key named."""
import numpy as np
import pytest
from scipy.optimize import brentq

from cosim.calibration.error_model import error_model
from cosim.calibration.joint_problem import JointProblem
from cosim.core import Model
from cosim.errors import InputError

THETA = np.radians([30.0, 37.0, 44.0, 51.0, 58.0])


def _fourbar_X(lengths, theta):
    """Oracle: the four-bar of Vitali 2020 ch. 1.1 solved here by root finding (scipy's brentq)
    on the loop closure |B + l2 e(phi) - D| = l3, crank pivot at the origin, D = (l4, 0), in the
    assembly mode of the thesis (phi = 0.6625 rad at theta = 30 deg, to its 4 decimals), and
    X = l1 cos(theta) + l2 / 2 cos(phi)."""
    l1, l2, l3, l4 = lengths
    out = []
    for t in theta:
        b = np.array([l1 * np.cos(t), l1 * np.sin(t)])

        def loop(phi):
            c = b + l2 * np.array([np.cos(phi), np.sin(phi)])
            return np.hypot(c[0] - l4, c[1]) - l3

        phi = brentq(loop, np.radians(0.0), np.radians(90.0), xtol=1e-15)
        out.append(l1 * np.cos(t) + 0.5 * l2 * np.cos(phi))
    return np.array(out)


def test_fourbar_error_model_predicts_the_independent_linkage_in_its_parameter_order():
    m = Model("fourbar")
    em = error_model(m)
    assert em.measure == "output" and em.columns == "core" and len(em.parameters) == 4
    nominal = np.array([m.param(n) for n in em.parameters])
    assert 0.6625 == pytest.approx(
        brentq(lambda p: np.hypot(nominal[0] * np.cos(THETA[0]) + nominal[1] * np.cos(p) - nominal[3],
                                  nominal[0] * np.sin(THETA[0]) + nominal[1] * np.sin(p)) - nominal[2], 0.0, 1.5),
        abs=0.5e-4)  # the thesis' assembly mode, phi printed to 4 decimals [rad]
    P = JointProblem(np.zeros(THETA.size), THETA, m, min_poses=1)
    p = nominal + np.array([0.3e-3, -0.5e-3, 0.55e-3, 0.7e-3])
    np.testing.assert_allclose(P.predict(p), _fourbar_X(p, THETA), rtol=0, atol=1e-12)
    # the columns follow the declared order: central differences of the oracle, 1e-6 m steps
    J = P.jacobian(p)
    for j in range(4):
        e = np.zeros(4)
        e[j] = 1e-6
        fd = (_fourbar_X(p + e, THETA) - _fourbar_X(p - e, THETA)) / 2e-6
        np.testing.assert_allclose(J[:, j], fd, rtol=0, atol=1e-7, err_msg=em.parameters[j])


def test_sixpus_error_model_is_sixty_parameters_per_leg_with_unit_rail_directions():
    m = Model("6pus")
    em = error_model(m)
    assert len(em.parameters) == 60 and len(em.joint_parameters) == 6 and len(em.unit_vectors) == 6
    # each rail direction a unit vector in the core: the dependent component keeps |s| = 1
    x = m.home()[None, :].repeat(12, 0)
    P = JointProblem(x, m.ik(x), m, min_poses=1)
    assert len(P.names) == 54
    p = P.p0.copy()
    p[[P.names.index("rail[3].sy"), P.names.index("rail[3].sz")]] += [4e-3, -3e-3]
    s = np.array([P.model_params(p)[f"rail[3].s{c}"] for c in "xyz"])
    assert np.linalg.norm(s) == pytest.approx(1.0, abs=1e-15)


def test_a_robot_without_an_error_model_gets_none():
    assert error_model(Model("robots/tripod_3rps.toml")) is None


@pytest.mark.parametrize("text, where", [
    ('parameters = ["link[1].l"]\nbogus = 1\n', "unknown key 'bogus'"),
    ('parameters = ["link[9].l"]\n', "parameters: fourbar has no parameter 'link[9].l'"),
    ('parameters = ["link[1].l"]\nmeasure = "torque"\n', "measure must be one of joints, output"),
    ('source = "x"\n', "lists 'parameters' or 'per_joint'"),
    ('parameters = [\n', "bad.toml"),
])
def test_a_bad_error_model_file_names_file_and_key(tmp_path, text, where):
    f = tmp_path / "bad.toml"
    f.write_text(text)
    with pytest.raises(InputError, match=r"bad\.toml") as e:
        error_model(Model("fourbar"), f)
    assert where in str(e.value)
