"""What the channels say together (:mod:`.stage`, after every channel's fit).

Each channel's inputs are chosen on that channel alone (:mod:`.select`); two rules then read the
channels side by side, each refitting a channel without some of its inputs' columns
(``refit(fit, without, why)``: the stage's fit of that channel with the groups ``without`` left
out, ``why`` the clause its statement ends with, or None where it cannot be made):

* **The pose on one channel alone** (:func:`without_lone_pose`): a force on the platform reaches
  every rail through the Jacobian; where one channel of several names anything and it names the
  pose, the channel is fitted without the pose, and that fit is the answer where the pose does
  not explain significantly more.
* **A kind of input on one channel alone** (:func:`without_lone_kinds`): where
  :data:`SHARED_BY` channels or more hold a force, it is one the robot shares (on the platform, or
  passed between the rails through it), a function of the state the channels share: the pose, the
  rails' positions and rates.  An input of a kind that is no such state (:data:`OWN_KINDS`: a
  low-passed history, an acceleration, a model effort, time) named on one of those channels and on
  no other is that channel's own: its controller's answer to the force (a copy the trees read
  better than the causes), or the one leave-one-out check of many that a chance gain passes.  The
  channel is fitted again without any input of that kind, and that fit is its answer.

On the seen MuJoCo sets (docs/records/flexible_rules.md, "A kind of input on one channel alone"):
19 of the 20 such inputs were outside the mechanism's declared inputs.
"""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from .clock import TIME
from .columns import input_groups
from .select import POSE, gain

#: a force held by at least this many channels is the robot's, not one rail's
SHARED_BY = 3
#: the kinds of input that are no state of the platform (group name prefixes, time's name) and
#: how the statement calls them
OWN_KINDS = {"history of ": "low-passed histories", "acceleration of ": "accelerations",
             "effort of ": "model efforts", TIME: "time"}


def kind(group: str) -> str | None:
    """The :data:`OWN_KINDS` key ``group`` is of, or None (a position, a rate, the pose)."""
    return next((k for k in OWN_KINDS if group == k or (k.endswith(" ") and group.startswith(k))), None)


def without_lone_pose(fits, channels: int, refit, fold_rows):
    """``fits`` with the one that names the platform pose, where it is the only one of the
    robot's ``channels`` (more than one) that names anything, fitted again without the pose's
    columns (``refit``), where that fit claims a share on named inputs and the fit with the pose
    does not beat it by the bar of a consequence (:func:`.select.gain`: :data:`.select.DROP_MIN`
    of the variance and :data:`.select.GAIN_Z` standard errors over the blocks ``fold_rows``;
    each fit's ``pred``, out of fold, against its ``target``).

    Where one channel holds a force and the others nothing the trees claim, the pose named there
    may stand for what it is computed from, the rails' positions, or for what the pose sets, the
    drive's load: the channel's trees are judged without it, and where they explain as much, what
    they name is the answer.  Where the pose explains significantly more, it stays: it carries
    what the trees on single columns do not (a gap between two rails in one tilt).  On the seen
    MuJoCo sets every channel that was the only one naming anything and named the pose held a
    rail's own force (docs/records/flexible_rules.md, "The pose on one channel alone")."""
    told = [f for f in fits if f.explained and f.named]
    if channels < 2 or len(told) != 1 or POSE not in told[0].named:
        return fits
    posed = told[0]
    again = refit(posed, (POSE,), f"{POSE} left out of the inputs: the only channel holding a force, which a "
                                  f"force on the platform would not be (it reaches every rail)")
    if again is None or not (again.explained and again.named):
        return fits
    y = np.asarray(posed.target, float)
    held_out = [SimpleNamespace(pred=f.pred, folds=fold_rows, mse=float(np.mean((y - f.pred) ** 2)))
                for f in (again, posed)]
    if gain(*held_out, y, float(np.var(y)))[1]:
        return fits
    return [again if f is posed else f for f in fits]


def without_lone_kinds(fits, groups, refit) -> list:
    """``fits`` with each channel that names an input of an :data:`OWN_KINDS` kind no other
    channel names, where :data:`SHARED_BY` or more name anything, fitted again without every
    group of those kinds among ``groups`` (the stage's group names; ``refit``); that fit is the
    channel's answer, whatever it claims, where it can be made.  Where it names another such kind
    on that channel alone (an acceleration in the place of time), the channel is fitted again
    without both, and so on: at most once per kind."""
    fits, left = list(fits), {}  # left: per position in fits, the kinds left out of its inputs
    for _ in OWN_KINDS:
        told = [f for f in fits if f.explained and f.named]
        if len(told) < SHARED_BY:
            break
        holders = {}
        for f in told:
            for k in {kind(g) for g in f.named} - {None}:
                holders.setdefault(k, []).append(f)
        lone = {}
        for k, fs in holders.items():
            if len(fs) == 1:
                lone.setdefault(id(fs[0]), set()).add(k)
        again = {}
        for i, f in enumerate(fits):
            if id(f) not in lone:
                continue
            kinds = sorted(set(left.get(i, ())) | lone[id(f)], key=list(OWN_KINDS).index)
            why = (f"{', '.join(OWN_KINDS[k] for k in kinds)} left out of the inputs: named on this channel and on "
                   f"no other of the {len(told)} holding a force (a force the robot shares is keyed on the state "
                   f"the channels share: an input of this kind on one of them is its controller's answer there)")
            got = refit(f, tuple(g for g in groups if kind(g) in kinds), why)
            if got is not None:
                again[i], left[i] = got, kinds
        if not again:
            break
        fits = [again.get(i, f) for i, f in enumerate(fits)]
    return fits


def across_channels(fits, channels: int, columns, refit, fold_rows) -> list:
    """The channels' fits read side by side: :func:`without_lone_pose`, then
    :func:`without_lone_kinds` over the groups of the stage's ``columns``."""
    fits = without_lone_pose(fits, channels, refit, fold_rows)
    return without_lone_kinds(fits, list(input_groups(columns)), refit)
