"""A partner stays named only where its shared columns add to the kept groups' model
(:func:`~.select.partners`, the flexible stage's choice of the inputs it names).

A group that shares columns with a named one (a joint's history and its rate share the history
signed by the direction of motion; the rate groups of a unit share the rates' projected column,
:mod:`.oblique`) is named as a partner where those shared columns add
:data:`~.select.DROP_MIN` of the variance above :data:`~.select.GAIN_Z` standard errors over the
folds (:func:`~.select.adds`) to the trees on the groups named so far.  The partners are judged
one after another, each against the groups named before it: a signed history judged beside one
rate, before the other rates of that rate's unit join, can add what those rates carry (the
direction of the platform's motion, which one rail's signed history follows), and it stays
named once they have joined although its columns then add nothing, or cost.  A force on the
platform's twist read through the rates (a drag on its angular velocity) is then named on a
joint's history beside them.

**The rule** (:func:`still_added`): once the partners are named, each is judged again on the
model the stage fits, the trees on the kept groups' columns (a partner's other columns are not
added to it): it stays named where the columns it shares with them add by the same bar.  The
order the partners were named in then does not matter.  A group the selection kept (not a
partner) is not judged; nor is a partner whose shared columns are all the kept groups' columns
(nothing to judge them beside).  A partner left out names nothing; its shared columns stay in the
model, which the kept groups' columns make.
"""
from __future__ import annotations


def still_added(out, kept, groups, y, var, cv_on, adds) -> list:
    """``out`` (:func:`~.select.partners`' named groups: the selection's ``kept`` and the partners
    added after them) without each partner whose columns shared with the ``kept`` groups do not
    add significantly to the trees on the kept groups' columns (:func:`~.select.adds`; module
    docstring).  ``cv_on(groups, without=(), under=None)``: :func:`~.select.select`'s
    cross-validation; ``adds``: :func:`~.select.adds` (passed in: this module is imported by
    :mod:`.select`)."""
    held = {i for g in kept for i in groups[g]}
    named = list(out)
    for h in [g for g in out if g not in kept]:
        shared = set(groups[h]) & held
        if shared and held - shared and not adds(shared, kept, y, var, cv_on):
            named.remove(h)
    return named
