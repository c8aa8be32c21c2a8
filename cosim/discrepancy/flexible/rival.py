"""A discovered equation against the flexible stage's trees, before it is named with confidence.

The discovery step (:mod:`..discovery`) names an equation when it passes its held-out tests
against fewer terms of its own library; nothing there asks whether its *form* holds what the
data hold.  A force no term family covers (a damping acting over one zone of the stroke) may be
approached by a sum of terms that passes every test (a viscous pair, a polynomial in position
times the direction, a smooth step) and leaves the channel with no structure, so that nothing
is left for the flexible stage either.

Here each discovered term not already called partial is compared, out of fold, with the
flexible stage's fit (:func:`~.stage.fit_channel`: the trees on the stage's inputs, over its
blocked folds, :mod:`.cv`) of the channel's residual *before* the term (the fitted parameters
without the term's: what the stage fits on a channel whose term is set aside).  The equation is
refitted per fold on the fold's fitted rows (each coefficient's contribution to the residual a
column, with a constant; its shape parameters, a step's place or a zone's edges, stay as the
discovery fitted them on the engine's fitted part), so both predict every sample with a model
that never saw it.

Per fold the difference of the two held-out mean squared errors, over the residual's variance,
is the share the trees explain beyond the equation; its mean over the folds is ``excess`` and
its standard error the folds' spread (as the stage's importances).  The term is named with
confidence only where the trees are shown to explain at most :data:`MARGIN` beyond it:
``excess + Z se <= MARGIN``; else it is called partial (:data:`PARTIAL`), where the stage claims
its fit.  The burden is the tie rule's (:func:`..discovery.judge_library`: a library effect the
discovered terms fit as well is not named with confidence): a form is a claim, so the claim must
pass the test.  The margin is the stage's own smallest claimed share
(:data:`~.stage.SHARE_MIN`: what the trees explain beyond the equation counts where the stage
would claim it at all), :data:`Z` its bar for an input's importance over the folds
(:data:`~.stage.BLOCK_Z`).  The flexible stage then reports that fit on the channel, the
residual without the term (:func:`~.stage.flexible_stage`'s stand-ins).  Where the equation
leaves at most :data:`MARGIN` of the residual's variance out of fold, no fit can beat it by the
margin: the trees are not fitted (the cost is then the equation's refit alone).
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, field, replace

import numpy as np

from .backfit import residual_at
from .columns import inputs
from .cv import N_FOLDS, folds, gap_for
from .select import fold_gain
from .stage import BLOCK_Z, SHARE_MIN

#: share of the residual's variance (before the term) the trees may explain beyond the equation
#: out of fold, and the standard errors over the folds within which that must be shown, for the
#: equation to be named with confidence: the stage's smallest claimed share (stage.SHARE_MIN)
#: and its bar of an input's importance (stage.BLOCK_Z)
MARGIN, Z = SHARE_MIN, BLOCK_Z
_LOG = logging.getLogger(__name__)
#: the start of a term's partial sentence where the trees may outfit it (the conclusion's short reason reads it)
PARTIAL = "a flexible model of the residual before the term may explain more of it than the term's form"


@dataclass(frozen=True)
class Rivalry:
    """One discovered term against the trees on its channel (0-based ``channel``): the shares of
    the residual before the term explained out of fold by the equation refitted per fold
    (``equation``) and by the trees (``trees``), the trees' ``excess`` (mean over the folds of
    the per-fold difference, in shares of the variance) and its standard error ``se`` (the three
    NaN where the trees were not fitted: the equation left at most :data:`MARGIN`); ``outfit``
    whether the term is called partial, ``fit`` the trees' :class:`~.stage.FlexibleFit`."""

    channel: int
    equation: float
    trees: float
    excess: float
    se: float
    outfit: bool
    fit: object = field(default=None, repr=False, compare=False)

    def sentence(self) -> str:
        return (f"{PARTIAL} (out of fold {100 * self.trees:.0f} % against the equation's "
                f"{100 * self.equation:.0f} %; "
                f"{100 * self.excess:+.0f} +- {100 * self.se:.0f} % over {N_FOLDS} folds, not shown to stay within "
                f"{100 * MARGIN:.0f} %): it may stand in for a force of another form, so it is not named as the physics")


def equation_columns(eng, theta, term, c, R) -> np.ndarray:
    """Each coefficient's contribution to channel ``c`` of the residual (decimated samples,
    coefficients): the residual with the coefficient at the value the model held before (its
    ``base``) less the residual ``R`` at ``theta``; a coefficient the core cannot move back
    gives none."""
    cols = []
    for p, coef in term.coefficients.items():
        Rb = residual_at(eng, dict(theta, **{p: coef.base}))
        if Rb is not None:
            cols.append(np.asarray(Rb, float)[:, c] - R[:, c])
    return np.column_stack(cols) if cols else np.zeros((len(R), 0))


def equation_out_of_fold(J, y, fold_rows) -> np.ndarray:
    """The out-of-fold prediction of ``y`` by a constant and the columns ``J``, least squares on
    each fold's fitted rows."""
    A = np.column_stack([np.ones(len(y)), J])
    pred = np.empty(len(y))
    for held, fit in fold_rows:
        coef = np.linalg.lstsq(A[fit], y[fit], rcond=None)[0]
        pred[held] = A[held] @ coef
    return pred


def compare(y, pred_eq, pred_trees, fold_rows, channel=0) -> Rivalry:
    """:class:`Rivalry` of two out-of-fold predictions of ``y`` over the folds ``fold_rows``: the
    excess what the trees gain over the equation (:func:`~.select.fold_gain`: the mean of the
    per-fold differences of the held-out errors over ``var(y)``, its standard error their spread
    over the folds), the term outfit unless ``excess + Z se <= MARGIN``."""
    var = float(np.var(y))
    if not var > 0:
        return Rivalry(channel, 0.0, 0.0, 0.0, 0.0, False)
    excess, se, outfit = fold_gain(y, pred_eq, pred_trees, fold_rows, var, lambda mean, se: mean + Z * se > MARGIN)
    share = lambda p: 1.0 - float(np.mean((y - p) ** 2)) / var  # noqa: E731
    return Rivalry(channel, share(pred_eq), share(pred_trees), excess, se, outfit)


def rivalled(eng, theta, R, found) -> tuple:
    """``(found, rivalries)``: the discovered terms ``found`` with each term the trees outfit on
    its channel called partial (:class:`Rivalry`'s sentence), and the comparisons made
    ({channel (0-based): :class:`Rivalry`}, the trees' fit in ``fit`` where they were fitted).
    ``R``: the residual at the fitted parameters ``theta`` (decimated samples x channels).  Terms
    already partial are left as they are.

    The equation is refitted out of fold first: where the share of the residual it leaves is
    at most :data:`MARGIN`, no prediction can beat it by the margin and the trees are not
    fitted.  Elsewhere the trees are the stage's own fit of the channel
    (:func:`~.stage.fit_channel` on the residual without the term, with the fitted model's
    columns there, :func:`~.backfit.stage_columns`), which the stage takes as its fit of the
    channel where the term is outfit."""
    from .backfit import stage_columns
    from .stage import BLOCK, fit_channel
    from ..structure import own_noise, samples_per_independent

    pipe = eng.pipe
    R = np.asarray(R, float)
    sure = [t for t in found if not t.partial and 0 < t.joint <= pipe.nd]
    if not sure or not theta or len(R) < N_FOLDS * BLOCK:
        return list(found), {}
    fold_rows = folds(len(R), gap_for(samples_per_independent(pipe)))
    done, before = {}, {}
    for t in sure:
        c = t.joint - 1
        R_wo = residual_at(eng, {k: v for k, v in theta.items() if k not in t.params()})
        if R_wo is None or c in done:
            continue
        y = np.asarray(R_wo, float)[:, c]
        pred = equation_out_of_fold(equation_columns(eng, theta, t, c, R), y, fold_rows)
        var = float(np.var(y))
        left = float(np.mean([np.mean((y[h] - pred[h]) ** 2) for h, _ in fold_rows]))
        if not var > 0 or left <= MARGIN * var:  # no prediction beats it by the margin over the folds
            done[c] = Rivalry(c, 1.0 - float(np.mean((y - pred) ** 2)) / var if var > 0 else 0.0, float("nan"),
                              float("nan"), float("nan"), False)
            _LOG.debug("rival %s: %s", t.channel, done[c])
            continue
        before[c] = (t, y, pred)
    if before:
        # the stage's inputs with those terms set aside (its effort inputs are the model's effort)
        R_fit = R.copy()
        for c, (_, y, _) in before.items():
            R_fit[:, c] = y
        X, columns = inputs(pipe, R_fit, direction=True)
        floor = eng.accuracy()
        for c, (t, y, pred) in before.items():
            fitted = stage_columns(eng, theta, {c: t}, [c]).get(c)
            fit = fit_channel(pipe, X, columns, y, own_noise(pipe, R[:, c], floor[c]),
                              (pipe.model.facts.effort_unit, pipe.channels[c]), fitted=fitted)
            r = compare(y, pred, fit.pred, fold_rows, c)
            done[c] = replace(r, outfit=r.outfit and fit.explained, fit=replace(fit, joint=c + 1, target=y.copy()))
            _LOG.debug("rival %s: %s", t.channel, done[c])
    out = [replace(t, partial=done[t.joint - 1].sentence()) if id(t) in {id(u) for u in sure}
           and t.joint - 1 in done and done[t.joint - 1].outfit else t for t in found]
    return out, done
