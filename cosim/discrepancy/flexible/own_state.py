"""The channel's own effort and rate beside the named inputs (:mod:`.stage`, the flexible
stage's choice of the inputs it names).

The screen passes a group on its permutation importance out of fold, a share of the whole
trees' explained variance.  Where a force is a product of the joint's position and its own
effort or rate (a thrust ripple or a screw's misalignment whose amplitude the drive's load
sets, an air cushion whose force grows with stroke and speed), the position alone carries most
of it: the trees split on the position first, and permuting the effort or the rate costs them
a share under the screen's bars (on the seen MuJoCo sets 0.006-0.058 of the variance, under
:data:`~.stage.IMPORTANCE_MIN` or a tenth of the strongest group's), though the trees on the
position and that factor explain more out of fold than those on the position alone (0.04-0.26
of the variance).

**The own joint's state beside the named inputs** (:func:`beside_named`): where the stage names
inputs and a claim, the channel's own joint's rate and effort that the screen did not pass are
each cross-validated beside them; one is named where it adds :data:`~.select.DROP_MIN` of the
variance above :data:`~.select.GAIN_Z` standard errors over the folds (:func:`~.select.gain`, the
bar of a consequence), the larger gain first and the other judged beside it.  Three guards keep
the closed-loop answer out:

* a group the screen passed was judged by the other rules (causes before consequences, copies,
  what a model effort is computed from: :mod:`.select`, :mod:`.beside`), and is not tried again;
* the effort carries the controller's answer to the force (:mod:`.copies`): it is named only
  where its counterpart along the reference motion (the reference's inverse dynamics: the load
  the commanded motion sets, which the force does not move) adds by the same bar in its place: a
  force keyed on the drive's load is keyed on the commanded load too, one the effort only echoes
  is not in it;
* the effort is tried only beside the own joint's named position: a force the drive's load
  scales acts along the joint's own stroke (a motor's thrust, a nut's contact); a force on the
  platform, named on its pose, its motion or the rates of its twist, reaches every drive's
  effort through the dynamics that effort is computed from, where the effort beside them is a
  copy of that force, no factor of it.

On a fit folded by the joint's direction (:mod:`.folded`) the rate is named as the direction
already and is not tried.  The rule names no kind of force.

Figures on the seen sets: docs/flexible.md, "The own joint's effort and rate beside the named inputs".
"""
from __future__ import annotations

import numpy as np

from .own_joint import joint_of
from .select import gain

#: the own joint's quantities tried beside the named inputs
QUANTITIES = ("rate", "effort")


def own_groups(groups, joint, named) -> list:
    """The groups of ``joint``'s rate and effort (:data:`QUANTITIES`) that are inputs and not
    among ``named``; [] for a channel of no joint."""
    if joint is None:
        return []
    return [g for g in groups if g not in named and joint_of(g) in {(q, joint) for q in QUANTITIES}]


def recorded(screen) -> tuple:
    """``(screen', passed)``: the stage's ``screen`` and the set of every group it passes, filled
    as it is called (:func:`beside_named`'s ``passed``)."""
    passed = set()

    def screen_(imp, share):
        got = screen(imp, share)
        passed.update(got)
        return got
    return screen_, passed


def beside_named(named, use, cv, groups, joint, X, y, fold_rows, reference, passed=(), direction=False,
                 cross_validate=None) -> tuple:
    """``(named, cv, use)`` with the own ``joint``'s rate and effort (:func:`own_groups`) added
    where they add significantly beside the named groups (module docstring): ``cv`` the trees'
    cross-validation on the columns ``use`` of ``X``, ``reference`` the channel's counterparts
    along the reference motion (an array of ``X``'s layout, a function giving it:
    :func:`.copies.on_channel`, or None: no effort is named then); ``cross_validate``: the
    stage's (:func:`~.cv.cross_validate` where None); ``passed``: the groups the screen passed
    (the other rules judged them: not tried again); ``direction``: the fit is folded by the
    joint's direction (:mod:`.folded`), which names its rate already.  Unchanged where nothing
    adds."""
    if cross_validate is None:
        from .cv import cross_validate
    var = float(np.var(y))
    stroke = any(joint_of(g) == ("position", joint) for g in named)  # the own joint's position named
    tried = [g for g in own_groups(groups, joint, list(named) + list(passed))
             if not (direction and joint_of(g)[0] == "rate") and (stroke or joint_of(g)[0] != "effort")]
    if not tried or not var > 0:
        return named, cv, use
    done = {}

    def cv_on(cols, on=None):
        key = (tuple(cols), on is not None)
        if key not in done:
            done[key] = cross_validate(X[:, cols] if on is None else on(cols), y, fold_rows)
        return done[key]

    def counterpart(g):  # the columns with the effort's replaced by their counterparts
        ref = reference() if callable(reference) else reference
        if ref is None:
            return None

        def on(cols):
            M = X[:, cols].copy()
            at = [j for j, i in enumerate(cols) if i in groups[g]]
            M[:, at] = ref[:, [cols[j] for j in at]]
            if getattr(M, "variants", None) is not None:
                M.variants[:, :, at] = ref[:, [cols[j] for j in at]]
            return M
        return on

    def adds(g, base, base_cv):
        cols = sorted(set(base) | set(groups[g]))
        got, shown = gain(base_cv, cv_on(cols), y, var)
        if shown and joint_of(g)[0] == "effort":
            on = counterpart(g)
            shown = on is not None and gain(base_cv, cv_on(cols, on), y, var)[1]
        return got if shown else None, cols

    gains = {g: adds(g, use, cv) for g in tried}
    order = sorted([g for g in tried if gains[g][0] is not None], key=lambda g: -gains[g][0])
    for k, g in enumerate(order):
        got, cols = gains[g] if k == 0 else adds(g, use, cv)  # the next judged beside the first
        if got is not None:
            named, use, cv = list(named) + [g], cols, cv_on(cols)
    return named, cv, use
