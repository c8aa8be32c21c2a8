"""The fitted model's parameters re-adjusted beside the flexible stage's trees (backfitting).

The residual the flexible stage fits (:mod:`.flexible`) is what the fitted model left: the
library effects and discovered terms were fitted before the stage, without the force nobody
listed, and they may have taken part of it on their own columns (a rotor inertia taking part
of a force keyed on another joint's acceleration, in proportion to its own joint's
acceleration).  What is left is then no function of the force's inputs alone, and trees on
those inputs explain less of it than the force does.

Here each fitted parameter that acts on the channel gives a column: what the channel's residual
becomes when the parameter is taken out of the fit (its contribution; for a parameter acting
linearly it spans the same line as its derivative) and, for one that does not act linearly, its
derivative's part off that line (:func:`fitted_columns`; a parameter the core refuses to take
out or move gives none).  The trees and a linear refit of those columns are fitted in turn
(backfitting; Hastie & Tibshirani 1990, ch. 4; Breiman & Friedman 1985), per fold of the stage's
blocked cross-validation on the fold's fitted rows only (:func:`backfit_cv`): the refit on the
residual less the trees' prediction, the trees on the residual less the refit.  Every sample is
predicted, trees plus refit, by a model that never saw it.  It is tried once inputs are named,
when a linear refit of the columns on what the trees leave adds :data:`LINEAR_MIN` out of fold,
and kept when it beats the trees alone as an added input must (:func:`readjusted`).

The share the stage then reports is 1 - MSE(residual - out-of-fold prediction) / var(residual)
with the refit in the prediction: what the force explains with the fitted model's parameters
free to move beside it.  It is the measure of the truth's share in ``bench/flexible_bench.py``,
whose predictor is the hidden force less what the fitted model took of it (g = force -
(residual before - residual after)): where the fitted model took part of the force, g is no
function of the force's inputs alone either.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .cv import CV, at, first_trees, grow

#: backfitting rounds after the trees on the residual alone (each: a linear refit per fold, then the trees)
ROUNDS = 2
#: a column acts on a channel when its RMS there is at least this share of the channel residual's RMS
ACTS = 1e-3
#: a derivative is kept beside a contribution when its part not on the contribution's line is at
#: least this share of it (the parameter does not act linearly)
NONLINEAR = 1e-3
#: a backfit is tried only when a linear refit of the columns adds this share of the variance out
#: of fold to the trees' prediction (no trees fitted)
LINEAR_MIN = 0.01
#: relative ridge of the linear refit (columns scaled to unit RMS): a discovered term's columns are
#: nearly collinear (tuning case report6 11120: out of fold -10.5 at 1e-6, 0.56 at 1e-2, trees alone 0.53)
RIDGE = 1e-2


def fitted_columns(eng, theta, channels) -> dict:
    """The fitted model's columns on each residual channel of ``channels`` (0-based) at
    ``theta``: per parameter that acts on the channel, the change of the residual
    (``eng.R``, decimated samples x channels) when it is taken out of the fit and, where the
    parameter does not act linearly (its derivative, central differences through the core, is
    off that line), the derivative's part off it.  Returns per channel ``(J (n, p), names)``;
    ``(n, 0)`` where no parameter acts.

    Example
    -------
    >>> cols = fitted_columns(eng, theta, [2])                        # doctest: +SKIP
    >>> cols[2][1]                                                    # doctest: +SKIP
    ['rail[3].effort_max', 'rail[3].effort_max (derivative)']
    """
    if not len(channels):  # (each parameter costs a residual of the core: none without a channel to read it)
        return {}
    base = np.asarray(eng.R(theta), float)
    scale = np.maximum(np.sqrt(np.mean(base ** 2, axis=0)), 1e-300)
    out = {c: ([], []) for c in channels}
    for p, v in theta.items():
        Rw = residual_at(eng, {k: w for k, w in theta.items() if k != p})
        if Rw is None:
            continue  # it cannot be taken out
        took = Rw - base
        acts = [c for c in channels if np.sqrt(np.mean(took[:, c] ** 2)) >= ACTS * scale[c]]
        d = _derivative(eng, theta, p, float(v), base) if acts else None
        for c in acts:
            out[c][0].append(took[:, c])
            out[c][1].append(p)
            if d is None:
                continue
            t = took[:, c]
            off = d[:, c] - t * float(d[:, c] @ t) / float(t @ t)
            if np.linalg.norm(off) >= NONLINEAR * np.linalg.norm(d[:, c]):
                out[c][0].append(off)  # the derivative's part off the contribution's line
                out[c][1].append(f"{p} (derivative)")
    return {c: (np.column_stack(J) if J else np.zeros((len(base), 0)), names) for c, (J, names) in out.items()}


def residual_at(eng, theta):
    """The residual at ``theta``, or None where the core cannot evaluate it: beside an invalid
    parameter set or a reading outside a stroke (``try_R``), a parameter taken out or moved may
    leave a model the core refuses along the recording (a drive whose effort terms self-lock,
    a delay beyond the pipeline's shifts); that column is left out."""
    from ...errors import PkmError
    from ..residuals import DiagnosisError

    try:
        return eng.R(theta)
    except (PkmError, DiagnosisError):
        return None


def _derivative(eng, theta, p, v, base):
    """Central difference of the residual in parameter ``p`` at ``v`` (one-sided where one side
    is no valid parameter set; ``base`` the residual at ``theta``); None when neither side is."""
    h = 1e-3 * abs(v) if v != 0 else 1e-4
    hi = residual_at(eng, dict(theta, **{p: v + h}))
    lo = residual_at(eng, dict(theta, **{p: v - h}))
    if hi is not None and lo is not None:
        return (hi - lo) / (2 * h)
    if hi is not None or lo is not None:
        return (hi - base) / h if hi is not None else (base - lo) / h
    return None


@dataclass(frozen=True)
class BackfitCV(CV):
    """A blocked cross-validation of trees plus a linear refit of the fitted model's columns:
    ``pred`` is their sum out of fold, ``linear`` the refit's part of it (per sample, by its
    held-out fold's refit), ``coef`` the refit per fold (columns scaled to unit RMS), ``scale``
    the columns' RMS.  ``models`` are the trees, fitted per fold on the residual less the fold's
    refit."""

    linear: np.ndarray = None
    coef: tuple = ()
    scale: np.ndarray = None

    def trees(self, y) -> tuple:
        """``(cross-validation of the trees alone, y less the refit)`` on the same folds: what
        :func:`~.cv.importance` reads (its held-out error is this one's)."""
        return CV(self.folds, self.models, self.iterations, self.pred - self.linear, self.mse), y - self.linear

    def less_refit(self, y, J) -> np.ndarray:
        """``y`` less the refit at every sample (the folds' refits averaged): what the trees on
        every sample are fitted on (:func:`~.cv.final_model`)."""
        return y - (J / np.where(self.scale > 0, self.scale, 1.0)) @ np.mean(self.coef, axis=0)


def _refit(J, r, ridge=RIDGE):
    """Least squares of ``r`` on the columns ``J`` (scaled to unit RMS), a relative ridge; the
    least-norm solution where the system is singular (columns that are zero on these rows, as a
    fitted effect's columns can be on one fold's fitted rows: the ridge is relative, so it is zero too)."""
    G = J.T @ J
    A, b = G + ridge * np.trace(G) / max(len(G), 1) * np.eye(len(G)), J.T @ r
    try:
        return np.linalg.solve(A, b)
    except np.linalg.LinAlgError:
        return np.linalg.lstsq(A, b, rcond=None)[0]


def linear_gain(J, y, cv) -> float:
    """The share of ``y``'s variance a linear refit of the columns ``J`` adds out of fold to the
    trees' out-of-fold prediction ``cv.pred``: per fold, fitted on the fold's fitted rows to what
    the trees' held-out predictions leave there (no trees fitted: a cheap sign of whether
    backfitting can add anything)."""
    if J.shape[1] == 0:
        return 0.0
    scale = np.sqrt(np.mean(J ** 2, axis=0))
    Js = J / np.where(scale > 0, scale, 1.0)
    r = y - cv.pred
    pred = np.zeros(len(y))
    for held, fit in cv.folds:
        pred[held] = Js[held] @ _refit(Js[fit], r[fit])
    return float((np.mean(r ** 2) - np.mean((r - pred) ** 2)) / np.var(y))


def backfit_cv(X, y, J, cv, rounds=ROUNDS) -> BackfitCV:
    """Trees on ``X`` and a linear refit of the fitted model's columns ``J`` (:func:`fitted_columns`)
    fitted in turn per fold of ``cv`` (the trees' cross-validation on ``y`` alone, its first
    round): the refit on the fold's fitted rows less the trees' prediction there, then the trees on
    the residual less the refit, ``rounds`` times.  Judged out of fold: every sample predicted by
    its held-out fold's trees plus refit."""
    scale = np.sqrt(np.mean(J ** 2, axis=0))
    Js = J / np.where(scale > 0, scale, 1.0)
    models, iters = list(cv.models), cv.iterations
    coef = [np.zeros(J.shape[1]) for _ in cv.folds]
    for _ in range(rounds):
        Y = np.empty((len(y), len(cv.folds)))
        for b, (held, fit) in enumerate(cv.folds):
            inside = first_trees(models[b], at(X, b)[fit], iters)
            coef[b] = _refit(Js[fit], y[fit] - inside)
            Y[:, b] = y - Js @ coef[b]
        models, iters, held_pred = grow(X, Y, cv.folds)
    pred, linear = np.empty(len(y)), np.empty(len(y))
    for b, (held, _) in enumerate(cv.folds):
        linear[held] = Js[held] @ coef[b]
        pred[held] = held_pred[b] + linear[held]
    return BackfitCV(cv.folds, tuple(models), iters, pred, float(np.mean((y - pred) ** 2)),
                     linear=linear, coef=tuple(coef), scale=scale)


def readjusted(X, y, fitted, cv):
    """The trees on ``X`` with the fitted model re-adjusted beside them (:func:`backfit_cv`), when
    that beats the trees alone (``cv``, on ``y``): by :data:`~.select.DROP_MIN` of the
    variance, above :data:`~.select.GAIN_Z` standard errors over the folds
    (:func:`~.select.gain`, the test of an added input).  ``fitted`` is ``(J, names)``
    of :func:`fitted_columns`.  Returns ``(cross-validation, the re-adjusted parameters)``, or
    ``(cv, ())`` when there is none to re-adjust, when a linear refit of the columns on what the
    trees leave adds under :data:`LINEAR_MIN` out of fold (no trees fitted), or when it does not
    beat them."""
    from .select import gain

    J, names = fitted if fitted is not None else (np.zeros((len(y), 0)), [])
    if J.shape[1] == 0 or linear_gain(J, y, cv) < LINEAR_MIN:
        return cv, ()
    cv_b = backfit_cv(X, y, J, cv)
    if not gain(cv, cv_b, y, float(np.var(y)))[1]:
        return cv, ()
    return cv_b, tuple(dict.fromkeys(n.replace(" (derivative)", "") for n in names))


def stage_columns(eng, theta, stand_ins, channels) -> dict:
    """:func:`fitted_columns` of the flexible stage's ``channels`` at the fitted ``theta``; on a
    channel whose partial discovered term is set aside (``stand_ins``: channel -> term), at
    ``theta`` without that term's parameters (the rest is re-adjusted, not the stand-in)."""
    if not theta:
        return {}
    out = fitted_columns(eng, theta, [c for c in channels if c not in stand_ins])
    for c in channels:
        if c in stand_ins:
            drop = set(stand_ins[c].params())
            out.update(fitted_columns(eng, {k: v for k, v in theta.items() if k not in drop}, [c]))
    return out
