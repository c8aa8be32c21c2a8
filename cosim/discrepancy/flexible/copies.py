"""Inputs that carry the robot's answer to a force, not its cause (:mod:`.select`, the flexible
stage's choice of the inputs it names).

In closed loop the controller answers an unexplained force: the force moves the joints off the
reference, and the drive's effort answers that tracking error at once.  The measured
accelerations, the model's efforts computed along the measured motion and their low-passed
histories therefore carry a copy of the force, whatever it depends on; beside the force's own
inputs they can add a share out of fold (the copy is sharper than trees on the causes) or stand
in for them.  The reference motion the controller was given is exogenous: the force does not move
it.  Where the recording has one, each input built from the measured accelerations or efforts has
a counterpart along it (:func:`counterparts`: the reference's acceleration, the pipeline's reference
effort, the histories of the reference's rate and effort), and a named input of that kind stays
named only where its counterpart, in its place, adds :data:`~.select.DROP_MIN` of the variance above
:data:`~.select.GAIN_Z` standard errors over the folds beside the other named inputs
(:func:`~.select.gain`; :func:`copies`): a force keyed on a drive's load is keyed on the load the
commanded motion sets too, and a force the effort only answers is not in the reference's effort.
The rule names no kind of force.
"""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from .columns import SINCE, blocks, histories
from .select import DROP_MIN, gain

#: the quantities of the columns built from the measured accelerations or model efforts
ANSWERED = ("acceleration", "effort", "history", "history x direction")
#: the groups made of such columns (a rate's group holds its signed history too: a rate is state,
#: and stays judged as it is)
ANSWERED_GROUPS = ("acceleration of ", "effort of ", "history of ")


def counterparts(pipe, X, columns):
    """``X`` (the stage's inputs, :func:`~.columns.inputs`) with each column built from the
    measured accelerations or model efforts replaced by its counterpart along the reference
    motion: the reference's acceleration (the second derivative of ``qref`` through the pipeline's
    smoother), the pipeline's reference effort (``tau_ref_s``: the core's inverse dynamics of the
    reference motion, smoothed as the efforts are), and the histories (:func:`~.columns.histories`)
    of the reference's rate and that effort; None where the recording has no reference or its
    reference effort is not finite."""
    ref = getattr(pipe, "tau_ref_s", None)
    qref = getattr(getattr(pipe, "rec", None), "qref", None)
    if ref is None or qref is None:
        return None
    idx = pipe.idx
    qref = np.asarray(qref, float)
    effort = np.asarray(ref, float)[idx]
    acc = pipe.S(qref, deriv=2)[idx]
    rate = np.gradient(qref, pipe.dt, axis=0)[idx]  # the columns' commanded rate
    if not (np.all(np.isfinite(effort)) and np.all(np.isfinite(acc))):
        return None
    starts, dt = blocks(pipe)
    out = np.array(X, float, copy=True)
    for k in range(pipe.nd):
        mine = [i for i, col in enumerate(columns) if col[2] == k + 1]
        for i in mine:
            if columns[i][3] == "effort":
                out[:, i] = effort[:, k]
            elif columns[i][3] == "acceleration":
                out[:, i] = acc[:, k]
        hist = [i for i in mine if columns[i][3] in ANSWERED[2:] and not columns[i][0].startswith(SINCE)]
        for i, v in zip(hist, histories(rate[:, k], effort[:, k], dt, starts)):
            out[:, i] = v
    return out


def on_channel(pipe, X, columns, keep, channel_X):
    """The :func:`counterparts` of a channel's inputs ``channel_X``, made on first call (most
    channels name no input they replace): the stage's inputs ``X`` (``columns``) at ``keep``,
    then the channel's own columns (the projected pose and rates, a line's phase) as they are."""
    made = []

    def get():
        if not made:
            ref = counterparts(pipe, X, columns)
            made.append(None if ref is None else np.column_stack([ref[:, keep], channel_X[:, len(keep):]]))
        return made[0]
    return get


def _mean_only(y, fold_rows):
    """The cross-validation of a constant (each fold's fitted mean): what no input explains."""
    pred = np.empty(len(y))
    for held, fit in fold_rows:
        pred[held] = np.mean(y[fit])
    return SimpleNamespace(pred=pred, folds=fold_rows, mse=float(np.mean((y - pred) ** 2)))


def copies(kept, groups, X, reference, y, fold_rows, cross_validate, done=None, checked=()) -> list:
    """The groups of ``kept`` that carry only the answer to the force: the accelerations, efforts
    and histories (:data:`ANSWERED_GROUPS`; not a joint's history beside its own rate, the level
    a slow state of the joint sets, as :func:`~.select.stand_ins` has it) whose leaving out costs
    less than :data:`~.select.DROP_MIN` above :data:`~.select.GAIN_Z` standard errors
    (:func:`~.select.gain`) once their columns (but those another named group holds) are their
    counterparts along the reference motion (``reference``, the channel's
    :func:`counterparts`, or a function giving them: :func:`on_channel`; the trees on no group: a
    constant).  Where ``X`` holds columns fitted per fold (:class:`~.cv.FoldInputs`), each fold's
    trees are fitted and judged on that fold's, the counterparts in place as in the whole array.
    ``done``: the cross-validations already made, by their columns; ``checked``: the groups that
    stay where leaving them out costs :data:`~.select.DROP_MIN` alone, the leave-one-out check's
    bar (a channel's own joint's input beside another joint's of the same quantity:
    :func:`.own_joint.beside_another`)."""
    answered = [g for g in kept if g.startswith(ANSWERED_GROUPS)
                and not (g.startswith("history of ") and g.replace("history of", "rate of", 1) in kept)]
    reference = reference() if callable(reference) and answered else reference
    if reference is None or not answered:
        return []
    done = {} if done is None else done
    var = float(np.var(y))

    state = {i for h in kept if h not in answered for i in groups[h]}
    judged = {i for h in answered for i in groups[h]} - state

    def exogenous(gs):  # the trees on gs' columns, the judged groups' replaced by their counterparts
        cols = tuple(sorted({i for h in gs for i in groups[h]}))
        if not cols:
            return _mean_only(y, fold_rows)
        if cols not in done:
            M = X[:, cols].copy()  # with the columns fitted per fold, where X has them (FoldInputs)
            at = [j for j, i in enumerate(cols) if i in judged]
            M[:, at] = reference[:, [cols[j] for j in at]]
            if getattr(M, "variants", None) is not None:  # the counterparts are fitted on no fold
                M.variants[:, :, at] = reference[:, [cols[j] for j in at]]
            done[cols] = cross_validate(M, y, fold_rows)
        return done[cols]

    whole = exogenous(kept)

    def costs(g):
        overall, shown = gain(exogenous([h for h in kept if h != g]), whole, y, var)
        return overall >= DROP_MIN if g in checked else shown
    return [g for g in answered if not costs(g)]
