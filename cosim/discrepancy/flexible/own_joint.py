"""The channel's own joint before another's (:mod:`.select`, the flexible stage's choice of the
inputs it names).

A force on a joint is first a function of that joint's state: a friction of its rate and of the
slow state its own motion sets (a wiper's debris, a grease's temperature: its history), a drive's
limit of its own speed.  Along the reference motion of a parallel mechanism the joints move
together, so another joint's rate or history is a close copy of the channel's own, and out of fold
it can win a share of a few blocks by noise, or stand beside the own joint's copy on a cost one
fold carries.  Two rules, general (no kind of force is named in them):

* **Another joint's input gives way to the own joint's of the same quantity**
  (:func:`own_first`): where a named group of another joint (its position, rate or history) has a
  counterpart on the channel's own joint that is no consequence of the force
  (:func:`~.select.consequences`: the own effort and acceleration, copies of it), the trees on the
  named groups with that counterpart in its place (left out where the counterpart is named
  already) are cross-validated; where they explain as much out of fold (:func:`as_much`: the
  named groups' gain over them under :data:`~.select.DROP_MIN` of the variance, the check's bar,
  or its mean over the folds within one standard error), and claim or not as the named groups do
  (the rule chooses between copies of an input, not whether the channel holds a force), the own
  joint's is named.  All such groups are replaced at once first (one fit), then, where that
  explains less, one by one in the order named.  A force truly keyed on another joint (a damper
  between two rails, a cable carrier pulled by their gap) loses far more than that bar without
  the other joint's input, and keeps it (MuJoCo's coupling damper 54704: 0.86 of the variance).
* **An own joint's group beside another joint's of the same quantity is judged by the check's
  bar** (:func:`beside_another`): the rule of :func:`.copies.copies` leaves it named where leaving
  out its counterpart along the reference costs :data:`~.select.DROP_MIN` of the variance, without
  significance over the folds (a limit one drive's load sets on another's effort: both efforts).

The rules: docs/flexible.md, "The channel's own joint before another's"; figures on the seen
sets: docs/records/flexible_rules.md, "The channel's own joint before another's".
"""
from __future__ import annotations

from .select import DROP_MIN, fold_gain

#: the quantities whose group on another joint has a counterpart on the channel's own joint
#: (an effort or an acceleration of the own joint is a consequence of its force, no cause)
QUANTITIES = ("position", "rate", "history")


def joint_of(group):
    """``(quantity, joint)`` of a joint's group ("rate of slider 6": ``("rate", 6)``); None for
    the pose, time, or any group not named "<quantity> of <joint noun> <number>"."""
    head, _, number = group.rpartition(" ")
    quantity, of, _ = head.partition(" of ")
    if not of or not number.isdigit():
        return None
    return quantity, int(number)


def counterpart(group, joint, groups, follow=()):
    """The group of ``joint`` of the same quantity as ``group``, another joint's (position, rate
    or history: :data:`QUANTITIES`); None where ``group`` is the joint's own, is of another
    quantity, or the counterpart is no input or a consequence (``follow``)."""
    got = joint_of(group)
    if joint is None or got is None or got[1] == joint or got[0] not in QUANTITIES:
        return None
    own = f"{group.rpartition(' ')[0]} {joint}"
    return own if own in groups and own not in follow else None


def swapped(kept, moves) -> list:
    """``kept`` with each group of ``moves`` (another joint's: its own joint's counterpart)
    replaced by its counterpart, in its place, where the counterpart is not named already."""
    out = []
    for g in kept:
        h = moves.get(g, g)
        if h not in out:
            out.append(h)
    return out


def as_much(own, other, y, var) -> bool:
    """Whether the cross-validation ``own`` (the trees with the own joint's inputs) explains as
    much of ``y`` (variance ``var``) out of fold as ``other`` (same folds): ``other``'s gain over it
    is under :data:`~.select.DROP_MIN` of the variance (what the leave-one-out check counts as no
    cost), or its mean over the folds is within one standard error of zero."""
    mean, se, _ = fold_gain(y, own.pred, other.pred, other.folds, var, lambda m, s: True)
    return (own.mse - other.mse) / var < DROP_MIN or mean <= se


def own_first(kept, groups, joint, follow, y, var, cv_on, claims=None) -> list:
    """``kept`` with the groups of other joints that have a counterpart on the channel's own
    ``joint`` (:func:`counterpart`) replaced by it wherever that explains as much out of fold
    (:func:`as_much`; ``cv_on``: :func:`~.select.select`'s cross-validations) and claims or not as
    ``kept`` does (``claims(cv)``: whether trees of that held-out error claim a force; None: not
    judged): all at once first, then one by one.  ``kept`` unchanged for a channel of no joint."""
    moves = {g: counterpart(g, joint, groups, follow) for g in kept}
    moves = {g: h for g, h in moves.items() if h is not None}
    if not moves:
        return kept

    def keeps(before, after):  # the own joint's named where it explains as much and claims alike
        own, other = cv_on(after)[0], cv_on(before)[0]
        alike = claims is None or claims(own) == claims(other)
        return not (alike and as_much(own, other, y, var))

    every = swapped(kept, moves)
    if not keeps(kept, every):
        return every
    if len(moves) == 1:
        return kept
    for g in [g for g in kept if g in moves]:
        trial = swapped(kept, {g: moves[g]})
        if not keeps(kept, trial):
            kept = trial
    return kept


def beside_another(kept, joint) -> set:
    """The groups of ``kept`` of the channel's own ``joint`` beside which another joint's group of
    the same quantity is named (its effort beside another drive's effort: a limit one drive's
    load sets on another).  The other rules judge them by the leave-one-out check's bar alone
    (:data:`~.select.DROP_MIN` of the variance, no significance over the folds): the own joint's
    state is the force's first input, and another joint's of the same quantity beside it is a
    copy of it along the reference motion that shares its cost when one fold carries it."""
    parsed = {g: joint_of(g) for g in kept}
    others = {p[0] for p in parsed.values() if p is not None and p[1] != joint}
    return {g for g, p in parsed.items() if joint is not None and p is not None and p[1] == joint and p[0] in others}
