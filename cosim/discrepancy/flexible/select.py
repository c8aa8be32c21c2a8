"""Which of the screened inputs the flexible stage names (:mod:`.flexible`): a check by
cross-validating without each, with two rules of cause before consequence.

* **Causes before consequences.**  In closed loop the controller answers the residual force:
  the force first accelerates its own joint (the tracking error), and the drive's effort moves
  with that acceleration at once.  The channel's own model effort (the inverse dynamics along
  the measured motion) and its own acceleration therefore carry a filtered copy of the force
  itself: they predict it without being its cause, and beside the true input they
  absorb part of what it explains.  These groups (:func:`consequences`) are judged last: the
  other screened groups (positions, rates, other joints' accelerations and efforts, histories, the pose,
  time) are checked among themselves first, and a consequence is named only when the trees on
  those inputs plus it beat the trees on those inputs alone by :data:`DROP_MIN` of the variance,
  significantly over the folds (:func:`gain`): only when the exogenous inputs cannot explain
  the same share.  A force truly keyed on the effort (a friction growing with the load) passes
  this test; one that the effort only follows does not.
* **A shared column names both groups.**  A history signed by the direction of motion belongs
  to the joint's rate and to its history (:func:`~.flexible.input_groups`): a friction level
  that a slow state sets is their product.  When one of the two is named and the other not,
  the trees on the named inputs are cross-validated without the shared columns; when those
  columns add :data:`DROP_MIN` significantly, the force depends on both factors and the other
  group is named too (for those columns: its others are not added to the model), instead of
  the product hiding behind one name.

* **Another joint's history stands in for the rates.**  Beside a named rate, the history of a
  joint whose rate is not named (:func:`stand_ins`) stays named only where leaving it out costs
  :data:`DROP_MIN` of the variance significantly over the folds (:func:`gain`): the check alone
  keeps it on a cost of :data:`DROP_MIN` that may swing over the folds.  A joint's history
  beside its own rate is checked as before (a friction level the joint's slow state sets).

* **A model effort where no rate is named: what it is computed from, where that says as much.**
  The model computes a joint's effort from the pose, the rates and the accelerations; a force on
  the platform (a function of its pose and twist) enters every rail's effort through the
  tracking error the controller answers, so a rail's effort can carry it better than its true
  inputs.  A friction keyed on a drive's load needs the direction of motion: beside a named
  rate the efforts stay.  Elsewhere the groups they are computed from (:func:`made_of`) are
  named in their place unless the efforts beat them by :data:`DROP_MIN` significantly over
  the folds (:func:`gain`, the bar of a consequence; :func:`made_of_efforts`).

* **The pose where no more than two rails' positions say the same.**  The pose is the forward
  kinematics of every rail's position, so a force keyed on two rails' positions (a cable
  carrier pulled by their gap, a friction preloaded by it) is a function of the pose too.
  Where the pose is named, the other named groups alone, then with one rail's position, then
  with two are cross-validated (:func:`fewest_rails`: greedy, at most three fits); the first the
  pose does not beat by :data:`DROP_MIN` of the variance out of fold is named in its place.  A
  force on the platform (a magnet, a contact, a tendon) depends on every rail: there the pose
  stays where two rails explain less.  On seen sets (the stage re-run on captured inputs,
  docs/records/flexible_mujoco_runs.md): MuJoCo's second set of kinds 6 of 10 declared inputs named (4 without),
  the gap-preloaded friction on rail 2's rate and rails 2's and 3's positions.

* **A consequence is no answer by itself.**  On a weak channel the stage judges the strongest
  single input alone (:func:`~.flexible.stage.fit_channel`); when that input is a consequence,
  it is the copy of the force the controller made, which out-predicts a force's causes when
  these act as a product (a friction sign(qd_j) |u_k| whose mean level a fitted Coulomb took:
  neither factor alone explains anything).  There the trees on every input are judged first,
  causes before consequences, and the consequence alone only when they claim nothing.

* **Replacements that lose together are undone.**  The efforts' constituents and then the
  fewest rails each replace groups the data do not show better by their own bar, so each may
  lose a little (under :data:`DROP_MIN`); where the groups they end at lose to the checked ones
  significantly (:func:`gain`), the efforts' constituents are not put in their place and the
  rules after them run on the checked groups (a thrust ripple, the command times a function of
  the position: position and effort give way to the pose and the rate, the pose to the
  position, and position and rate explain 0.71 where position and effort explain 0.89).

* **A replacement stands where it claims.**  The rules after the check (the efforts' constituents,
  the caller's ``after``, the fewest rails) decide on gains over the folds, which a force acting
  in a few blocks does not show significant however large; where the groups they leave claim
  nothing and the checked ones do, the checked ones are named (:func:`claimed_or_checked`).
* **The inputs that stood out, before the strongest alone.**  Where the trees on every input
  claim nothing, the groups their importance passes are checked by the same rules and their
  trees judged alone (:func:`screened_first`) before the strongest single column alone.

The check of the other screened groups is the one the stage always had: a group is kept when
leaving it out costs at least :data:`DROP_MIN` of the residual's variance out of fold; when none
is kept (interchangeable inputs), all are.  The rate groups that hold the rates' projected column
(:mod:`.oblique`) are one unit there (:func:`units`): left out together, kept or dropped whole.
"""
from __future__ import annotations

import math

import numpy as np

#: the platform pose's group (:func:`~.flexible.stage.inputs`)
POSE = "the platform pose"

#: a group is kept (or a consequence or a partner added) when it is worth this share of the
#: residual's variance out of fold ...
DROP_MIN = 0.03
#: ... and, for a consequence or a partner, when that gain exceeds this many standard errors
#: over the folds
GAIN_Z = 2.0


def consequences(columns, groups, joint) -> set:
    """The groups that follow the residual force of ``joint``'s channel in closed loop: the
    joint's own model effort and acceleration (all their columns of those kinds).  Another
    joint's effort moves with the force only through the mechanism's coupling, and it is the
    cause of a force that one drive's load sets on another joint (a preloaded bearing)."""
    def follows(col):
        return col[3] in ("effort", "acceleration") and col[2] == joint
    return {g for g, idx in groups.items() if idx and all(follows(columns[i]) for i in idx)}


def stand_ins(named) -> set:
    """The histories among ``named`` that may only stand in for the rates beside them: another
    joint's history (its own rate not named) on a channel where a rate is named.  A low-passed
    |rate|, effort or power of a joint in motion is a smoothed copy of that motion, which the
    named rates carry; out of fold it can take a share by chance beside them (a heating friction
    on rail 5 named with rail 1's history, MuJoCo, docs/records/flexible_mujoco_runs.md).  A joint's history beside
    its own rate is not one: that is the friction level a slow state of the joint sets."""
    if not any(g.startswith("rate of ") for g in named):
        return set()
    return {g for g in named if g.startswith("history of ") and g.replace("history of", "rate of", 1) not in named}


def fold_gain(y, pred_without, pred_with, fold_rows, var, shown) -> tuple:
    """What the out-of-fold prediction ``pred_with`` of ``y`` gains over ``pred_without`` on the
    folds ``fold_rows``: per fold the held-out mean squared error without less that with, over
    ``var`` (shares of the variance).  ``shown(mean, se)`` is the criterion the gain is judged
    by.  Returns ``(mean over the folds, its standard error (inf for one fold: no spread),
    shown(mean, se))``."""
    d = np.array([(np.mean((y[h] - pred_without[h]) ** 2) - np.mean((y[h] - pred_with[h]) ** 2)) / var
                  for h, _ in fold_rows])
    se = float(np.std(d, ddof=1)) / math.sqrt(len(d)) if len(d) > 1 else float("inf")
    mean = float(np.mean(d))
    return mean, se, bool(shown(mean, se))


def gain(without, with_, y, var) -> tuple:
    """What cross-validation ``with_`` gains over ``without`` (same folds): ``(share of the
    variance, whether it is at least DROP_MIN and above GAIN_Z standard errors over the folds)``."""
    overall = float((without.mse - with_.mse) / var)
    return overall, fold_gain(y, without.pred, with_.pred, without.folds, var,
                              lambda mean, se: overall >= DROP_MIN and mean > GAIN_Z * se)[2]


def select(X, y, fold_rows, groups, named, var, follow=(), cross_validate=None, known=None, after=None,
           directed=False, claims=None):
    """The named groups among the screened ``named``, their trees cross-validated on them
    alone: ``(kept, cross-validation, its columns)``.  ``follow``: the consequence groups
    (:func:`consequences`), judged after the others; ``known``: cross-validations already
    made, by their sorted columns; ``after(kept, cv_on)``: the caller's further rules on the
    kept groups (:mod:`.beside`), given this selection's cross-validations; ``directed``: the fit
    is folded by the joint's direction (:func:`made_of_efforts`); ``claims(cv)``: whether a
    cross-validation passes the stage's two bars (:func:`claimed_or_checked`)."""
    if cross_validate is None:
        from .cv import cross_validate
    done = dict(known or {})

    def cv_on(gs, without=(), under=None):  # a column two groups share leaves with either; one fit per set of columns
        cols = sorted({i for g in gs for i in groups[g]} - set(without))
        if tuple(cols) in done:
            return done[tuple(cols)], cols
        got = cross_validate(X[:, cols], y, fold_rows) if under is None else \
            cross_validate(X[:, cols], y, fold_rows, under=under)
        if not getattr(got, "stopped", False):
            done[tuple(cols)] = got
        return got, cols

    def check(gs):  # a unit is kept when leaving it out costs DROP_MIN; none kept: all
        us = units(gs, groups)
        if len(us) == 1:
            return list(gs)
        full = cv_on(gs)[0]
        bar = full.mse + DROP_MIN * var  # below it the unit is out, on the trees of 10, 25 or 50 iterations as on all
        out = {g for u in us if (cv_on(gs, [i for h in u for i in groups[h]], bar)[0].mse - full.mse) / var < DROP_MIN
               for g in u}
        kept = [g for g in gs if g not in out]
        return kept if kept else list(gs)

    causes = [g for g in named if g not in follow]
    kept = check(causes) if causes else check(named)
    if causes:
        base = cv_on(kept)[0]
        kept += [g for g in named if g in follow and gain(base, cv_on(kept + [g])[0], y, var)[1]]
    for h in [g for g in kept if g in stand_ins(kept)]:  # named only where it adds significantly
        rest = [g for g in kept if g != h]
        if not gain(cv_on(rest)[0], cv_on(kept)[0], y, var)[1]:
            kept = rest
    checked = kept

    def replaced(kept):
        if after is not None:
            kept = after(kept, cv_on)
        return fewest_rails(kept, groups, follow, X, y, fold_rows, var, cv_on)
    made = made_of_efforts(kept, groups, follow, y, var, cv_on, directed)
    kept = replaced(made)
    if made != checked and kept != checked and gain(cv_on(kept)[0], cv_on(checked)[0], y, var)[1]:
        kept = replaced(checked)  # (the two replacements together beaten by the checked groups)
    kept = claimed_or_checked(kept, checked, cv_on, claims)
    cv, cols = cv_on(kept)
    return partners(kept, groups, y, var, cv_on), cv, cols


def claimed_or_checked(kept, checked, cv_on, claims=None) -> list:
    """``kept`` (the groups the rules after the check put in the place of the ``checked`` ones, or
    left of them), or ``checked`` where the trees on ``kept`` claim nothing and those on
    ``checked`` do (``claims(cv)``: the stage's two bars; None: ``kept``).

    The rules that replace named groups (what a model effort is computed from, the fewest rails'
    positions, the choice made again without the fitted levels) decide by whether the groups
    they replace beat the others significantly over the folds; a force that acts in a few blocks
    (a drive's saturation above a high effort) gives a large gain that the folds do not show
    significant, and the groups put in its place may then explain nothing at all.  A replacement
    stands where its trees still carry the claim, as another joint's input gives way to the own
    joint's only where that claims alike (:func:`.own_joint.own_first`)."""
    if claims is None or kept == checked or claims(cv_on(kept)[0]) or not claims(cv_on(checked)[0]):
        return kept
    return checked


def adds(without, with_, y, var, cv_on) -> bool:
    """Whether the columns ``without`` leaves out of the groups ``with_`` add a significant
    share (:func:`gain`): ``cv_on(groups, without=(), under=None)`` is :func:`select`'s
    cross-validation of the groups' columns less ``without``, whose trees may stop after 10, 25
    or 50 iterations once their held-out error is ``under`` a bar (``under`` of
    :func:`~.cv.cross_validate`).  Under the trees on ``with_`` plus :data:`DROP_MIN` of the
    variance the gain falls short of DROP_MIN, and the error of trees grown further is lower
    still: decided on the fewer trees as on the whole growth."""
    full = cv_on(with_)[0]
    return gain(cv_on(with_, without, full.mse + DROP_MIN * var)[0], full, y, var)[1]


def units(gs, groups) -> list:
    """``gs`` in the units the leave-one-out check judges: the rate groups that hold a column in
    common (the rates' projected column, :mod:`.oblique`, in the group of every joint of a large
    weight) form one, every other group is one by itself.  Leaving one such rate group out takes
    the common column with it, so each of them costs as much as the column (3 to 5 fits naming
    all of them); judged as one, the unit costs one fit and is named whole or not at all."""
    rates = [g for g in gs if g.startswith("rate of ")]
    unit = {g: {g} for g in gs}
    for i, g in enumerate(rates):
        for h in rates[i + 1:]:
            if unit[g] is not unit[h] and set(groups[g]) & set(groups[h]):
                merged = unit[g] | unit[h]
                for k in merged:
                    unit[k] = merged
    out = []
    for g in gs:
        if unit[g] not in out:
            out.append(unit[g])
    return [[g for g in gs if g in u] for u in out]


def made_of(effort, groups, follow=()) -> tuple:
    """What the model effort group ``effort`` ("effort of slider 4") is computed from, as the
    inverse dynamics along the measured motion: ``(where, rate, acceleration)``, the platform
    pose (:data:`POSE`; the joint's position where no pose is recorded), the joint's rate and
    its acceleration, each () where not an input or a consequence (``follow``)."""
    joint = effort[len("effort of "):]
    place = POSE if POSE in groups else f"position of {joint}"
    return tuple((g,) if g in groups and g not in follow else () for g in
                 (place, f"rate of {joint}", f"acceleration of {joint}"))


def made_of_efforts(kept, groups, follow, y, var, cv_on, directed=False) -> list:
    """``kept`` with its model efforts replaced by what they are computed from (:func:`made_of`)
    unless the efforts beat that by :data:`DROP_MIN` significantly over the folds (:func:`gain`),
    when no rate is named beside them; ``directed``: the fit is folded by the joint's direction
    (:mod:`.folded`), whose rate is named as that direction: the efforts stay.

    A model effort is no physical input: the model computes it from the pose, the rates and the
    accelerations.  A force acting on the platform (a tendon, a contact, a magnet: functions of
    its pose and twist) enters every rail's effort twice: through the pose, and through the
    tracking error's acceleration the controller answers it with, a copy of the force itself; so
    a rail's effort can out-predict the pose, as the channel's own effort does (a consequence,
    judged by the same bar).  A friction keyed on a drive's load is the force the effort is the
    input of, and a friction needs the direction of motion: beside a named rate the efforts stay.
    Elsewhere the fewest constituents first: the groups left beside the efforts, then with the
    pose, then the pose and the rates or the pose and the accelerations (the lower held-out
    error), then all three; the first the efforts do not beat is named in their place, each
    larger set only where a smaller one is beaten."""
    efforts = [g for g in kept if g.startswith("effort of ")]
    if not efforts or directed or any(g.startswith("rate of ") for g in kept):
        return kept
    rest = [g for g in kept if g not in efforts]
    parts = [made_of(g, groups, follow) for g in efforts]
    place, rates, accs = ([h for p in parts for h in p[i] if h not in rest] for i in range(3))
    ladder = [[rest]] if rest else []
    ladder += [[rest + place], [rest + place + rates, rest + place + accs], [rest + place + rates + accs]]
    full = cv_on(kept)[0]
    for step in ladder:
        step = [list(dict.fromkeys(s)) for s in step if s]
        if not step:
            continue
        best = min(step, key=lambda s: cv_on(s)[0].mse)
        if not gain(cv_on(best)[0], full, y, var)[1]:
            return best
    return kept


def fewest_rails(kept, groups, follow, X, y, fold_rows, var, cv_on) -> list:
    """``kept`` with the pose (:data:`POSE`) replaced by the fewest joints' positions, none, one
    or two, where the pose does not beat them by :data:`DROP_MIN` of the variance out of fold.

    The pose is the forward kinematics of every joint's position: a force keyed on two rails'
    positions (a cable carrier pulled by their gap, a friction preloaded by it) is a function of
    the pose too, and a tilt of the platform can carry that gap in one column.  Named "the
    platform pose", it says less than the two positions it depends on.  A force on the platform
    (a magnet, a contact, a tendon) depends on all of them: there one or two rails' positions
    explain less and the pose stays.

    Greedy, at most three cross-validations per channel where the pose is named: the other kept
    groups alone (``s0``); with the position that explains most of what their trees leave out of
    fold (``s1``: a step function of it alone, :func:`~.cv.binned_shares`, no trees); with that
    position and the one whose position, or its difference from the first, explains most of
    what the trees on ``s1`` leave (``s2``).  The first of these the pose does not beat is named
    in its place, or the next one where its rail costs :data:`DROP_MIN` of the variance left out
    (the check of :func:`select`): a force on the gap of two rails is partly a function of
    either alone.

    The bar is the check's, not :func:`gain`'s: the positions take the pose's place, and a pose
    that explains 0.66 of the variance where one rail's position explains -0.10 is not
    significantly better over five folds when the force acts in one fold's blocks (a tendon
    taut part of the time, ``tests/discrepancy/test_flexible_beside.py``)."""
    from .cv import binned_shares

    rails = [g for g in groups if g.startswith("position of ") and g not in follow and g not in kept]
    if POSE not in kept or not rails:
        return kept
    full = cv_on(kept)[0]

    def beaten(cv):  # the pose's held-out error lower by DROP_MIN of the variance
        return (cv.mse - full.mse) / var >= DROP_MIN

    steps, cvs, named = [[g for g in kept if g != POSE]], [], None
    while True:
        cvs.append(cv_on(steps[-1])[0] if steps[-1] else None)
        left = [g for g in rails if g not in steps[-1]]
        if named is not None or len(steps) == 3 or not left:
            break
        if cvs[-1] is not None and not beaten(cvs[-1]):
            named = len(steps) - 1
        q = np.column_stack([np.asarray(X[:, groups[g][0]], float) for g in left])
        added = [g for g in steps[-1] if g in rails]  # a gap to the rail added before: its difference too
        if added:
            q = np.column_stack([q, q - np.asarray(X[:, groups[added[0]][0]], float)[:, None]])
        shares = binned_shares(q, y - (cvs[-1].pred if cvs[-1] is not None else 0.0), fold_rows)
        steps.append(steps[-1] + [left[int(np.argmax(shares)) % len(left)]])
    if named is None:
        named = next((i for i, cv in enumerate(cvs) if cv is not None and not beaten(cv)), None)
    if named is None:
        return kept
    if named + 1 < len(cvs) and (cvs[named].mse - cvs[named + 1].mse) / var >= DROP_MIN:  # the check's bar
        return steps[named + 1]
    return steps[named]


def partners(kept, groups, y, var, cv_on) -> list:
    """``kept`` with the groups that share columns with a kept one added where those shared
    columns add a significant share (:func:`gain`) to the trees on the kept groups.  A partner
    is named for its shared columns: its other columns are not added to the model (they were
    not shown to add anything).

    The partners of a unit's members (:func:`units`: rate groups holding the rates' projected
    column) on columns other than the unit's common ones (their joints' signed histories) are
    judged together first: where all their shared columns left out at once add nothing
    significant, none of them is named (one fit, not one per member)."""
    out = list(kept)
    judged_out = set()
    for u in [u for u in units(kept, groups) if len(u) > 1]:
        common = {i for g in u for h in u if h != g for i in set(groups[g]) & set(groups[h])}
        pairs = [(g, h) for g in u for h in groups if h not in out and set(groups[g]) & set(groups[h])
                 and not set(groups[g]) & set(groups[h]) & common]
        together = {i for g, h in pairs for i in set(groups[g]) & set(groups[h])}
        if len(pairs) > 1 and not adds(together, out, y, var, cv_on):
            judged_out.update(pairs)
    for g in kept:
        for h, idx in groups.items():
            shared = set(groups[g]) & set(idx)
            if (g, h) in judged_out or h in out or not shared or not {i for k in out for i in groups[k]} - shared:
                continue
            if adds(shared, out, y, var, cv_on):
                out.append(h)
    return still_added(out, kept, groups, y, var, cv_on)


def still_added(out, kept, groups, y, var, cv_on) -> list:
    """``out`` (:func:`partners`' named groups: ``kept`` and the partners added after them)
    without each partner whose columns shared with the ``kept`` groups do not add (:func:`adds`)
    to the trees on the kept groups' columns, the model the stage fits.  :func:`partners` judges
    each partner against the groups named before it, earlier partners' own columns included,
    which that model never holds: a signed history judged beside one rate, before the other
    rates of that rate's unit join, can add what those rates carry and stay named once they have
    joined although its columns then add nothing (docs/flexible.md).  Judged again here, the
    order the partners were named in does not matter.  A partner whose shared columns are all
    the kept groups' columns is not judged (nothing to judge them beside)."""
    held = {i for g in kept for i in groups[g]}
    named = list(out)
    for h in [g for g in out if g not in kept]:
        shared = set(groups[h]) & held
        if shared and held - shared and not adds(shared, kept, y, var, cv_on):
            named.remove(h)
    return named


def lean(X, y, fold_rows, groups, named, use, cv, cross_validate) -> tuple:
    """The trees on fewer columns where named groups share columns (a signed history: the rate's
    and the history's): per such group, cross-validated without its columns no other named group
    holds (it stays named for its shared ones); ``(cv, use)`` of the smallest held-out error, the
    full model's on a tie (``cross_validate``: the stage's).  Columns that carry nothing more add
    variance (docs/flexible.md).

    The rate groups of a unit (:func:`units`: they hold the rates' projected column) are one
    candidate, as in the check: cross-validated without all their columns but the common ones and
    those another named group holds (one fit, not one per member: 3-5 on a spindle's channels,
    docs/records/speed_runs.md, Speed)."""
    best = (cv, use)
    joint = [u for u in units(list(named), groups) if len(u) > 1]
    for gs in [[g] for g in named if not any(g in u for u in joint)] + joint:
        held = {i for g in gs for i in groups[g]}
        others = {i for h in named if h not in gs for i in groups[h]}
        common = set.intersection(*(set(groups[g]) for g in gs)) if len(gs) > 1 else set()
        sub = [i for i in use if i not in held - others - common]
        if not held & (others | common) or len(sub) == len(use):
            continue
        cv_s = cross_validate(X[:, sub], y, fold_rows)
        if cv_s.mse < best[0].mse:
            best = (cv_s, sub)
    return best


def strongest_alone(X, y, fold_rows, groups, cross_validate):
    """The group whose strongest column alone explains the most out of fold as a step
    function (:func:`~.cv.binned_shares`, on the same blocks), and the trees cross-validated on
    that group's columns (``cross_validate``: the stage's): ``(group, cross-validation)``."""
    from .cv import binned_shares

    shares = binned_shares(X, y, fold_rows)
    g = max(groups, key=lambda k: float(np.max(shares[groups[k]])))
    return g, cross_validate(X[:, groups[g]], y, fold_rows)


def causes_alone(X, y, fold_rows, groups, follow, rng, judged, chosen, screen, cross_validate, after=None,
                 directed=False) -> tuple:
    """The causes alone where they explain the same share as ``chosen`` (``(kept, cross-validation,
    columns)`` of :func:`select`, a consequence among them): the trees cross-validated on every
    input but the consequences ``follow`` (:func:`consequences`), grown as the full model's
    (stopped after a step once they claim: ``enough`` of :func:`~.cv.cross_validate`), screened
    (``screen``: the stage's, on their permutation importance) and checked as the full model's; ``chosen`` stays
    when those trees claim nothing (``judged``: the stage's two bars) or ``chosen`` beats the
    causes' refit significantly (:func:`gain`); ``after``, ``directed``: :func:`select`'s."""
    from .cv import importance

    cols = sorted({i for g, idx in groups.items() if g not in follow for i in idx})
    cv = cross_validate(X[:, cols], y, fold_rows, enough=lambda mse: judged(mse)[2])  # as the stage's on every input
    share, _, ok = judged(cv.mse)
    sub = {g: [cols.index(i) for i in idx] for g, idx in groups.items() if g not in follow}
    causes = screen(importance(cv, X[:, cols], y, sub, rng), share) if ok else []
    if not causes:
        return chosen
    var = float(np.var(y))
    alone = select(X, y, fold_rows, groups, causes, var, follow=follow, cross_validate=cross_validate, after=after,
                   directed=directed, claims=lambda c: judged(c.mse)[2])
    return chosen if gain(alone[1], chosen[1], y, var)[1] else alone


def screened_first(X, y, fold_rows, groups, follow, judged, cv, share, screen, cross_validate, after=None,
                   directed=False):
    """Where the trees on every input (``cv``, ``share``) claim nothing: the groups their
    permutation importance passes (``screen``: the stage's), checked as the full model's are
    (:func:`select`, causes before consequences, :func:`causes_alone`), and their trees' claim
    judged by the same two bars (``judged``); ``(named, cross-validation, columns, share,
    chi-square)``, None when no group passes or their trees claim nothing either; ``after``,
    ``directed``: :func:`select`'s.

    Many inputs that carry nothing add variance that can drown a force on two of them (a Coulomb
    level keyed on the rail's position, MuJoCo: the trees on every input -0.07 out of fold, on
    that rail's rate and position alone 0.70, docs/records/flexible_mujoco_runs.md); the importance is read out of
    fold, so the groups that stand out there are judged before the strongest single column
    alone, which names at most one factor of such a product."""
    from .cv import importance

    rng = np.random.default_rng(0)  # its own draws: the named inputs' importance keeps the stage's
    named = screen(importance(cv, X, y, groups, rng), share)
    if not named:
        return None
    var = float(np.var(y))
    kept, cv_k, use_k = select(X, y, fold_rows, groups, named, var, follow=follow, cross_validate=cross_validate,
                               after=after, directed=directed, claims=lambda c: judged(c.mse)[2])
    if any(g in follow for g in kept):
        kept, cv_k, use_k = causes_alone(X, y, fold_rows, groups, follow, rng, judged, (kept, cv_k, use_k),
                                         screen, cross_validate, after=after, directed=directed)
    share_k, z_k, ok = judged(cv_k.mse)
    return (kept, cv_k, use_k, share_k, z_k) if ok else None
