"""What stands beside a force's inputs without being one (:mod:`.select`, the flexible stage's
choice of the inputs it names).

A force on the platform (a function of its pose, and of its twist where it is damped) shows in
more of the recorded inputs than its own: the controller answers it, so the rails'
accelerations and efforts carry a copy of it; an excursion that happens once in the recording
lasts over neighbouring blocks, which time, or a low-passed history of the motion, then tells
apart from the rest; and a fitted effect whose level the force set (an effort limit) leaves in
the residual a part keyed on the effort itself.  Out of fold such an input can win a share of a
few blocks beside the pose, or instead of it.  Four rules, each general (no kind of force is
named in them):

* **Time is judged last** (:func:`judged_last`): it stands for anything that changes once or
  slowly in the recording, so, as a consequence of the force in closed loop is
  (:func:`~.select.consequences`), it is named only where the trees on the other inputs plus it
  beat the other inputs alone by :data:`~.select.DROP_MIN` of the variance, above
  :data:`~.select.GAIN_Z` standard errors over the folds (:func:`~.select.gain`).  Where the
  low-passed histories named instead do not beat time by that bar, time is named in their place
  (:func:`.clock.on_time`: a state set by time, a window or a warming from cold, that slow
  histories follow by chance over the one change a recording holds), then judged as time named
  beside other groups is (:func:`once`) without the replaced histories' columns
  (:func:`.clock.timed`: their signed columns a named rate holds).
* **Beside the pose, only what adds significantly** (:func:`beside_pose`): beside the named
  platform pose, a history, an acceleration, an effort or time stays named only where leaving
  it out costs :data:`~.select.DROP_MIN` above :data:`~.select.GAIN_Z` standard errors over the
  folds; the leave-one-out check alone keeps a group on a cost that one fold may carry.  The
  pose, the positions that set it and the rates (its twist) are the state a force on the
  platform is a function of, and are checked as before.
* **An effort limit passes the force on** (:func:`without_levels`): where the fitted model holds
  an effect on the channel that does not act linearly (its derivative is off its contribution's
  line: a limit, a level), what it took of the force is keyed on the effort, and the linear
  re-adjustment beside the trees (:mod:`.backfit`) does not undo it.  Where efforts are named
  (no rate beside them), the choice between the efforts and what they are computed from
  (:func:`~.select.made_of_efforts`) is made again on the residual with those effects taken
  out (their contributions added back), and its answer is named.
* **A copy alone is no answer** (:func:`copy_alone`): on a weak channel, where the strongest
  single input is a model effort and what it is computed from claims nothing, no input is named
  (the claim stays on no single input).
"""
from __future__ import annotations

import numpy as np

from .clock import TIME, level, timed
from .copies import copies
from .own_joint import beside_another, own_first
from .cv import BLOCKS_PER_FOLD, N_FOLDS, folds
from .select import POSE, gain, made_of_efforts


def judged_last(follow, groups, lines=()) -> set:
    """The groups judged after the others: the consequences ``follow``
    (:func:`~.select.consequences`) and time, where it is an input and holds no line's phase
    (``lines``, :func:`.periodic.extend`): a line is fitted per fold and repeats through every
    block, no event one block carries."""
    return set(follow) | (set() if lines else {TIME} & set(groups))


def beside_pose(kept) -> set:
    """The groups of ``kept`` that stay named beside the platform pose only where they add
    significantly: every one but the pose, the positions and the rates, when the pose is named."""
    if POSE not in kept:
        return set()
    return {g for g in kept if g != POSE and not g.startswith(("position of ", "rate of "))}


def significant_only(kept, groups, y, var, cv_on) -> list:
    """``kept`` without each group of :func:`beside_pose` whose leaving out costs less than
    :data:`~.select.DROP_MIN` above :data:`~.select.GAIN_Z` standard errors over the folds
    (:func:`~.select.gain`; ``cv_on``: the cross-validations of :func:`~.select.select`)."""
    for h in sorted(beside_pose(kept), key=kept.index):
        rest = [g for g in kept if g != h]
        if rest and not gain(cv_on(rest)[0], cv_on(kept)[0], y, var)[1]:
            kept = rest
    return kept


def without_levels(y, fitted):
    """The residual ``y`` with the fitted effects that do not act linearly on the channel taken
    out (their contributions added back; ``fitted``: ``(J, names)`` of
    :func:`~.backfit.fitted_columns`, a parameter acting non-linearly holds a ``(derivative)``
    column beside its contribution); None where there is none."""
    if fitted is None:
        return None
    J, names = fitted
    levels = {n.replace(" (derivative)", "") for n in names if n.endswith(" (derivative)")}
    took = [J[:, i] for i, n in enumerate(names) if n in levels]
    return np.asarray(y, float) + np.sum(took, axis=0) if took else None


def passed_on(kept, groups, follow, X, y, fold_rows, fitted, cross_validate, directed=False) -> list:
    """``kept`` where efforts are named without a rate: the choice of
    :func:`~.select.made_of_efforts` made again on the residual without the effects that do not
    act linearly (:func:`without_levels`); ``kept`` unchanged where there is none; ``directed``:
    the fit is folded by the joint's direction (:func:`~.select.made_of_efforts`)."""
    if not any(g.startswith("effort of ") for g in kept) or any(g.startswith("rate of ") for g in kept):
        return kept
    y2 = without_levels(y, fitted)
    if y2 is None or not np.var(y2) > 0:  # nothing to judge on (a NaN variance included)
        return kept
    done = {}

    def cv_on(gs, without=()):
        cols = sorted({i for g in gs for i in groups[g]} - set(without))
        if tuple(cols) not in done:
            done[tuple(cols)] = cross_validate(X[:, cols], y2, fold_rows)
        return done[tuple(cols)], cols

    return made_of_efforts(kept, groups, follow, y2, float(np.var(y2)), cv_on, directed)


def copy_alone(named, kept, claimed) -> bool:
    """Whether the single ``named`` input of a weak channel is a model effort that gave way to
    what it is computed from (``kept`` differs) whose trees do not claim (``claimed`` False)."""
    return kept != named and not claimed and any(g.startswith("effort of ") for g in named)


def once(kept, groups, X, y, cross_validate, without=()) -> list:
    """``kept`` without time where it is named beside other groups and does not add
    significantly (:func:`~.select.gain`) once each held-out block's neighbours are held out
    too (a gap of one block on each side); ``without``: columns left out of both fits (the
    replaced histories' columns, :func:`.clock.timed`).  Trees on time predict a
    held-out block from the fitted rows nearest in time: a change slower than the blocks (a
    drift, a warming) is still there two blocks away, an event that lasts a block or two (an
    excursion of the pose that happens once) is not."""
    if TIME not in kept or len(kept) == 1:
        return kept
    wide = folds(len(y), len(y) // (N_FOLDS * BLOCKS_PER_FOLD))
    rest = [g for g in kept if g != TIME]

    def cv(gs):
        cols = sorted({i for g in gs for i in groups[g]} - set(without))
        return cross_validate(X[:, cols], y, wide) if cols else level(y, wide)
    return kept if gain(cv(rest), cv(kept), y, float(np.var(y)))[1] else rest


def rules(X, y, fold_rows, groups, follow, fitted, cross_validate, lines=(), reference=None, joint=None, judged=None,
          directed=False):
    """The ``after`` of :func:`~.select.select` on one channel: the groups that carry only the
    controller's answer to the force left out where others stay (:func:`.copies.copies`, on the
    channel's ``reference`` counterparts; none without), the efforts' choice made again
    without the fitted levels (:func:`passed_on`), the groups beside the pose named only where
    they add significantly (:func:`significant_only`), time beside other groups only where it
    adds with the neighbouring blocks held out (:func:`once`), then time in the place of
    histories that do not beat it significantly (:func:`.clock.on_time`; judged by :func:`once`
    again beside other groups, without the replaced histories' columns), unless time holds a
    line's phase (``lines``: see :func:`judged_last`); first, on the channel of ``joint``
    (1-based), another joint's input gives way to the own joint's of the same quantity where
    that explains as much and claims alike (:func:`.own_joint.own_first`; ``judged(mse)``: the
    stage's bars, whose third item is the claim; ``directed``: the fit is folded by the joint's
    direction, :func:`passed_on`)."""
    var = float(np.var(y))
    swapped = {}

    def after(kept, cv_on):
        kept = own_first(kept, groups, joint, follow, y, var, cv_on,
                         None if judged is None else (lambda cv: judged(cv.mse)[2]))
        answers = copies(kept, groups, X, reference, y, fold_rows, cross_validate, swapped,
                         checked=beside_another(kept, joint))
        kept = [g for g in kept if g not in answers] or kept
        kept = passed_on(kept, groups, follow, X, y, fold_rows, fitted, cross_validate, directed)
        kept = significant_only(kept, groups, y, var, cv_on)
        if lines:
            return kept
        kept = once(kept, groups, X, y, cross_validate)
        named, without = timed(kept, groups, y, var, cv_on)
        return kept if named == kept else once(named, groups, X, y, cross_validate, without)
    return after
