"""Calibration solvers with one interface (Vitali 2020 ch. 2-3, Tiberi 2020 eq. 3.6).

``solve(problem, method, free=..., ...)`` minimises ``L = ||w (y - predict(p))||^2`` over
the free parameters (w: the problem's row weights, 1 if it has none) and returns a :class:`Solution` with standard errors, so that the methods
can be compared on the same problem:

``"pinv"``
    one pseudo-inverse step from the nominal parameters, ``dp = J^+ (y - f(p0))``
    (Vitali 2020 eq. 2.2, Tiberi 2020 eq. 3.6);
``"pinv-iter"``
    the same step repeated from the new parameters with the Jacobian re-evaluated
    (Tiberi 2020 after eq. 3.6), full steps;
``"gauss-newton"``
    the Gauss-Newton step ``J^T J p = J^T e`` (Vitali 2020 eq. 3.9) with a step length alpha
    halved until L decreases (Vitali 2020 eq. 3.2-3.3);
``"lm"``
    Levenberg-Marquardt (Vitali 2020 eq. 3.10) by ``scipy.optimize.least_squares``
    (MINPACK) with the analytic Jacobian;
``"golden"``
    derivative-free direct search (Vitali 2020 ch. 3.1): a golden-section line search on
    one coordinate at a time within ``p_j +- width_j``, sweeping the coordinates until no
    coordinate moves.  ``basis="svd"`` searches along the principal axes of the scaled
    Jacobian at the start instead of along the parameters, which decouples a quadratic
    cost (for an ill-conditioned problem the plain coordinate search crawls).

Linear steps are solved by SVD of the column-scaled Jacobian (Tiberi 2020 eq. 3.13), with
singular values below ``rcond * mu_1`` discarded: ``rcond = 1/cond_max`` is the prediction
model of Tiberi 2020 3.1.2; the default keeps everything numerically non-zero.

Standard errors at the solution, per independent block if the problem has blocks: by
default the heteroscedasticity-consistent sandwich estimate (HC2), because the noise of
the equations differs from pose to pose (see ``_covariance``); ``se="ols"`` gives the
classical ``sigma^2 (J^T J)^+`` with ``sigma^2 = ||r||^2 / (m - k)`` (k = the number of
identified directions).  Fixed (not free)
parameters have a standard error of 0; a block with no more equations than identified
directions has no noise estimate: its standard errors are ``inf``.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from .ident import column_scale
from ..errors import InputError

__all__ = ["METHODS", "Solution", "solve"]

METHODS = ("pinv", "pinv-iter", "gauss-newton", "lm", "golden")

_GOLD = (np.sqrt(5.0) - 1.0) / 2.0  # 0.618..., Vitali 2020: d2 = 2/(1 + sqrt 5) d1


@dataclass
class Solution:
    """Result of one solver run (parameters in the problem's coordinates and units)."""

    method: str
    names: list
    p0: np.ndarray
    p: np.ndarray
    free: np.ndarray  # bool mask of the estimated parameters
    iterations: int
    nfev: int
    cost: list  # L = ||w r||^2 after each iteration, starting with L(p0) (w: the problem's row weights)
    converged: bool
    message: str
    se: np.ndarray  # standard errors (0 for fixed parameters)
    cov: np.ndarray  # covariance of the free parameters
    sigma: np.ndarray  # residual standard deviation (per block, or one value)
    rank: int  # identified directions
    seconds: float
    residual: np.ndarray = field(repr=False, default=None)  # y - f(p), unweighted
    rms0: float = 0.0  # RMS of the unweighted residual at p0

    @property
    def dp(self) -> np.ndarray:
        return self.p - self.p0

    @property
    def rms_before(self) -> float:
        """RMS of the (unweighted) residual at the start [measurement units]."""
        return self.rms0

    @property
    def rms_after(self) -> float:
        """RMS of the (unweighted) residual at the solution."""
        return float(np.sqrt(np.mean(self.residual ** 2))) if self.residual.size else 0.0

    def estimates(self) -> dict:
        """name -> (nominal, estimate, estimate - nominal, standard error) of free parameters."""
        return {n: (float(self.p0[j]), float(self.p[j]), float(self.dp[j]), float(self.se[j]))
                for j, n in enumerate(self.names) if self.free[j]}


def _free_blocks(blocks, fi, m):
    """The problem's independent blocks as (rows, positions among the free columns)."""
    if blocks is None:
        return [(np.arange(m), np.arange(len(fi)))]
    pos = {c: k for k, c in enumerate(fi)}
    out = []
    for _, rows, cols in blocks:
        loc = np.array([pos[c] for c in cols if c in pos], dtype=int)
        if loc.size:
            out.append((np.asarray(rows), loc))
    return out


def _step(J, r, rcond, fblocks):
    """Least-squares step dp = J^+ r by SVD of the column-scaled J, truncated at rcond.

    A block-diagonal J (independent legs) is solved block by block: the same result,
    and small SVDs stay fast where a threaded BLAS on a busy machine is not."""
    dp = np.zeros(J.shape[1])
    rank = 0
    for rows, loc in fblocks:
        Jb = J[np.ix_(rows, loc)]
        h = column_scale(Jb)
        U, s, Vt = np.linalg.svd(Jb * h, full_matrices=False)
        if s.size == 0 or s[0] == 0:
            continue
        keep = s > rcond * s[0]
        dp[loc] = h * (Vt[keep].T @ ((U[:, keep].T @ r[rows]) / s[keep]))
        rank += int(keep.sum())
    return dp, rank


def _covariance(J, r, rcond, fblocks, se="hc2"):
    """Per-block sigma and the covariance of the free parameters.

    ``se="ols"``: sigma^2 (J^T J)^+, right when every equation has the same noise.
    ``se="hc2"``: the heteroscedasticity-consistent (sandwich) estimate
    J^+ diag(r_i^2 / (1 - h_i)) J^+T, h_i the leverage of equation i (MacKinnon and
    White's HC2, unbiased when the variances happen to be equal).  The 6-PUS needs it: tracker noise reaches the strokes through the
    inverse-kinematic Jacobian, which differs from pose to pose (much larger near the
    edge of a leg's reach), so the equations do not share one variance.
    """
    nfree = J.shape[1]
    cov = np.zeros((nfree, nfree))
    sig, rank_total = [], 0
    for rows, ix in fblocks:
        Jb = J[np.ix_(rows, ix)]
        h = column_scale(Jb)
        U, s, Vt = np.linalg.svd(Jb * h, full_matrices=False)
        keep = s > rcond * s[0] if s.size and s[0] > 0 else np.zeros(s.size, bool)
        k = int(keep.sum())
        rank_total += k
        dof = len(rows) - k
        rb = r[rows]
        if dof <= 0:
            # no redundant equation: the residual says nothing about the noise
            sig.append(np.inf)
            cov[np.ix_(ix, ix)] = np.diag(np.full(len(ix), np.inf))
            continue
        s2 = float(rb @ rb) / dof
        sig.append(np.sqrt(s2))
        G = h[:, None] * (Vt[keep].T * (1.0 / s[keep]))  # parameters per unit of U^T r
        Uk = U[:, keep]
        if se == "ols":
            cov[np.ix_(ix, ix)] = G @ G.T * s2
        else:
            lev = np.sum(Uk ** 2, axis=1)
            w = rb ** 2 / np.maximum(1.0 - lev, 1e-12)
            cov[np.ix_(ix, ix)] = G @ ((Uk.T * w) @ Uk) @ G.T
    return np.array(sig), cov, rank_total


def _golden_1d(f, a, b, tol, fa_cache=None):
    """Golden-section minimum of f on [a, b] to width tol (Vitali 2020 ch. 3.1)."""
    d = _GOLD * (b - a)
    xa, xb = b - d, a + d  # seed: delta_A = max - d2, delta_B = min + d2
    fa, fb = f(xa), f(xb)
    n = 2
    while (b - a) > tol and n < 200:
        if fa < fb:  # keep [min, delta_B]
            b, xb, fb = xb, xa, fa
            xa = b - _GOLD * (b - a)
            fa = f(xa)
        else:  # keep [delta_A, max]
            a, xa, fa = xa, xb, fb
            xb = a + _GOLD * (b - a)
            fb = f(xb)
        n += 1
    return (xa, fa, n) if fa < fb else (xb, fb, n)


class _Cost:
    """The weighted cost L = |w r|^2 of a problem, counting its evaluations."""

    def __init__(self, problem):
        self.problem, self.nfev, self.first = problem, 0, None

    def __call__(self, p):
        self.nfev += 1
        r = self.problem.wresidual(p)
        L = float(r @ r)
        if self.first is None:
            self.first = L
        return L, r


def _linear_steps(problem, method, p, L, r, fi, cost, rcond, fblocks, tol, prior, max_iter):
    """pinv (one step), pinv-iter (full steps) and Gauss-Newton (a step halved until L decreases,
    Vitali 2020 eq. 3.3) from p: (p, L, r, the costs after each step, iterations, converged,
    message)."""
    iters = 1 if method == "pinv" else max_iter
    costs, it = [], 0
    for it in range(1, iters + 1):
        J = problem.wjacobian(p)[:, fi]
        dp, _ = _step(J, r, rcond, fblocks)
        alpha = 1.0
        if method == "gauss-newton":
            # Vitali 2020 eq. 3.3: accept only a step that lowers L
            for _ in range(30):
                Lt, rt = cost(_with(p, fi, dp * alpha))
                if Lt < L:
                    break
                alpha *= 0.5
            else:
                return p, L, r, costs, it, True, "no step lowers L further (at the numerical floor)"
        else:
            Lt, rt = cost(_with(p, fi, dp))
        p = _with(p, fi, dp * alpha)
        small_step = np.all(np.abs(dp * alpha) <= tol * prior)
        small_gain = abs(L - Lt) <= tol * max(L, 1e-300)
        L, r = Lt, rt
        costs.append(L)
        if method == "pinv":
            return p, L, r, costs, it, True, "one pseudo-inverse step"
        if small_step or small_gain:
            return p, L, r, costs, it, True, "step below tolerance" if small_step else "L no longer decreases"
    return p, L, r, costs, it, False, f"not converged after {iters} iterations"


def _levenberg_marquardt(problem, p0, fi, cost, max_iter):
    """Levenberg-Marquardt (MINPACK through scipy) with the analytic Jacobian, from p0."""
    from scipy.optimize import least_squares

    def fun(x):
        cost.nfev += 1
        return -problem.wresidual(_set(p0, fi, x))

    def jac(x):
        return problem.wjacobian(_set(p0, fi, x))[:, fi]

    res = least_squares(fun, p0[fi], jac=jac, method="lm", x_scale="jac", xtol=1e-15, ftol=1e-15,
                        gtol=1e-15, max_nfev=max(100, 20 * max_iter))
    p = _set(p0, fi, res.x)
    L, r = cost(p)
    return p, L, r, [L], int(res.njev or 0), bool(res.status > 0), res.message


def _golden_search(problem, p0, L, fi, cost, width, prior, tol, basis, max_sweeps):
    """Golden-section line searches along the parameters (or the principal axes of the scaled
    Jacobian, ``basis="svd"``), swept until nothing moves by more than its tolerance."""
    if basis == "svd":
        J0 = problem.wjacobian(p0)[:, fi]
        h = column_scale(J0)
        _, s, Vt = np.linalg.svd(J0 * h, full_matrices=False)
        D = (h[:, None] * Vt.T)  # columns: principal directions in parameter units
        D = D / np.abs(D).max(axis=0)
        half = np.array([np.max(np.abs(D[:, k]) * width) / np.max(np.abs(D[:, k])) for k in range(D.shape[1])])
    elif basis == "parameters":
        D = np.eye(fi.size)
        half = width
    else:
        raise InputError(f"basis must be 'parameters' or 'svd', got {basis!r}")
    tols = tol * np.array([np.max(np.abs(D[:, k]) * prior) for k in range(D.shape[1])]) / \
        np.maximum(np.abs(D).max(axis=0), 1e-300)
    p, costs, converged, message = p0.copy(), [], False, ""
    for it in range(1, max_sweeps + 1):
        moved = 0.0
        for k in range(D.shape[1]):
            base = p.copy()

            def f(t):
                return cost(_with(base, fi, D[:, k] * t))[0]

            t, Lt, _ = _golden_1d(f, -half[k], half[k], tols[k])
            if Lt < L:
                p = _with(base, fi, D[:, k] * t)
                L = Lt
                moved = max(moved, abs(t) / max(tols[k], 1e-300))
        costs.append(L)
        if moved <= 1.0:
            converged, message = True, "no coordinate moves by more than its tolerance"
            break
    else:
        message = f"not converged after {max_sweeps} sweeps (coordinate search on an ill-conditioned cost)"
    L, r = cost(p)
    return p, L, r, costs, it, converged, message


def solve(problem, method: str = "gauss-newton", free=None, p_start=None, rcond: float = 1e-10,
          tol: float = 1e-10, max_iter: int = 50, width=None, basis: str = "parameters",
          max_sweeps: int = 200, se: str = "hc2") -> Solution:
    """Estimate the free parameters of a calibration problem.

    Parameters
    ----------
    problem : cosim.calibration.problems.Problem
    method : {"pinv", "pinv-iter", "gauss-newton", "lm", "golden"}
    free : bool mask or list of names, optional
        Parameters to estimate (default all); the others stay at ``p_start``.
    p_start : array_like, optional
        Starting parameters (default ``problem.p0``, the nominal ones).
    rcond : float
        Singular values of the scaled Jacobian below ``rcond * mu_1`` are discarded
        (``1/cond_max`` gives the prediction model).
    tol : float
        Convergence: every step below ``tol * problem.prior`` (relative to each
        parameter's expected error), or L decreasing by less than ``tol * L``.
    max_iter : int
        Iterations (golden: sweeps are limited by ``max_sweeps``).
    width : array_like, optional
        Golden search half-intervals (default ``2 * problem.prior``).
    basis : {"parameters", "svd"}
        Golden search directions.
    se : {"hc2", "ols"}
        Standard-error estimate (see the module docstring).

    Returns
    -------
    Solution
    """
    if method not in METHODS:
        raise InputError(f"unknown calibration method {method!r} (known: {', '.join(METHODS)})")
    if se not in ("hc2", "ols"):
        raise InputError(f"se must be 'hc2' or 'ols', got {se!r}")
    t0 = time.perf_counter()
    n = len(problem.names)
    p0 = np.asarray(problem.p0 if p_start is None else p_start, float).copy()
    if method == "golden" and basis not in ("parameters", "svd"):
        raise InputError(f"basis must be 'parameters' or 'svd', got {basis!r}")
    if free is None:
        mask = np.ones(n, bool)
    elif len(free) and isinstance(next(iter(free)), str):
        unknown = [f for f in free if f not in problem.names]
        if unknown:
            raise InputError(f"unknown parameter(s) {unknown} (calibrated coordinates: {problem.names})")
        mask = np.array([nm in set(free) for nm in problem.names])
    else:
        mask = np.asarray(free, bool)
    fi = np.flatnonzero(mask)
    if fi.size == 0:
        raise InputError("no free parameter to estimate")
    m = problem.nmeas
    if m < fi.size and method in ("lm",):
        raise InputError(f"{m} measurements for {fi.size} free parameters: Levenberg-Marquardt (MINPACK) needs "
                         f"at least as many measurements as parameters")
    prior = np.asarray(problem.prior, float)
    fblocks = _free_blocks(problem.blocks, fi, m)
    cost = _Cost(problem)
    L, r = cost(p0)
    if method in ("pinv", "pinv-iter", "gauss-newton"):
        p, L, r, more, it, converged, message = _linear_steps(problem, method, p0, L, r, fi, cost, rcond, fblocks,
                                                              tol, prior[fi], max_iter)
    elif method == "lm":
        p, L, r, more, it, converged, message = _levenberg_marquardt(problem, p0, fi, cost, max_iter)
    else:
        w = 2.0 * prior if width is None else np.broadcast_to(np.asarray(width, float), (n,)).copy()
        p, L, r, more, it, converged, message = _golden_search(problem, p0, L, fi, cost, w[fi], prior[fi], tol,
                                                               basis, max_sweeps)
    costs = [cost.first] + more
    nfev = cost.nfev
    J = problem.wjacobian(p)[:, fi]
    r_plain = problem.residual(p)
    r0 = problem.residual(p0)
    sigma, cov, rank = _covariance(J, r, rcond, fblocks, se)
    se = np.zeros(n)
    se[fi] = np.sqrt(np.maximum(np.diag(cov), 0.0))
    return Solution(method=method, names=list(problem.names), p0=p0, p=p, free=mask, iterations=it, nfev=nfev,
                    cost=costs, converged=converged, message=message, se=se, cov=cov, sigma=sigma, rank=rank,
                    seconds=time.perf_counter() - t0, residual=r_plain,
                    rms0=float(np.sqrt(np.mean(r0 ** 2))) if r0.size else 0.0)


def _with(p, idx, d):
    q = p.copy()
    q[idx] += d
    return q


def _set(p, idx, v):
    q = p.copy()
    q[idx] = v
    return q
