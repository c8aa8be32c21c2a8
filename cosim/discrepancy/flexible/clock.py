"""A state set by time, not by the motion: time named in the place of the low-passed histories
that only stand in for it (:mod:`.beside`, the flexible stage's choice of the inputs it names).

A force whose level a window of time, a step or a slow change from the run's start sets (a
brake that drags over a few seconds, a grease warming from cold, debris building up over the
run) is a function of time.  In one recording that change is seen once, and the joints'
low-passed histories (:mod:`.columns`: per joint |rate|, effort and dissipated power low-passed
over 0.5-8 s, the time since a reversal) are some sixty slow columns, several of which rise and
fall over the run with the motion's programme.  Out of fold the best of them can follow a change
of time as well as time does, or better where its slope happens to sit at the change's edges,
which time's trees cannot place inside a held-out block.  Judged last (:func:`.beside.judged_last`)
time then loses to them: the trees on every input spread the change over the histories, whose
permutation importance passes the screen while time's does not.

**Time in the place of the histories** (:func:`on_time`): where the named groups hold histories
and not time, the named groups with the histories replaced by time are cross-validated too.
Time is named in their place where

* the histories do not beat time by :data:`~.select.DROP_MIN` of the variance above
  :data:`~.select.GAIN_Z` standard errors over the folds (:func:`~.select.gain`, the bar a
  consequence or a partner must pass), and
* time adds at least :data:`~.select.DROP_MIN` of the variance to the other named groups (the
  check's bar for keeping a group, :func:`~.select.select`; over nothing where no other is named).

**Time judged beside the rate's own columns** (:func:`timed`): a joint's histories signed by its
direction of motion (its dissipated power low-passed, the time since it reversed) are columns of
its rate's group as well as of its history's (:func:`~.columns.input_groups`), so where time
takes the place of a joint's history beside that joint's named rate, the rate's group still
holds the history's signed columns.  Time named beside other groups is judged once more with
each held-out block's neighbours held out too (:func:`.beside.once`); there it is judged without
the replaced histories' columns, beside the other groups' own.  The fitted model keeps them (the
trees on the named groups' columns): only the judgement leaves them out.

**The pose before time** where the platform pose is an input and not named: it is the candidate
in the histories' place instead of time where the trees on the other named groups and it beat
those on them and time by :data:`~.select.DROP_MIN` of the variance out of fold.  The slow state
the histories follow is then the motion's: a force of the pose on only in the stretches where
the platform comes near a point (a tendon taut in a few stretches of a repeated programme) is
followed by slow histories and, between neighbouring blocks, by time; trees on the pose know the
stretches wherever they recur.

Physically: a state the motion sets follows the motion: a joint's temperature falls when it
rests and rises when it works, a reversal resets a seal's lip, so the relation of the force to
the history holds through the whole recording, at its pauses and restarts, where the single time
column cannot follow it: there the histories beat time significantly and stay named.  A state
set by time is explained by time; a history explains it only through its chance correlation
with time over the one change the recording holds.  Statistically: the histories the screen
passes are the best of many slow columns on the same folds, so their gain over the one column
of time is biased upward by the choice; only a gain above the significance bar is evidence that
the motion, not time, sets the state.  Time that adds less than :data:`~.select.DROP_MIN` to the
other named groups carries nothing there, and the histories stay (a history beside the rates
that carries a product with the direction of motion, not a change in time).  Where time took the
histories' place, their signed columns in the rate's group are the stand-in just judged not to
beat time: the power a brake dissipates rises over its window, so its low-passed, signed copy
(the effort the drive answers the brake with, times the rate) follows the window's level as the
histories did, and beside it time must beat the column it replaced.  A window that time explains
would then be dropped by its own stand-in (MuJoCo's brake windows 60706 and 73706, seen: time
beside the rate with the signed power adds 0.28 and 0.13 of the variance with the neighbouring
blocks held out, 1.7 and 0.7 standard errors; beside the rate's own columns 0.68 and 0.51, 2.4
and 4.0, docs/records/flexible_rules.md, "Time beside a rate that holds the signed histories").
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .select import DROP_MIN, POSE, gain

#: the group of time (:func:`~.columns.input_groups`)
TIME = "time"


@dataclass(frozen=True)
class _Level:
    """The out-of-fold prediction of no input: each held-out block's fitted rows' mean (the
    ``pred``, ``mse`` and ``folds`` of a :class:`~.cv.CV`)."""

    folds: tuple
    pred: np.ndarray
    mse: float


def level(y, fold_rows) -> _Level:
    """The cross-validation of no input on the folds ``fold_rows``: each fold's held-out rows
    predicted by the mean of its fitted rows."""
    y = np.asarray(y, float)
    pred = np.zeros(len(y))
    for held, fitted in fold_rows:
        pred[held] = float(np.mean(y[fitted])) if len(fitted) else 0.0
    return _Level(tuple(fold_rows), pred, float(np.mean((y - pred) ** 2)))


def histories(kept) -> list:
    """The low-passed histories among the named groups ``kept`` (``"history of slider 4"``)."""
    return [g for g in kept if g.startswith("history of ")]


def on_time(kept, groups, y, var, cv_on) -> list:
    """``kept`` with its histories (:func:`histories`) replaced by time where they do not beat
    time significantly (:func:`~.select.gain`) and time adds at least
    :data:`~.select.DROP_MIN` of the variance ``var`` to the other named groups (module
    docstring); the platform pose in the place of time where it is an input, not named, and
    beats time there by :data:`~.select.DROP_MIN`; ``kept`` unchanged where time is no input or
    is named, or no history is.
    ``cv_on(groups)``: :func:`~.select.select`'s cross-validation of the groups' columns,
    ``(cv, columns)``."""
    return timed(kept, groups, y, var, cv_on)[0]


def timed(kept, groups, y, var, cv_on) -> tuple:
    """:func:`on_time`'s named groups and the columns time is judged without beside them
    (:func:`.beside.once`): ``(named, without)``, ``without`` the replaced histories' columns
    where time took their place (the signed ones a named rate group holds stay in its model),
    else ()."""
    past = histories(kept)
    if TIME not in groups or TIME in kept or not past or not var > 0:
        return kept, ()
    rest = [g for g in kept if g not in past]
    clock, without = rest + [TIME], tuple(sorted({i for h in past for i in groups[h]}))
    with_histories, with_time = cv_on(kept)[0], cv_on(clock)[0]
    if gain(with_time, with_histories, y, var)[1]:  # the motion sets the state: the histories beat time
        return kept, ()
    if POSE in groups and POSE not in rest:  # the slow state the histories follow: the pose's where it beats time
        posed = rest + [POSE]
        with_pose = cv_on(posed)[0]
        if (with_time.mse - with_pose.mse) / var >= DROP_MIN:
            clock, with_time, without = posed, with_pose, ()
    base = cv_on(rest)[0] if rest else level(y, with_time.folds)
    held = min((base.mse - with_histories.mse) / var, (base.mse - with_time.mse) / var)
    return (clock, without) if held >= DROP_MIN else (kept, ())
