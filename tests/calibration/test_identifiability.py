"""Identifiability analysis (Tiberi 2020 ch. 3.1 and 4.2)."""
import warnings

import numpy as np
import pytest

from cosim.calibration.ident import column_scale, identifiability
from cosim.calibration.joint_problem import JointProblem
from cosim.calibration.problems import (PKM_FRAME_PLATFORM, PKM_FRAME_WORLD, CalibrationWarning,
                                        calib_rows)
from cosim.calibration.data import SEED000_POSES
from cosim.calibration.seed import SEED000_LEG_NAMES, SEED000_TABLE_4_22
from cosim.core import Model

# Tiberi 2020 Table 4.22 (leg 1 at the ten poses of Tables 4.2-4.20, columns X, Y, Z, S0x, S0y, S0z, L,
# sx, sy, sz) and the poses, as the calibration package holds them
TABLE_4_22, NAMES, POSES = SEED000_TABLE_4_22, SEED000_LEG_NAMES, SEED000_POSES


def test_seed_table_rail_origin_not_identifiable_with_platform_point():
    rep = identifiability(TABLE_4_22, NAMES)
    b = rep.blocks[0]
    assert b.rank == 7
    # QR in the error-model order: R_44, R_55, R_66 ~ 1e-16 (Tiberi 2020 ch. 4.2)
    assert np.all(b.qr_diag[3:6] < 1e-12) and np.all(b.qr_diag[[0, 1, 2, 6, 7, 8, 9]] > 1e-4)
    assert sorted(b.not_identifiable) == ["S0x", "S0y", "S0z"]
    # found from the null space, with the combination: moving P and S0 together is invisible
    combos = [set(v) for v in b.null_space]
    assert sorted(map(sorted, combos)) == [["S0x", "X"], ["S0y", "Y"], ["S0z", "Z"]]
    for v in b.null_space:
        np.testing.assert_allclose(sorted(v.values()), [1.0, 1.0], atol=1e-9)
    # what the structural model estimates: X - S0x etc.
    for c in b.combinations:
        if c.parameter in ("S0x", "S0y", "S0z"):
            assert c.residual < 1e-9
            key = c.parameter[-1].upper()
            assert c.coefficients[key] == pytest.approx(-1.0, abs=1e-9)
    assert b.cond_after < 100
    assert "not identifiable" in rep.text()


def _seed_poses_rows(frame):
    model = Model("6pus")
    x = POSES
    rows, ok = [], []
    for k in range(10):
        try:
            rows.append(calib_rows(model, x[k], frame)[0])  # leg 1
            ok.append(k)
        except Exception:  # another leg of this robot cannot reach the pose
            pass
    return np.array(rows), ok


def test_core_rows_at_seed_poses_world_frame_same_conclusion():
    J, ok = _seed_poses_rows(PKM_FRAME_WORLD)
    assert len(ok) >= 8
    b = identifiability(J, NAMES).blocks[0]
    assert sorted(b.not_identifiable) == ["S0x", "S0y", "S0z"]
    assert b.rank == 7


def test_platform_frame_makes_rail_origin_identifiable_in_principle():
    # with the platform point constant in the platform frame, rotations separate it from
    # the rail origin: no exact null direction between them any more
    J, ok = _seed_poses_rows(PKM_FRAME_PLATFORM)
    b = identifiability(J, NAMES).blocks[0]
    assert b.rank == min(len(ok), 10)
    assert not any(set(v) <= {"X", "Y", "Z", "S0x", "S0y", "S0z"} for v in b.null_space)


def test_elimination_drops_the_dominant_parameter_and_reports_the_combination():
    rng = np.random.default_rng(3)
    J = rng.normal(size=(40, 4))
    J = np.column_stack([J, J[:, 1] - 2.0 * J[:, 2] + 1e-4 * rng.normal(size=40)])  # near-dependent column
    rep = identifiability(J, list("abcde"))
    b = rep.blocks[0]
    assert b.rank == 5 and b.cond_scaled > 100
    assert [e.dropped for e in b.eliminations] == ["e"]
    assert b.cond_after < 100 and b.retained == list("abcd")
    (c,) = b.combinations
    assert c.coefficients["b"] == pytest.approx(1.0, abs=1e-3)
    assert c.coefficients["c"] == pytest.approx(-2.0, abs=1e-3)
    assert 0 < c.residual < 1e-3 and b.ill_conditioned == ["e"]


def test_combination_values_equal_the_structural_estimates_in_a_linear_model():
    rng = np.random.default_rng(4)
    J = rng.normal(size=(30, 3))
    J = np.column_stack([J, J[:, 0] + J[:, 2]])  # d = a + c: not identifiable
    truth = {"a": 0.3, "b": -0.2, "c": 0.5, "d": 0.7}
    y = J @ np.array([truth[k] for k in "abcd"])
    rep = identifiability(J, list("abcd"))
    assert rep.not_identifiable == ["d"]
    keep = rep.retained_mask()
    est = np.linalg.lstsq(J[:, keep], y, rcond=None)[0]
    want = rep.combination_values(truth)
    np.testing.assert_allclose(est, [want[n] for n in rep.retained], atol=1e-12)
    assert want["a"] == pytest.approx(0.3 + 0.7) and want["c"] == pytest.approx(0.5 + 0.7)


def test_column_scaling_makes_units_irrelevant():
    rng = np.random.default_rng(5)
    J = rng.normal(size=(20, 4))
    D = np.diag([1e-3, 1.0, 1e3, 7.0])
    a = identifiability(J, list("abcd")).blocks[0]
    b = identifiability(J @ D, list("abcd")).blocks[0]
    np.testing.assert_allclose(a.singular_values, b.singular_values, rtol=1e-10)
    assert b.cond_unscaled > 1e5 > a.cond_scaled
    np.testing.assert_allclose(column_scale(np.array([[0.0, 3.0], [0.0, 4.0]])), [1.0, 0.2])


def test_prediction_model_keeps_the_well_conditioned_directions():
    rng = np.random.default_rng(6)
    U, _ = np.linalg.qr(rng.normal(size=(30, 4)))
    V, _ = np.linalg.qr(rng.normal(size=(4, 4)))
    J = U @ np.diag([1.0, 0.5, 0.1, 1e-4]) @ V.T
    b = identifiability(J / np.linalg.norm(J, axis=0), list("abcd")).blocks[0]
    assert b.prediction_kept == 3 and len(b.prediction_dropped) == 1


def test_bad_matrix_is_an_error_naming_row_and_column():
    J = np.ones((5, 3))
    J[3, 1] = np.nan
    with pytest.raises(ValueError, match="row 3, column 'b'"):
        identifiability(J, list("abc"))
    with pytest.raises(ValueError, match="3 columns but 2"):
        identifiability(np.ones((5, 3)), list("ab"))


def test_too_few_equations_warn():
    b = identifiability(np.random.default_rng(0).normal(size=(3, 5)), list("abcde")).blocks[0]
    assert any("only 3 equations for 5 parameters" in w for w in b.warnings)
    assert b.rank == 3


def test_sixpus_block_structure_one_leg_per_block():
    m = Model("6pus")
    x = np.tile(m.home(), (12, 1))
    rng = np.random.default_rng(1)
    x[:, :2] += rng.uniform(-0.01, 0.01, (12, 2))
    x[:, 3:] += np.radians(rng.uniform(-4, 4, (12, 3)))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", CalibrationWarning)
        P = JointProblem(x, m.ik(x), m)
    J = P.jacobian(P.p0)
    for b, (_, rows, cols) in enumerate(P.blocks):
        other = np.setdiff1d(np.arange(J.shape[1]), cols)
        assert np.all(J[np.ix_(rows, other)] == 0)  # Tiberi 2020 eq. 4.7
    rep = identifiability(J, P.names, P.units, blocks=P.blocks)
    assert [b.label for b in rep.blocks] == [f"leg {i}" for i in range(1, 7)]
