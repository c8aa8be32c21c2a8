"""Solver interface and standard errors, on linear problems with known answers."""
import numpy as np
import pytest

from cosim.calibration.problems import LinearProblem
from cosim.calibration.solvers import METHODS, solve


def _problem(seed=0, m=40, noise=0.0):
    rng = np.random.default_rng(seed)
    J = rng.normal(size=(m, 4)) * [1.0, 10.0, 0.1, 3.0]
    truth = np.array([0.2, -0.05, 3.0, 0.4])
    y = J @ truth + noise * rng.normal(size=m)
    return LinearProblem(J, y, list("abcd"), prior=np.ones(4)), truth


@pytest.mark.parametrize("method", METHODS)
def test_every_method_solves_a_linear_problem(method):
    P, truth = _problem()
    kw = {"basis": "svd"} if method == "golden" else {}
    s = solve(P, method, width=10.0, **kw) if method == "golden" else solve(P, method)
    np.testing.assert_allclose(s.p, truth, atol=1e-6)
    assert s.converged and s.cost[-1] <= s.cost[0]


def test_free_parameters_by_name_keep_the_others_fixed():
    P, truth = _problem()
    s = solve(P, "gauss-newton", free=["a", "c"], p_start=np.array([0, truth[1], 0, truth[3]]))
    np.testing.assert_allclose(s.p, truth, atol=1e-10)
    assert s.se[1] == 0 and s.se[3] == 0 and list(s.estimates()) == ["a", "c"]
    with pytest.raises(ValueError, match="unknown parameter"):
        solve(P, "pinv", free=["a", "zz"])
    with pytest.raises(ValueError, match="unknown calibration method"):
        solve(P, "newton-raphson")


@pytest.mark.parametrize("se", ["ols", "hc2"])
def test_standard_errors_cover_the_truth(se):
    # 300 noisy repetitions of one design: (estimate - truth)/SE has unit spread
    z = []
    for k in range(300):
        P, truth = _problem(seed=1, noise=0.01)
        P.y = P.J @ truth + 0.01 * np.random.default_rng(100 + k).normal(size=P.y.size)
        s = solve(P, "pinv", se=se)
        z.append((s.p - truth) / s.se)
    z = np.abs(np.array(z))
    assert 0.9 < np.sqrt(np.mean(z ** 2)) < 1.15
    assert 0.6 < np.mean(z < 1) < 0.76


def test_ols_standard_error_formula():
    P, truth = _problem(seed=2, noise=0.01)
    s = solve(P, "gauss-newton", se="ols")
    r = P.y - P.J @ s.p
    sigma2 = r @ r / (P.y.size - 4)
    np.testing.assert_allclose(s.se, np.sqrt(np.diag(np.linalg.inv(P.J.T @ P.J)) * sigma2), rtol=1e-8)


def test_no_redundancy_gives_infinite_standard_errors():
    P, _ = _problem(m=4)
    s = solve(P, "pinv")
    assert np.all(np.isinf(s.se))


def test_prediction_model_truncates_the_weak_direction():
    rng = np.random.default_rng(3)
    J = rng.normal(size=(30, 3))
    J = np.column_stack([J, J[:, 0] + 1e-6 * rng.normal(size=30)])
    P = LinearProblem(J, J @ [1.0, 2.0, 3.0, 4.0], list("abcd"))
    s = solve(P, "pinv", rcond=1e-2)
    assert s.rank == 3
    # the minimum-norm split of the a/d combination (scaled), the fit itself is exact
    assert s.p[0] + s.p[3] == pytest.approx(5.0, rel=1e-4)
    np.testing.assert_allclose(s.p[1:3], [2.0, 3.0], atol=1e-4)
