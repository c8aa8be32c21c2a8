"""small_lstsq is numpy.linalg.lstsq's solution bit for bit (the same LAPACK kernel with
less argument checking), on full-rank, ill-conditioned and rank-deficient systems."""
import numpy as np
import pytest

from cosim.discrepancy._linalg import small_lstsq


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
