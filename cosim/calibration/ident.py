"""Identifiability of calibration parameters (Tiberi 2020 ch. 3.1).

Given a regression matrix J (rows: measurements, columns: parameter errors; Delta y = J
Delta eta, Tiberi 2020 eq. 3.4) this module answers which parameters can be identified from
those measurements, which only in combination with others (and which combination), and
how well conditioned the problem is:

* column scaling ``J H``, ``h_j = 1 / ||j_j||`` (1 for a zero column), eq. 3.13-3.14, so
  that singular values of parameters with different units can be compared;
* QR of the scaled matrix in the error-model order (a near-zero ``R_jj`` means column j
  is a combination of the columns before it, the check of Tiberi 2020 ch. 4.2) and with column
  pivoting (numerical rank and a well-conditioned subset);
* SVD: singular values, condition number ``k = mu_1 / mu_r`` (eq. 3.10) and the null
  space (the parameter combinations the measurements cannot see);
* the structural model (3.1.1): while ``k > cond_max`` (100), drop the parameter that
  dominates the right singular vector of the smallest singular value;
* the prediction model (3.1.2): keep every parameter, discard the singular directions
  with ``mu_j < mu_1 / cond_max`` (truncated SVD).

For a dropped parameter d the retained estimates absorb it: with J_d = J_K b (b the least
squares fit of its column on the retained ones), ``Delta y = J_K (Delta eta_K + b Delta eta_d)``,
so what is identified is the combination ``Delta eta_K + b Delta eta_d``
(:meth:`IdentifiabilityReport.combination_values`).

Everything here is linear algebra on a given J; the physics (the columns) comes from the
core through the calibration problems of :mod:`cosim.calibration.problems`.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla

from ..errors import InputError

__all__ = [
    "column_scale",
    "identifiability",
    "IdentifiabilityReport",
    "BlockReport",
    "Elimination",
    "Combination",
]

#: relative singular value below which a direction counts as not identifiable at all
#: (rank deficiency), as opposed to merely ill-conditioned (cond_max)
RANK_RTOL = 1e-8
#: relative singular value below which a direction is flagged as nearly not identifiable:
#: at the level of the perturbation that measurement noise puts into the regressors
#: themselves (J is evaluated at measured poses)
NEAR_RANK_RTOL = 1e-3


def column_scale(J: np.ndarray) -> np.ndarray:
    """Tiberi 2020 eq. 3.13: ``h_j = 1/||j_j||``, or 1 for a zero column."""
    n = np.linalg.norm(J, axis=0)
    return np.where(n > 0, 1.0 / np.where(n > 0, n, 1.0), 1.0)


def _cond(s: np.ndarray) -> float:
    if s.size == 0:
        return 1.0
    return float(s[0] / s[-1]) if s[-1] > 0 else float("inf")


def _dominant(v: np.ndarray) -> int:
    """Index of the entry of largest magnitude; near-ties (1e-6) go to the later parameter.

    Exact ties happen when two columns are equal up to sign (X and S0x in the seed's
    world-frame rows).  Dropping the later one keeps the error model's order meaning
    "expressed by the earlier columns", as in the unpivoted QR check.
    """
    a = np.abs(v)
    top = a.max()
    return int(np.flatnonzero(a >= top * (1 - 1e-6))[-1])


@dataclass
class Elimination:
    """One step of the condition-number loop (Tiberi 2020 3.1.1)."""

    dropped: str
    cond_before: float
    singular_value: float
    vr: dict  # entries of the right singular vector of the smallest singular value


@dataclass
class Combination:
    """A dropped parameter and what the retained estimates absorb of it."""

    parameter: str
    coefficients: dict  # retained name -> b_k: the estimate of k is Delta k + b_k Delta parameter
    residual: float  # ||J_d - J_K b|| / ||J_d||: 0 = exact combination (not identifiable), > 0 only ill-conditioned

    def text(self) -> str:
        kind = "not identifiable" if self.residual < 1e-6 else f"ill-conditioned (fit residual {self.residual:.2g})"
        parts = ", ".join(f"{k} absorbs {c:+.4g} x d{self.parameter}" for k, c in self.coefficients.items())
        return f"{self.parameter}: {kind}; " + (parts if parts else "absorbed by no retained parameter")


@dataclass
class BlockReport:
    """Identifiability of one independent block of parameters (e.g. one 6-PUS leg)."""

    label: str
    names: list
    units: list
    nrows: int
    scale: np.ndarray
    qr_diag: np.ndarray  # |R_jj| of the scaled J in error-model order, relative to |R_00|
    pivot_order: list
    pivot_diag: np.ndarray  # |R_jj| with column pivoting, relative
    singular_values: np.ndarray  # of the scaled J, descending
    rank: int
    cond_unscaled: float
    cond_scaled: float
    null_space: list  # list of dict name -> coefficient (physical units), one per null direction
    eliminations: list
    retained: list
    cond_after: float
    combinations: list
    prediction_kept: int  # singular directions kept by the prediction model
    prediction_dropped: list  # dict name -> coefficient of each discarded direction (scaled)
    warnings: list = field(default_factory=list)

    @property
    def not_identifiable(self) -> list:
        """Parameters whose columns are exact combinations of retained ones (rank deficiency)."""
        return [c.parameter for c in self.combinations if c.residual < 1e-6]

    @property
    def ill_conditioned(self) -> list:
        """Parameters dropped only because the condition number exceeded the limit."""
        return [c.parameter for c in self.combinations if c.residual >= 1e-6]

    def text(self, cond_max: float = 100.0) -> str:
        L = []
        L.append(f"[{self.label}] {self.nrows} equations, {len(self.names)} parameters, rank {self.rank}")
        L.append(f"  cond(J) = {self.cond_unscaled:.4g} unscaled, {self.cond_scaled:.4g} with column scaling")
        small = [f"{n} {d:.1e}" for n, d in zip(self.names, self.qr_diag) if d < 1e-6]
        if small:
            L.append("  QR in error-model order: near-zero |R_jj| (column is a combination of earlier ones): "
                     + ", ".join(small))
        sv = ", ".join(f"{s:.3g}" for s in self.singular_values)
        L.append(f"  singular values (scaled): {sv}")
        for k, v in enumerate(self.null_space):
            terms = " ".join(f"{c:+.4g}*{n}" for n, c in v.items())
            L.append(f"  null direction {k + 1} (invisible to the measurements): {terms}")
        for e in self.eliminations:
            top = sorted(e.vr.items(), key=lambda t: -abs(t[1]))[:4]
            vr = ", ".join(f"{n} {c:+.3f}" for n, c in top)
            L.append(f"  cond {e.cond_before:.4g} > {cond_max:g}: drop {e.dropped} (v_r: {vr})")
        L.append(f"  structural model: {len(self.retained)} identifiable parameters, cond {self.cond_after:.4g}: "
                 + ", ".join(self.retained))
        for c in self.combinations:
            L.append("  " + c.text())
        L.append(f"  prediction model: {self.prediction_kept} of {len(self.names)} singular directions kept "
                 f"(mu_j >= mu_1/{cond_max:g}), {self.rank - self.prediction_kept} ill-conditioned and "
                 f"{len(self.names) - self.rank} null directions discarded")
        for v in self.prediction_dropped:
            terms = " ".join(f"{c:+.3f}*{n}" for n, c in v.items())
            L.append(f"    ill-conditioned direction (a combination the data barely sees): {terms}")
        for w in self.warnings:
            L.append("  warning: " + w)
        return "\n".join(L)


@dataclass
class IdentifiabilityReport:
    """Identifiability of a whole parameter set, block by block."""

    names: list
    blocks: list
    cond_max: float

    @property
    def retained(self) -> list:
        return [n for b in self.blocks for n in b.retained]

    @property
    def dropped(self) -> list:
        return [c.parameter for b in self.blocks for c in b.combinations]

    @property
    def not_identifiable(self) -> list:
        return [n for b in self.blocks for n in b.not_identifiable]

    @property
    def warnings(self) -> list:
        return [f"[{b.label}] {w}" for b in self.blocks for w in b.warnings]

    @property
    def cond_before(self) -> float:
        return max(b.cond_scaled for b in self.blocks)

    @property
    def cond_after(self) -> float:
        return max(b.cond_after for b in self.blocks)

    def retained_mask(self) -> np.ndarray:
        keep = set(self.retained)
        return np.array([n in keep for n in self.names])

    def combination_values(self, delta: dict) -> dict:
        """What the structural model identifies, given the true parameter errors ``delta``.

        Returns ``{retained: delta[retained] + sum_d b_{retained,d} delta[d]}`` over the
        dropped parameters d (the identifiable combinations).  Used to check estimates
        against a known truth.
        """
        out = {n: float(delta.get(n, 0.0)) for n in self.retained}
        for b in self.blocks:
            for c in b.combinations:
                for k, coef in c.coefficients.items():
                    out[k] += coef * float(delta.get(c.parameter, 0.0))
        return out

    def text(self) -> str:
        L = [f"Identifiability: {len(self.names)} parameters in {len(self.blocks)} independent block(s); "
             f"condition number limit {self.cond_max:g}"]
        for b in self.blocks:
            L.append(b.text(self.cond_max))
        L.append(f"Overall: {len(self.retained)} identifiable, {len(self.dropped)} dropped "
                 f"({len(self.not_identifiable)} not identifiable at all); worst cond {self.cond_before:.4g} -> "
                 f"{self.cond_after:.4g}")
        return "\n".join(L)


def _null_basis(Vt: np.ndarray, s: np.ndarray, h: np.ndarray, names, rtol) -> tuple[list, list]:
    """Null directions in physical units, in reduced form (a unit coefficient on one
    parameter each) so that a multi-dimensional null space reads as simple combinations."""
    tol = rtol * (s[0] if s.size else 0.0)
    n = Vt.shape[1]
    null = Vt[np.flatnonzero(np.concatenate([s, np.zeros(n - s.size)]) <= tol)] if s.size else Vt
    if null.shape[0] == 0:
        return [], []
    N = (null * h).T  # physical directions, columns
    # pivoted QR on N^T picks well-separated pivot parameters; prefer later parameters on
    # ties by reversing the column order
    rev = N[::-1].T
    _, _, piv = sla.qr(rev, pivoting=True, mode="economic")
    k = N.shape[1]
    pivots = sorted(n - 1 - piv[:k])
    Nr = N @ np.linalg.inv(N[pivots, :])  # column j has a unit coefficient on pivots[j]
    out = []
    for j in range(k):
        v = Nr[:, j]
        big = np.abs(v) > 1e-9 * np.abs(v).max()
        out.append({names[i]: float(v[i]) for i in np.flatnonzero(big)})
    return out, [names[p] for p in pivots]


def _block(J, names, units, label, cond_max, rank_rtol) -> BlockReport:
    m, n = J.shape
    warnings = []
    if m < n:
        warnings.append(f"only {m} equations for {n} parameters: at most {m} combinations can be identified")
    h = column_scale(J)
    Js = J * h
    zero = [names[j] for j in range(n) if not np.any(J[:, j])]
    if zero:
        warnings.append("zero columns (these parameters have no effect on the measurements): " + ", ".join(zero))
    s_un = np.linalg.svd(J, compute_uv=False) if m and n else np.zeros(0)
    # V must span all n columns (null space included); U is not needed at all
    _, s, Vt = np.linalg.svd(Js, full_matrices=m < n) if m and n else (None, np.zeros(0), np.eye(n))
    rank = int(np.sum(s > rank_rtol * s[0])) if s.size else 0
    # QR in the error-model order (Tiberi 2020 ch. 4.2) and with pivoting
    R = sla.qr(Js, mode="r")[0] if m and n else np.zeros((0, n))
    d = np.abs(np.diag(R)) if R.size else np.zeros(0)
    qr_diag = np.concatenate([d, np.zeros(n - d.size)]) / (d[0] if d.size and d[0] > 0 else 1.0)
    Rp, piv = sla.qr(Js, mode="r", pivoting=True) if m and n else (np.zeros((0, n)), np.arange(n))
    dp = np.abs(np.diag(Rp))
    pivot_diag = np.concatenate([dp, np.zeros(n - dp.size)]) / (dp[0] if dp.size and dp[0] > 0 else 1.0)
    null, _ = _null_basis(Vt, s, h, names, rank_rtol)
    if rank < n:
        warnings.append(f"rank-deficient: the measurements determine only {rank} of {n} parameter combinations")
    near = [k for k in range(rank) if s[k] < NEAR_RANK_RTOL * s[0]]
    if near:
        dirs = []
        for k in near:
            v = Vt[k] * h
            v = v / np.abs(v).max()
            dirs.append(" ".join(f"{v[i]:+.2f}*{names[i]}" for i in np.argsort(-np.abs(v)) if abs(v[i]) > 0.2))
        warnings.append(f"nearly rank-deficient: {len(near)} direction(s) with mu/mu_1 < {NEAR_RANK_RTOL:g}, "
                        f"barely above the noise in the regressors (practically not identifiable): " + "; ".join(dirs))

    # Structural model: the condition-number elimination loop (3.1.1).
    keep = list(range(n))
    elim = []
    while len(keep) > 1:
        _, sk, Vk = np.linalg.svd(Js[:, keep], full_matrices=False)
        ck = _cond(sk) if sk.size == len(keep) else float("inf")
        if ck <= cond_max:
            break
        vr = Vk[-1] if sk.size == len(keep) else sla.null_space(Js[:, keep])[:, -1]
        j = _dominant(vr)
        elim.append(Elimination(names[keep[j]], ck, float(sk[-1]) if sk.size == len(keep) else 0.0,
                                {names[keep[i]]: float(vr[i]) for i in range(len(keep))}))
        del keep[j]
    sk = np.linalg.svd(Js[:, keep], compute_uv=False) if keep else np.zeros(0)
    cond_after = _cond(sk)
    combos = []
    dropped = [j for j in range(n) if j not in keep]
    if dropped and keep:
        JK = J[:, keep]
        for j in dropped:
            b, *_ = np.linalg.lstsq(JK, J[:, j], rcond=None)
            nj = np.linalg.norm(J[:, j])
            res = float(np.linalg.norm(J[:, j] - JK @ b) / nj) if nj > 0 else 0.0
            # report coefficients that matter in scaled terms
            bs = b * np.linalg.norm(JK, axis=0) / (nj if nj > 0 else 1.0)
            coef = {names[keep[i]]: float(b[i]) for i in range(len(keep)) if abs(bs[i]) > 1e-3}
            combos.append(Combination(names[j], coef, res))
    # Prediction model (3.1.2): truncated SVD
    kept = int(np.sum(s >= s[0] / cond_max)) if s.size else 0
    pred_dropped = []
    for v in Vt[kept:max(kept, rank)]:  # the exact null directions are listed above
        big = np.abs(v) >= 0.2 * np.abs(v).max()
        pred_dropped.append({names[i]: float(v[i]) for i in np.argsort(-np.abs(v)) if big[i]})
    return BlockReport(
        label=label, names=list(names), units=list(units), nrows=m, scale=h, qr_diag=qr_diag,
        pivot_order=[names[p] for p in piv], pivot_diag=pivot_diag, singular_values=s,
        rank=rank, cond_unscaled=_cond(s_un) if s_un.size == n else float("inf"),
        cond_scaled=_cond(s) if s.size == n else float("inf"), null_space=null, eliminations=elim,
        retained=[names[j] for j in keep], cond_after=cond_after, combinations=combos,
        prediction_kept=kept, prediction_dropped=pred_dropped, warnings=warnings,
    )


def identifiability(J, names, units=None, cond_max: float = 100.0, blocks=None,
                    rank_rtol: float = RANK_RTOL) -> IdentifiabilityReport:
    """Identifiability analysis of a regression matrix.

    Parameters
    ----------
    J : array_like, shape (m, n)
        Regression matrix: d(measurement)/d(parameter), in physical units.
    names : list of str, length n
        Parameter names (columns).
    units : list of str, optional
    cond_max : float
        Condition-number limit of the structural model (Tiberi 2020: 100).
    blocks : list of (label, row_indices, column_indices), optional
        Independent blocks (J is block diagonal, e.g. the six 6-PUS legs, Tiberi 2020
        eq. 4.7); each is analysed on its own.  Default: one block.
    rank_rtol : float
        Singular values below ``rank_rtol * mu_1`` count as zero (not identifiable).

    Raises
    ------
    ValueError
        On a J with NaN/Inf entries (naming the first row and column) or a size mismatch.
    """
    J = np.asarray(J, dtype=float)
    if J.ndim != 2:
        raise InputError(f"regression matrix must be 2-D, got shape {J.shape}")
    names = list(names)
    if J.shape[1] != len(names):
        raise InputError(f"regression matrix has {J.shape[1]} columns but {len(names)} parameter names")
    bad = np.argwhere(~np.isfinite(J))
    if bad.size:
        r, c = bad[0]
        raise InputError(f"regression matrix row {r}, column {names[c]!r} is not finite ({J[r, c]!r})")
    units = list(units) if units is not None else [""] * len(names)
    if blocks is None:
        blocks = [("all", np.arange(J.shape[0]), np.arange(J.shape[1]))]
    reps = []
    for label, rows, cols in blocks:
        rows, cols = np.asarray(rows), np.asarray(cols)
        reps.append(_block(J[np.ix_(rows, cols)], [names[c] for c in cols], [units[c] for c in cols], label,
                           cond_max, rank_rtol))
    return IdentifiabilityReport(names=names, blocks=reps, cond_max=cond_max)
