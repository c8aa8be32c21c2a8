"""small_lstsq is numpy.linalg.lstsq's solution bit for bit (the same LAPACK kernel with
less argument checking), on full-rank, ill-conditioned and rank-deficient systems; and
small_lstsq_many, a stack of them in one call, each system's solution bit for bit."""
import numpy as np
import pytest

from cosim.discrepancy._linalg import small_lstsq, small_lstsq_many


@pytest.mark.parametrize("n", [1, 2, 3, 5, 8, 12])
def test_small_lstsq_is_numpys_solution_bit_for_bit(n):
    rng = np.random.default_rng(n)
    for kind in ("full", "gram", "ill", "deficient"):
        X = rng.standard_normal((3 * n + 5, n))
        if kind == "ill":
            X[:, -1] = X[:, 0] * (1 + 1e-11)
        if kind == "deficient" and n > 1:
            X[:, -1] = 2 * X[:, 0]
        a = X.T @ X if kind != "full" else X
        b = rng.standard_normal(a.shape[0])
        assert np.array_equal(small_lstsq(a, b), np.linalg.lstsq(a, b, rcond=None)[0]), kind


def test_a_non_finite_system_fails_as_numpys_does():
    a = np.array([[1.0, np.nan], [0.0, 1.0]])
    with pytest.raises(np.linalg.LinAlgError):
        np.linalg.lstsq(a, np.ones(2), rcond=None)
    with pytest.raises(np.linalg.LinAlgError), np.errstate(invalid="ignore"):
        small_lstsq(a, np.ones(2))


@pytest.mark.parametrize("n", [1, 2, 3, 5, 8])
def test_a_stack_of_systems_is_solved_as_each_alone_bit_for_bit(n):
    rng = np.random.default_rng(10 + n)
    X = rng.standard_normal((40, 12))
    X[:, 5] = X[:, 4] * (1 + 1e-11)  # an ill-conditioned pair
    X[:, 7] = 2 * X[:, 6]  # a dependent pair
    G, g = X.T @ X, X.T @ rng.standard_normal(40)
    idx = np.array([rng.choice(12, n, replace=False) for _ in range(30)])
    a, b = G[idx[:, :, None], idx[:, None, :]], g[idx]
    x = small_lstsq_many(a, b)
    for k in range(len(idx)):
        assert np.array_equal(x[k], np.linalg.lstsq(a[k], b[k], rcond=None)[0]), k


def test_a_failing_system_in_a_stack_fails_as_numpys_does():
    a = np.array([[[1.0, 0.0], [0.0, 1.0]], [[1.0, np.nan], [0.0, 1.0]]])
    with pytest.raises(np.linalg.LinAlgError), np.errstate(invalid="ignore"):
        small_lstsq_many(a, np.ones((2, 2)))
