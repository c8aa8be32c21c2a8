"""Intervals robust to the residual's correlation in time (heteroscedasticity and
autocorrelation consistent, HAC).

A residual of a closed-loop recording is not white: the smoother correlates a window of
samples, and what the model still misses (the pipeline's small errors at the jerk peaks, a term
that is close to the truth but not it) drifts slowly along the trajectory.  A covariance
``(X'X)^-1 s^2`` that counts a fixed number of samples per independent one then states
intervals too narrow whenever that drift is correlated with a coefficient's column.  The
estimate here sums the products of the coefficient's *scores* (column times residual) over
lags, with the Bartlett kernel (Newey and West, 1987) and the bandwidth chosen from the scores
themselves by Andrews' AR(1) plug-in rule (Andrews, 1991): a slow misfit gives persistent
scores, hence a long bandwidth and a wider interval; white noise gives a bandwidth near zero
and the classical sandwich.  A long bandwidth averages few lags, and the interval's multiplier
is then the fixed-b critical value of Kiefer and Vogelsang (2005) instead of 1.96: 2.26 at a
bandwidth of a tenth of the series (a simulation of 6000 white series of 400 samples gives
2.25), which keeps the stated 95 % where the normal multiplier holds 88 % (a drifting
residual, tests/discrepancy/test_intervals.py).
"""
from __future__ import annotations

import math

import numpy as np

#: the bandwidth never exceeds this share of the series (a longer one has too few lags to average)
MAX_SHARE = 0.25


def andrews_bandwidth(g: np.ndarray) -> float:
    """Bartlett-kernel bandwidth [samples] of Andrews' AR(1) plug-in rule for the score series
    ``g`` (n, p): 1.1447 (alpha n)^(1/3), alpha from an AR(1) fit of each score component.

    Example
    -------
    >>> rng = np.random.default_rng(0)
    >>> round(andrews_bandwidth(rng.normal(size=(1000, 1))))  # white scores: a short bandwidth
    1
    """
    n = g.shape[0]
    num = den = 0.0
    for a in range(g.shape[1]):
        x = g[:, a] - g[:, a].mean()
        d = float(x[:-1] @ x[:-1])
        if d <= 0:
            continue
        rho = min(max(float(x[1:] @ x[:-1]) / d, -0.97), 0.97)
        s2 = float(np.mean((x[1:] - rho * x[:-1]) ** 2))
        num += 4 * rho ** 2 * s2 ** 2 / ((1 - rho) ** 6 * (1 + rho) ** 2)
        den += s2 ** 2 / (1 - rho) ** 4
    if den <= 0:
        return 0.0
    return float(min(1.1447 * (num / den * n) ** (1.0 / 3.0), MAX_SHARE * n))


def critical_value(bandwidth: float, n: int) -> float:
    """Two-sided 95 % multiplier of a HAC standard error with the Bartlett kernel of
    ``bandwidth`` samples over ``n`` samples: the fixed-b quantile of Kiefer and Vogelsang
    (2005), 1.96 + 2.9694 b + 0.4160 b^2 - 0.5324 b^3 with b = (bandwidth + 1) / n (1.96 at
    b = 0).

    Example
    -------
    >>> round(critical_value(39.0, 400), 2)
    2.26
    """
    b = min((bandwidth + 1.0) / max(n, 1), 1.0) if bandwidth > 0 else 0.0
    return 1.96 + 2.9694 * b + 0.4160 * b ** 2 - 0.5324 * b ** 3


def hac_covariance(X: np.ndarray, e: np.ndarray, Z: np.ndarray | None = None, n_series: int = 1,
                   bandwidth: float | None = None) -> tuple[np.ndarray, float]:
    """HAC covariance of the coefficients c fitted so that ``t + X c`` has residual ``e``
    (least squares, or instrumental variables ``Z'(t + X c) = 0`` with ``Z``).

    Parameters
    ----------
    X : (N, p) array
        The columns (weighted as in the fit; the covariance does not depend on the weights'
        scale).
    e : (N,) array
        The residual at the estimate, same rows.
    Z : (N, p) array, optional
        Instruments (None: least squares, Z = X).
    n_series : int
        The rows are ``n_series`` series of equal length one after the other, each in time
        order (channels of the same samples): the scores of the same sample are summed over
        the series before their correlation in time is taken.
    bandwidth : float, optional
        Bartlett bandwidth in samples (default: :func:`andrews_bandwidth` of the scores).

    Returns
    -------
    (cov, z95) : ((p, p) array, float)
        ``(Z'X)^-1 S (X'Z)^-1`` with ``S`` the Bartlett-weighted sum of the scores'
        autocovariances, and the multiplier of its standard errors for 95 % intervals
        (:func:`critical_value` of the bandwidth used).

    Example
    -------
    >>> rng = np.random.default_rng(1)
    >>> X = rng.normal(size=(400, 1)); e = rng.normal(size=400)
    >>> cov, z95 = hac_covariance(X, e)
    >>> bool(abs(cov[0, 0] * 400 - 1) < 0.3)  # white noise of unit variance: about 1 / N
    True
    """
    Z = X if Z is None else Z
    N, p = X.shape
    if p == 0 or N == 0:
        return np.zeros((p, p)), 1.96
    n = N // n_series
    g = (Z * e[:, None]).reshape(n_series, n, p).sum(axis=0)
    L = andrews_bandwidth(g) if bandwidth is None else float(bandwidth)
    S = g.T @ g
    for lag in range(1, int(math.floor(L)) + 1):
        w = 1.0 - lag / (L + 1.0)
        G = g[lag:].T @ g[:-lag]
        S += w * (G + G.T)
    A = np.linalg.pinv(Z.T @ X, rcond=1e-12)
    return A @ S @ A.T, critical_value(L, n)


#: the library's intervals include the estimate's spread across windows (:func:`block_jackknife`);
#: False leaves the noise's alone (for measuring what the spread adds)
WINDOW_SPREAD = True

#: a friction's interval includes its estimate's spread across its joint's speed bands
#: (:func:`block_jackknife` with ``order``); False leaves the windows in time alone
SPEED_BANDS = True

#: contiguous blocks of :func:`block_jackknife` (a tenth of the recording each: long enough to
#: hold several of the trajectory's phases and a slow misfit's swing, with 9 degrees of freedom
#: for the Student multiplier)
JACKKNIFE_BLOCKS = 10


def block_jackknife(X: np.ndarray, e: np.ndarray, Z: np.ndarray | None = None, n_series: int = 1,
                    blocks: int = JACKKNIFE_BLOCKS, order: np.ndarray | None = None) -> tuple[np.ndarray, float]:
    """Delete-one-block jackknife covariance of the coefficients fitted so that ``t + X c``
    has residual ``e`` (least squares, or instrumental variables with ``Z``): the spread of
    the estimate across the recording's windows.

    Each of ``blocks`` contiguous stretches of time (every series' samples of that stretch)
    is left out in turn and the fit, linearised at the estimate, refitted on the rest:
    ``d_k = (Z_k'X_k)^-1 Z_k' e_k`` over the kept rows ``k``.  The covariance is
    ``(K - 1) / K sum (d_k - mean d)^2`` (Efron and Stein 1981; Kunsch 1989 for blocks of a
    dependent series).  Where the model is the plant's, the windows agree within the noise and
    this is the sampling covariance; where it is not (a gap whose contact is soft, a spring
    read through a drive of its own), the estimate depends on which motions the window holds,
    and that model-form error shows as spread that no noise model counts.

    Parameters
    ----------
    X, e, Z, n_series
        As for :func:`hac_covariance`.
    blocks : int
        Number of blocks K (at least 2).
    order : (n,) array, optional
        A value per time sample (a joint's speed): the blocks are then the K bands of equal
        count of its ranks (the samples of its smallest tenth, the next tenth, ...) instead of
        stretches of time, and the covariance is the estimate's spread across those bands.

    Returns
    -------
    (cov, t95) : ((p, p) array, float)
        The jackknife covariance and the two-sided 95 % Student multiplier with K - 1
        degrees of freedom (2.262 for K = 10).

    Example
    -------
    >>> rng = np.random.default_rng(2)
    >>> X = rng.normal(size=(2000, 1)); e = rng.normal(size=2000); e -= X[:, 0] * (X[:, 0] @ e) / (X[:, 0] @ X[:, 0])
    >>> cov, t95 = block_jackknife(X, e)
    >>> bool(0.4 < cov[0, 0] * 2000 < 2.0), round(t95, 3)  # white noise: about 1 / N
    (True, 2.262)
    """
    Z = X if Z is None else Z
    N, p = X.shape
    K = int(max(blocks, 2))
    n = N // max(n_series, 1)
    if p == 0 or n < 2 * K:
        return np.full((p, p), np.nan), float("nan")
    idx = np.arange(N) % n  # time index of each row (the series one after the other)
    if order is not None:
        rank = np.empty(n, dtype=int)
        rank[np.argsort(np.asarray(order, float)[:n], kind="stable")] = np.arange(n)
        idx = rank[idx]  # the row's place in the order instead of in time
    edges = np.linspace(0, n, K + 1).astype(int)
    ZX, Ze = Z.T @ X, Z.T @ e
    d = []
    for k in range(K):
        out = (idx >= edges[k]) & (idx < edges[k + 1])
        A = ZX - Z[out].T @ X[out]
        b = Ze - Z[out].T @ e[out]
        d.append(np.linalg.lstsq(A, b, rcond=None)[0])
    d = np.asarray(d)
    dev = d - d.mean(axis=0)
    return (K - 1) / K * dev.T @ dev, _T95.get(K - 1, 1.96)


#: two-sided 95 % quantiles of Student's t (Abramowitz and Stegun 1964, table 26.10)
_T95 = {1: 12.706, 2: 4.303, 3: 3.182, 4: 2.776, 5: 2.571, 6: 2.447, 7: 2.365, 8: 2.306, 9: 2.262,
        10: 2.228, 11: 2.201, 12: 2.179, 14: 2.145, 19: 2.093}
