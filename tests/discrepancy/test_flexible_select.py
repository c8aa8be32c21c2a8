"""Which inputs the flexible stage names (cosim.discrepancy.flexible.select): on a weak channel
a consequence of the force is no answer by itself.

Synthetic, truth in closed form: a friction on slider 1 in proportion to another drive's effort,
sign(qd1) 0.25 (|effort2| - mean |effort2|) (a bearing preloaded by the neighbouring drive, its
mean level taken by a fitted Coulomb friction), and the channel's own model effort carrying the
motion's own load and a copy of that force lagged by 30 ms (what the drive's controller answers
in closed loop).
"""
import math
import types

import numpy as np

from cosim.discrepancy.flexible import stage as flexible


def _preloaded(n=900, sigma=0.05, seed=3):
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 9.0, n)
    qd1 = np.sin(2 * np.pi * 0.41 * t) + 0.4 * np.sin(2 * np.pi * 1.3 * t + 0.5)
    effort2 = np.sin(2 * np.pi * 0.17 * t + 1.0) + 0.6 * np.sin(2 * np.pi * 0.53 * t)
    f = np.tanh(qd1 / 0.05) * 0.25 * (np.abs(effort2) - np.mean(np.abs(effort2)))
    a = np.exp(-(t[1] - t[0]) / 0.03)
    copy = np.empty(n)
    copy[0] = f[0]
    for i in range(1, n):
        copy[i] = a * copy[i - 1] + (1 - a) * f[i]
    y = f + rng.normal(0.0, sigma, n)
    load = 0.3 * np.sin(2 * np.pi * 0.29 * t + 2.0)
    X = np.column_stack([qd1, effort2, load + copy, rng.uniform(-1, 1, (n, 2))])
    cols = [("qd1", "rate of slider 1", 1, "rate", "m/s"), ("effort2", "effort of slider 2", 2, "effort", "N"),
            ("effort1", "effort of slider 1", 1, "effort", "N"),
            ("q3", "position of slider 3", 3, "position", "m"), ("q4", "position of slider 4", 4, "position", "m")]
    pipe = types.SimpleNamespace(channels=["tau1"], window=5, step=5)
    return pipe, X, cols, y, sigma


def test_a_weak_channel_whose_strongest_input_is_a_consequence_gets_the_trees_on_every_input():
    # the strongest input alone is the channel's own model effort (a lagged copy of the force);
    # without the rule it is named alone; with it the trees on every input are judged, causes
    # before consequences, and the two causes of the product are named
    pipe, X, cols, y, sigma = _preloaded()
    fit = flexible.fit_channel(pipe, X, cols, y, sigma, ("N", "tau1"), weak=True)
    assert fit.explained
    assert sorted(d.group for d in fit.inputs) == ["effort of slider 2", "rate of slider 1"]


def _coulomb_zone(n=900, sigma=0.05, seed=3, others=16):
    """A Coulomb level on slider 1 rising over a band of its stroke, its mean level taken by a
    fitted Coulomb friction: 0.3 tanh(qd1 / 0.05) (band(q1) - mean band), beside ``others`` smooth
    inputs that carry nothing (sums of three sines at random frequencies)."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 9.0, n)
    q1 = np.sin(2 * np.pi * 0.23 * t) + 0.5 * np.sin(2 * np.pi * 0.61 * t + 1.0)
    qd1 = np.gradient(q1, t)
    band = 0.5 * (np.tanh((q1 + 0.2) / 0.05) - np.tanh((q1 - 0.6) / 0.05))
    y = 0.3 * np.tanh(qd1 / 0.05) * (band - np.mean(band)) + rng.normal(0.0, sigma, n)
    carry_nothing = [sum(np.sin(2 * np.pi * f * t + p) for f, p in zip(rng.uniform(0.05, 1.0, 3),
                                                                        rng.uniform(0.0, 6.3, 3)))
                     for _ in range(others)]
    X = np.column_stack([q1, qd1] + carry_nothing)
    cols = [("q1", "position of slider 1", 1, "position", "m"), ("qd1", "rate of slider 1", 1, "rate", "m/s")]
    cols += [(f"q{i + 2}", f"position of slider {i + 2}", i + 2, "position", "m") for i in range(others)]
    pipe = types.SimpleNamespace(channels=["tau1"], window=5, step=5)
    return pipe, X, cols, y, sigma


def test_where_the_trees_on_every_input_claim_nothing_the_screened_inputs_are_judged_before_the_strongest_alone():
    # the trees on all 18 inputs explain nothing out of fold (the 16 that carry nothing add their
    # variance); their importance still singles out the rail's rate and position, whose trees
    # alone explain 0.63: both are named.  Without the rule the strongest column alone is judged
    # (one factor of the product, or nothing)
    pipe, X, cols, y, sigma = _coulomb_zone()
    full = flexible.cross_validate(X, y, flexible.folds(len(y), flexible.gap_for(1.0)))
    assert 1.0 - full.mse / np.var(y) < flexible.SHARE_MIN  # the situation the rule is for
    fit = flexible.fit_channel(pipe, X, cols, y, sigma, ("N", "tau1"))
    assert fit.explained and fit.share > 0.5
    assert sorted(d.group for d in fit.inputs) == ["position of slider 1", "rate of slider 1"]



def _stub(per_fold_mse, rate="rate of slider 5"):
    """The groups ``select`` names among a rate (column 0) and the history of slider 1 (column
    1), with a cross-validation stub: ``per_fold_mse`` per set of columns, on a residual of
    variance 1 over four folds, so that every held-out error is set by the test, not by trees."""
    from cosim.discrepancy.flexible import select as flexible_select

    n = 40
    y = np.where(np.arange(n) % 2 == 0, 1.0, -1.0)
    fold_rows = [(np.arange(i, n, 4), np.setdiff1d(np.arange(n), np.arange(i, n, 4))) for i in range(4)]
    X = np.tile(np.arange(2.0), (n, 1))

    def cross_validate(Xs, y_, rows, enough=None, under=None):  # the whole growth: a stub has no steps
        e = np.zeros(n)
        for (h, _), m in zip(rows, per_fold_mse[tuple(int(v) for v in Xs[0])]):
            e[h] = math.sqrt(m)
        return types.SimpleNamespace(mse=float(np.mean(e ** 2)), pred=y_ + e, folds=rows)

    groups = {rate: [0], "history of slider 1": [1]}
    return flexible_select.select(X, y, fold_rows, groups, list(groups), 1.0, cross_validate=cross_validate)[0]


#: leaving the history out costs 0.04 of the variance (over DROP_MIN: the check alone keeps it),
#: but that cost swings over the folds (+0.12, -0.04, +0.12, -0.04: under two standard errors)
SWINGS = {(0, 1): [0.5] * 4, (0,): [0.62, 0.46, 0.62, 0.46], (1,): [0.9] * 4}


def test_another_joints_history_beside_a_rate_is_named_only_where_it_adds_significantly():
    assert _stub(SWINGS) == ["rate of slider 5"]


def test_another_joints_history_that_adds_on_every_fold_is_named():
    assert _stub({(0, 1): [0.5] * 4, (0,): [0.58] * 4, (1,): [0.9] * 4}) == ["rate of slider 5",
                                                                             "history of slider 1"]


def test_a_joints_history_beside_its_own_rate_is_checked_as_before():
    # a friction level the joint's slow state sets (a heating drive): the check's cost suffices
    assert _stub(SWINGS, rate="rate of slider 1") == ["rate of slider 1", "history of slider 1"]


def _effort_or_pose(claims):
    """The groups ``select`` names on a model effort (column 0) that explains 0.7 of a residual of
    variance 1 on every fold, beside the pose (column 1) it is computed from, which explains
    nothing on three folds and less than nothing on the fourth (a force in that fold's blocks):
    the effort's gain (0.875 of the variance) is not significant over the folds, so
    ``made_of_efforts`` puts the pose in its place; ``claims``: the stage's bars (a stub)."""
    from cosim.discrepancy.flexible import select as flexible_select

    n = 40
    y = np.where(np.arange(n) % 2 == 0, 1.0, -1.0)
    fold_rows = [(np.arange(i, n, 4), np.setdiff1d(np.arange(n), np.arange(i, n, 4))) for i in range(4)]
    X = np.tile(np.arange(2.0), (n, 1))
    per_fold = {(0,): [0.3] * 4, (1,): [3.8, 0.3, 0.3, 0.3], (0, 1): [0.3] * 4}

    def cross_validate(Xs, y_, rows, enough=None, under=None):
        e = np.zeros(n)
        for (h, _), m in zip(rows, per_fold[tuple(int(v) for v in Xs[0])]):
            e[h] = math.sqrt(m)
        return types.SimpleNamespace(mse=float(np.mean(e ** 2)), pred=y_ + e, folds=rows)

    groups = {"effort of slider 4": [0], "the platform pose": [1]}
    return flexible_select.select(X, y, fold_rows, groups, ["effort of slider 4"], 1.0, cross_validate=cross_validate,
                                  claims=claims)[0]


def test_a_replacement_whose_trees_claim_nothing_leaves_the_checked_groups_named():
    # the pose's trees (held-out error 1.175 of the variance) claim nothing, the effort's (0.3) do
    assert _effort_or_pose(lambda cv: cv.mse <= 0.95) == ["effort of slider 4"]


def test_a_replacement_whose_trees_claim_stands():
    assert _effort_or_pose(lambda cv: cv.mse <= 1.5) == ["the platform pose"]


def test_replacements_that_together_lose_significantly_leave_the_efforts_named():
    # a force keyed on slider 6's position and model effort (a thrust ripple: the command times a
    # function of the position), the two named by the check (leaving either out costs 0.4 of the
    # variance); the effort's constituents (the pose and the rate) lose 0.02 of the variance, under
    # DROP_MIN: made_of_efforts puts them in the effort's place; the pose then loses 0.02 to the
    # rail's own position beside the rate, under the bar: fewest_rails takes the position.  Each
    # step passes its own bar, but position and rate lose 0.04 to position and effort on every
    # fold: the replacements are undone, the effort stays named (without the guard: position and
    # rate of slider 6)
    from cosim.discrepancy.flexible import select as flexible_select

    n = 40
    y = np.where(np.arange(n) % 2 == 0, 1.0, -1.0)
    fold_rows = [(np.arange(i, n, 4), np.setdiff1d(np.arange(n), np.arange(i, n, 4))) for i in range(4)]
    X = np.tile(np.arange(5.0), (n, 1))
    X[1:, 4] = np.random.default_rng(0).uniform(-1.0, 1.0, n - 1)  # slider 3's position: fewest_rails bins it
    per_fold = {(0, 1): [0.10] * 4, (0,): [0.5] * 4, (1,): [0.5] * 4, (1, 2): [0.3] * 4,
                (1, 2, 3): [0.12] * 4, (1, 3): [0.14] * 4, (1, 3, 4): [0.14] * 4}

    def cross_validate(Xs, y_, rows, enough=None, under=None):
        e = np.zeros(n)
        for (h, _), m in zip(rows, per_fold[tuple(int(v) for v in Xs[0])]):
            e[h] = math.sqrt(m)
        return types.SimpleNamespace(mse=float(np.mean(e ** 2)), pred=y_ + e, folds=rows)

    groups = {"effort of slider 6": [0], "position of slider 6": [1], "the platform pose": [2],
              "rate of slider 6": [3], "position of slider 3": [4]}
    named = flexible_select.select(X, y, fold_rows, groups, ["position of slider 6", "effort of slider 6"], 1.0,
                                   cross_validate=cross_validate)[0]
    assert sorted(named) == ["effort of slider 6", "position of slider 6"]
