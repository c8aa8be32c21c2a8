"""A force that switches with the direction of motion, its level set by other inputs: the
flexible stage's trees fitted to the residual folded by the direction (:mod:`.flexible`).

A friction whose level is keyed on something else is ``sigma_j g(x)``: ``sigma_j`` = +-1 the
direction of motion of the channel's own joint ``j``, ``g`` its level (an eddy-current brake
over a zone of the stroke, ``c |qd_j|`` there; a Coulomb level in a zone; a level growing with
another joint's rate or effort).  The library's Coulomb and viscous frictions take its mean
level, and what is left, ``sigma_j (g(x) - mean)``, is a product neither factor explains alone:
greedy trees need the splits of both at once and their importance spreads.  Fitted to
``sigma_j y`` instead of ``y`` the trees learn ``g`` alone, a function of ``x``, and predict
``y`` as ``sigma_j g(x)``.

Since ``sigma_j^2 = 1`` the out-of-fold error of ``sigma_j g`` against ``y`` is that of ``g``
against ``sigma_j y``: the claim is judged on ``y`` as a plain fit's is (its share against
``var(y)``, its chi-square against the residual's noise), by the same two bars.

``sigma_j`` (:func:`direction`) is the held sign of the stage's own input "the time since the
joint's direction last changed" (:func:`~.columns._since_reversal`: of the commanded rate where
the recording has a reference, else of the smoothed rate held through a dead band), read from
its two columns (that time, and that time signed by the direction), so that a model evaluated on
the stage's columns alone (the black box, a replay of the stage) folds as the fit did.

The folded fit is made only where a cheap screen says it may do better (:func:`prefer`): the
best single input as a step function (:func:`~.cv.binned_shares`, out of fold on the stage's
blocks) must explain at least :data:`MARGIN` more of ``var(y)`` folded than plain (one screen on
each target, the quantile bins shared, no trees).  From :data:`ALONE` more it replaces the plain
fit; between the two the channel is fitted both ways and the
fit whose claim explains more of ``y`` out of fold is kept (:func:`kept`): a friction whose level
a slow state of its own joint sets (a drive's temperature) is such a product too, but the plain
fit has a column for it (the power signed by the direction, :mod:`.columns`) that no other
joint's history mimics, while folded its level competes with the other joints' correlated
histories.
"""
from __future__ import annotations

import numpy as np

from .columns import SINCE

#: the folded fit is used when the best single input explains, out of fold as a step function,
#: at least this share of var(y) more on the folded residual than on the residual itself
#: (docs/records/flexible_mujoco_runs.md: set on the seen MuJoCo sets and the own generator's tuning set)
MARGIN = 0.10
#: ... and instead of the plain fit (no plain fit made) where it explains at least this much more
#: on a column that is not the joint's own history (docs/records/flexible_mujoco_runs.md: above the largest gain of a
#: friction whose level its own joint's history sets, 0.30, where the plain fit explained more)
ALONE = 0.40


def direction(X, columns, joint) -> np.ndarray | None:
    """The direction of motion of ``joint`` (1-based), +-1 per row of ``X`` (its ``columns``,
    :func:`~.columns.inputs` with ``direction=True``): the held sign read from the columns
    "time since qd{joint} reversed" and that time signed by the direction; at a reversal or a
    block's start (the time is 0 there) the sign of the joint's commanded rate, else of its rate.
    None when those columns are not among ``columns``."""
    names = [c[0] for c in columns]
    since_name = f"{SINCE} qd{joint} reversed"
    if since_name not in names or f"{since_name} x sign(qd{joint})" not in names:
        return None
    since = np.asarray(X[:, names.index(since_name)], float)
    signed = np.asarray(X[:, names.index(f"{since_name} x sign(qd{joint})")], float)
    rate_name = f"qd{joint} reference" if f"qd{joint} reference" in names else f"qd{joint}"
    rate = np.asarray(X[:, names.index(rate_name)], float)
    sigma = np.where(since > 0, np.sign(signed), np.sign(rate))
    return np.where(sigma == 0, 1.0, sigma)  # no direction yet (at rest): either sign, sigma^2 = 1 holds


def direction_columns(columns, joint) -> list:
    """The indices in ``columns`` :func:`direction` reads (the time since the reversal, it
    signed, the rate it falls back on)."""
    names = [c[0] for c in columns]
    since_name = f"{SINCE} qd{joint} reversed"
    rate_name = f"qd{joint} reference" if f"qd{joint} reference" in names else f"qd{joint}"
    return [names.index(since_name), names.index(f"{since_name} x sign(qd{joint})"), names.index(rate_name)]


def prefer(X, y, sigma, fold_rows, own_history=(), margin: float = MARGIN, alone: float = ALONE) -> str:
    """Whether the folded fit is made: the best single column of ``X`` as a step function
    (:func:`~.cv.binned_shares`, out of fold on ``fold_rows``) explains more of ``sigma y`` than
    of ``y`` (both errors over ``var(y)``) by at least ``alone``, that column not one of
    ``own_history`` (the joint's own history: the plain fit has it signed by the direction, the
    power and the time since a reversal): ``"folded"`` (instead of the plain fit); by at least
    ``margin``: ``"both"`` (the one explaining more kept, :func:`kept`); else ``""``.

    Example
    -------
    >>> from cosim.discrepancy.flexible.cv import folds
    >>> t = np.linspace(0.0, 40.0, 800)
    >>> sigma, x = np.sign(np.sin(t)), np.sin(0.37 * t)
    >>> prefer(np.column_stack([x, np.sin(t)]), sigma * x, sigma, folds(800, gap=4))  # sigma x: x alone folded
    'folded'
    >>> prefer(np.column_stack([x, np.sin(t)]), np.abs(x), sigma, folds(800, gap=4))  # |x| does not switch
    ''
    """
    from .cv import binned_shares

    var = float(np.var(y))
    if sigma is None or var <= 0:
        return ""
    folded = sigma * y
    plain, shares = float(np.max(binned_shares(X, y, fold_rows))), binned_shares(X, folded, fold_rows)
    # the folded target's share over its own variance, on var(y): the same held-out error
    gain = 1.0 - (1.0 - float(np.max(shares))) * float(np.var(folded)) / var - plain
    return "folded" if gain >= alone and int(np.argmax(shares)) not in own_history else "both" if gain >= margin else ""


def screen(X, y, columns, joint, fold_rows) -> tuple:
    """:func:`prefer` on the channel of ``joint`` (1-based; ``X`` and its ``columns`` the stage's):
    ``(its answer, the direction or None)``."""
    own = [i for i, col in enumerate(columns) if col[2] == joint and col[3].startswith("history")]
    sigma = direction(X, columns, joint)
    return prefer(X, y, sigma, fold_rows, own), sigma


class FoldedModel:
    """``sigma g(x)``: the trees ``level`` (the level ``g`` on the first ``n_level`` columns of
    what it is given) times the direction read from its last three columns (:func:`direction`'s
    ``since``, ``signed``, ``rate``), so that it predicts the residual from the stage's columns
    as a plain model does (:func:`~.stage.black_box_force`)."""

    def __init__(self, level, n_level: int):
        self.level, self.n_level = level, n_level

    def sigma(self, X) -> np.ndarray:
        since, signed, rate = (np.asarray(X[:, self.n_level + i], float) for i in range(3))
        s = np.where(since > 0, np.sign(signed), np.sign(rate))
        return np.where(s == 0, 1.0, s)

    def predict(self, X) -> np.ndarray:
        X = np.asarray(X, float)
        return self.sigma(X) * self.level.predict(X[:, :self.n_level])


def importance_on_y(imp, target, sigma) -> dict:
    """The permutation importances ``imp`` (:func:`~.cv.importance`: per group, mean and standard
    error over ``var(target)``) over the variance of the residual itself, ``sigma target``, as the
    share is; ``imp`` itself where ``sigma`` is None (the plain fit)."""
    if sigma is None:
        return imp
    r = float(np.var(target)) / max(float(np.var(sigma * target)), 1e-300)
    return {g: (m * r, se * r) for g, (m, se) in imp.items()}


def direction_importance(cv, y, sigma, rng) -> tuple:
    """The share of ``var(y)`` lost out of fold when the direction is permuted (drawn from the
    whole recording, as :func:`~.cv.importance` draws a group), the level ``cv.pred`` kept:
    ``(mean over the folds, standard error)``."""
    var = float(np.var(y))
    perm = rng.permutation(len(y))
    d = [(np.mean((y[h] - sigma[perm[h]] * cv.pred[h]) ** 2) - np.mean((y[h] - sigma[h] * cv.pred[h]) ** 2)) / var
         for h, _ in cv.folds]
    return float(np.mean(d)), float(np.std(d, ddof=1) / np.sqrt(len(d)))


def fitted_folded(fitted, sigma):
    """The fitted model's columns (:func:`~.backfit.fitted_columns`: ``(J, names)`` or None) on
    the folded residual: ``sigma J``, so that the refit beside the trees of the level is the
    refit of ``J`` beside ``sigma g`` on the residual itself."""
    if fitted is None:
        return None
    J, names = fitted
    return np.asarray(J, float) * np.asarray(sigma, float)[:, None], names


def direction_dependence(group, importance, level) -> tuple:
    """The :class:`~.stage.Dependence` fields of the direction of motion itself (``group``: the
    rate of the channel's joint): its ``importance`` (:func:`direction_importance`) and, as its
    partial dependence, the force's mean at each direction (``sigma`` times the mean of the
    ``level`` predicted on every sample)."""
    m = float(np.mean(level))
    return dict(group=group, feature="direction of motion", quantity="rate", importance=float(importance), unit="",
                grid=(-1.0, 1.0), curve=(-m, m), where="")


def kept(plain, folded):
    """The fit kept where both were made: the folded one (:class:`~.stage.FlexibleFit`) where it
    is claimed and explains more of the residual out of fold than the plain one (both shares
    over ``var(y)``; the plain one where it claims nothing), else the plain one.  Only channels
    the screen passed (:func:`prefer`) are fitted twice."""
    if folded.explained and (not plain.explained or folded.share > plain.share):
        return folded
    return plain
