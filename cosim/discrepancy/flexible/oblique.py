"""The pose and the rates projected on the direction a linear fit of the residual takes (:mod:`.flexible`).

Boosted trees split on one column at a time.  A force that is a function of an oblique
direction of a group of columns (the distance of the platform to a point, the depth along a
plane's normal: a direction of the 6-column pose that is none of its columns) takes many
splits on several columns to learn from some 700 decimated samples, and a single column that
moves nearly linearly along that direction gives the trees the same course in one.  The same
holds for the joints' rates: a gyroscopic moment H x omega is linear in the platform's angular
rate, an oblique combination of the rails' rates.

Per channel, the platform pose and the joints' rates (the smoothed readings) each get one more
column: the columns (scaled to unit RMS on the rows fitted) projected on the direction of a ridge
fit of the residual on them (relative ridge :data:`RIDGE`).  The pose's is in the pose's group;
the rates' only where their linear fit beats the best single rate's out of fold by
:data:`OBLIQUE_MIN` (:func:`oblique_gain`), in the rate group of each joint whose weight is at
least :data:`MEMBER` of the largest (on every sample: which inputs the column stands for, not its
values).  The direction is fitted per fold of the cross-validation on that fold's fitted rows
only (:class:`~.cv.FoldInputs`: no held-out row moves the column its trees are judged on), and
once on every sample for the final model, its partial dependence and the black box
(:func:`extended`).  Measured on seen sets: docs/records/flexible_mujoco_runs.md, "Forces on the platform".
"""
from __future__ import annotations

import re

import numpy as np

from .cv import FoldInputs

#: the columns projected: (quantity, the pattern of their feature names, whether only where oblique)
PROJECTED = (("pose", r"pose\[\d+\]", False), ("rate", r"qd\d+", True))
#: the rates are projected only where the linear fit on all of them explains, out of fold, this share
#: of the residual's variance more than the linear fit on the best single one: a friction on one
#: joint's rate (the own generator's heating) is fitted on that rate, and the column, spread over
#: the rate groups of the joints the excitation moves with it, names their rates (measured without it:
#: flexible_mujoco_bench 12002, rails 5, 4 and 1 named for a friction on rail 6)
OBLIQUE_MIN = 0.1
#: a rate group holds the rates' projected column when its joint's weight is this share of the largest
MEMBER = 0.5
#: relative ridge of the linear fit (columns scaled to unit RMS on the fitted rows)
RIDGE = 1e-2


def direction(Z, y) -> tuple:
    """The ridge fit of ``y`` on the columns ``Z`` (rows fitted): ``(mean, scale, weights)`` with
    the projected column ``((Z - mean) / scale) @ weights`` (:func:`projected`)."""
    mean = Z.mean(axis=0)
    scale = Z.std(axis=0)
    scale = np.where(scale > 0, scale, 1.0)
    S = (Z - mean) / scale
    A = S.T @ S
    lam = RIDGE * max(float(np.trace(A)) / max(A.shape[0], 1), 1e-300)
    w = np.linalg.solve(A + lam * np.eye(A.shape[0]), S.T @ (y - y.mean()))
    return mean, scale, w


def oblique_gain(Z, y, fold_rows) -> float:
    """The share of ``y``'s variance the linear fit on all columns ``Z`` explains out of fold beyond
    the linear fit on the best single column (:func:`direction` per fold, on its fitted rows)."""
    var = float(np.var(y))
    if not var > 0:
        return 0.0
    sse = np.zeros(Z.shape[1] + 1)
    for held, fit in fold_rows:
        for k, cols in enumerate([list(range(Z.shape[1]))] + [[j] for j in range(Z.shape[1])]):
            d = direction(Z[fit][:, cols], y[fit])
            e = y[held] - y[fit].mean() - projected(Z[held][:, cols], d)
            sse[k] += float(e @ e)
    share = 1.0 - sse / len(y) / var
    return float(share[0] - share[1:].max())


def projected(Z, fitted) -> np.ndarray:
    """The columns ``Z`` projected on a direction of :func:`direction`.

    Parameters
    ----------
    Z : ndarray, shape (n, k)
        The columns, each in its own unit (a pose coordinate's m or rad, a rate's m/s or rad/s,
        a filtered acceleration's m/s^2).
    fitted : tuple
        ``(mean, scale, weights)`` as :func:`direction` returns them: ``mean`` and ``scale``
        (k,) in the columns' units, ``weights`` (k,) in the unit of the target it was fitted on.

    Returns
    -------
    ndarray, shape (n,)
        ``((Z - mean) / scale) @ weights``: the ridge fit's prediction of the target less the
        target's mean, in the target's unit (the residual's N or N m)."""
    mean, scale, w = fitted
    return ((Z - mean) / scale) @ w


def extend(X, columns, groups, y, fold_rows) -> tuple:
    """``X`` (n, p) with, per group of :data:`PROJECTED` of at least 2 columns, the group's
    columns projected on the direction of a ridge fit of ``y`` on them: fitted per fold on its
    fitted rows (``fold_rows``) and on every sample.  Returns ``(X as a FoldInputs, columns,
    groups, projections)``, ``projections`` per added column ``(the group's columns (indices
    into X), mean, scale, weights)`` fitted on every sample (:func:`extended`)."""
    X = np.asarray(X, float)
    y = np.asarray(y, float)
    added, per_fold, projections = [], [], []
    columns, groups = list(columns), {g: list(c) for g, c in groups.items()}
    for quantity, pattern, only_oblique in PROJECTED:
        cols = [i for i, col in enumerate(columns[:X.shape[1]]) if col[3] == quantity and re.fullmatch(pattern, col[0])]
        if len(cols) < 2:
            continue
        Z = X[:, cols]
        if only_oblique and oblique_gain(Z, y, fold_rows) < OBLIQUE_MIN:
            continue
        whole = direction(Z, y)
        added.append(projected(Z, whole))
        per_fold.append([projected(Z, direction(Z[fit], y[fit])) for _, fit in fold_rows])
        projections.append((tuple(cols),) + whole)
        w = np.abs(whole[2])
        held_by = [columns[i][1] for i, wi in zip(cols, w) if wi >= MEMBER * w.max()] if quantity == "rate" \
            else [columns[cols[0]][1]]
        for g in held_by:
            groups[g].append(X.shape[1] + len(added) - 1)
        columns.append((f"{quantity} along its linear fit", held_by[0], None, quantity, ""))
    if not added:
        return X, columns, groups, ()
    whole = np.column_stack([X] + added)
    variants = np.stack([np.column_stack([X] + [p[b] for p in per_fold]) for b in range(len(fold_rows))])
    return FoldInputs(whole, variants), columns, groups, tuple(projections)


def extended(X, projections) -> np.ndarray:
    """The stage's inputs ``X`` with the projected columns fitted on every sample
    (``projections`` of :func:`extend`), in the order :func:`extend` added them."""
    X = np.asarray(X, float)
    if not projections:
        return X
    return np.column_stack([X] + [projected(X[:, list(cols)], (m, s, w)) for cols, m, s, w in projections])
