"""6-PUS kinematics through the Python binding (cosim.core.Model): parameters as JSON,
batched IK in one call, FK round trips, errors naming the leg, and derivatives
(Jacobian, calibration rows) against central finite differences of core functions."""
import json

import numpy as np
import pytest

from cosim.errors import ArgumentError, JointLimitError, ParameterError, UnreachableError
from cosim.core import Model

DEG = np.pi / 180


@pytest.fixture()
def m():
    return Model("6pus")


def workspace_poses(n, rng, xy=0.05, z=(0.02, 0.10), deg=5.0):
    return np.column_stack([rng.uniform(-xy, xy, n), rng.uniform(-xy, xy, n), rng.uniform(*z, n),
                            rng.uniform(-deg, deg, (n, 3)) * DEG])


def test_parameters_have_units_and_export_as_json(m):
    doc = json.loads(m.to_json())
    p = doc["parameters"]
    assert doc["robot"] == "6pus"
    assert p["leg[1].L"] == {"value": 0.116, "unit": "m", "description": p["leg[1].L"]["description"]}
    assert p["rail[1].S0x"]["value"] == -0.085
    assert p["platform.Ixx"]["unit"] == "kg m2"
    assert p["rail[3].coulomb"]["unit"] == "N"          # the drive layer's, named per rail
    assert p["leg[2].branch"]["value"] == -1.0
    for i in range(1, 7):
        for key in ("L", "px", "py", "pz", "branch", "m"):
            assert f"leg[{i}].{key}" in p
        for key in ("S0x", "S0y", "S0z", "sx", "sy", "sz", "qmin", "qmax"):
            assert f"rail[{i}].{key}" in p
        assert p[f"slider[{i}].m"]["value"] == 0.12
    assert all(v["description"] for v in p.values())


def test_invalid_set_names_the_parameter_and_keeps_the_old_values(m):
    with pytest.raises(ParameterError, match=r"rail\[2\]\.sx"):
        m.set_params({"rail[2].sx": 0.8})
    assert m.param("rail[2].sx") == 1.0
    with pytest.raises(ParameterError, match=r"leg\[4\]\.branch"):
        m.set_params({"leg[4].branch": 0.0})
    np.testing.assert_allclose(m.ik(m.home())[1:], 0.055, atol=1e-15)


def test_batched_ik_of_100k_poses_in_one_call(m):
    rng = np.random.default_rng(1)
    x = workspace_poses(100_000, rng)
    q, status = m.ik(x, errors="status")
    ok = status == 0
    assert ok.mean() > 0.5
    assert np.isfinite(q[ok]).all()
    assert np.isnan(q[~ok]).all()           # failures are flagged by their status, never silent
    assert set(np.unique(status[~ok])) <= {-3, -4, -6}
    with pytest.raises((UnreachableError, JointLimitError)):
        m.ik(x)                              # errors="raise" reports the first failure


def test_fk_round_trip_from_nearby_guesses(m):
    rng = np.random.default_rng(2)
    x = workspace_poses(4000, rng)
    q, status = m.ik(x, errors="status")
    x, q = x[status == 0][:2000], q[status == 0][:2000]
    guess = x + np.column_stack([rng.uniform(-2e-3, 2e-3, (len(x), 3)), rng.uniform(-1, 1, (len(x), 3)) * DEG])
    # A guess must itself be a valid pose: the legs reach it inside their strokes (the Newton
    # iteration of kinematics/generic_kinematics.cpp checks every iterate's strokes).
    _, gs = m.ik(guess, errors="status")
    keep = gs == 0
    xf = m.fk(q[keep], guess[keep])
    assert np.abs(xf - x[keep]).max() < 1e-10
    _, it, res = m.fk_info(q[0], guess[0])
    assert it <= 10 and res <= 1e-13


def test_errors_name_the_leg(m):
    x = m.home()
    with pytest.raises(UnreachableError, match="leg 6"):
        m.ik(x + [0, 0.047, 0, 0, 0, 0])
    with pytest.raises(JointLimitError, match=r"leg 1 joint q = -0.02\d+ outside \[0, 0.17\]"):
        m.ik(x + [-0.05, 0, -0.055, 0, 0, 0])
    m.set_params({"leg[1].L": 0.086})
    with pytest.raises(UnreachableError, match="leg 1 .*perpendicular to its rail .inverse-kinematic singularity"):
        m.ik([0, 0, np.sqrt(0.086**2 - 0.008**2), 0, 0, 0])
    with pytest.raises(ArgumentError, match=r"x\[2\]"):
        m.ik([0, 0, np.nan, 0, 0, 0])


def test_jacobian_against_central_differences(m):
    rng = np.random.default_rng(3)
    for x in workspace_poses(20, rng, xy=0.02, z=(0.06, 0.09)):
        J = m.jacobian(x)
        h = 1e-6
        fd = np.column_stack([(m.ik(x + h * e) - m.ik(x - h * e)) / (2 * h) for e in np.eye(6)])
        assert np.abs(J - fd).max() <= 1e-6 * np.abs(fd).max()


def _dq_dparam(m, x, key, h=1e-6):
    """Central difference of the joints at pose x in parameter ``key`` (set back afterwards)."""
    v = m.param(key)
    m.set_params({key: v + h})
    qp = m.ik(x)
    m.set_params({key: v - h})
    qm = m.ik(x)
    m.set_params({key: v})
    return (qp - qm) / (2 * h)


def test_calibration_rows_against_central_differences(m):
    x = m.home() + [0.01, -0.005, -0.01, 2 * DEG, -1 * DEG, 3 * DEG]
    rows_w = m.calib_rows(x, "world")
    rows_p = m.calib_rows(x, "platform")
    for i in (1, 4):
        for c, name in enumerate(["px", "py", "pz"]):
            assert rows_p[i - 1, c] == pytest.approx(_dq_dparam(m, x, f"leg[{i}].{name}")[i - 1], rel=1e-6)
        for c, key in [(3, f"rail[{i}].S0y"), (6, f"leg[{i}].L"), (9, f"rail[{i}].sz")]:
            c = c + 1 if c == 3 else c
            assert rows_w[i - 1, c] == pytest.approx(_dq_dparam(m, x, key)[i - 1], rel=1e-6), key
    # World and platform frames differ by the rotation of the platform point only.
    np.testing.assert_array_equal(rows_w[:, 3:], rows_p[:, 3:])


def test_leg_points_keep_the_leg_lengths(m):
    rng = np.random.default_rng(4)
    x = workspace_poses(50, rng, xy=0.02, z=(0.06, 0.09))
    P, S = m.leg_points(x)
    np.testing.assert_allclose(np.linalg.norm(P - S, axis=-1), 0.116, atol=1e-14)
    S0x = np.array([m.param(f"rail[{i}].S0x") for i in range(1, 7)])
    np.testing.assert_allclose(S[..., 0] - m.ik(x), np.broadcast_to(S0x, (50, 6)), atol=1e-15)


def test_singularity_measures_are_in_range(m):
    rng = np.random.default_rng(5)
    s = m.singularity(workspace_poses(200, rng, xy=0.025, z=(0.065, 0.085)))
    assert (s > 0).all() and (s <= 1).all()
    assert 1 / s[:, 1].min() < 9.0                       # no architecture singularity (docs/6pus.md)
