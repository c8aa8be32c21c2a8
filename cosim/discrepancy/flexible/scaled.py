"""A force a drive's effort scales (:mod:`.stage`, the flexible stage's choice of the inputs it
names).

A force that is a drive's effort times a function of the motion (a screw's friction whose edge
load is the axial load times a misalignment along the stroke, a coil's stray field on a
neighbouring carriage, a motor's ripple) is a product: u_k g(x).  Boosted trees fit a product
by splitting on each factor in turn; on some 800 samples, with g itself a function of two
inputs (a position and a direction), the trees on the named inputs plus the effort's column
gain a few hundredths of the variance over those on the named inputs alone, under the bars
that add an input (:func:`~.select.gain`), though the effort is no function of the named
inputs (R^2 0.13-0.22 out of fold on the seen MuJoCo cases) and carries the force's scale.

**The test of the product** (:func:`scaled_by`): once inputs are named and a claim made, for
each joint whose position is named and whose effort is not, trees g are fitted to the
residual over the effort s (|s| or s, the better out of fold), weighted by s^2 (least squares
of y - s g), on the named columns, cross-validated on the stage's blocked folds: the residual
predicted as s g.  The effort is named where that model beats the trees on the named inputs
by :data:`~.select.DROP_MIN` of the variance above :data:`~.select.GAIN_Z` standard errors over
the folds (the bar of a consequence), and so does the same product with the effort's
counterpart along the reference motion in its place (:mod:`.copies`: the load the commanded
motion sets, which the force does not move; a force the effort only echoes is not scaled by
it).  A force that is no product of the effort gains nothing: s g can fit only what scales
with s, and where s varies apart from the named inputs it then fits worse than the trees on
them.  The effort is tried only beside its joint's named position: a force a drive's load
scales acts along a stroke (its own, or a carriage's beside it); a force on the platform
reaches every effort through the dynamics the efforts are computed from.  One effort is named
(the largest gain); the model the stage reports stays the trees on the named groups' columns.

Figures on the seen sets: docs/flexible.md, "A force a drive's effort scales".
"""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from .cv import MIN_ITER, TREES, at
from .own_joint import joint_of
from .select import DROP_MIN, GAIN_Z, fold_gain

#: the chi-square a claim's variance is judged by (the stage's CHI2_MIN)
CHI2_MIN = 25.0
#: ... or this share of what the trees on the named inputs leave (their held-out error)
RELATIVE_MIN = 0.25

#: the trees of the product's level g: the stage's settings, grown to this many iterations
ITERATIONS = 50


def scaled_cv(Xn, s, y, fold_rows) -> SimpleNamespace:
    """The residual ``y`` predicted as ``s`` times trees on ``Xn`` (fitted to y / s with weights
    s^2: least squares of y - s g), cross-validated on ``fold_rows``; the number of iterations
    the one with the smallest summed held-out loss.  ``(pred, mse, folds)`` as a
    :class:`~.cv.CV`'s."""
    from sklearn.ensemble import HistGradientBoostingRegressor

    s = np.asarray(s, float)
    s = s / max(float(np.sqrt(np.mean(s ** 2))), 1e-300)  # unit RMS: the trees' regularisation as on y
    safe = np.where(np.abs(s) < 1e-6, 1e-6, s)
    staged = []
    for b, (held, fit) in enumerate(fold_rows):
        m = HistGradientBoostingRegressor(**dict(TREES, max_iter=ITERATIONS))
        Xb = at(Xn, b)
        m.fit(Xb[fit], y[fit] / safe[fit], sample_weight=s[fit] ** 2)
        staged.append(np.array(list(m.staged_predict(Xb[held]))) * s[held][None, :])
    total = sum(np.sum((y[held][None, :] - p) ** 2, axis=1) for (held, _), p in zip(fold_rows, staged))
    best = int(np.argmin(total[MIN_ITER - 1:])) + MIN_ITER
    pred = np.empty(len(y))
    for (held, _), p in zip(fold_rows, staged):
        pred[held] = p[best - 1]
    return SimpleNamespace(pred=pred, mse=float(np.mean((y - pred) ** 2)), folds=tuple(fold_rows))


def candidates(named, groups) -> list:
    """The effort groups tried: of each joint whose position is named, where its effort is an
    input and not named."""
    out = []
    for g in named:
        got = joint_of(g)
        if got is not None and got[0] == "position":
            e = f"effort of {g[len('position of '):]}"
            if e in groups and e not in named and e not in out:
                out.append(e)
    return out


def scaled_by(named, use, cv, groups, X, y, fold_rows, reference, judged, cross_validate=None) -> tuple:
    """``(named, cv, use)`` with the effort whose product with the named inputs beats their trees
    (module docstring, :func:`beats`) added, ``cv`` then the trees' on the columns ``use`` with its
    column; unchanged where none does.  ``reference``: the channel's counterparts along the
    reference motion (an array of ``X``'s layout, a function giving it, or None: no effort is
    named); ``judged(mse)``: the stage's ``(share, chi-square, claimed)`` of a held-out error."""
    tried = candidates(named, groups)
    var = float(np.var(y))
    if not tried or not var > 0:
        return named, cv, use
    if cross_validate is None:
        from .cv import cross_validate
    Xn = X[:, use]
    best = None
    for e in tried:
        col = groups[e][0]
        s = np.asarray(X[:, col], float)
        fits = [(f, scaled_cv(Xn, f(s), y, fold_rows)) for f in (np.abs, np.asarray)]
        f, got = min(fits, key=lambda p: p[1].mse)
        share = beats(cv, got, y, var, judged)
        if share is None or (best is not None and share <= best[1]):
            continue
        ref = reference() if callable(reference) else reference
        if ref is None or beats(cv, scaled_cv(Xn, f(np.asarray(ref[:, col], float)), y, fold_rows), y, var,
                                judged) is None:
            continue
        best = (e, share)
    if best is None:
        return named, cv, use
    use = sorted(set(use) | set(groups[best[0]]))
    return list(named) + [best[0]], cross_validate(X[:, use], y, fold_rows), use


def beats(base, product, y, var, judged):
    """The share of the variance ``product`` gains over ``base`` where it beats it: the gain at
    least :data:`~.select.DROP_MIN` of the variance or :data:`RELATIVE_MIN` of the base's held-out
    error, its mean over the folds above :data:`~.select.GAIN_Z` standard errors, and the
    variance it explains a chi-square above :data:`~.stage.CHI2_MIN` against the noise (the
    bar of a claim, ``judged``); else None."""
    overall = float((base.mse - product.mse) / var)
    mean, se, _ = fold_gain(y, base.pred, product.pred, base.folds, var, lambda m, e: True)
    chi2 = judged(product.mse)[1] - judged(base.mse)[1]
    if overall >= min(DROP_MIN, RELATIVE_MIN * base.mse / var) and mean > GAIN_Z * se and chi2 > CHI2_MIN:
        return overall
    return None
