"""The rate groups that share the rates' projected column are judged as one unit
(cosim.discrepancy.flexible.select.units): named as the per-group check names them, in fewer
cross-validations.

Synthetic, truth in closed form: four rails' rates (sums of three sines at random frequencies),
a moment 0.5 r, r the rates along (1, 0.8, -1, 0) scaled to unit RMS (a gyroscopic H x omega),
its column shared by the rate groups of rails 1-3 (what :mod:`.oblique` builds); per rail a
history signed by its rate (tanh(qd / 0.05) times a state moving at half the rates' frequencies),
shared by the rail's rate and history groups.  With ``signed``, the
force adds 0.3 of rail 1's signed history (scaled to unit RMS): a friction level its slow state sets.
"""
import numpy as np

from cosim.discrepancy.flexible import select as sel
from cosim.discrepancy.flexible.cv import cross_validate, folds


def _sines(rng, t, k):
    return [sum(np.sin(2 * np.pi * f * t + p) for f, p in zip(rng.uniform(0.05, 0.8, 3), rng.uniform(0.0, 6.3, 3)))
            for _ in range(k)]


def _spindle_groups(n=700, sigma=0.05, seed=11, signed=False):
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 9.0, n)
    qd = np.column_stack(_sines(rng, t, 4))
    slow = np.column_stack(_sines(rng, t / 2.0, 4))
    sh = np.tanh(qd / 0.05) * slow
    r = qd @ np.array([1.0, 0.8, -1.0, 0.0])
    r /= np.std(r)
    y = 0.5 * r + rng.normal(0.0, sigma, n)
    if signed:
        y += 0.3 * sh[:, 0] / np.std(sh[:, 0])
    X = np.column_stack([qd, r, sh, slow])  # columns: qd 0-3, projected 4, signed 5-8, histories 9-12
    groups = {f"rate of slider {k + 1}": [k, 5 + k] + ([4] if k < 3 else []) for k in range(4)}
    groups.update({f"history of slider {k + 1}": [9 + k, 5 + k] for k in range(4)})
    return X, y, groups


def _counted():
    calls = []

    def cv(X, y, fold_rows, enough=None, under=None):
        calls.append(X.shape[1])
        return cross_validate(X, y, fold_rows, enough=enough, under=under)
    return cv, calls


def _per_group(gs, groups):
    return [[g] for g in gs]


def test_the_rate_groups_holding_the_projected_column_form_one_unit():
    _, _, groups = _spindle_groups()
    gs = ["rate of slider 1", "history of slider 2", "rate of slider 3", "rate of slider 4"]
    assert sel.units(gs, groups) == [["rate of slider 1", "rate of slider 3"], ["history of slider 2"],
                                     ["rate of slider 4"]]


def _select(X, y, groups, named):
    cv, calls = _counted()
    rows = folds(len(y), 10)
    kept = sel.select(X, y, rows, groups, named, float(np.var(y)), cross_validate=cv)[0]
    return sorted(kept), len(calls)


def test_a_unit_names_what_the_per_group_check_names_in_fewer_cross_validations(monkeypatch):
    # the per-group check: 3 leave-one-out fits, each costing the shared column, and one partner fit
    # per rail's signed history (7 in all, measured); the unit: one fit of the members' histories
    # left out together and the trees on the rates (2)
    X, y, groups = _spindle_groups()
    named = ["rate of slider 1", "rate of slider 2", "rate of slider 3"]
    kept_unit, fits_unit = _select(X, y, groups, named)
    monkeypatch.setattr(sel, "units", _per_group)
    kept_each, fits_each = _select(X, y, groups, named)
    assert kept_unit == kept_each == named
    assert fits_unit <= 3 < fits_each


def test_a_members_signed_history_that_adds_is_still_named(monkeypatch):
    # the histories judged together pass (rail 1's adds 0.3 of unit RMS): each is then judged alone
    X, y, groups = _spindle_groups(signed=True)
    named = ["rate of slider 1", "rate of slider 2", "rate of slider 3"]
    kept_unit, _ = _select(X, y, groups, named)
    monkeypatch.setattr(sel, "units", _per_group)
    kept_each, _ = _select(X, y, groups, named)
    assert kept_unit == kept_each
    assert "history of slider 1" in kept_unit and "history of slider 2" not in kept_unit


def test_a_single_rate_groups_partners_are_checked_one_by_one():
    # one rate group named: no unit, no joint check of its partners; each checked alone: the trees
    # on rail 1's rate, one fit per partner (rails 2 and 3 on the projected column, rail 1's history
    # on its signed history) and one per partner added (the trees on the kept groups then): 1 + 3 + 2
    X, y, groups = _spindle_groups()
    kept, fits = _select(X, y, groups, ["rate of slider 1"])
    assert kept == ["rate of slider 1", "rate of slider 2", "rate of slider 3"]
    assert fits == 6


def test_the_fits_whose_gain_already_falls_short_stop_early_and_name_as_the_whole_growth():
    # the leave-one-out fits of the check and the partners' fits stop after their first step where
    # their held-out error is already under the kept groups' plus DROP_MIN of the variance (it only
    # falls with more trees): the same names, columns and trees on them as with every fit grown whole
    from cosim.discrepancy.flexible import cv as flexible_cv

    X, y, groups = _spindle_groups(signed=True)
    named = ["rate of slider 1", "rate of slider 2", "history of slider 4", "rate of slider 4"]
    rows = folds(len(y), 10)
    got = {}
    for how in ("whole", "early"):
        flexible_cv._DONE.clear()
        flexible_cv._STOPPED.clear()
        made = []

        def cv(Xs, ys, fold_rows, enough=None, under=None):
            made.append(cross_validate(Xs, ys, fold_rows, enough=None if how == "whole" else enough,
                                       under=None if how == "whole" else under))
            return made[-1]
        kept, cv_k, cols = sel.select(X, y, rows, groups, named, float(np.var(y)), cross_validate=cv)
        got[how] = (kept, cols, cv_k.mse, sum(c.stopped for c in made))
    assert got["early"][:3] == got["whole"][:3]
    assert got["whole"][3] == 0 and got["early"][3] >= 1


def test_the_lean_refit_judges_a_unit_as_one_candidate():
    # the rates of rails 1-3 hold the projected column (4): one refit without all their own columns
    # (the trees on the projected column alone), not one per member; a rate and its history sharing
    # a signed history are still refitted one by one (each without its own columns)
    X, y, groups = _spindle_groups()
    rows = folds(len(y), 10)
    cv, calls = _counted()
    named = ["rate of slider 1", "rate of slider 2", "rate of slider 3"]
    use = sorted({i for g in named for i in groups[g]})
    full = cross_validate(X[:, use], y, rows)
    seen = []

    def logged(Xs, ys, fold_rows, enough=None, under=None):
        seen.append(Xs.shape[1])
        return cv(Xs, ys, fold_rows, enough=enough, under=under)
    got, sub = sel.lean(X, y, rows, groups, named, use, full, logged)
    assert seen == [1]
    assert sub in (use, [4]) and got.mse <= full.mse
    seen.clear()
    named = ["rate of slider 4", "history of slider 4"]
    use = sorted({i for g in named for i in groups[g]})
    sel.lean(X, y, rows, groups, named, use, cross_validate(X[:, use], y, rows), logged)
    assert seen == [2, 2]
